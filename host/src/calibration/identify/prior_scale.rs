//! The prior's scale, chosen on held-out poses: what `armcal identify` fits
//! by default.
//!
//! The prior on the D-H parameter errors ([`crate::calibration::fit::prior`]) states a scale
//! (1 mm and 1 mrad unless the model file or the flags say otherwise), the
//! tolerances of an industrial arm. A real arm can be off by more — a joint
//! mastered 20 mrad off, a link machined for another variant — or by less.
//! Too tight a prior pulls the parameters the data determine poorly toward
//! nominal, and the calibration predicts new poses worse than the data allow;
//! too loose a one lets them follow the noise. Which scale predicts best is
//! measured, as [`crate::calibration::diagnose`] measures it: the linearised
//! k-fold cross-validation of the tool point about the fit at the stated
//! prior, each factor `f` of [`PRIOR_FACTORS`] scored by the RMS of the
//! held-out tool-point errors (m; for a session without a tracker, of the
//! distances of the tool points to their fixed points or planes).
//!
//! About the fit's solution (the weighted normal equations `A`, `b = Jᵀr`
//! summed per fold, each unknown's prior precision `P` and offset `o` from
//! nominal), fold `k`'s training poses give the MAP step
//!
//! `(A − A_k + P/f²) δ = (b − b_k) − (P/f²) o`
//!
//! and its held-out tool-point rows, in m, the sum of squares
//!
//! `‖r_k − J_k δ‖² = r_kᵀr_k − 2 δᵀ(J_kᵀr_k) + δᵀ(J_kᵀJ_k) δ`.
//!
//! Every factor is scored from the folds' sums, which one pass over the
//! poses gathers ([`fold_normals`]): the time of one iteration of the fit and
//! memory independent of the number of poses. The step is the Gauss–Newton
//! step of the fit at `f` from the fit at the stated prior; its error is of
//! second order in the parameters' change (µm on a metre arm for a change of
//! tens of mrad), far below the noise the scores differ by. The factor of
//! least held-out RMS is chosen (the smaller on a tie) and the fit is made
//! again at it; the known distances of a session without a tracker are
//! trained on in every fold.
//!
//! When the data determine the geometry so well that no factor could change
//! the held-out residuals' sum of squares by a tenth of its own sampling
//! error ([`immaterial`]: a PUMA 560 tracker session from 10³ positions on), no cross-validation
//! could tell the scales apart, and the stated one is kept without one.

use crate::calibration::dense::unit_scale;
use crate::calibration::fit::{FoldNormals, FullFit, fold_normals};
use crate::calibration::validation::folds::DEFAULT_FOLDS;
use crate::calibration::validation::folds::interleaved_folds;
use crate::session::channel::{Channel, UNUSED, Weighed, WeightFactors};
use crate::session::configurations::Configurations;
use crate::session::constraints::Constraints;
use crate::session::observation::Observation;
use crate::session::prior::{PRIOR_FACTORS, Prior};
use faer::linalg::solvers::Solve;
use faer::{Col, Mat, Side};

/// How the identification sets the prior's scale.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PriorScale {
    /// As stated (the flags, the model file's `[prior]`, else 1 mm, 1 mrad).
    Stated,
    /// The stated scale times the factor of [`PRIOR_FACTORS`] of least
    /// held-out error over `folds` interleaved folds.
    Chosen {
        /// Folds of the cross-validation.
        folds: usize,
    },
}

impl Default for PriorScale {
    fn default() -> Self {
        Self::Chosen {
            folds: DEFAULT_FOLDS,
        }
    }
}

/// One factor's held-out score.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PriorScore {
    /// The factor on the stated scale.
    pub factor: f64,
    /// The RMS of the held-out tool-point errors, m.
    pub held_out: f64,
}

/// What the choice of the prior's scale found.
#[derive(Clone, Debug, PartialEq)]
pub enum PriorChoice {
    /// Every factor scored: the factor of least held-out RMS, fitted at.
    CrossValidated {
        /// The factor on the stated scale the calibration is fitted at.
        factor: f64,
        /// Folds of the cross-validation.
        folds: usize,
        /// Each factor a training set of every fold determines, in the order
        /// of [`PRIOR_FACTORS`].
        scores: Vec<PriorScore>,
    },
    /// The data determine the geometry so well that no factor tried could
    /// change the held-out sum of squares by [`IMMATERIAL`] of its sampling
    /// error: the stated scale, nothing cross-validated.
    Immaterial,
    /// No training set of the folds determines the model at any factor: the
    /// stated scale.
    Undetermined {
        /// Folds of the cross-validation.
        folds: usize,
    },
}

impl PriorChoice {
    /// The factor on the stated scale the calibration is fitted at.
    pub fn factor(&self) -> f64 {
        match self {
            Self::CrossValidated { factor, .. } => *factor,
            Self::Immaterial | Self::Undetermined { .. } => 1.0,
        }
    }

    /// The chosen factor's held-out RMS, m, when it was scored.
    pub fn held_out(&self) -> Option<f64> {
        self.score_of(self.factor())
    }

    /// Factor `factor`'s held-out RMS, m, when it was scored.
    pub fn score_of(&self, factor: f64) -> Option<f64> {
        match self {
            Self::CrossValidated { scores, .. } => scores
                .iter()
                .find(|s| s.factor == factor)
                .map(|s| s.held_out),
            Self::Immaterial | Self::Undetermined { .. } => None,
        }
    }
}

/// The largest change of the held-out residuals' sum of squares, in units of
/// its sampling error, that a prior's scale may cause and still not matter:
/// a tenth — a cross-validation could not tell the scales apart.
pub const IMMATERIAL: f64 = 0.1;

/// Whether no factor of [`PRIOR_FACTORS`] could change `fit`'s held-out sum
/// of squares by [`IMMATERIAL`] of its sampling error
/// ([`FullFit::prior_reach`]).
pub fn immaterial(fit: &FullFit) -> bool {
    fit.prior_reach <= IMMATERIAL
}

/// Scores each factor of [`PRIOR_FACTORS`] on `prior` (the prior `fit` was
/// made at) by the linearised cross-validation of `data` in `folds`
/// interleaved folds about `fit`, and picks the least.
pub fn choose(
    fit: &FullFit,
    data: &[Observation],
    constraints: &Constraints,
    prior: &Prior,
    folds: usize,
) -> PriorChoice {
    if immaterial(fit) {
        return PriorChoice::Immaterial;
    }
    let (k, sums) = fold_sums(fit, data, constraints, prior, folds);
    choose_among(fit, (k, &sums), &WeightFactors::NOISE)
}

/// The factors of the prior's scale worth scoring about `fit`: every one of
/// [`PRIOR_FACTORS`] when the scale is chosen (`chosen`) and material, else
/// the stated scale alone.
pub(crate) fn factors_to_score(fit: &FullFit, chosen: bool) -> &'static [f64] {
    if chosen && !immaterial(fit) {
        &PRIOR_FACTORS
    } else {
        &[1.0]
    }
}

/// The factor of [`PRIOR_FACTORS`] of least held-out error over the `k`
/// folds' normal equations `sums` about `fit`, every kind of row weighed by
/// `weights`; immaterial when no factor could matter.
pub(crate) fn choose_among(
    fit: &FullFit,
    (k, sums): (usize, &FoldNormals),
    weights: &WeightFactors,
) -> PriorChoice {
    if immaterial(fit) {
        return PriorChoice::Immaterial;
    }
    let scores = scores(sums, weights);
    // The first least: the smaller factor on a tie.
    match scores
        .iter()
        .min_by(|a, b| a.held_out.total_cmp(&b.held_out))
    {
        Some(least) => PriorChoice::CrossValidated {
            factor: least.factor,
            folds: k,
            scores,
        },
        None => PriorChoice::Undetermined { folds: k },
    }
}

/// The score of each factor of [`PRIOR_FACTORS`] a training set of every
/// fold of `sums` determines, every kind of row weighed by `weights`.
fn scores(sums: &FoldNormals, weights: &WeightFactors) -> Vec<PriorScore> {
    PRIOR_FACTORS
        .iter()
        .filter_map(|&factor| {
            held_out(sums, factor, weights).map(|held_out| PriorScore { factor, held_out })
        })
        .collect()
}

/// The folds used (`folds`, at least 2 and at most one per pose) and the
/// normal equations about `fit` summed over each ([`fold_normals`]): the
/// poses of `data` in interleaved folds, a robot configuration held out whole.
pub(crate) fn fold_sums(
    fit: &FullFit,
    data: &[Observation],
    constraints: &Constraints,
    prior: &Prior,
    folds: usize,
) -> (usize, FoldNormals) {
    let contacts: Vec<_> = data.iter().map(|o| o.contact).collect();
    let k = folds.clamp(2, data.len().max(2));
    let configurations =
        Configurations::of_robot(&fit.calibrated, data, fit.cancel).index(data.len());
    let fold = interleaved_folds(&contacts, &configurations, k);
    (
        k,
        fold_normals(fit, data.into(), constraints, prior, &fold, k),
    )
}

/// The RMS of the held-out tool-point errors at `factor` times the prior
/// `sums` were gathered at, every kind of row weighed by `weights`, m; `None`
/// when a fold's training poses cannot determine the unknowns.
fn held_out(sums: &FoldNormals, factor: f64, weights: &WeightFactors) -> Option<f64> {
    let steps = fold_steps(sums, factor, weights)?;
    let (squares, poses) = held_out_squares(sums, &steps, None);
    (poses > 0 && squares.is_finite()).then(|| (squares.max(0.0) / poses as f64).sqrt())
}

/// Each fold's MAP step from the fit `sums` were gathered about, at
/// `factor` times its prior and each kind of row's weight at the factor
/// `weights` gives it (relative to its noise's; a kind not used at
/// [`UNUSED`], its limit); `None` when a fold's training poses cannot
/// determine the unknowns.
pub(crate) fn fold_steps(
    sums: &FoldNormals,
    factor: f64,
    weights: &WeightFactors,
) -> Option<Vec<Col<f64>>> {
    let p = sums.offset.len();
    let precision: Vec<f64> = sums
        .precision
        .iter()
        .map(|q| q / (factor * factor))
        .collect();
    // What each weighed kind's share is taken down by, from the weight it
    // was gathered at to the weight asked.
    let less = |w: Weighed| 1.0 - weights[w].max(UNUSED) / sums.fitted.fitted(w);
    let channels: Vec<(Channel, f64)> = Weighed::ALL
        .into_iter()
        .map(|w| (w.channel(), less(w)))
        .filter(|&(_, less)| less != 0.0)
        .collect();
    let (a, b) = &sums.all;
    let (mut a, mut b) = (a.clone(), b.clone());
    for &(c, less) in &channels {
        a -= &sums.shares[c].0 * less;
        b -= &sums.shares[c].1 * less;
    }
    sums.folds
        .iter()
        .map(|fold| {
            let mut a = &a - &fold.a;
            let mut b = &b - &fold.b;
            for &(c, less) in &channels {
                a += &fold.shares[c].0 * less;
                b += &fold.shares[c].1 * less;
            }
            let rhs = Col::from_fn(p, |i| b[i] - precision[i] * sums.offset[i]);
            // Scaled to a unit diagonal, for the conditioning of the factorisation.
            let scale: Vec<f64> = (0..p)
                .map(|i| unit_scale(a[(i, i)] + precision[i]))
                .collect();
            let n = Mat::from_fn(p, p, |i, j| {
                let prior = if i == j { precision[i] } else { 0.0 };
                (a[(i, j)] + prior) * scale[i] * scale[j]
            });
            let x = n
                .llt(Side::Lower)
                .ok()?
                .solve(Col::from_fn(p, |i| rhs[i] * scale[i]));
            Some(Col::from_fn(p, |i| x[i] * scale[i]))
        })
        .collect()
}

/// The held-out tool-point rows' sum of squares after each fold's step
/// `steps`, m², and the poses held out: of every tool-point channel but
/// `except`.
pub(crate) fn held_out_squares(
    sums: &FoldNormals,
    steps: &[Col<f64>],
    except: Option<Channel>,
) -> (f64, usize) {
    sums.folds
        .iter()
        .zip(steps)
        .fold((0.0, 0), |(mut squares, mut poses), (fold, delta)| {
            for (c, held) in Channel::ALL.into_iter().zip(&fold.held.0) {
                if let (Some(held), true) = (held, Some(c) != except) {
                    squares += held.rtr - 2.0 * (delta.transpose() * &held.b)
                        + delta.transpose() * (&held.a * delta);
                    poses += held.poses;
                }
            }
            (squares, poses)
        })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::calibration::fit::{Extension, FitRequest, FullOptions, linearize};
    use crate::calibration::identify::{IdentifyRequest, identify};
    use crate::calibration::simulate::{Scenario, simulate};
    use crate::calibration::validation::folds::{Folds, Subset};
    use crate::io::measurements::{load_measurements, parse_measurements};
    use crate::io::model_file::{load_model, load_model_with};
    use crate::io::urdf::ChainSpec;
    use crate::session::measurements::Measurements;
    use crate::session::model::RobotModel;

    /// A simulated tracker session of `model`: `poses` positions of a robot
    /// off nominal by up to `errors` (m, rad) on every parameter.
    fn tracker(model: &str, poses: usize, errors: f64, seed: u64) -> (RobotModel, Measurements) {
        let model = load_model(model).unwrap();
        let scenario = Scenario {
            errors: crate::calibration::simulate::ErrorSizes::uniform(errors, errors),
            ..Scenario::tracker(poses, seed)
        };
        let s = simulate(&model.robot, &scenario).unwrap();
        let data = parse_measurements(&s.to_csv(&model.units, "test"), "s.csv", &model).unwrap();
        (model, data)
    }

    /// MUKCA's panda_6 ball seated in two sockets, front placement: a real
    /// session without a tracker.
    fn mukca_front() -> (RobotModel, Measurements) {
        let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../data/mukca-ball-socket");
        let spec = ChainSpec {
            tip_link: Some("ball_link".into()),
            ..ChainSpec::default()
        };
        let model = load_model_with(&format!("{dir}/original/urdf/panda.urdf"), &spec).unwrap();
        let data = load_measurements(&format!("{dir}/panda_6/front.csv"), &model).unwrap();
        (model, data)
    }

    /// The folds' normal equations, summed in one pass, score each factor
    /// as the stored linearisation's cross-validation of every column does
    /// (the same step about the same fit, the same folds): equal to
    /// rounding, for measured positions and for a session of contacts
    /// (points, a known distance trained on in every fold).
    #[test]
    fn fold_sums_score_as_the_stored_linearisation() {
        for (model, data) in [tracker("ur5e", 60, 1e-3, 3), mukca_front()] {
            let options = FullOptions::default();
            let (poses, constraints) = (&data.poses, &data.constraints);
            let fit = FitRequest::new(&model.robot, poses, &options)
                .constrained(constraints)
                .run()
                .unwrap();
            let (k, sums) = fold_sums(&fit, poses, constraints, &options.prior, 10);
            let scores = scores(&sums, &WeightFactors::NOISE);
            assert_eq!(scores.len(), PRIOR_FACTORS.len(), "{}", data.file);
            let lin = linearize(&fit, Extension::NONE, poses, constraints, &options.prior);
            let folds = Folds::interleaved(&lin, k);
            for s in &scores {
                let subset = Subset {
                    columns: (0..lin.j.ncols()).collect(),
                    precision_factor: 1.0 / (s.factor * s.factor),
                };
                let stored = folds.evaluate(&subset).unwrap().held.rms;
                assert!(
                    (s.held_out - stored).abs() < 1e-9 * stored,
                    "{} ×{}: {} against {stored}",
                    data.file,
                    s.factor,
                    s.held_out
                );
            }
        }
    }

    /// The RMS distance between `robot`'s tool points and the measured
    /// positions of `rows`, m.
    fn rms(robot: &armcal_shared::Robot<f64>, rows: &[Observation]) -> f64 {
        let sum: f64 = rows
            .iter()
            .map(|o| {
                (robot.forward(&o.q).unwrap().translation.vector - o.position.coords).norm_squared()
            })
            .sum();
        (sum / rows.len() as f64).sqrt()
    }

    /// An arm built ten times outside the stated tolerance (every parameter
    /// up to 10 mm, 10 mrad off; the prior 1 mm, 1 mrad): the stated prior
    /// holds the parameters 25–40 poses determine least near nominal, the
    /// scale chosen lets them go, and the calibration predicts 200 poses it
    /// was not fitted to better (measured positions, 20 µm noise; four
    /// sessions: measured 1–31 % better).
    #[test]
    fn an_arm_outside_its_tolerance_gets_a_wider_prior_and_predicts_better() {
        for (poses, seed) in [(40, 5), (30, 6), (30, 7), (25, 8)] {
            let (model, mut data) = tracker("ur5e", 200 + poses, 1e-2, seed);
            let held: Vec<Observation> = data.poses.split_off(poses);
            let options = FullOptions::default();
            let fit = |scale| {
                identify(
                    &model,
                    &data,
                    &IdentifyRequest {
                        scale,
                        ..IdentifyRequest::new(options)
                    },
                )
                .unwrap()
            };
            let (stated, chosen) = (fit(PriorScale::Stated), fit(PriorScale::default()));
            let factor = chosen.prior.as_ref().unwrap().factor();
            let (e_stated, e_chosen) = (
                rms(&stated.calibrated(), &held),
                rms(&chosen.calibrated(), &held),
            );
            eprintln!(
                "{poses} poses: ×{factor}, held out {:.4} mm against {:.4} mm at the stated prior",
                e_chosen * 1e3,
                e_stated * 1e3
            );
            assert!(factor > 1.0, "{poses} poses: ×{factor}");
            assert!(e_chosen < e_stated, "{poses} poses: {e_chosen} {e_stated}");
        }
    }
}
