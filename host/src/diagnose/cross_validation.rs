//! Held-out errors: k-fold cross-validation of the tool-point position.
//!
//! Folds are interleaved (pose `i` in fold `i mod k`), so that a drift in time
//! falls into every fold. The figure is the held-out 3-D position error of each
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
//! [`cross_validate`] refits every fold from scratch: the reference the tests
//! hold the linearisation to.

use armcal_shared::Robot;
use armcal_shared::effects::Effect;
use faer::linalg::solvers::Solve;
use faer::{Mat, Side};
use nalgebra::Vector3;

use super::{DiagnoseOptions, position_errors};
use crate::identify::full::{
    FullError, Linearization, Observation, identify_with_effects, unit_diagonal_scale,
};

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

/// k-fold cross-validation of the model of `options.fit` with `effects` and
/// `extra`, every fold fitted from scratch: the held-out position errors of
/// every pose.
pub fn cross_validate(
    nominal: &Robot<f64>,
    effects: &[Effect<f64>],
    extra: &[armcal_shared::Param],
    data: &[Observation],
    options: &DiagnoseOptions,
) -> Result<HeldOut, FullError> {
    let k = options.folds.max(2);
    let mut errors = Vec::with_capacity(data.len());
    for fold in 0..k {
        let (train, test): (Vec<_>, Vec<_>) =
            data.iter().enumerate().partition(|(i, _)| i % k != fold);
        let train: Vec<Observation> = train.into_iter().map(|(_, o)| o.clone()).collect();
        let test: Vec<Observation> = test.into_iter().map(|(_, o)| o.clone()).collect();
        let fit = identify_with_effects(nominal, effects, extra, &train, &options.fit)?;
        errors.extend(position_errors(&fit, &test));
    }
    Ok(HeldOut::of(&errors))
}

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
    fold: Vec<Option<usize>>,
    parts: Vec<(Mat<f64>, Mat<f64>)>,
    all: (Mat<f64>, Mat<f64>),
    rtr: f64,
}

impl<'a> Folds<'a> {
    /// Folds of `lin`'s poses: `fold[i]` is pose `i`'s fold, `None` for a pose
    /// that is always trained on and never held out.
    pub fn new(lin: &'a Linearization, fold: Vec<Option<usize>>) -> Self {
        let columns = lin.j.ncols();
        let k = fold.iter().flatten().max().map_or(0, |m| m + 1);
        let zero = || {
            (
                Mat::<f64>::zeros(columns, columns),
                Mat::<f64>::zeros(columns, 1),
            )
        };
        let mut parts: Vec<(Mat<f64>, Mat<f64>)> = (0..k).map(|_| zero()).collect();
        let mut always = zero();
        for (i, f) in fold.iter().enumerate() {
            let (a, b) = match f {
                Some(f) => &mut parts[*f],
                None => &mut always,
            };
            for row in lin.rows_of(i) {
                for c in 0..columns {
                    let jc = lin.j[(row, c)];
                    if jc == 0.0 {
                        continue;
                    }
                    b[(c, 0)] += jc * lin.r[(row, 0)];
                    for d in 0..=c {
                        a[(c, d)] += jc * lin.j[(row, d)];
                    }
                }
            }
        }
        let mut all = always;
        for (a, b) in &parts {
            all.0 += a;
            all.1 += b;
        }
        for c in 0..columns {
            for d in 0..c {
                all.0[(d, c)] = all.0[(c, d)];
                for (a, _) in &mut parts {
                    a[(d, c)] = a[(c, d)];
                }
            }
        }
        Self {
            lin,
            fold,
            parts,
            all,
            rtr: lin.r.squared_norm_l2(),
        }
    }

    /// Interleaved folds over every pose: pose `i` in fold `i mod k`.
    pub fn interleaved(lin: &'a Linearization, k: usize) -> Self {
        let n = lin.first_rows.len();
        let k = k.clamp(2, n.max(2));
        Self::new(lin, (0..n).map(|i| Some(i % k)).collect())
    }

    /// Whether every column of `columns` from index `lin.fitted` on keeps at
    /// least `separability` of its (unit) norm beside the columns before it:
    /// a candidate the data cannot tell apart from the model is not scored.
    pub fn separable(&self, columns: &[usize], separability: f64) -> bool {
        let m = columns.len();
        let a = Mat::from_fn(m, m, |i, j| self.all.0[(columns[i], columns[j])]);
        let scale = unit_diagonal_scale(&a);
        let scaled = Mat::from_fn(m, m, |i, j| a[(i, j)] * scale[i] * scale[j]);
        let Ok(llt) = scaled.llt(Side::Lower) else {
            return false;
        };
        let l = llt.L();
        (0..m)
            .filter(|&i| columns[i] >= self.lin.fitted)
            .all(|i| scale[i] > 0.0 && l[(i, i)] >= separability)
    }

    /// The MAP step of `subset` from the normal matrix `a` and right-hand side
    /// `b` of some poses: the step of every column (the free ones solved, the
    /// others moved back to nominal).
    fn step(&self, subset: &Subset, a: &Mat<f64>, b: &Mat<f64>) -> Option<Vec<f64>> {
        let lin = self.lin;
        let s = &subset.columns;
        let m = s.len();
        let mut delta: Vec<f64> = lin.offset.iter().map(|o| -o).collect();
        let held: Vec<usize> = (0..lin.j.ncols()).filter(|c| !s.contains(c)).collect();
        let precision = |c: usize| lin.precision[c] * subset.precision_factor;
        let n = Mat::from_fn(m, m, |i, j| {
            a[(s[i], s[j])] + if i == j { precision(s[i]) } else { 0.0 }
        });
        let rhs = Mat::from_fn(m, 1, |i, _| {
            let c = s[i];
            b[(c, 0)] + held.iter().map(|&h| a[(c, h)] * lin.offset[h]).sum::<f64>()
                - precision(c) * lin.offset[c]
        });
        let scale = unit_diagonal_scale(&n);
        let scaled = Mat::from_fn(m, m, |i, j| n[(i, j)] * scale[i] * scale[j]);
        let llt = scaled.llt(Side::Lower).ok()?;
        let x = llt.solve(&Mat::from_fn(m, 1, |i, _| rhs[(i, 0)] * scale[i]));
        for i in 0..m {
            delta[s[i]] = x[(i, 0)] * scale[i];
        }
        delta.iter().all(|d| d.is_finite()).then_some(delta)
    }

    /// The linearised cross-validation of `subset`; `None` when a training
    /// set cannot determine it.
    pub fn evaluate(&self, subset: &Subset) -> Option<Evaluation> {
        let lin = self.lin;
        let columns = lin.j.ncols();
        let n = lin.first_rows.len();
        let mut errors = vec![0.0; n];
        for (f, (ak, bk)) in self.parts.iter().enumerate() {
            let delta = self.step(subset, &(&self.all.0 - ak), &(&self.all.1 - bk))?;
            for i in (0..n).filter(|&i| self.fold[i] == Some(f)) {
                let row = lin.first_rows[i];
                let e = Vector3::from_fn(|axis, _| {
                    lin.r[(row + axis, 0)]
                        - (0..columns)
                            .map(|c| lin.j[(row + axis, c)] * delta[c])
                            .sum::<f64>()
                });
                errors[i] = e.norm() * lin.position_noise;
            }
        }
        // The fit to every pose: r'ᵀr' − 2 δᵀb' + δᵀAδ with the step δ of every
        // column (b' = Jᵀr), plus the prior's term at the new values.
        let delta = self.step(subset, &self.all.0, &self.all.1)?;
        let (a, b) = &self.all;
        let mut objective = self.rtr;
        for c in 0..columns {
            objective -= 2.0 * delta[c] * b[(c, 0)];
            for d in 0..columns {
                objective += delta[c] * a[(c, d)] * delta[d];
            }
        }
        for &c in &subset.columns {
            let x = lin.offset[c] + delta[c];
            objective += lin.precision[c] * subset.precision_factor * x * x;
        }
        let held: Vec<f64> = (0..n)
            .filter(|&i| self.fold[i].is_some())
            .map(|i| errors[i])
            .collect();
        Some(Evaluation {
            held: HeldOut::of(&held),
            errors,
            objective,
        })
    }
}
