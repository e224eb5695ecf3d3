//! The weight of each kind of row beside the others, chosen on held-out
//! tool points: what `armcal identify` and `armcal diagnose` fit at by
//! default (`--orientation-weight`, `--point-weight`, `--plane-weight`,
//! each `chosen`).
//!
//! Each channel's rows are weighed by `1/σ_c²`, `σ_c` the noise its
//! residuals show ([`super::noise`]). That is right for rows whose error is
//! noise. An instrument's rows are often *biased* instead: a camera's or a
//! marker frame's orientations (a hand-eye rotation error, a marker frame
//! built from few points, an error growing with distance), a plate that is
//! not flat or a probe that deflects, a socket that moved. A bias is not
//! noise: weighed by its scatter, the biased rows pull the geometry toward
//! the bias, and the calibration predicts the tool point (what it is used
//! for) worse than the other rows alone would.
//!
//! **What is weighed against what.** The tool point is judged by the rows
//! that locate it ([`Channel::Position`], [`Channel::Point`],
//! [`Channel::Plane`], in metres). The first of those the data have — the
//! measured positions, else the point contacts, else the plane contacts —
//! is the reference and keeps its weight; every other kind the data have
//! ([`Weighed`]: orientations, and point or plane contacts beside a kind
//! before them) is weighed, one after the other in that order, each at the
//! weights chosen before it. A kind of contact is judged on the held-out
//! rows of the other kinds that locate the tool point; the orientations, on
//! all of them.
//!
//! **The known distances are not weighed.** They are the length standard of
//! a session without a tracker, and nothing else sees the arm's scale: every
//! contact's residual shrinks with the arm, so a held-out error in metres
//! always prefers the distances gone (measured: a UR5e socket session
//! predicted its held-out contacts 4–13 standard errors "better" without
//! them, and missed the true tool points by 27–30 mm). They keep the
//! uncertainty each line states.
//!
//! Which weight predicts best is measured, as the prior's scale is
//! ([`super::prior_scale`]): about the fit at the weights the noise gives
//! (`w = 1`), the folds' normal equations ([`fold_normals`](crate::calibration::fit::fold_normals)) give, for
//! kind `c`'s rows weighed `w` times as much and the prior `f` times as
//! wide, fold `k`'s MAP step
//!
//! `(A_w − A_w,k + P/f²) δ = (b_w − b_w,k) − (P/f²) o`, `A_w = A − (1 − w) A_c`
//!
//! (`A_c`, `b_c` the kind's share) and its held-out rows' sum of squares
//! `S(w, f)` (m²). The weights [`WEIGHTS`] (×1, ×0.1, ×0.01 and none) are
//! each scored at every prior factor; a weight's score is its best
//! factor's. Not used (`w = 0`) is scored at `w = 10⁻⁹` ([`UNUSED`](crate::session::channel::UNUSED)): its
//! limit, the geometry from the other rows and what only the kind's own
//! rows see (the tool's rotation, a socket's centre, a plane) still from
//! them. Contacts not used are fitted at that limit too; orientations not
//! used are fitted at 0, the tool's rotation registered to them apart.
//!
//! **The margin.** Two weights' held-out sums differ by
//! `ΔS = Σ_i (2 e_iᵀ Δ_i + ‖Δ_i‖²)` over the held-out rows, `Δ_i = J_i(δ_a − δ_b)`
//! the difference of their predictions. Paired on the same rows, with the
//! errors `e_i` scattering by `σ_e` per row and independent of `Δ_i`, `ΔS`
//! scatters by `2 σ_e √(Σ_k D_kᵀ H_k D_k)` (`D_k` the difference of fold
//! `k`'s steps, `H_k` its held-out rows' `JᵀJ`, `σ_e²` the best weight's
//! held-out mean square per row). The weight chosen is the largest whose
//! held-out sum is within [`MARGIN`] of those standard errors of the
//! least: rows as clean as their noise are kept (they predict no worse, and
//! chance alone rarely makes another weight look two standard errors
//! better), biased ones are weighed down only when the other rows say so.
//! The fit is then made again at the weights chosen (and the prior's
//! factor chosen with them, [`super::prior_scale`]), a weighed-down
//! channel's noise held at its estimate (variance components would restore
//! the weight).
//!
//! **Disagreement.** A weight below 1 chosen this way is a finding: the
//! kind predicts the other rows significantly worse than they predict
//! themselves — it disagrees with them beyond its own scatter, which no
//! noise can do and a bias does. The reports name it with the kind's
//! residual RMS at the weight chosen and the held-out figures of both
//! weights.
//!
//! Units: SI inside (m, rad); the scores are RMS held-out tool-point errors, m.

use faer::Col;
use std::collections::BTreeMap;

use super::prior_scale::{
    PriorChoice, PriorScale, fold_steps, fold_sums, held_out_squares, immaterial,
};
use crate::calibration::fit::{FitRequest, FoldNormals, FullFit};
use crate::calibration::validation::folds::DEFAULT_FOLDS;
use crate::session::channel::{Channel, PerWeighed, Weighed, WeightFactors};
use crate::session::constraints::Constraints;
use crate::session::observation::Observation;
use crate::session::prior::Prior;

/// The weights scored, relative to what the noise gives: as estimated, a
/// tenth, a hundredth, not used.
pub const WEIGHTS: [f64; 4] = [1.0, 0.1, 0.01, 0.0];

/// How many standard errors of the paired difference a smaller weight's
/// held-out sum of squares must be below a larger one's to be chosen over it.
pub const MARGIN: f64 = 2.0;

/// How the identification weighs one kind of row.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ChannelWeight {
    /// This factor on the weight their noise gives them (1: as estimated,
    /// 0: not used).
    Stated(f64),
    /// The weight of [`WEIGHTS`] that predicts held-out tool points best
    /// over `folds` interleaved folds (see the module).
    Chosen {
        /// Folds of the cross-validation.
        folds: usize,
    },
}

impl Default for ChannelWeight {
    fn default() -> Self {
        Self::Chosen {
            folds: DEFAULT_FOLDS,
        }
    }
}

impl ChannelWeight {
    /// The weight's name on the command line and in the reports: `estimated`,
    /// `0.1`, `0.01`, `none`, or the factor.
    pub fn name(weight: f64) -> String {
        if weight == 1.0 {
            "estimated".into()
        } else if weight == 0.0 {
            "none".into()
        } else {
            format!("{weight}")
        }
    }
}

/// How each kind of row is to be weighed: a request.
pub type ChannelWeights = PerWeighed<ChannelWeight>;

impl ChannelWeights {
    /// Every kind chosen over `folds` folds.
    pub fn chosen(folds: usize) -> Self {
        Self::from_fn(|_| ChannelWeight::Chosen { folds })
    }

    /// These weights with every chosen one over `folds` folds.
    pub fn with_folds(self, folds: usize) -> Self {
        Self::from_fn(|w| match self[w] {
            ChannelWeight::Chosen { .. } => ChannelWeight::Chosen { folds },
            stated => stated,
        })
    }
}

/// One weight's held-out score, at its best prior factor.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WeightScore {
    /// The factor on the weight the noise gives.
    pub weight: f64,
    /// The prior's factor it scores best at (1 when the prior's scale is
    /// stated or immaterial).
    pub prior_factor: f64,
    /// The RMS of the held-out tool-point errors, m.
    pub held_out: f64,
}

/// What the choice of one kind's weight found.
#[derive(Clone, Debug, PartialEq)]
pub enum WeightChoice {
    /// As stated (`--orientation-weight` and the like): nothing cross-validated.
    Stated {
        /// The factor fitted at.
        weight: f64,
    },
    /// Every weight scored, the largest within [`MARGIN`] standard errors
    /// of the least fitted at.
    CrossValidated {
        /// The factor fitted at.
        weight: f64,
        /// Folds of the cross-validation.
        folds: usize,
        /// Each weight a training set of every fold determines, in the
        /// order of [`WEIGHTS`].
        scores: Vec<WeightScore>,
        /// How far the weight chosen predicts better than the weight the
        /// noise gives: the held-out sums' difference in standard errors of
        /// the paired difference (0 when it is that weight).
        significance: f64,
        /// The kind's noise the fit at full weight shows (rad or m per axis).
        noise: f64,
    },
    /// No training set of the folds determines the model at the weight the
    /// noise gives: that weight.
    Undetermined {
        /// Folds of the cross-validation.
        folds: usize,
    },
}

impl WeightChoice {
    /// The factor fitted at.
    pub fn weight(&self) -> f64 {
        match self {
            Self::Stated { weight } | Self::CrossValidated { weight, .. } => *weight,
            Self::Undetermined { .. } => 1.0,
        }
    }

    /// Weight `weight`'s held-out RMS, m, when it was scored.
    pub fn score_of(&self, weight: f64) -> Option<f64> {
        match self {
            Self::CrossValidated { scores, .. } => scores
                .iter()
                .find(|s| s.weight == weight)
                .map(|s| s.held_out),
            Self::Stated { .. } | Self::Undetermined { .. } => None,
        }
    }

    /// Whether the kind disagrees with the other rows: a weight below the
    /// noise's chosen on held-out tool points (see the module).
    pub fn disagrees(&self) -> bool {
        matches!(self, Self::CrossValidated { weight, .. } if *weight < 1.0)
    }
}

/// One kind's weight and how it was found.
#[derive(Clone, Debug, PartialEq)]
pub struct KindWeight {
    /// The kind of row.
    pub kind: Weighed,
    /// Its weight.
    pub choice: WeightChoice,
}

/// The weights of every kind of row the data have beside the reference
/// (see the module), in the order of [`Weighed::ALL`].
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Weighting(pub Vec<KindWeight>);

/// The kinds of `data`'s rows weighed against the others (see the module):
/// measured orientations; point contacts beside measured positions; plane
/// contacts beside either.
pub fn weighed_kinds(data: &[Observation]) -> Vec<Weighed> {
    let has = |c: Channel| {
        data.iter()
            .any(|o| o.channel() == c && o.position_rows() > 0)
    };
    let (positions, points, planes) = (
        has(Channel::Position),
        has(Channel::Point),
        has(Channel::Plane),
    );
    let orientations = data.iter().any(|o| o.orientation_rows() > 0);
    Weighed::ALL
        .into_iter()
        .filter(|&w| match w {
            Weighed::Orientation => orientations,
            Weighed::Point => points && positions,
            Weighed::Plane => planes && (positions || points),
        })
        .collect()
}

/// One cell of the scores: a weight at a prior factor.
struct Cell {
    weight: f64,
    factor: f64,
    squares: f64,
    poses: usize,
    steps: Vec<Col<f64>>,
}

/// The standard error of the difference of two cells' held-out sums of
/// squares, m², their errors scattering by `sigma2` per row (m²), on the
/// held-out rows of every tool-point channel but `except`.
fn paired_error(
    sums: &FoldNormals,
    a: &Cell,
    b: &Cell,
    sigma2: f64,
    except: Option<Channel>,
) -> f64 {
    let spread: f64 = sums
        .folds
        .iter()
        .zip(a.steps.iter().zip(&b.steps))
        .map(|(fold, (x, y))| {
            let d = x - y;
            Channel::ALL
                .into_iter()
                .zip(&fold.held.0)
                .filter(|&(c, _)| Some(c) != except)
                .filter_map(|(_, held)| held.as_ref())
                .map(|held| d.transpose() * (&held.a * &d))
                .sum::<f64>()
        })
        .sum();
    2.0 * (sigma2 * spread.max(0.0)).sqrt()
}

/// The kind's noise at full weight in `fit` (rad or m).
fn noise_at_full_weight(fit: &FullFit, kind: Weighed) -> f64 {
    fit.noise.channel(kind.channel()).map_or(0.0, |n| n.shown)
}

/// Chooses kind `kind`'s weight, the other kinds at `at`, among [`WEIGHTS`]
/// at each prior factor of `factors` (see the module).
fn choose_kind(
    fit: &FullFit,
    (k, sums): (usize, &FoldNormals),
    kind: Weighed,
    at: &WeightFactors,
    factors: &[f64],
) -> WeightChoice {
    // A contact is judged on the other rows that locate the tool point.
    let except = Some(kind.channel()).filter(|&c| c != Channel::Orientation);
    let cells: Vec<Cell> = WEIGHTS
        .iter()
        .flat_map(|&weight| factors.iter().map(move |&factor| (weight, factor)))
        .filter_map(|(weight, factor)| {
            let mut weights = *at;
            weights[kind] = weight;
            let steps = fold_steps(sums, factor, &weights)?;
            let (squares, poses) = held_out_squares(sums, &steps, except);
            (poses > 0 && squares.is_finite()).then_some(Cell {
                weight,
                factor,
                squares: squares.max(0.0),
                poses,
                steps,
            })
        })
        .collect();
    // Each weight's best factor (the first least: the smaller on a tie).
    let best_of = |weight: f64| {
        cells
            .iter()
            .filter(|c| c.weight == weight)
            .min_by(|a, b| a.squares.total_cmp(&b.squares))
    };
    let Some(estimated) = best_of(1.0) else {
        return WeightChoice::Undetermined { folds: k };
    };
    let bests: Vec<&Cell> = WEIGHTS.iter().filter_map(|&w| best_of(w)).collect();
    let least = bests
        .iter()
        .min_by(|a, b| a.squares.total_cmp(&b.squares))
        .copied()
        .unwrap_or(estimated);
    let rows_per_pose = if except.is_some() { 1 } else { 3 };
    let sigma2 = least.squares / (rows_per_pose * least.poses.max(1)) as f64;
    let error = |a: &Cell, b: &Cell| paired_error(sums, a, b, sigma2, except);
    // The largest weight within the margin of the least.
    let chosen = bests
        .iter()
        .find(|c| c.squares - least.squares <= MARGIN * error(c, least))
        .copied()
        .unwrap_or(least);
    let significance = if chosen.weight == 1.0 {
        0.0
    } else {
        let se = error(estimated, chosen);
        if se > 0.0 {
            (estimated.squares - chosen.squares) / se
        } else {
            f64::INFINITY
        }
    };
    WeightChoice::CrossValidated {
        weight: chosen.weight,
        folds: k,
        scores: bests
            .iter()
            .map(|c| WeightScore {
                weight: c.weight,
                prior_factor: c.factor,
                held_out: (c.squares / c.poses as f64).sqrt(),
            })
            .collect(),
        significance,
        noise: noise_at_full_weight(fit, kind),
    }
}

/// Weighs each kind of `data`'s rows beside the others as `request` says —
/// stated, or chosen by the linearised cross-validation of `data` about
/// `fit` (made at the weights the noise gives and the stated `prior`), one
/// kind after the other (see the module) — and, when `scale` asks for it,
/// chooses the prior's factor at the weights found (each weight chosen at
/// its best factor). The folds are `folds`.
pub fn choose(
    fit: &FullFit,
    data: &[Observation],
    constraints: &Constraints,
    prior: &Prior,
    folds: usize,
    (scale, request): (PriorScale, &ChannelWeights),
) -> (Weighting, Option<PriorChoice>) {
    let kinds = weighed_kinds(data);
    let scale_chosen = matches!(scale, PriorScale::Chosen { .. }) && prior.has_scale();
    let any_chosen = kinds
        .iter()
        .any(|&w| matches!(request[w], ChannelWeight::Chosen { .. }));
    let prior_material = scale_chosen && !immaterial(fit);
    if !any_chosen && !prior_material {
        // Nothing to cross-validate: no pass over the data.
        let stated = kinds
            .iter()
            .filter_map(|&kind| match request[kind] {
                ChannelWeight::Stated(weight) => Some(KindWeight {
                    kind,
                    choice: WeightChoice::Stated { weight },
                }),
                ChannelWeight::Chosen { .. } => None,
            })
            .collect();
        return (
            Weighting(stated),
            scale_chosen.then_some(PriorChoice::Immaterial),
        );
    }
    let (k, sums) = fold_sums(fit, data, constraints, prior, folds);
    let factors = super::prior_scale::factors_to_score(fit, scale_chosen);
    let mut at = WeightFactors::NOISE;
    let mut weighting = Vec::new();
    for kind in kinds {
        let choice = match request[kind] {
            ChannelWeight::Stated(weight) => WeightChoice::Stated { weight },
            ChannelWeight::Chosen { .. } => choose_kind(fit, (k, &sums), kind, &at, factors),
        };
        at[kind] = choice.weight();
        weighting.push(KindWeight { kind, choice });
    }
    let prior_choice = scale_chosen.then(|| super::prior_scale::choose_among(fit, (k, &sums), &at));
    (Weighting(weighting), prior_choice)
}

/// The weights of a diagnosis of `data`: the fit of every D-H parameter at
/// `options` (the stated prior, every kind weighed by its noise), the
/// weights chosen about it (at the stated prior: the diagnosis chooses its
/// own) or stated, and `options` at those weights, the noise held at the
/// fit's estimate: what every fit of the diagnosis then uses.
pub fn for_diagnosis(
    nominal: &armcal_shared::Robot<f64>,
    data: &[Observation],
    constraints: &Constraints,
    options: &crate::calibration::fit::FullOptions,
    request: &ChannelWeights,
) -> Result<(Weighting, crate::calibration::fit::FullOptions), crate::calibration::fit::FullError> {
    if weighed_kinds(data).is_empty() {
        return Ok((Weighting::default(), *options));
    }
    let reference_options = crate::calibration::fit::FullOptions {
        geometry: crate::calibration::fit::prior::Geometry::Full,
        weights: WeightFactors::NOISE,
        ..*options
    };
    let reference = FitRequest::new(nominal, data, &reference_options)
        .constrained(constraints)
        .run()?;
    let folds = match Weighed::ALL
        .map(|w| request[w])
        .into_iter()
        .find_map(|w| match w {
            ChannelWeight::Chosen { folds } => Some(folds),
            ChannelWeight::Stated(_) => None,
        }) {
        Some(folds) => folds,
        None => DEFAULT_FOLDS,
    };
    let (weighting, _) = choose(
        &reference,
        data,
        constraints,
        &options.prior,
        folds,
        (PriorScale::Stated, request),
    );
    let weighted = weighting.options(options, &reference);
    Ok((weighting, weighted))
}

impl Weighting {
    /// The factors fitted at (1 for a kind not weighed).
    pub fn factors(&self) -> WeightFactors {
        let mut at = WeightFactors::NOISE;
        for w in &self.0 {
            at[w.kind] = w.choice.weight();
        }
        at
    }

    /// The orientations' weight, when weighed.
    pub fn orientation(&self) -> Option<&WeightChoice> {
        self.0
            .iter()
            .find(|w| w.kind == Weighed::Orientation)
            .map(|w| &w.choice)
    }

    /// `options` at these weights, the noise held at `reference`'s
    /// estimate (the fit at the weights the noise gives) when any is below
    /// 1; `options` themselves otherwise.
    pub fn options(
        &self,
        options: &crate::calibration::fit::FullOptions,
        reference: &FullFit,
    ) -> crate::calibration::fit::FullOptions {
        let factors = self.factors();
        if factors == WeightFactors::NOISE {
            *options
        } else {
            crate::calibration::fit::FullOptions {
                weights: factors,
                ..options.at_noise_of(reference)
            }
        }
    }

    /// The reports' `orientation_weight` and `contact_weights`
    /// (docs/file-formats.md §6), the residuals from `fit`.
    pub fn reports(&self, fit: &FullFit) -> WeightReports {
        let mut out = WeightReports::default();
        for w in &self.0 {
            let report = w.choice.report(w.kind, residual(fit, w.kind));
            match w.kind {
                Weighed::Orientation => out.orientation_weight = Some(report),
                kind => {
                    out.contact_weights
                        .get_or_insert_with(BTreeMap::new)
                        .insert(kind.key(), report);
                }
            }
        }
        out
    }
}

/// Kind `kind`'s residual RMS in `fit`, rad or m: the orientations' RMS
/// (per pose), else what the kind's residuals show per axis.
fn residual(fit: &FullFit, kind: Weighed) -> f64 {
    match kind {
        Weighed::Orientation => fit.orientation_rms,
        Weighed::Point => fit.noise.point.map_or(0.0, |n| n.shown),
        Weighed::Plane => fit.noise.plane.map_or(0.0, |n| n.shown),
    }
}

/// The reports' weights: `orientation_weight` and `contact_weights`, each
/// present when that kind was weighed ([`Weighting::reports`]).
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct WeightReports {
    /// The orientations' weight.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub orientation_weight: Option<WeightReport>,
    /// The contacts' weights, by kind (`point`, `plane`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub contact_weights: Option<BTreeMap<&'static str, WeightReport>>,
}

/// One kind's weight as the reports give it ([`WeightChoice::report`]).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct WeightReport {
    /// The factor fitted at.
    pub weight: f64,
    /// Its name (`estimated`, `0.1`, …).
    pub name: String,
    /// `stated`, `undetermined` or `cross-validation`.
    pub chosen_by: ChosenBy,
    /// The cross-validation's folds.
    pub folds: Option<usize>,
    /// Each weight's held-out score.
    pub held_out: Vec<WeightScoreReport>,
    /// The kind's disagreement with the other rows, when found.
    pub disagreement: Option<Disagreement>,
}

/// How a kind's weight was chosen, as the reports say it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum ChosenBy {
    /// Stated by its option.
    Stated,
    /// No training set determines the model: the noise's weight kept.
    Undetermined,
    /// By the held-out tool points.
    CrossValidation,
}

/// One weight's held-out score in the reports.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct WeightScoreReport {
    /// The factor on the weight the noise gives.
    pub weight: f64,
    /// Its name.
    pub name: String,
    /// The prior's factor it scores best at.
    pub prior_factor: f64,
    /// The RMS of the held-out tool-point errors, mm.
    pub held_out_rms_mm: f64,
}

/// A kind's disagreement with the other rows: the significance, and the
/// kind's noise at full weight and residual at the weight chosen, keyed by
/// the kind's unit.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
#[serde(untagged)]
pub enum Disagreement {
    /// The orientations', mrad.
    Orientation {
        /// In standard errors of the paired difference.
        significance: Option<f64>,
        /// Their noise at full weight, mrad per axis.
        orientation_noise_at_full_weight_mrad: f64,
        /// Their residual RMS at the weight chosen, mrad.
        orientation_rms_mrad: f64,
    },
    /// A contact kind's, mm.
    Contact {
        /// In standard errors of the paired difference.
        significance: Option<f64>,
        /// Its noise at full weight, mm per axis.
        noise_at_full_weight_mm: f64,
        /// Its residual RMS at the weight chosen, mm.
        residual_rms_mm: f64,
    },
}

impl Disagreement {
    /// Its significance (`None`: not finite), noise at full weight and
    /// residual at the weight chosen, in the kind's unit.
    fn figures(&self) -> (Option<f64>, f64, f64) {
        match *self {
            Self::Orientation {
                significance,
                orientation_noise_at_full_weight_mrad: noise,
                orientation_rms_mrad: residual,
            }
            | Self::Contact {
                significance,
                noise_at_full_weight_mm: noise,
                residual_rms_mm: residual,
            } => (significance, noise, residual),
        }
    }
}

/// How a kind's values read in the reports: the unit, its factor from SI,
/// and what its disagreement suggests.
fn reading(kind: Weighed) -> (&'static str, f64, &'static str) {
    match kind {
        Weighed::Orientation => ("mrad", 1e3, "a hand-eye or marker-frame error?"),
        Weighed::Point => ("mm", 1e3, "a socket that moved, or a ball not seated?"),
        Weighed::Plane => (
            "mm",
            1e3,
            "a probe whose tip is not the ball's centre, a plate that is not flat, or a probe that deflects?",
        ),
    }
}

impl WeightChoice {
    /// The reports' entry for kind `kind` (docs/file-formats.md §6): the
    /// weight, how it was chosen, each weight's held-out RMS (mm) and the
    /// disagreement found, with the kind's residual RMS at the weight chosen
    /// (`residual`, rad or m; given in mrad or mm).
    pub fn report(&self, kind: Weighed, residual: f64) -> WeightReport {
        let (chosen_by, folds, scores, significance, noise) = match self {
            Self::Stated { .. } => (ChosenBy::Stated, None, &[][..], None, None),
            Self::Undetermined { folds } => {
                (ChosenBy::Undetermined, Some(*folds), &[][..], None, None)
            }
            Self::CrossValidated {
                folds,
                scores,
                significance,
                noise,
                ..
            } => (
                ChosenBy::CrossValidation,
                Some(*folds),
                &scores[..],
                Some(*significance),
                Some(*noise),
            ),
        };
        let (_, to, _) = reading(kind);
        let disagreement = self.disagrees().then(|| {
            let significance = significance.filter(|s| s.is_finite());
            let (noise, residual) = (noise.unwrap_or(f64::NAN) * to, residual * to);
            match kind {
                Weighed::Orientation => Disagreement::Orientation {
                    significance,
                    orientation_noise_at_full_weight_mrad: noise,
                    orientation_rms_mrad: residual,
                },
                Weighed::Point | Weighed::Plane => Disagreement::Contact {
                    significance,
                    noise_at_full_weight_mm: noise,
                    residual_rms_mm: residual,
                },
            }
        });
        WeightReport {
            weight: self.weight(),
            name: ChannelWeight::name(self.weight()),
            chosen_by,
            folds,
            held_out: scores
                .iter()
                .map(|s| WeightScoreReport {
                    weight: s.weight,
                    name: ChannelWeight::name(s.weight),
                    prior_factor: s.prior_factor,
                    held_out_rms_mm: s.held_out * 1e3,
                })
                .collect(),
            disagreement,
        }
    }
}

impl WeightReport {
    /// The summary's lines for kind `kind`: the weight fitted at and how it
    /// was chosen (each weight's held-out RMS of the tool point, mm), and
    /// when the kind disagrees with the other rows, that finding with its
    /// residual RMS at the weight chosen.
    pub fn summary(&self, kind: Weighed) -> String {
        let what = kind.key();
        let mut out = match (self.chosen_by, self.folds) {
            (ChosenBy::Stated, _) | (_, None) => {
                format!("{what} weight: {} (stated, --{what}-weight)\n", self.name)
            }
            (ChosenBy::Undetermined, Some(folds)) => format!(
                "{what} weight: estimated (no training set of {folds} folds determines the model: nothing chosen)\n"
            ),
            (ChosenBy::CrossValidation, Some(folds)) => format!(
                "{what} weight: {} (chosen, {folds}-fold held-out tool-point RMS: {})\n",
                self.name,
                self.held_out
                    .iter()
                    .map(|s| format!("{} {:.4} mm", s.name, s.held_out_rms_mm))
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
        };
        if let Some(d) = &self.disagreement {
            let (significance, noise, residual) = d.figures();
            let score = |w: f64| {
                self.held_out
                    .iter()
                    .find(|s| s.weight == w)
                    .map_or(f64::NAN, |s| s.held_out_rms_mm)
            };
            let (unit, _, cause) = reading(kind);
            let others = match kind {
                Weighed::Orientation => "positions",
                Weighed::Point | Weighed::Plane => "other contacts",
            };
            out.push_str(&format!(
                "  the {} disagree with the {others}: weighed by their noise \
                 ({noise:.3} {unit} per axis) they predict held-out tool points {:.4} mm against {:.4} \
                 mm at {} ({:.1} standard errors of the difference); their residual \
                 at the weight chosen is {residual:.3} {unit} RMS: {cause}\n",
                kind.name(),
                score(1.0),
                score(self.weight),
                self.name,
                significance.unwrap_or(f64::NAN),
            ));
        }
        out
    }

    /// The HTML report's section for kind `kind`: the summary's lines as a
    /// table of each weight's held-out RMS and the finding.
    pub fn html(&self, kind: Weighed) -> String {
        let what = kind.key();
        let mut title = what.to_string();
        title[..1].make_ascii_uppercase();
        let mut s = format!("<h2>{title} weight</h2>\n");
        if self.chosen_by == ChosenBy::CrossValidation {
            s.push_str(&format!(
                "<table><tr><th>{what} weight</th><th>prior factor</th>\
                 <th>held-out tool-point RMS (mm)</th></tr>\n",
            ));
            for score in &self.held_out {
                let mark = if score.weight == self.weight {
                    " (chosen)"
                } else {
                    ""
                };
                s.push_str(&format!(
                    "<tr><td>{}{mark}</td><td>×{}</td><td>{:.4}</td></tr>\n",
                    score.name, score.prior_factor, score.held_out_rms_mm
                ));
            }
            s.push_str("</table>\n");
        }
        for line in self.summary(kind).lines() {
            s.push_str(&format!(
                "<p>{}</p>\n",
                crate::report::html::html_escape(line.trim())
            ));
        }
        s
    }
}

impl WeightReports {
    /// Each kind weighed, in the reports' order ([`Weighed::ALL`]).
    fn each(&self) -> impl Iterator<Item = (Weighed, &WeightReport)> {
        Weighed::ALL.into_iter().filter_map(|kind| {
            let report = match kind {
                Weighed::Orientation => self.orientation_weight.as_ref(),
                kind => self.contact_weights.as_ref()?.get(kind.key()),
            };
            report.map(|r| (kind, r))
        })
    }

    /// The summary's lines, a kind after another ([`WeightReport::summary`]).
    pub fn summary(&self) -> String {
        self.each().map(|(kind, r)| r.summary(kind)).collect()
    }

    /// The HTML page's sections, a kind after another ([`WeightReport::html`]).
    pub fn html(&self) -> String {
        self.each().map(|(kind, r)| r.html(kind)).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::calibration::fit::FullOptions;
    use crate::calibration::identify::{IdentifyRequest, identify};
    use crate::calibration::simulate::{OrientationBias, Scenario, simulate};
    use crate::io::measurements::parse_measurements;
    use crate::io::model_file::load_model;
    use crate::session::measurements::Measurements;
    use crate::session::model::RobotModel;
    use crate::test_support::true_error;
    use armcal_shared::Robot;

    /// Full poses of a UR5e off nominal by ±1 mm / ±1 mrad, measured as an
    /// optical tracker measures a marker frame: positions to 50 µm,
    /// orientations to 0.1 mrad per axis, biased by `bias`. `poses`
    /// fitted and 200 other configurations, with the true robot.
    fn session(
        poses: usize,
        bias: OrientationBias,
        seed: u64,
    ) -> (RobotModel, Measurements, Robot<f64>, Vec<Vec<f64>>) {
        let model = load_model("ur5e").unwrap();
        let scenario = Scenario {
            position_noise: 50e-6,
            orientation_noise: Some(1e-4),
            orientation_bias: bias,
            ..Scenario::tracker(poses + 200, seed)
        };
        let s = simulate(&model.robot, &scenario).unwrap();
        let mut data =
            parse_measurements(&s.to_csv(&model.units, "test"), "s.csv", &model).unwrap();
        let held: Vec<Vec<f64>> = data
            .poses
            .split_off(poses)
            .into_iter()
            .map(|o| o.q)
            .collect();
        (model, data, s.truth, held)
    }

    /// The true held-out error of the calibration of `data` with the
    /// orientations weighed as `weight` says, and the weight fitted at.
    fn calibrated(
        model: &RobotModel,
        data: &Measurements,
        weight: ChannelWeight,
        truth: &Robot<f64>,
        held: &[Vec<f64>],
    ) -> (f64, f64) {
        let options = FullOptions::default();
        let mut weights = ChannelWeights::chosen(DEFAULT_FOLDS);
        weights[Weighed::Orientation] = weight;
        let fit = identify(
            model,
            data,
            &IdentifyRequest {
                weights,
                ..IdentifyRequest::new(options)
            },
        )
        .unwrap();
        let w = fit
            .weighting
            .orientation()
            .map_or(1.0, WeightChoice::weight);
        (true_error(&fit.calibrated(), truth, held), w)
    }

    /// `data` without its orientations: the positions alone.
    fn positions(data: &Measurements) -> Measurements {
        let mut positions = data.clone();
        for p in &mut positions.poses {
            p.orientation = None;
        }
        positions
    }

    /// A 2 mrad hand-eye rotation error (the orientations reported in a
    /// frame turned from the positions', 20–40 poses), and a camera's
    /// error growing by 2 mrad a metre from the instrument: weighed by the
    /// scatter they show, the biased orientations pull the geometry and
    /// the calibration predicts 200 unseen tool points of the true robot
    /// several times worse than from the positions alone; the weight chosen
    /// on held-out positions predicts them as well as the positions alone.
    /// The camera's error (0.6–1.8 mrad over the arm's reach, smooth over
    /// the workspace) harms less than the orientations help: they are kept,
    /// and predict better than the positions alone. Either way the weight
    /// chosen predicts as well as the better of the two.
    /// "As well": within the spread two calibrations from the same position
    /// rows may differ by where their prior's factor is chosen (its
    /// cross-validation on the full poses' linearisation, the positions-only
    /// one on its own) — a tenth of the error, far below the bias's harm.
    #[test]
    fn a_biased_orientation_channel_is_weighed_down_to_predict_as_the_positions_alone() {
        let fixed = OrientationBias {
            fixed: 2e-3,
            ..OrientationBias::default()
        };
        // A camera's: 2 mrad a metre from the instrument, across the line of sight.
        let growing = OrientationBias {
            per_metre: 2e-3,
            ..OrientationBias::default()
        };
        let mut disagreements = 0;
        let cases = [
            (20, 1, fixed),
            (20, 2, fixed),
            (30, 3, fixed),
            (40, 4, fixed),
        ];
        for (poses, seed, bias) in cases.into_iter().chain([(20, 5, growing)]) {
            let (model, data, truth, held) = session(poses, bias, seed);
            let only = positions(&data);
            let (e_chosen, w) = calibrated(&model, &data, ChannelWeight::default(), &truth, &held);
            let (e_estimated, _) =
                calibrated(&model, &data, ChannelWeight::Stated(1.0), &truth, &held);
            let (e_positions, _) =
                calibrated(&model, &only, ChannelWeight::default(), &truth, &held);
            eprintln!(
                "{poses} poses, seed {seed}: weight {} held out {:.4} mm; as estimated {:.4} mm; \
                 positions alone {:.4} mm",
                ChannelWeight::name(w),
                e_chosen * 1e3,
                e_estimated * 1e3,
                e_positions * 1e3
            );
            if bias.fixed > 0.0 {
                disagreements += usize::from(w < 1.0);
                assert!(
                    e_chosen < e_estimated,
                    "{poses} poses: {e_chosen} {e_estimated}"
                );
            }
            assert!(
                e_chosen <= 1.1 * e_positions.min(e_estimated),
                "{poses} poses: {e_chosen} against {e_positions} from the positions, \
                 {e_estimated} as estimated"
            );
        }
        assert_eq!(disagreements, 4, "the fixed bias named in every session");
    }

    /// Clean full poses (20, the orientations' error their noise): the
    /// orientations are kept at the weight their noise gives in every
    /// session, and they help — the calibration predicts 200 unseen tool
    /// points of the true robot better than from the positions alone, on
    /// the sessions' mean.
    #[test]
    fn clean_orientations_are_kept_and_help() {
        let (mut with, mut without) = (0.0, 0.0);
        let seeds = 1..=6;
        for seed in seeds.clone() {
            let (model, data, truth, held) = session(20, OrientationBias::default(), seed);
            let (e_chosen, w) = calibrated(&model, &data, ChannelWeight::default(), &truth, &held);
            let (e_positions, _) = calibrated(
                &model,
                &positions(&data),
                ChannelWeight::default(),
                &truth,
                &held,
            );
            eprintln!(
                "seed {seed}: weight {} held out {:.4} mm; positions alone {:.4} mm",
                ChannelWeight::name(w),
                e_chosen * 1e3,
                e_positions * 1e3
            );
            assert_eq!(w, 1.0, "seed {seed}: clean orientations weighed down");
            with += e_chosen;
            without += e_positions;
        }
        assert!(
            with < without,
            "{with} against {without} without orientations"
        );
    }
}
