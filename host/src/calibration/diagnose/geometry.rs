//! The geometric model, chosen on held-out poses: the nested models of
//! [`Geometry`] (registration, offsets, lengths, every D-H parameter), each
//! with the prior's scale a factor of [`PRIOR_FACTORS`] times the stated one,
//! scored by the linearised k-fold cross-validation of the tool point
//! ([`crate::calibration::validation::folds`]) about the fit of every parameter.
//!
//! The nominal model competes too, scored on the poses themselves (it fits
//! nothing, so every pose is held out). The calibrated model of least held-out
//! RMS is chosen when its held-out errors are significantly smaller than the
//! nominal model's, pose by pose (a one-sided paired t-test at 5 %): on 20
//! poses a lower mean can be luck, and a calibration that is not shown to be
//! better must not replace the nominal model. Otherwise the nominal model is
//! chosen, and the calibration changes nothing.

use armcal_shared::{Param, Robot};

use crate::calibration::fit::prior::Geometry;
use crate::calibration::fit::{Linearization, Unknown};
use crate::calibration::parallel;
use crate::calibration::validation::folds::{Folds, HeldOut, Subset};
use crate::calibration::validation::stats::significantly_smaller;

/// The level of the paired test a calibrated model must pass against nominal.
pub const LEVEL: f64 = 0.05;

use crate::session::prior::PRIOR_FACTORS;

/// One candidate geometric model and its held-out error.
#[derive(Clone, Debug, PartialEq)]
pub struct ModelScore {
    /// The model; `None` is the nominal model, nothing fitted.
    pub geometry: Option<Geometry>,
    /// The factor on the stated prior scale (1 where no D-H parameter is free).
    pub prior_factor: f64,
    /// The free parameters.
    pub parameters: usize,
    /// Held-out statistics of the tool point.
    pub held: HeldOut,
    /// The held-out position error of each pose, m.
    pub errors: Vec<f64>,
}

impl ModelScore {
    /// The name in reports: `nominal`, `registration`, `offsets, prior ×0.3` …
    pub fn label(&self) -> String {
        match self.geometry {
            None => "nominal".into(),
            Some(Geometry::Registration) => "registration".into(),
            Some(g) => format!("{}, prior ×{}", g.name(), self.prior_factor),
        }
    }
}

/// Scores every candidate model on `lin` (the linearisation of the fit of every
/// parameter at the stated prior), with `folds` folds, beside the nominal
/// model's errors `nominal` on the same poses.
pub fn score(
    robot: &Robot<f64>,
    lin: &Linearization,
    folds: usize,
    nominal: &[f64],
) -> Vec<ModelScore> {
    let folds = Folds::interleaved(lin, folds);
    let mut out = vec![ModelScore {
        geometry: None,
        prior_factor: 1.0,
        parameters: 0,
        held: HeldOut::of(nominal),
        errors: nominal.to_vec(),
    }];
    // The columns each model frees, in the order of the first model that
    // frees them, so that each model's are a prefix of the next one's: the
    // models at one prior factor share one factorisation per fold.
    let first = |c: usize| match lin.unknowns[c] {
        // A Hayati tilt is an effect found, free in every model.
        Unknown::Param(Param::Beta(_))
        | Unknown::Effect { .. }
        | Unknown::Point { .. }
        | Unknown::Plane { .. }
        | Unknown::Session { .. } => Some(Geometry::Registration),
        Unknown::Param(p) => Geometry::ALL.into_iter().find(|g| g.frees(robot, p)),
    };
    let mut order: Vec<usize> = (0..lin.j.ncols()).filter(|&c| first(c).is_some()).collect();
    order.sort_by_key(|&c| first(c));
    let columns = |geometry: Geometry| -> Vec<usize> {
        order
            .iter()
            .copied()
            .filter(|&c| first(c).is_some_and(|g| g <= geometry))
            .collect()
    };
    // The registration at the stated prior only (it has no D-H parameter);
    // every other model at every prior factor. Each factor's models on a core.
    let groups: Vec<(f64, Vec<Geometry>)> = PRIOR_FACTORS
        .iter()
        .map(|&factor| {
            let models = Geometry::ALL
                .into_iter()
                .filter(|&g| g != Geometry::Registration || factor == 1.0)
                .collect();
            (factor, models)
        })
        .collect();
    let scored = parallel::map_if(folds.spread(), &groups, |(factor, models)| {
        // Not scored once the caller asked to stop: its next check drops them.
        if lin.cancel.requested() {
            return vec![None; models.len()];
        }
        let subsets: Vec<Subset> = models
            .iter()
            .map(|&g| Subset {
                columns: columns(g),
                precision_factor: 1.0 / (factor * factor),
            })
            .collect();
        folds.evaluate_nested(&subsets)
    });
    let mut scores = Vec::new();
    for ((prior_factor, models), evaluations) in groups.into_iter().zip(scored) {
        for (geometry, e) in models.into_iter().zip(evaluations) {
            if let Some(e) = e {
                scores.push(ModelScore {
                    geometry: Some(geometry),
                    prior_factor,
                    parameters: columns(geometry).len(),
                    held: e.held,
                    errors: e.errors,
                });
            }
        }
    }
    // In the order of the models, the simplest first (the first of equals is
    // chosen), each at its prior factors in increasing order.
    scores.sort_by(|a, b| {
        (a.geometry.cmp(&b.geometry)).then(a.prior_factor.total_cmp(&b.prior_factor))
    });
    out.extend(scores);
    out
}

/// The chosen model: of the calibrated models the one of least held-out RMS
/// (the first, so the simplest, of equals), when its held-out errors are
/// significantly smaller than the nominal model's (the paired test of
/// [`significantly_smaller`] at [`LEVEL`]); the nominal model otherwise.
pub fn best(scores: &[ModelScore]) -> &ModelScore {
    let nominal = &scores[0];
    scores[1..]
        .iter()
        .reduce(|a, b| if b.held.rms < a.held.rms { b } else { a })
        .filter(|b| significantly_smaller(&nominal.errors, &b.errors, LEVEL))
        .unwrap_or(nominal)
}
