//! The linearisation about a fit's solution: the stored Jacobian and residual
//! of every unknown ([`linearize`]) and the normal equations summed fold by
//! fold ([`fold_normals`]), what the cross-validations of `diagnose` and of
//! the prior's scale ([`crate::calibration::identify::prior_scale`]) step from.

use armcal_shared::{FrameAxis, Param};
use faer::{Col, Mat};
use nalgebra::Point3;

use super::rows::{DistanceRows, LinearSystem, NormalEquations};
use super::{Constraints, Extension, FullFit, Model, PlaneEstimate, Status, Unknown};
use crate::calibration::dense;
use crate::cancel::Cancel;
use crate::session::channel::Channel;
use crate::session::channel::{PerChannel, Weighed, WeightFactors};
use crate::session::configurations::Configurations;
use crate::session::observation::Contact;
use crate::session::prior::Prior;
use crate::session::rows::Rows;

/// The model at a fit's solution and the unknowns of a linearisation about
/// it ([`linearize`], [`fold_normals`]): the fit's identified parameters, its
/// points, planes and effects, then `extra` and `effects`'s parameters.
pub(super) struct AtFit {
    pub(super) model: Model,
    pub(super) unknowns: Vec<Unknown>,
    pub(super) fitted: usize,
    pub(super) precision: Vec<f64>,
    pub(super) offset: Vec<f64>,
}

impl AtFit {
    pub(super) fn of(
        fit: &FullFit,
        Extension { effects, extra }: Extension<'_>,
        constraints: &Constraints,
        prior: &Prior,
    ) -> Self {
        let mut model = Model::of(fit.calibrated.clone(), fit.fitted_effects());
        model.constraints = constraints.clone();
        model.registrations = fit.registrations.clone();
        model.points = fit.points.iter().map(|p| p.position).collect();
        model.planes = fit
            .planes
            .iter()
            .map(|p| PlaneEstimate::through(&Point3::from(p.normal * p.offset), &p.normal))
            .collect();
        let identified = |s: &Status| matches!(s, Status::Identified { .. });
        // Orientations not used: no row weighs the tool's rotation (it was
        // registered to them apart), no step moves it.
        let weighed = |p: Param| {
            fit.weights[Weighed::Orientation] > 0.0
                || !matches!(
                    p,
                    Param::Tool(FrameAxis::Rx | FrameAxis::Ry | FrameAxis::Rz)
                )
        };
        let mut unknowns: Vec<Unknown> = Vec::new();
        let mut offset: Vec<f64> = Vec::new();
        for p in fit
            .params
            .iter()
            .filter(|p| identified(&p.status) && weighed(p.param))
        {
            unknowns.push(Unknown::Param(p.param));
            offset.push(p.error);
        }
        for (session, own) in fit.sessions.iter().enumerate() {
            for (param, _, _) in own.frames.iter().filter(|f| identified(&f.2)) {
                unknowns.push(Unknown::Session {
                    session,
                    param: *param,
                });
            }
        }
        offset.resize(unknowns.len(), 0.0);
        for (point, p) in fit.points.iter().enumerate() {
            unknowns.extend(
                (0..3)
                    .filter(|&a| p.std[a].is_finite())
                    .map(|axis| Unknown::Point { point, axis }),
            );
        }
        for plane in 0..fit.planes.len() {
            unknowns.extend((0..3).map(|component| Unknown::Plane { plane, component }));
        }
        for (effect, e) in fit.effects.iter().enumerate() {
            for (component, _) in e.status.iter().enumerate().filter(|(_, s)| identified(s)) {
                unknowns.push(Unknown::Effect { effect, component });
            }
        }
        let fitted = unknowns.len();
        unknowns.extend(extra.iter().map(|p| Unknown::Param(*p)));
        for e in effects {
            let effect = model.effects.len();
            model.effects.push(*e);
            unknowns.extend(
                (0..e.parameter_count()).map(|component| Unknown::Effect { effect, component }),
            );
        }
        // Only the geometry is off its nominal value: points, planes and effects
        // have no prior's centre.
        offset.resize(unknowns.len(), 0.0);
        let precision = unknowns
            .iter()
            .map(|u| match u {
                Unknown::Param(p) => prior.precision(*p),
                Unknown::Effect { .. }
                | Unknown::Point { .. }
                | Unknown::Plane { .. }
                | Unknown::Session { .. } => 0.0,
            })
            .collect();
        Self {
            model,
            unknowns,
            fitted,
            precision,
            offset,
        }
    }
}

/// The weighted linearisation of a fitted model, extended: the Jacobian columns
/// of `fit`'s identified unknowns (geometry, the identified coordinates of a
/// constraint session's points and every parameter of its planes, then its
/// effects' parameters), then of the `extra` geometric parameters, then of the
/// parameters of `effects` (at their values, usually zero), all at `fit`'s
/// solution; and the weighted residual. Rows as in the fit: per pose 3
/// position rows (divided by the noise of its kind), or 1 for a touch of a
/// plane, then 3 orientation rows when measured; then one row per known
/// distance of `constraints` (empty for a session of coordinates), after the
/// poses in [`Linearization::first_rows`] (a cross-validation trains on them
/// always). Each column carries its `prior` precision and its current offset
/// from nominal, so that a solve on any subset of the poses is the MAP step of
/// the fit. What [`crate::calibration::diagnose`] cross-validates models with,
/// by one Gauss–Newton step per fold.
pub fn linearize<'a>(
    fit: &FullFit,
    extension: Extension<'_>,
    data: impl Into<Rows<'a>>,
    constraints: &Constraints,
    prior: &Prior,
) -> Linearization {
    let data = data.into();
    let AtFit {
        model,
        unknowns,
        fitted,
        precision,
        offset,
    } = AtFit::of(fit, extension, constraints, prior);
    let weights = fit.weights();
    // Asked to stop while its rows were made: the linearisation of no pose
    // (its known distances alone), which the caller's next check drops.
    let (sys, data) = match LinearSystem::build(&model, data, &unknowns, &weights, fit.cancel) {
        Some(sys) => (sys, data),
        None => (LinearSystem::empty(unknowns.len()), data.slice(0..0)),
    };
    let distances = DistanceRows::rows(&model, &unknowns);
    let poses_rows = sys.j.nrows();
    let (j, r) = if distances.is_empty() {
        (sys.j, sys.r)
    } else {
        let rows = poses_rows + distances.len();
        let j = Mat::from_fn(rows, unknowns.len(), |i, c| {
            if i < poses_rows {
                sys.j[(i, c)]
            } else {
                distances[i - poses_rows].0[c]
            }
        });
        let r = Mat::from_fn(rows, 1, |i, _| {
            if i < poses_rows {
                sys.r[(i, 0)]
            } else {
                distances[i - poses_rows].1
            }
        });
        (j, r)
    };
    let mut first_rows = Vec::with_capacity(data.len() + distances.len());
    let mut row = 0;
    for obs in data {
        first_rows.push(row);
        row += obs.equations();
    }
    first_rows.extend(poses_rows..poses_rows + distances.len());
    Linearization {
        j,
        r,
        first_rows,
        contacts: data.iter().map(|o| o.contact).collect(),
        configurations: Configurations::of_robot(&fit.calibrated, data, fit.cancel)
            .index(data.len()),
        fitted,
        noise: data
            .iter()
            .map(|o| fit.row_scale(o.channel()))
            .chain(constraints.distances.iter().map(|d| d.std))
            .collect(),
        unknowns,
        precision,
        offset,
        cancel: fit.cancel,
    }
}

/// A weighted linearisation ([`linearize`]).
pub struct Linearization {
    /// Weighted Jacobian, rows × unknowns.
    pub j: Mat<f64>,
    /// Weighted residual, rows × 1.
    pub r: Mat<f64>,
    /// The first row of each pose (its 3 position rows; then 3 orientation
    /// rows if measured), then of each known distance.
    pub first_rows: Vec<usize>,
    /// What each pose's tool point is held to, one per pose (its folds follow it:
    /// [`crate::calibration::validation::folds::interleaved_folds`]).
    pub contacts: Vec<Contact>,
    /// The robot configuration of each pose: its index among the joint
    /// configurations of the poses, whatever point or session measured them
    /// ([`crate::session::configurations::Configurations::of_robot`]): a
    /// fold holds a configuration out whole.
    pub configurations: Vec<usize>,
    /// How many leading columns are the fit's own unknowns.
    pub fitted: usize,
    /// The noise the position rows of each pose (the rows of its tool point:
    /// a measured position or a contact) are divided by, then of each
    /// distance row: m, in the order of [`Linearization::first_rows`].
    pub noise: Vec<f64>,
    /// The unknown of each column.
    pub unknowns: Vec<Unknown>,
    /// The prior precision `1/τ²` of each column (0: none).
    pub precision: Vec<f64>,
    /// Each column's value less its nominal value (its prior's centre), SI.
    pub offset: Vec<f64>,
    /// The fit's request to stop ([`FullFit::cancel`]): what is computed
    /// from the linearisation asks it too.
    pub cancel: Cancel,
}

impl Linearization {
    /// How many of [`Linearization::first_rows`] are poses; the others are
    /// known distances, which a cross-validation trains on in every fold.
    pub fn poses(&self) -> usize {
        self.contacts.len()
    }

    /// The rows of pose `i`.
    pub fn rows_of(&self, i: usize) -> std::ops::Range<usize> {
        self.first_rows[i]
            ..self
                .first_rows
                .get(i + 1)
                .copied()
                .unwrap_or(self.j.nrows())
    }

    /// The rows of `poses` (indices into [`Linearization::first_rows`]: poses
    /// or known distances), in order: their Jacobian and weighted residual.
    pub fn gathered(&self, poses: &[usize]) -> (Mat<f64>, Mat<f64>) {
        let runs: Vec<std::ops::Range<usize>> = poses.iter().map(|&i| self.rows_of(i)).collect();
        self.rows(&runs)
    }

    /// The rows in `runs`, in order: their Jacobian and weighted residual,
    /// gathered a column at a time.
    pub fn rows(&self, runs: &[std::ops::Range<usize>]) -> (Mat<f64>, Mat<f64>) {
        let index: Vec<usize> = runs.iter().flat_map(|r| r.clone()).collect();
        let gather = |from: &Mat<f64>| {
            let mut into = Mat::zeros(index.len(), from.ncols());
            for c in 0..from.ncols() {
                let column = dense::column(from, c);
                let into = into
                    .col_mut(c)
                    .try_as_col_major_mut()
                    .expect(dense::CONTIGUOUS)
                    .as_slice_mut();
                for (into, &row) in into.iter_mut().zip(&index) {
                    *into = column[row];
                }
            }
            into
        };
        (gather(&self.j), gather(&self.r))
    }
}

/// The normal equations of some rows: `JᵀJ` and `Jᵀr`.
pub type Normal = (Mat<f64>, Col<f64>);

/// A fold's held-out rows of one tool-point channel (a measured position or
/// a contact; not the orientation), each row in m (multiplied back by what
/// the fit divided it by), so that `‖r − Jδ‖²` of those rows is in m².
pub struct HeldRows {
    /// `JᵀJ` of the rows, m².
    pub a: Mat<f64>,
    /// `Jᵀr` of the rows, m.
    pub b: Col<f64>,
    /// `rᵀr` of the rows, m².
    pub rtr: f64,
    /// The poses they belong to.
    pub poses: usize,
}

/// One fold's share of the normal equations about a fit ([`fold_normals`]).
pub struct FoldNormal {
    /// `JᵀJ` of the fold's pose rows, every channel, each row divided as in
    /// the fit (by its noise, times the square root of its weight's factor).
    pub a: Mat<f64>,
    /// `Jᵀr` of the same rows.
    pub b: Col<f64>,
    /// Each channel's share of `a` and `b` (zero for a channel without
    /// rows): what another weight of the channel scales
    /// ([`crate::calibration::identify::channel_weight`]).
    pub shares: PerChannel<Normal>,
    /// Each tool-point channel's rows, in m (`None` for the orientations
    /// and for a channel without rows in the fold).
    pub held: PerChannel<Option<HeldRows>>,
    /// The fold's poses.
    pub poses: usize,
}

/// The normal equations about a fit's solution, summed fold by fold: all a
/// linearised k-fold cross-validation of the fit's unknowns at another prior
/// or other channel weights needs, in memory independent of the number of
/// poses (`O(k p²)`).
pub struct FoldNormals {
    /// Each fold's.
    pub folds: Vec<FoldNormal>,
    /// `JᵀJ` and `Jᵀr` of every row: each fold's poses and the known
    /// distances (trained on in every fold).
    pub all: Normal,
    /// Each channel's share of `all`.
    pub shares: PerChannel<Normal>,
    /// The factors the fit weighed each kind of row by: the shares' weights.
    pub fitted: WeightFactors,
    /// Each unknown's prior precision `1/τ²` (0: none).
    pub precision: Vec<f64>,
    /// Each unknown's value less its nominal value (its prior's centre), SI.
    pub offset: Vec<f64>,
}

/// The normal equations of the fit's unknowns (those of [`linearize`]
/// without effects or extras) at its solution, summed over the poses of each
/// fold: pose `i` in fold `fold[i]` of `k`. One pass over the poses, however
/// many folds.
pub fn fold_normals(
    fit: &FullFit,
    data: Rows<'_>,
    constraints: &Constraints,
    prior: &Prior,
    fold: &[usize],
    k: usize,
) -> FoldNormals {
    let AtFit {
        model,
        unknowns,
        precision,
        offset,
        ..
    } = AtFit::of(fit, Extension::NONE, constraints, prior);
    let weights = fit.weights();
    let p = unknowns.len();
    // The sums as they are, in faer: `Jᵀr` as a column.
    let normal = |jtj: &Mat<f64>, jtr: &Mat<f64>| (jtj.clone(), jtr.col(0).to_owned());
    let zero = || (Mat::zeros(p, p), Col::zeros(p));
    let folds: Vec<FoldNormal> = (0..k)
        .map(|f| {
            let picked =
                data.positions_of((0..data.len().min(fold.len())).filter(|&i| fold[i] == f));
            let poses = Rows::picked(data.all(), &picked);
            let sums = NormalEquations::accumulate(&model, poses, &unknowns, &weights, fit.cancel);
            let mut fold = FoldNormal {
                a: Mat::zeros(p, p),
                b: Col::zeros(p),
                shares: PerChannel::from_fn(|_| zero()),
                held: PerChannel::default(),
                poses: poses.len(),
            };
            for c in Channel::ALL {
                let (a, b) = normal(&sums.jtj[c], &sums.jtr[c]);
                if c != Channel::Orientation && sums.rows[c] > 0 {
                    let s2 = fit.row_scale(c).powi(2);
                    fold.held[c] = Some(HeldRows {
                        a: &a * s2,
                        b: &b * s2,
                        rtr: sums.rtr[c] * s2,
                        poses: poses.iter().filter(|o| o.channel() == c).count(),
                    });
                }
                fold.a += &a;
                fold.b += &b;
                fold.shares[c] = (a, b);
            }
            fold
        })
        .collect();
    let distances = DistanceRows::of(&model, &unknowns);
    let mut all = normal(&distances.jtj, &distances.jtr);
    let mut shares = PerChannel::from_fn(|_| zero());
    for fold in &folds {
        all.0 += &fold.a;
        all.1 += &fold.b;
        for c in Channel::ALL {
            shares[c].0 += &fold.shares[c].0;
            shares[c].1 += &fold.shares[c].1;
        }
    }
    FoldNormals {
        folds,
        all,
        shares,
        fitted: fit.weights,
        precision,
        offset,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::calibration::fit::{FitRequest, FullOptions};
    use crate::calibration::simulate::{Scenario, simulate};
    use crate::calibration::validation::blunders::deleted_residuals;
    use crate::cancel::Interrupt;
    use crate::io::model_file::load_model;

    /// A linearisation asked to stop before its Jacobian is made is of no
    /// pose (none of its rows allocated), and the deleted residuals computed
    /// from it stop at their first question; never asked, it has every
    /// pose's rows, as the fit does.
    #[test]
    fn a_linearisation_asked_to_stop_is_of_no_pose() {
        let nominal = load_model("ur5e").unwrap().robot;
        let data = simulate(&nominal, &Scenario::tracker(40, 5))
            .unwrap()
            .observations;
        let options = FullOptions::default();
        let mut fit = FitRequest::new(&nominal, &data, &options).run().unwrap();
        let none = Constraints::default();
        let whole = linearize(&fit, Extension::NONE, &data, &none, &options.prior);
        assert_eq!((whole.poses(), whole.j.nrows()), (40, 120));
        let interrupt = Interrupt::new();
        interrupt.raise();
        fit.cancel = interrupt.cancel();
        let stopped = linearize(&fit, Extension::NONE, &data, &none, &options.prior);
        assert_eq!((stopped.poses(), stopped.j.nrows()), (0, 0));
        assert_eq!(stopped.j.ncols(), whole.j.ncols());
        assert!(deleted_residuals(&stopped, &[]).is_none());
    }

    /// The Jacobian zeroed a few columns at a time is [`Mat::zeros`]: the
    /// same shape and layout, every entry zero.
    #[test]
    fn the_jacobian_zeroed_in_steps_is_the_zero_matrix() {
        use crate::calibration::fit::rows::stoppable_zeros;
        let (rows, cols) = (1001, 2 * 8 + 3);
        let zeros = stoppable_zeros(rows, cols, Cancel::NEVER).unwrap();
        let whole = Mat::<f64>::zeros(rows, cols);
        assert_eq!(zeros.shape(), whole.shape());
        assert_eq!(zeros.col_stride(), whole.col_stride());
        assert!(zeros.col_iter().all(|c| c.iter().all(|&x| x == 0.0)));
        let interrupt = Interrupt::new();
        interrupt.raise();
        assert!(stoppable_zeros(rows, cols, interrupt.cancel()).is_none());
    }
}
