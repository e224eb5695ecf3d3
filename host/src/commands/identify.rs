//! `identify`: the geometric errors of a model from one session, as
//! [`crate::calibration::identify`] computes them, checked and judged the same
//! way whichever front end asks.
//!
//! Scales are in the model's units as the user states them; the calibration
//! is SI (docs/file-formats.md §5).

use armcal_shared::TargetFrame;

use super::{Front, fit_options};
use crate::calibration::fit::{Extension, FitRequest, FullOptions};
use crate::calibration::gravity::{TorqueSign, with_measured_gravity};
use crate::calibration::identify::channel_weight::ChannelWeights;
use crate::calibration::identify::prior_scale::PriorScale;
use crate::calibration::identify::sessions::{Trained, held_out_by_session};
use crate::calibration::identify::{self, Identification, ParamSet, StatedScales, suspect_rows};
use crate::calibration::validation::acceptance::FailedCalibration;
use crate::cancel::Cancel;
use crate::session::input_error::InputError;
use crate::session::measurements::Measurements;
use crate::session::model::RobotModel;
use crate::session::observation::Observation;
use crate::session::registration::FrameSharing;
use armcal_shared::Param;

/// What `identify` is asked.
#[derive(Clone, Copy, Debug)]
pub struct Request {
    /// The parameters identified.
    pub params: ParamSet,
    /// The noise and prior scales stated (model units).
    pub scales: StatedScales,
    /// The prior's scale: stated, or chosen by cross-validation.
    pub prior_scale: PriorScale,
    /// The weight of each kind of row beside the reference: stated, or
    /// chosen by cross-validation (positions only: nothing to choose).
    pub channel_weights: ChannelWeights,
    /// The frame the compensation's targets will be given in.
    pub targets: TargetFrame,
    /// With several sessions, which frames are each session's own.
    pub frames: FrameSharing,
    /// The sign of the session's `tau` columns; `None`: read from the data
    /// ([`crate::calibration::gravity`]).
    pub torque_sign: Option<TorqueSign>,
    /// The caller's request to stop, asked at the computation's step
    /// boundaries ([`crate::cancel`]); [`Cancel::NEVER`] on the
    /// command line, which SIGINT ends.
    pub cancel: Cancel,
}

/// What `identify` found.
#[derive(Debug)]
pub struct Identified {
    /// The model identified: the one asked with, its masses fitted to the
    /// joint torques the session measured, if it did
    /// ([`crate::calibration::gravity`]); what the reports read.
    pub model: RobotModel,
    /// The fit, its report and its calibration (with the request's target
    /// frame).
    pub result: Identification,
    /// Why the calibration is not written unless asked (the fit did not
    /// converge, or it fits its data worse than the nominal model).
    pub failed: Option<FailedCalibration>,
}

/// Identifies `model` from `data` (a session [`super::require_session`]
/// accepted): refused when a scale is not positive, when the measured joint
/// torques cannot be the arm's gravity and the model has no masses, when the
/// fit cannot be made, or when the fitted model cannot be of these measurements
/// ([`Measurements::require_fit_supported`]).
pub fn run(
    front: Front,
    model: &RobotModel,
    data: &Measurements,
    request: &Request,
) -> anyhow::Result<Identified> {
    let (fitted, gravity) = with_measured_gravity(model, data, request.torque_sign)?;
    let model = &fitted;
    let options = FullOptions {
        sessions: request.frames,
        cancel: request.cancel,
        ..fit_options(front, model, &request.scales)?
    };
    if request.params == ParamSet::Paper && data.session_count() > 1 {
        return Err(InputError::argument(
            front.flag("--params"),
            "paper: one session (Mirman & Gupta's regression has one base and one tool); \
             several sessions are identified by --params full",
        )
        .into());
    }
    let mut result = identify::identify(
        model,
        data,
        &identify::IdentifyRequest {
            params: request.params,
            options,
            scale: request.prior_scale,
            weights: request.channel_weights,
        },
    )?;
    if let Some(fit) = result.full.as_ref().filter(|f| f.sessions.len() > 1) {
        // Each session left out, the others calibrated at the prior's scale chosen.
        let factor = result.prior.as_ref().map_or(1.0, |p| p.factor());
        let at = FullOptions {
            prior: options.prior.scaled(factor),
            weights: fit.weights,
            ..options.at_noise_of(fit)
        };
        let tilts: Vec<Param> = model.tilted.iter().map(|&k| Param::Beta(k)).collect();
        let calibrate = |rows: &[Observation]| {
            FitRequest::new(&model.robot, rows, &at)
                .extended(Extension {
                    effects: &[],
                    extra: &tilts,
                })
                .run()
                .map(|f| Trained {
                    effects: Vec::new(),
                    ..Trained::of(&f)
                })
        };
        result.sessions_held_out =
            held_out_by_session(&data.poses, &calibrate, request.frames, &at);
    }
    // Each stage below is a pass over the rows or more: none starts once asked to stop.
    request.cancel.check()?;
    if let Some(fit) = &result.full {
        let factor = result.prior.as_ref().map_or(1.0, |p| p.factor());
        result.suspect_rows = suspect_rows::of_fit(
            fit,
            &data.poses,
            &data.constraints,
            &options.prior.scaled(factor),
        );
    }
    request.cancel.check()?;
    data.require_fit_supported(model, result.position_rms, || {
        super::nominal_worst_row(model, data)
    })?;
    let verdict = result.verdict(model, data, front.write_failed());
    result.judgement = Some(verdict.judgement);
    let failed = verdict.refusal;
    result.calibration.targets = request.targets;
    result.gravity = gravity;
    Ok(Identified {
        model: fitted,
        result,
        failed,
    })
}
