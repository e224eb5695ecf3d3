//! Held-out errors: k-fold cross-validation of the tool-point position.
//!
//! Folds are interleaved (pose `i` in fold `i mod k`; the rows of each fixed
//! point or plane of a session without a tracker interleaved among
//! themselves: [`interleaved_folds`]), so that a drift in time falls into
//! every fold; the rows of one configuration of the robot (several points on
//! the flange, sessions that revisit it) share a fold. The figure is the held-out 3-D position error of each
//! pose, in metres, from a model fitted without its fold.
//!
//! [`Folds`] cross-validates by linearisation: about one fit's solution `x*`
//! (the Jacobian `J` of all columns, the weighted residual `r`, each column's
//! prior precision `p` and offset `o = x* − x_nominal`), a candidate model is
//! a subset `S` of the columns, the others moved back to nominal (`δ = −o`),
//! with its own prior scale. For each fold's training poses `T` one
//! Gauss–Newton step solves the MAP normal equations
//!
//! `(J_TSᵀ J_TS + P_S) δ_S = J_TSᵀ (r_T + J_T¬S o_¬S) − P_S o_S`
//!
//! and the held-out residual of a pose `i` of the fold is `r_i − J_i δ`. The
//! training normal matrices are the whole set's less the fold's (`A − A_k`),
//! so one linearisation and one pass over the rows serve every candidate: the
//! folds' optima lie within a fraction of a standard error of `x*` for the
//! effects and within the parameter errors (mm, mrad) for the geometry, and
//! the step reaches them to second order in that distance (µm on a metre arm).
//! [`crate::calibration::diagnose::cross_validate`] refits every fold from
//! scratch: the reference the tests hold the linearisation to.

use faer::linalg::solvers::{Llt, Solve};
use faer::linalg::triangular_solve::{
    solve_lower_triangular_in_place, solve_upper_triangular_in_place,
};
use faer::{Col, Mat, Par, Side};

use crate::calibration::dense::{column, normal_equations, unit_scale};
use crate::calibration::fit::Linearization;
use crate::calibration::parallel;
use crate::session::observation::Contact;
use std::collections::HashMap;

/// Held-out statistics: RMS, mean and max of the position error, m.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HeldOut {
    /// Root mean square.
    pub rms: f64,
    /// Mean.
    pub mean: f64,
    /// Largest.
    pub max: f64,
}

impl HeldOut {
    /// The statistics of `errors`.
    pub fn of(errors: &[f64]) -> Self {
        let n = errors.len().max(1) as f64;
        Self {
            rms: (errors.iter().map(|e| e * e).sum::<f64>() / n).sqrt(),
            mean: errors.iter().sum::<f64>() / n,
            max: errors.iter().copied().fold(0.0, f64::max),
        }
    }
}

/// The most poses a model is chosen on, and the deleted residuals screened
/// on, by default: the held-out RMS of this many poses is known to about
/// 0.2 % (its standard error is `1/√(2n)` of it), and a longer session is
/// sampled ([`crate::calibration::diagnose::large`]).
pub const SELECTION_POSES: usize = 100_000;

/// The fold of each pose of `contacts` (what each pose's tool point is held
/// to) in `k` interleaved folds, the poses of one robot configuration
/// (`configurations`: each pose's, [`Configurations::of_robot`]) together:
/// the `r`-th configuration held to one contact (a measured position, or one
/// fixed point or plane) in fold `(f + r) mod k`, `f` the index of that
/// contact's first pose, and every later pose of a configuration in its
/// first pose's fold. For measured coordinates of distinct configurations
/// pose `i` is in fold `i mod k`; the rows of each fixed point or plane are
/// spread over the folds, so that every fold trains on some of them (a
/// session that visits ten sockets in turn, twice, would otherwise hold out
/// both rows of a socket together, and nothing would locate it in that
/// fold). A configuration seen through three SMRs, or in two sessions, is
/// held out whole: its copies would predict it as well as itself.
///
/// [`Configurations::of_robot`]: crate::session::configurations::Configurations::of_robot
pub fn interleaved_folds(contacts: &[Contact], configurations: &[usize], k: usize) -> Vec<usize> {
    debug_assert_eq!(contacts.len(), configurations.len());
    let mut seen: HashMap<Contact, (usize, usize)> = HashMap::new();
    let mut fold_of: HashMap<usize, usize> = HashMap::new();
    contacts
        .iter()
        .zip(configurations)
        .enumerate()
        .map(|(i, (c, g))| {
            if let Some(&fold) = fold_of.get(g) {
                return fold;
            }
            let (first, rank) = seen.entry(*c).or_insert((i, 0));
            let fold = (*first + *rank) % k;
            *rank += 1;
            fold_of.insert(*g, fold);
            fold
        })
        .collect()
}

/// What a pose is to a cross-validation.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Role {
    /// Held out in fold `k`, trained on in the others.
    Fold(usize),
    /// Trained on in every fold, never held out.
    Train,
    /// Left out altogether.
    Out,
}

/// The rows of a group of poses (a fold's, or those trained on in every
/// fold with the known distances), gathered: each pose's position rows (3, or
/// 1 for a touch of a plane) first, in the order of the poses, then their
/// other rows; their Jacobian `j` and weighted residual `r`.
#[derive(Clone)]
struct GroupRows {
    /// Each pose with how many position rows it has.
    poses: Vec<(usize, usize)>,
    /// How many leading rows are position rows.
    position_rows: usize,
    j: Mat<f64>,
    r: Mat<f64>,
}

impl GroupRows {
    fn of(lin: &Linearization, poses: &[usize]) -> Self {
        let mut position = Vec::new();
        let mut other = Vec::new();
        let poses = poses
            .iter()
            .map(|&i| {
                let own = lin.rows_of(i);
                let n = own.len().min(3);
                position.push(own.start..own.start + n);
                other.push(own.start + n..own.end);
                (i, n)
            })
            .collect();
        let position_rows = position.iter().map(|r| r.len()).sum();
        position.extend(other);
        let (j, r) = lin.rows(&position);
        Self {
            poses,
            position_rows,
            j,
            r,
        }
    }
}

/// The Cholesky factor of a scaled MAP normal matrix (see [`Folds::factor`]):
/// `L`, and each column's scale to a unit diagonal.
struct Factor {
    l: Mat<f64>,
    scale: Vec<f64>,
}

/// The columns a step moves: the free ones and those moved back to nominal.
fn moving(delta: &[f64]) -> Vec<usize> {
    (0..delta.len()).filter(|&c| delta[c] != 0.0).collect()
}

/// The folds of a cross-validation unless told otherwise (at most one per
/// pose): `diagnose`'s, `identify`'s choice of the prior's scale, `holdout`'s.
pub const DEFAULT_FOLDS: usize = 10;

/// The fewest poses for which candidates are cross-validated on every core
/// ([`Folds::spread`]). A candidate's cross-validation costs a few
/// factorisations of its `p × p` system (`p` about 30: tens of µs) and, for
/// each fold, one product with the fold's held-out rows (`3n/k × p`): on
/// fewer poses it takes no longer than waking a sleeping worker, and the
/// candidates run one after the other.
pub const SPREAD_POSES: usize = 1000;

/// A candidate model as the linearisation sees it.
#[derive(Clone, Debug)]
pub struct Subset {
    /// The free columns; the others are moved back to nominal.
    pub columns: Vec<usize>,
    /// The factor on every column's prior precision (`1/m²` for a prior `m`
    /// times the stated one).
    pub precision_factor: f64,
}

/// What the linearised cross-validation of one candidate gives.
#[derive(Clone, Debug)]
pub struct Evaluation {
    /// Held-out position error of each pose in a fold, m (poses in no fold: 0).
    pub errors: Vec<f64>,
    /// Their statistics over the poses in folds.
    pub held: HeldOut,
    /// The objective (weighted sum of squares plus the prior's term) after the
    /// step on every pose: the fit of the candidate to all poses.
    pub objective: f64,
}

/// The linearised k-fold cross-validation of candidate models (see the module
/// header): each fold's normal matrix and right-hand side over every column.
pub struct Folds<'a> {
    lin: &'a Linearization,
    fold: Vec<Role>,
    /// Each fold's training normal equations: every pose's less the fold's.
    training: Vec<(Mat<f64>, Col<f64>)>,
    /// Each fold's held-out rows.
    held_rows: Vec<GroupRows>,
    all: (Mat<f64>, Col<f64>),
    rtr: f64,
}

impl<'a> Folds<'a> {
    /// Folds of `lin`'s poses: `fold[i]` is pose `i`'s role. The known
    /// distances of a session without a tracker are trained on in every fold:
    /// they tie the points together, and a fold holds out where a pose's tool
    /// point lands, not a distance.
    pub fn new(lin: &'a Linearization, fold: Vec<Role>) -> Self {
        debug_assert_eq!(fold.len(), lin.poses());
        let k = fold
            .iter()
            .filter_map(|r| match r {
                Role::Fold(f) => Some(f + 1),
                _ => None,
            })
            .max()
            .unwrap_or(0);
        // Each group's rows gathered, its normal matrix by one product.
        let normal = |poses: Vec<usize>| {
            let rows = GroupRows::of(lin, &poses);
            (normal_equations(&rows.j, &rows.r), rows)
        };
        let distances = lin.poses()..lin.first_rows.len();
        let group = |g: Role| -> Vec<usize> {
            let poses = (0..fold.len()).filter(|&i| fold[i] == g);
            if g == Role::Train {
                poses.chain(distances.clone()).collect()
            } else {
                poses.collect()
            }
        };
        // Each fold's, then the poses trained on in every fold; on every core
        // when the poses are many (see `SPREAD_POSES`).
        // Once the caller asked to stop (`lin.cancel`), the groups not started
        // are left empty: the caller's next check drops the folds.
        let groups: Vec<Role> = (0..k).map(Role::Fold).chain([Role::Train]).collect();
        let mut parts = parallel::map_if(fold.len() >= SPREAD_POSES, &groups, |&g| {
            normal(if lin.cancel.requested() {
                Vec::new()
            } else {
                group(g)
            })
        });
        let (mut all, _) = parts.pop().expect("the poses trained on in every fold");
        for ((a, b), _) in &parts {
            all.0 += a;
            all.1 += b;
        }
        let (training, held_rows) = parts
            .into_iter()
            .map(|((a, b), rows)| ((&all.0 - a, &all.1 - b), rows))
            .unzip();
        let rtr = (0..fold.len())
            .filter(|&i| fold[i] != Role::Out)
            .chain(distances)
            .flat_map(|i| lin.rows_of(i))
            .map(|row| lin.r[(row, 0)].powi(2))
            .sum();
        Self {
            lin,
            fold,
            training,
            held_rows,
            all,
            rtr,
        }
    }

    /// These folds with `pose`, left out of them ([`Role::Out`]), trained on
    /// in every fold ([`Role::Train`]): its rows' normal equations added to
    /// every fold's training set, without a pass over the other poses.
    pub fn adding(&self, pose: usize) -> Self {
        debug_assert_eq!(self.fold[pose], Role::Out);
        let lin = self.lin;
        let rows: Vec<usize> = lin.rows_of(pose).collect();
        let columns = lin.j.ncols();
        let a = Mat::from_fn(columns, columns, |i, k| {
            rows.iter()
                .map(|&r| lin.j[(r, i)] * lin.j[(r, k)])
                .sum::<f64>()
        });
        let b = Col::from_fn(columns, |i| {
            rows.iter()
                .map(|&r| lin.j[(r, i)] * lin.r[(r, 0)])
                .sum::<f64>()
        });
        let add = |(m, v): &(Mat<f64>, Col<f64>)| (m + &a, v + &b);
        let mut fold = self.fold.clone();
        fold[pose] = Role::Train;
        Self {
            lin,
            fold,
            training: self.training.iter().map(add).collect(),
            held_rows: self.held_rows.clone(),
            all: add(&self.all),
            rtr: self.rtr + rows.iter().map(|&r| lin.r[(r, 0)].powi(2)).sum::<f64>(),
        }
    }

    /// The normal equations `(JᵀJ, Jᵀr)` of every pose but those left out
    /// ([`Role::Out`]), over every column, without the prior.
    pub fn normal_equations(&self) -> &(Mat<f64>, Col<f64>) {
        &self.all
    }

    /// Whether candidates are worth cross-validating on every core: at least
    /// [`SPREAD_POSES`] poses.
    pub fn spread(&self) -> bool {
        self.fold.len() >= SPREAD_POSES
    }

    /// Interleaved folds over every pose ([`interleaved_folds`]): for
    /// measured coordinates pose `i` in fold `i mod k`.
    pub fn interleaved(lin: &'a Linearization, k: usize) -> Self {
        let k = k.clamp(2, lin.poses().max(2));
        let folds = interleaved_folds(&lin.contacts, &lin.configurations, k);
        Self::new(lin, folds.into_iter().map(Role::Fold).collect())
    }

    /// Whether every column of `columns` from index `lin.fitted` on keeps at
    /// least `separability` of its (unit) norm beside the columns before it:
    /// a candidate the data cannot tell apart from the model is not scored.
    pub fn separable(&self, columns: &[usize], separability: f64) -> bool {
        // Every pose's normal matrix without the prior, unit-scaled.
        let Some(Factor { l, scale }) = self.factor(columns, 0.0, None) else {
            return false;
        };
        (0..columns.len())
            .filter(|&i| columns[i] >= self.lin.fitted)
            .all(|i| scale[i] > 0.0 && l[(i, i)] >= separability)
    }

    /// The scaled MAP normal matrix of `columns` on a fold's training poses
    /// (every pose's for `fold` `None`), factorised. The factor of a leading
    /// block is the leading block of the factor, so one factorisation serves
    /// every candidate whose columns are a prefix of `columns`.
    fn factor(
        &self,
        columns: &[usize],
        precision_factor: f64,
        fold: Option<usize>,
    ) -> Option<Factor> {
        let s = columns;
        let m = s.len();
        // The training poses' normal matrix: every pose's less the fold's.
        let a = &fold.map_or(&self.all, |f| &self.training[f]).0;
        let precision = |c: usize| self.lin.precision[c] * precision_factor;
        // Scaled to a unit diagonal, for the conditioning of the factorisation.
        let scale: Vec<f64> = s
            .iter()
            .map(|&c| unit_scale(a[(c, c)] + precision(c)))
            .collect();
        // The lower half: all the factorisation reads.
        let mut n = Mat::zeros(m, m);
        for j in 0..m {
            n[(j, j)] = (a[(s[j], s[j])] + precision(s[j])) * scale[j] * scale[j];
            for i in j + 1..m {
                n[(i, j)] = a[(s[i], s[j])] * scale[i] * scale[j];
            }
        }
        Some(Factor {
            l: n.llt(Side::Lower).ok()?.L().to_owned(),
            scale,
        })
    }

    /// The MAP step of `subset` on a fold's training poses (every pose's for
    /// `None`) from `factor`, the factor of columns that `subset`'s are a
    /// prefix of, at its prior: the step of every column (the free ones
    /// solved, the `held` ones moved back to nominal).
    fn solve(
        &self,
        factor: &Factor,
        subset: &Subset,
        held: &[usize],
        fold: Option<usize>,
    ) -> Option<Vec<f64>> {
        let lin = self.lin;
        let s = &subset.columns;
        let m = s.len();
        let (a, b) = fold.map_or(&self.all, |f| &self.training[f]);
        let precision = |c: usize| lin.precision[c] * subset.precision_factor;
        let scale = &factor.scale;
        let mut x = Col::from_fn(m, |i| {
            let c = s[i];
            (b[c] + held.iter().map(|&h| a[(c, h)] * lin.offset[h]).sum::<f64>()
                - precision(c) * lin.offset[c])
                * scale[i]
        });
        // `L Lᵀ x = rhs` by the leading block of the factor.
        let l = factor.l.as_ref().submatrix(0, 0, m, m);
        solve_lower_triangular_in_place(l, x.as_mat_mut(), Par::Seq);
        solve_upper_triangular_in_place(l.transpose(), x.as_mat_mut(), Par::Seq);
        let mut delta: Vec<f64> = lin.offset.iter().map(|o| -o).collect();
        for i in 0..m {
            delta[s[i]] = x[i] * scale[i];
        }
        delta.iter().all(|d| d.is_finite()).then_some(delta)
    }

    /// The MAP step of `subset` on a fold's training poses (every pose's for
    /// `None`), the `held` columns moved back to nominal.
    fn step(&self, subset: &Subset, held: &[usize], fold: Option<usize>) -> Option<Vec<f64>> {
        let factor = self.factor(&subset.columns, subset.precision_factor, fold)?;
        self.solve(&factor, subset, held, fold)
    }

    /// The objective (weighted sum of squares plus the prior's term) of the
    /// fit of `subset` to every pose: `rᵀr − 2 δᵀb + δᵀAδ` with the step `δ`
    /// of every column (`b = Jᵀr`), plus the prior's term at the new values.
    pub fn objective(&self, subset: &Subset) -> Option<f64> {
        let held = self.held(subset);
        let delta = self.step(subset, &held, None)?;
        Some(self.objective_after(subset, &delta))
    }

    /// The objective of the fit of `subset` to every pose after its step
    /// `delta` (see [`Folds::objective`]).
    fn objective_after(&self, subset: &Subset, delta: &[f64]) -> f64 {
        let lin = self.lin;
        let moved = moving(delta);
        let (a, b) = &self.all;
        let mut objective = self.rtr;
        for &c in &moved {
            objective -= 2.0 * delta[c] * b[c];
            for &d in &moved {
                objective += delta[c] * a[(c, d)] * delta[d];
            }
        }
        for &c in &subset.columns {
            let x = lin.offset[c] + delta[c];
            objective += lin.precision[c] * subset.precision_factor * x * x;
        }
        objective
    }

    /// The columns outside `subset` moved back to nominal that move anything.
    fn held(&self, subset: &Subset) -> Vec<usize> {
        let mut free = vec![false; self.lin.j.ncols()];
        for &c in &subset.columns {
            free[c] = true;
        }
        (0..free.len())
            .filter(|&c| !free[c] && self.lin.offset[c] != 0.0)
            .collect()
    }

    /// The linearised cross-validation of `subset`; `None` when a training
    /// set cannot determine it.
    pub fn evaluate(&self, subset: &Subset) -> Option<Evaluation> {
        let held = self.held(subset);
        self.evaluation(subset, |fold| self.step(subset, &held, fold))
    }

    /// [`Folds::evaluate`] of nested candidates (each one's columns a prefix
    /// of the next one's, all at one prior: the geometric models at one prior
    /// factor), each fold's steps from one factorisation of the largest (each
    /// candidate factorised alone where that one cannot be).
    pub fn evaluate_nested(&self, subsets: &[Subset]) -> Vec<Option<Evaluation>> {
        debug_assert!(subsets.windows(2).all(|w| {
            w[0].precision_factor == w[1].precision_factor
                && w[1].columns.starts_with(&w[0].columns)
        }));
        let Some(largest) = subsets.last() else {
            return Vec::new();
        };
        let folds = (0..self.training.len()).map(Some).chain([None]);
        let factors: Vec<Option<Factor>> = folds
            .map(|fold| self.factor(&largest.columns, largest.precision_factor, fold))
            .collect();
        subsets
            .iter()
            .map(|subset| {
                let held = self.held(subset);
                self.evaluation(subset, |fold| {
                    match &factors[fold.unwrap_or(self.training.len())] {
                        Some(factor) => self.solve(factor, subset, &held, fold),
                        None => self.step(subset, &held, fold),
                    }
                })
            })
            .collect()
    }

    /// The cross-validation of `subset` from its step on each fold's training
    /// poses (`Some(f)`) and on every pose (`None`).
    fn evaluation(
        &self,
        subset: &Subset,
        step: impl Fn(Option<usize>) -> Option<Vec<f64>>,
    ) -> Option<Evaluation> {
        let lin = self.lin;
        let n = lin.poses();
        let mut errors = vec![0.0; n];
        for (f, fold) in self.held_rows.iter().enumerate() {
            let delta = step(Some(f))?;
            // The held-out position rows' residuals after the step, r − J δ,
            // a column of J at a time (it is stored by columns).
            let held = fold.position_rows;
            let mut e = column(&fold.r, 0)[..held].to_vec();
            for c in moving(&delta) {
                for (e, j) in e.iter_mut().zip(&column(&fold.j, c)[..held]) {
                    *e -= j * delta[c];
                }
            }
            let mut e = e.into_iter();
            for &(i, rows) in &fold.poses {
                let sum: f64 = e.by_ref().take(rows).map(|x| x * x).sum();
                errors[i] = sum.sqrt() * lin.noise[i];
            }
        }
        let objective = self.objective_after(subset, &step(None)?);
        let held: Vec<f64> = (0..n)
            .filter(|&i| matches!(self.fold[i], Role::Fold(_)))
            .map(|i| errors[i])
            .collect();
        Some(Evaluation {
            held: HeldOut::of(&held),
            errors,
            objective,
        })
    }
}

/// A factor of a base model's scaled normal matrix on some poses, and the
/// forward solution `L⁻¹ rhs` of its right-hand side.
struct BaseFactor {
    factor: Factor,
    y: Col<f64>,
}

/// A candidate's columns `C` beside a factored base `B` (see [`Extensions`]):
/// `W = L_B⁻¹ N_BC`, the factor of the Schur complement `N_CC − WᵀW`, and the
/// scales of `C` to a unit diagonal.
struct Block {
    w: Mat<f64>,
    schur: Llt<f64>,
    scale: Vec<f64>,
}

/// Candidates that each add a few columns `C` to one base model `B` (each
/// round's effects beside the model fitted so far), solved by blocks: the
/// base's factor `L_B` on each fold's training poses (and on every pose) is
/// computed once, and each candidate only needs `W = L_B⁻¹ N_BC` and the
/// factor `L_C` of its Schur complement `N_CC − WᵀW`, for `[L_B 0; Wᵀ L_C]` is
/// the factor of its whole matrix. The same steps as [`Folds::evaluate`] and
/// [`Folds::objective`] of the base's columns and the candidate's, but about
/// `p²k` operations a fold instead of `p³/3` for a base of `p` columns. The
/// columns outside the base must be at nominal (no column is then moved back,
/// and the base's right-hand side is every candidate's); otherwise each
/// candidate is solved whole.
pub struct Extensions<'f, 'a> {
    folds: &'f Folds<'a>,
    base: Subset,
    /// The base's factor on each fold's training poses, then on every pose;
    /// empty when a column outside the base is not at nominal.
    factors: Vec<Option<BaseFactor>>,
    /// The base's factor of the unit-scaled normal matrix of every pose, no
    /// prior (the test of [`Folds::separable`]).
    plain: Option<Factor>,
}

impl<'a> Folds<'a> {
    /// The candidates that add columns to `base` (see [`Extensions`]).
    pub fn extensions(&self, base: &Subset) -> Extensions<'_, 'a> {
        let lin = self.lin;
        let mut in_base = vec![false; lin.j.ncols()];
        for &c in &base.columns {
            in_base[c] = true;
        }
        let at_nominal = (0..in_base.len()).all(|c| in_base[c] || lin.offset[c] == 0.0);
        let s = &base.columns;
        let m = s.len();
        let factor = |fold: Option<usize>| {
            let factor = self.factor(s, base.precision_factor, fold)?;
            let b = &fold.map_or(&self.all, |f| &self.training[f]).1;
            let precision = |c: usize| lin.precision[c] * base.precision_factor;
            let mut y = Col::from_fn(m, |i| {
                (b[s[i]] - precision(s[i]) * lin.offset[s[i]]) * factor.scale[i]
            });
            solve_lower_triangular_in_place(factor.l.as_ref(), y.as_mat_mut(), Par::Seq);
            Some(BaseFactor { factor, y })
        };
        let factors = if at_nominal {
            (0..self.training.len())
                .map(Some)
                .chain([None])
                .map(factor)
                .collect()
        } else {
            Vec::new()
        };
        Extensions {
            folds: self,
            base: base.clone(),
            factors,
            plain: self.factor(s, 0.0, None),
        }
    }
}

impl Extensions<'_, '_> {
    /// The base's columns and `extra`.
    pub fn subset(&self, extra: &[usize]) -> Subset {
        let mut columns = self.base.columns.clone();
        columns.extend_from_slice(extra);
        Subset {
            columns,
            precision_factor: self.base.precision_factor,
        }
    }

    /// [`Folds::separable`] of the base's columns and `extra` (the base's own
    /// columns must come before `lin.fitted`, the extra ones after).
    pub fn separable(&self, extra: &[usize], separability: f64) -> bool {
        let Some(plain) = &self.plain else {
            return false;
        };
        let Some(block) = self.block(plain, &self.folds.all.0, extra, |_| 0.0) else {
            return false;
        };
        let lc = block.schur.L();
        debug_assert!(self.base.columns.iter().all(|&c| c < self.folds.lin.fitted));
        (0..extra.len()).all(|i| {
            extra[i] < self.folds.lin.fitted || (block.scale[i] > 0.0 && lc[(i, i)] >= separability)
        })
    }

    /// The block of `extra` beside the base's `factor` of the normal matrix
    /// `a` plus `precision` on the diagonal, `extra`'s columns scaled to a
    /// unit diagonal: `W = L_B⁻¹ N_BC` and the factor of `N_CC − WᵀW`.
    fn block(
        &self,
        factor: &Factor,
        a: &Mat<f64>,
        extra: &[usize],
        precision: impl Fn(usize) -> f64,
    ) -> Option<Block> {
        let s = &self.base.columns;
        let k = extra.len();
        let scale: Vec<f64> = extra
            .iter()
            .map(|&c| unit_scale(a[(c, c)] + precision(c)))
            .collect();
        let mut w = Mat::from_fn(s.len(), k, |i, j| {
            a[(s[i], extra[j])] * factor.scale[i] * scale[j]
        });
        solve_lower_triangular_in_place(factor.l.as_ref(), w.as_mut(), Par::Seq);
        let ncc = Mat::from_fn(k, k, |i, j| {
            let prior = if i == j { precision(extra[i]) } else { 0.0 };
            (a[(extra[i], extra[j])] + prior) * scale[i] * scale[j]
        });
        let schur = (ncc - w.transpose() * &w).llt(Side::Lower).ok()?;
        Some(Block { w, schur, scale })
    }

    /// The step of the base's columns and `extra` on a fold's training poses
    /// (every pose's for `None`), by blocks.
    fn step(&self, extra: &[usize], fold: Option<usize>) -> Option<Vec<f64>> {
        let folds = self.folds;
        let lin = folds.lin;
        let shared = self.factors[fold.unwrap_or(folds.training.len())].as_ref()?;
        let (factor, y) = (&shared.factor, &shared.y);
        let (a, b) = fold.map_or(&folds.all, |f| &folds.training[f]);
        let precision = |c: usize| lin.precision[c] * self.base.precision_factor;
        let s = &self.base.columns;
        let k = extra.len();
        let Block { w, schur, scale } = self.block(factor, a, extra, precision)?;
        let rhs = Col::from_fn(k, |i| {
            let c = extra[i];
            (b[c] - precision(c) * lin.offset[c]) * scale[i]
        });
        let x_extra = schur.solve(rhs - w.transpose() * y);
        let mut x_base = y - &w * &x_extra;
        solve_upper_triangular_in_place(factor.l.transpose(), x_base.as_mat_mut(), Par::Seq);
        let mut delta: Vec<f64> = lin.offset.iter().map(|o| -o).collect();
        for (i, &c) in s.iter().enumerate() {
            delta[c] = x_base[i] * factor.scale[i];
        }
        for (i, &c) in extra.iter().enumerate() {
            delta[c] = x_extra[i] * scale[i];
        }
        delta.iter().all(|d| d.is_finite()).then_some(delta)
    }

    /// [`Folds::objective`] of the base's columns and `extra`.
    pub fn objective(&self, extra: &[usize]) -> Option<f64> {
        let subset = self.subset(extra);
        if self.factors.is_empty() {
            return self.folds.objective(&subset);
        }
        let delta = self.step(extra, None)?;
        Some(self.folds.objective_after(&subset, &delta))
    }

    /// [`Folds::evaluate`] of the base's columns and `extra`.
    pub fn evaluate(&self, extra: &[usize]) -> Option<Evaluation> {
        let subset = self.subset(extra);
        if self.factors.is_empty() {
            return self.folds.evaluate(&subset);
        }
        self.folds
            .evaluation(&subset, |fold| self.step(extra, fold))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::calibration::simulate::{measure, random_configurations, rng};
    use crate::io::model_file::load_model;
    use crate::session::configurations::Configurations;

    /// One configuration of the robot seen through three SMRs, each a session
    /// of its own (24 configurations, three points each): the three rows of a
    /// configuration always share a fold, whatever their sessions, so that no
    /// fold is tested on a configuration its training set holds; and every
    /// fold holds some out. Distinct configurations keep `i mod k`.
    #[test]
    fn the_rows_of_one_configuration_share_a_fold() {
        let robot = load_model("puma560").unwrap().robot;
        let qs = random_configurations(&robot, 24, &mut rng(3));
        let mut data = Vec::new();
        for session in 0..3 {
            let mut rows = measure(&robot, &qs, 20e-6, None, &mut rng(session as u64));
            for r in &mut rows {
                r.session = session;
            }
            data.extend(rows);
        }
        let configurations =
            Configurations::of_robot(&robot, &data, crate::cancel::Cancel::NEVER).index(data.len());
        assert_eq!(*configurations.iter().max().unwrap(), 23);
        let contacts: Vec<Contact> = data.iter().map(|o| o.contact).collect();
        let folds = interleaved_folds(&contacts, &configurations, 10);
        for c in 0..24 {
            assert_eq!(folds[c], folds[24 + c], "configuration {c}");
            assert_eq!(folds[c], folds[48 + c], "configuration {c}");
        }
        assert!((0..10).all(|f| folds.contains(&f)));
        // Distinct configurations: pose i in fold i mod k.
        let alone: Vec<usize> = (0..24).collect();
        let folds = interleaved_folds(&contacts[..24], &alone, 10);
        assert!(folds.iter().enumerate().all(|(i, &f)| f == i % 10));
    }
}
