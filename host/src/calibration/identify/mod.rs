//! Geometric identification: the D-H parameter errors from measured poses.
//!
//! | module | model |
//! | --- | --- |
//! | [`crate::calibration::fit`] | `--params full` (the default): joint offsets, every `s, a, α`, base and tool, weighted Levenberg–Marquardt with a rank-revealing Cholesky, standard errors and observability |
//! | [`paper`] | `--params paper`: the 3M position-independent model and the Iterative Regression Algorithm of Mirman & Gupta (1992), as the paper gives them |
//! | [`crate::calibration::fit::prior`] | the prior on the D-H errors and the nested geometric models |
//! | [`prior_scale`] | the prior's scale chosen on held-out poses (`--prior-scale chosen`, the default) |
//! | [`channel_weight`] | the orientation rows' weight chosen on held-out positions (`--orientation-weight chosen`, the default) |
//! | [`noise`] | each channel's noise, estimated from the residuals as variance components |
//! | [`sessions`] | several sessions in the reports: each session's figures and frames |
//! | `summary` | the report of `armcal identify`: the JSON of `docs/file-formats.md` §6 and the human summary |
//!
//! This module runs either model ([`identify`]) and turns its result into the
//! [`Calibration`] the controller loads. Values are SI inside; the report
//! converts every length and angle to the model file's units (`mm`-suffixed
//! fields excepted).

pub mod channel_weight;
pub mod paper;
pub mod prior_scale;
pub mod report;
pub mod sessions;
mod summary;
pub mod suspect_rows;

#[cfg(test)]
mod constraint_tests;

use armcal_shared::calibration::ParamError;
use armcal_shared::compensation::Task;
use armcal_shared::{Calibration, Param, Robot};

use crate::calibration::fit::noise;
use crate::calibration::fit::{Extension, FitRequest, FullFit, FullOptions, Status};
use crate::calibration::validation::acceptance::Judgement;
use crate::session::measurements::Measurements;
use crate::session::model::RobotModel;
use crate::session::observation::Observation;
use crate::session::prior::Prior;
use crate::session::registration::Registrations;
use channel_weight::{ChannelWeights, Weighting};
use paper::{PaperOptions, PaperPose};
use prior_scale::{PriorChoice, PriorScale};

/// Which model to identify.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ParamSet {
    /// The 3M position-independent model of Mirman & Gupta.
    Paper,
    /// Every identifiable geometric parameter, base and tool included.
    Full,
}

impl ParamSet {
    /// The name used on the command line and in the JSON.
    pub fn name(self) -> &'static str {
        match self {
            Self::Paper => "paper",
            Self::Full => "full",
        }
    }
}

/// The noise and prior scales a user states (`--position-noise`,
/// `--orientation-noise`, `--point-noise`, `--plane-noise`, `--prior-length`,
/// `--prior-angle`), in the model's length and angle units; `None` leaves the
/// default (the noise estimated from the residuals, each kind of row its own;
/// the prior of the model file or 1 mm and 1 mrad). A stated position noise
/// is also the noise of the contacts whose kind has none stated
/// ([`noise`]).
#[derive(Clone, Copy, Debug, Default)]
pub struct StatedScales {
    /// Position noise, one standard deviation per axis.
    pub position_noise: Option<f64>,
    /// Orientation noise, one standard deviation per axis.
    pub orientation_noise: Option<f64>,
    /// Noise of a tool point at an unknown fixed point, per axis.
    pub point_noise: Option<f64>,
    /// Noise of a tool point on an unknown plane, along its normal.
    pub plane_noise: Option<f64>,
    /// Prior scale of a D-H length error.
    pub prior_length: Option<f64>,
    /// Prior scale of a D-H angle error.
    pub prior_angle: Option<f64>,
}

/// A stated scale that is not a positive number: which one, and its value.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NotPositive {
    /// The scale's name as a flag, `--position-noise` …
    pub flag: &'static str,
    /// The value given.
    pub value: f64,
}

impl StatedScales {
    /// The options of a full identification of `model` with these scales,
    /// converted to SI; refused if one is not a positive finite number.
    pub fn options(&self, model: &RobotModel) -> Result<FullOptions, NotPositive> {
        let positive = |flag: &'static str, v: Option<f64>| match v {
            Some(value) if !(value.is_finite() && value > 0.0) => Err(NotPositive { flag, value }),
            _ => Ok(v),
        };
        let u = &model.units;
        let mut options = FullOptions {
            prior: model.prior,
            ..FullOptions::default()
        };
        if let Some(v) = positive("--position-noise", self.position_noise)? {
            options.position_noise = u.length_to_si(v);
            options.position_source = noise::NoiseSource::Stated;
        }
        if let Some(v) = positive("--orientation-noise", self.orientation_noise)? {
            options.orientation_noise = u.angle_to_si(v);
            options.orientation_source = noise::NoiseSource::Stated;
        }
        let stated = |v: f64| noise::Noise {
            sigma: u.length_to_si(v),
            source: noise::NoiseSource::Stated,
        };
        options.point_noise = positive("--point-noise", self.point_noise)?.map(stated);
        options.plane_noise = positive("--plane-noise", self.plane_noise)?.map(stated);
        if let Some(v) = positive("--prior-length", self.prior_length)? {
            options.prior.length = u.length_to_si(v);
        }
        if let Some(v) = positive("--prior-angle", self.prior_angle)? {
            options.prior.angle = u.angle_to_si(v);
        }
        Ok(options)
    }
}

/// One parameter of the report, SI units.
#[derive(Clone, Debug, PartialEq)]
pub struct ParamRow {
    /// Which parameter.
    pub param: Param,
    /// Nominal value.
    pub nominal: f64,
    /// Identified minus nominal.
    pub error: f64,
    /// Standard error, when the method gives one.
    pub std: Option<f64>,
    /// `None` when identified, the reason when held at nominal.
    pub fixed: Option<String>,
}

/// The outcome of `armcal identify`.
#[derive(Clone, Debug)]
pub struct Identification {
    /// The model identified.
    pub params: ParamSet,
    /// Iterations run.
    pub iterations: usize,
    /// Whether the iterations converged.
    pub converged: bool,
    /// Every parameter.
    pub parameters: Vec<ParamRow>,
    /// RMS position residual, m.
    pub position_rms: f64,
    /// RMS orientation residual, rad (0 without orientation data).
    pub orientation_rms: f64,
    /// Full model only: its statistics.
    pub full: Option<FullFit>,
    /// The prior as stated (flags, model file, default), SI.
    pub stated_prior: Prior,
    /// Full model with the prior's scale chosen: the factor on the stated
    /// prior it was fitted at and every factor's held-out score.
    pub prior: Option<PriorChoice>,
    /// Full model: the weight of each kind of row beside the reference
    /// (orientations, contacts, known distances) fitted at, stated or
    /// chosen with every weight's held-out score ([`channel_weight`]).
    pub weighting: Weighting,
    /// The calibration to write.
    pub calibration: Calibration,
    /// The nominal model's and the calibration's residuals on the rows,
    /// once judged ([`Identification::verdict`]).
    pub judgement: Option<Judgement>,
    /// The masses fitted to the session's measured joint torques, when it
    /// has them ([`crate::calibration::gravity`]).
    pub gravity: Option<crate::calibration::gravity::GravityFit>,
    /// With several sessions, each one left out in turn
    /// ([`sessions::held_out_by_session`]); empty otherwise.
    pub sessions_held_out: Vec<sessions::SessionHeldOut>,
    /// The rows the full fit explains worst that fail the deleted-residual
    /// test ([`suspect_rows`]); none for `--params paper`.
    pub suspect_rows: suspect_rows::SuspectRows,
}

/// Why an identification could not be made.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum IdentifyError {
    /// The full model failed.
    #[error(transparent)]
    Full(#[from] crate::calibration::fit::FullError),
    /// The paper's model failed.
    #[error(transparent)]
    Paper(#[from] paper::PaperError),
    /// The paper's model needs orientations.
    #[error(
        "{file}: --params paper needs full poses (columns qw, qx, qy, qz): Mirman & Gupta's regression uses the rotational and translational errors of eq. (15); use --params full for positions"
    )]
    PaperNeedsPoses {
        /// The data file.
        file: String,
    },
    /// The calibration could not be encoded.
    #[error("the calibration cannot be written: {0}")]
    Calibration(#[from] armcal_shared::CalibrationError),
    /// The session's measured joint torques cannot be the arm's gravity
    /// ([`crate::calibration::gravity`]).
    #[error(transparent)]
    Input(#[from] crate::session::input_error::InputError),
}

/// The observations of `data`, SI, with each pose's context: temperature and
/// payload from the `temp` and `load` columns, and the approach direction of
/// every joint from row order (the sign of its last change, held while the joint
/// holds: [`armcal_shared::effects::Approach`]).
pub fn observations(data: &Measurements) -> &[Observation] {
    &data.poses
}

/// What an identification is asked: which parameters, the fit's options,
/// how the prior's scale is set and how each kind of row beside the
/// reference is weighed.
#[derive(Clone, Copy, Debug)]
pub struct IdentifyRequest {
    /// `--params`: every identifiable parameter, or the paper's.
    pub params: ParamSet,
    /// The fit's options: the noise, the stated prior, the sessions' frames,
    /// the cancel.
    pub options: FullOptions,
    /// `--params full`: the prior as stated, or at the factor on it that
    /// predicts held-out poses best ([`prior_scale`]; the fit at the stated
    /// prior first, then again at the factor chosen when it differs).
    pub scale: PriorScale,
    /// Each kind of row beside the reference: weighed as stated, or at the
    /// weight that predicts held-out tool points best ([`channel_weight`];
    /// a session of positions alone has one kind and no choice).
    pub weights: ChannelWeights,
}

impl IdentifyRequest {
    /// The full model fitted with `options`, the prior's scale and each
    /// kind's weight chosen held-out: the command line's defaults.
    pub fn new(options: FullOptions) -> Self {
        Self {
            params: ParamSet::Full,
            options,
            scale: PriorScale::default(),
            weights: ChannelWeights::chosen(crate::calibration::validation::folds::DEFAULT_FOLDS),
        }
    }
}

/// Runs the identification `request` asks on `data`.
pub fn identify(
    model: &RobotModel,
    data: &Measurements,
    request: &IdentifyRequest,
) -> Result<Identification, IdentifyError> {
    let IdentifyRequest {
        params: set,
        ref options,
        scale,
        ref weights,
    } = *request;
    let nominal = &model.robot;
    // Full poses when any row has an orientation (the paper's model needs
    // every one).
    let task = if data.poses.iter().any(|p| p.orientation.is_some()) {
        Task::Pose
    } else {
        Task::Position
    };
    let Fitted {
        iterations,
        converged,
        parameters,
        calibrated,
        fit,
        prior,
        weighting,
    } = match set {
        ParamSet::Full => fit_full(model, data, options, scale, weights)?,
        ParamSet::Paper => fit_paper(model, data)?,
    };
    let (position_rms, orientation_rms) = match &fit {
        // The fit's last linearisation is at the solution: its sums of squares
        // (for a constraint session, of each tool point's distance to its
        // estimated fixed point or plane).
        Some(f) => (f.position_rms, f.orientation_rms),
        None => crate::calibration::fit::residual_rms(&calibrated, observations(data)),
    };
    let mut calibration = Calibration::nominal(nominal.clone(), task, model.units);
    calibration.flange = model.flange;
    calibration.ranges = Some(crate::session::observation::ranges(&data.poses));
    // What the prior's cross-validation measured of the fit written.
    calibration.held_out = prior.as_ref().and_then(PriorChoice::held_out);
    for row in parameters
        .iter()
        .filter(|r| r.fixed.is_none() && r.error != 0.0)
    {
        // At most 4M + 12 parameters: the capacity of the calibration.
        let _ = calibration.errors.push(ParamError {
            param: row.param,
            error: row.error,
        });
    }
    // Refuse now, before anything is written, if the calibration cannot be encoded.
    calibration.to_bytes()?;
    Ok(Identification {
        params: set,
        iterations,
        converged,
        parameters,
        position_rms,
        orientation_rms,
        full: fit,
        stated_prior: options.prior,
        prior,
        weighting,
        calibration,
        judgement: None,
        gravity: None,
        sessions_held_out: Vec::new(),
        suspect_rows: suspect_rows::SuspectRows::default(),
    })
}

/// What either parameter set's fit gives the identification.
struct Fitted {
    /// Iterations of the fit.
    iterations: usize,
    /// Whether it converged.
    converged: bool,
    /// Each parameter's row of the report.
    parameters: Vec<ParamRow>,
    /// The calibrated model.
    calibrated: Robot<f64>,
    /// The full fit (`--params full`).
    fit: Option<FullFit>,
    /// The prior's scale chosen by cross-validation, when asked.
    prior: Option<PriorChoice>,
    /// The weight of each kind of row beside the reference.
    weighting: Weighting,
}

/// `--params full`: the fit at the stated prior (the orientations weighed by
/// their noise), then at the factor and the orientation weight chosen
/// held-out when `scale` and `weight` ask for them and they differ.
fn fit_full(
    model: &RobotModel,
    data: &Measurements,
    options: &FullOptions,
    scale: PriorScale,
    weights: &ChannelWeights,
) -> Result<Fitted, IdentifyError> {
    let nominal = &model.robot;
    let mut prior = None;
    let mut weighting = Weighting::default();
    // The model's own tilts (a URDF's parallel axes) beside its D-H parameters.
    let tilts: Vec<Param> = model.tilted.iter().map(|&k| Param::Beta(k)).collect();
    let fit_at = |factor: f64, options: &FullOptions| {
        FitRequest::new(
            nominal,
            observations(data),
            &FullOptions {
                prior: options.prior.scaled(factor),
                ..*options
            },
        )
        .extended(Extension {
            effects: &[],
            extra: &tilts,
        })
        .constrained(&data.constraints)
        .run()
    };
    let mut fit = fit_at(1.0, options)?;
    // Each choice below is a pass over the rows (its folds' normal
    // equations): none starts once the caller asked to stop.
    let asked_to_stop = || {
        options
            .cancel
            .check()
            .map_err(crate::calibration::fit::FullError::from)
    };
    asked_to_stop()?;
    let observed = observations(data);
    let kinds = channel_weight::weighed_kinds(observed);
    let scale_chosen = matches!(scale, PriorScale::Chosen { .. }) && options.prior.has_scale();
    if !kinds.is_empty() || scale_chosen {
        // The weights chosen (or stated) and the prior's factor at them; a
        // weighed-down kind's noise held at its estimate at full weight.
        let folds = match scale {
            PriorScale::Chosen { folds } => folds,
            PriorScale::Stated => crate::calibration::validation::folds::DEFAULT_FOLDS,
        };
        let (chosen, prior_choice) = channel_weight::choose(
            &fit,
            observed,
            &data.constraints,
            &options.prior,
            folds,
            (scale, weights),
        );
        asked_to_stop()?;
        let factor = prior_choice.as_ref().map_or(1.0, PriorChoice::factor);
        if factor != 1.0 || chosen.factors() != crate::session::channel::WeightFactors::NOISE {
            let weighted = chosen.options(options, &fit);
            fit = fit_at(factor, &weighted)?;
        }
        prior = prior_choice;
        weighting = chosen;
    }
    let rows: Vec<ParamRow> = fit
        .params
        .iter()
        .map(|p| ParamRow {
            param: p.param,
            nominal: p.nominal,
            error: p.error,
            std: match &p.status {
                Status::Identified { std } => Some(*std),
                Status::Fixed { .. } => None,
            },
            fixed: match &p.status {
                Status::Identified { .. } => None,
                Status::Fixed { reason } => Some(reason.clone()),
            },
        })
        .collect();
    Ok(Fitted {
        iterations: fit.iterations,
        converged: fit.converged,
        parameters: rows,
        calibrated: fit.calibrated.clone(),
        fit: Some(fit),
        prior,
        weighting,
    })
}

/// `--params paper`: Mirman & Gupta's regression on full poses.
fn fit_paper(model: &RobotModel, data: &Measurements) -> Result<Fitted, IdentifyError> {
    let nominal = &model.robot;
    let mut poses = Vec::with_capacity(data.poses.len());
    for p in &data.poses {
        let Some(q) = p.orientation else {
            return Err(IdentifyError::PaperNeedsPoses {
                file: data.file.clone(),
            });
        };
        poses.push(PaperPose {
            q: p.q.clone(),
            actual: nalgebra::IsometryMatrix3::from_parts(
                p.position.coords.into(),
                q.to_rotation_matrix(),
            ),
            joint_errors: None,
        });
    }
    let fit = paper::identify_paper(nominal, &poses, &PaperOptions::default())?;
    let last = fit.iterations.last();
    let rows = fit
        .params
        .iter()
        .zip(&fit.errors)
        .map(|(&param, &error)| {
            let dependent =
                last.and_then(|it| it.dependent.iter().find(|(held, _, _)| *held == param));
            ParamRow {
                param,
                nominal: nominal.param(param).unwrap_or(0.0),
                error,
                std: None,
                fixed: dependent
                    .map(|(_, beside, r)| format!("not separable from {beside} (r = {r:.9})")),
            }
        })
        .collect();
    let mut calibrated = nominal.clone();
    for (p, e) in fit.params.iter().zip(&fit.errors) {
        if let Some(v) = calibrated.param_mut(*p) {
            *v += e;
        }
    }
    Ok(Fitted {
        iterations: fit.iterations.len(),
        converged: fit.converged,
        parameters: rows,
        calibrated,
        fit: None,
        prior: None,
        weighting: Weighting::default(),
    })
}

impl Identification {
    /// The calibrated model.
    pub fn calibrated(&self) -> Robot<f64> {
        self.calibration.calibrated()
    }

    /// Why this calibration of `model` from `data` must not be written (it
    /// did not converge, or fits `data` worse than the nominal model:
    /// [`crate::calibration::validation::acceptance`]); `flag` names the way to write it
    /// anyway. `None` when it may be; with the residuals it judged by.
    pub fn verdict(
        &self,
        model: &RobotModel,
        data: &Measurements,
        flag: &'static str,
    ) -> crate::calibration::validation::acceptance::Verdict {
        use crate::calibration::validation::acceptance::{Ending, Judged, Residual, verdict};
        use crate::calibration::validation::contact_check::geometric;
        let ending = Ending {
            iterations: self.iterations,
            converged: self.converged,
            last_decrease: self.full.as_ref().map(|f| f.last_decrease),
        };
        // Measured coordinates, and every parameter held at its nominal
        // value: the file holds the fit's own model, whose residual the fit
        // has (a pass over a million rows spared).
        let own = self.full.is_some()
            && !data.is_constrained()
            && self
                .parameters
                .iter()
                .all(|r| r.fixed.is_none() || r.error == 0.0);
        let residual = own.then(|| Residual {
            position: self.position_rms,
            orientation: data.has_orientation().then_some(self.orientation_rms),
        });
        verdict(
            &model.robot,
            Judged {
                model: &geometric(&self.calibrated()),
                registrations: self
                    .full
                    .as_ref()
                    .map_or(&Registrations::default(), |f| &f.registrations),
                residual,
            },
            data,
            &[],
            ending,
            &model.units,
            flag,
        )
    }
}
