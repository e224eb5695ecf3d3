//! `diagnose`: the geometry fitted, what it misses named, the model extended
//! and the gain measured held out, as [`crate::calibration::diagnose`]
//! computes it, checked and judged the same way whichever front end asks.
//!
//! Scales are in the model's units as the user states them; the calibration
//! is SI (docs/file-formats.md §5).

use armcal_shared::{Calibration, TargetFrame};

use super::{Front, fit_options, folds};
use crate::calibration::diagnose::Choice;
use crate::calibration::diagnose::report::RowPlaces;
use crate::calibration::diagnose::report::{ApproachOrder, DiagnoseReport};
use crate::calibration::diagnose::{DiagnoseOptions, Diagnosis, diagnose_with_progress};
use crate::calibration::fit::{Extension, FitRequest, FullOptions};
use crate::calibration::gravity::{GravityFit, TorqueSign, with_measured_gravity};
use crate::calibration::identify::channel_weight::{self, ChannelWeights, Weighting};
use crate::calibration::identify::sessions::{SessionHeldOut, Trained, held_out_by_session};
use crate::calibration::identify::{self, StatedScales, sessions};
use crate::calibration::validation::acceptance::FailedCalibration;
use crate::cancel::Cancel;
use crate::session::measurements::Measurements;
use crate::session::model::RobotModel;
use crate::session::observation::Observation;
use crate::session::registration::FrameSharing;
use crate::session::rows::Rows;
use armcal_shared::Param;

/// What `diagnose` is asked.
#[derive(Clone, Copy, Debug)]
pub struct Request {
    /// Folds of the cross-validation; `None` for the default
    /// ([`super::folds`]).
    pub folds: Option<usize>,
    /// The noise and prior scales stated (model units).
    pub scales: StatedScales,
    /// The weight of each kind of row beside the reference: stated, or
    /// chosen at the reference fit by cross-validation and kept for the rest
    /// of the diagnosis.
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

/// What `diagnose` found.
#[derive(Debug)]
pub struct Diagnosed {
    /// The model diagnosed: the one asked with, its masses fitted to the
    /// joint torques the session measured, if it did
    /// ([`crate::calibration::gravity`]); what the reports read.
    pub model: RobotModel,
    /// The masses' fit to the measured torques, if the session has them.
    pub gravity: Option<GravityFit>,
    /// The diagnosis: the fits, the effects named, the held-out figures.
    pub diagnosis: Diagnosis,
    /// The settings it ran with (the folds chosen, the fit's options).
    pub options: DiagnoseOptions,
    /// What `--out` writes: the model chosen, with the request's target
    /// frame.
    pub calibration: Calibration,
    /// Why the calibration is not written unless asked (its final fit did
    /// not converge, or it fits its data worse than the nominal model).
    pub failed: Option<FailedCalibration>,
    /// With several sessions, each one left out in turn, the others
    /// calibrated as the diagnosis chose ([`held_out_by_session`]); empty
    /// otherwise.
    pub sessions_held_out: Vec<SessionHeldOut>,
    /// The weight of each kind of row beside the reference every fit used,
    /// stated or chosen at the reference fit ([`channel_weight`]).
    pub weighting: Weighting,
}

/// Diagnoses `model` on `data` (a session [`super::require_session`]
/// accepted), calling `progress(round, candidate, candidates)` before each
/// effect candidate is scored: refused when the folds or a scale are out of
/// range, when the fit cannot be made, or when the fitted model cannot be of
/// these measurements ([`Measurements::require_fit_supported`]).
pub fn run(
    front: Front,
    model: &RobotModel,
    data: &Measurements,
    request: &Request,
    progress: &mut dyn FnMut(usize, usize, usize),
) -> anyhow::Result<Diagnosed> {
    let (fitted, gravity) = with_measured_gravity(model, data, request.torque_sign)?;
    let model = &fitted;
    let folds = folds(front, request.folds, data.len())?;
    let mut options = DiagnoseOptions {
        folds,
        fit: FullOptions {
            sessions: request.frames,
            cancel: request.cancel,
            ..fit_options(front, model, &request.scales)?
        },
        ..Default::default()
    };
    let observations = identify::observations(data);
    // The weight of each kind of row beside the reference chosen (or
    // stated) at the reference fit, kept by every fit of the diagnosis;
    // positions alone have nothing to choose.
    let (weighting, weighted) = channel_weight::for_diagnosis(
        &model.robot,
        observations,
        &data.constraints,
        &options.fit,
        &request.channel_weights.with_folds(folds),
    )?;
    options.fit = weighted;
    let diagnosis = diagnose_with_progress(
        &model.robot,
        observations.into(),
        &data.constraints,
        &options,
        progress,
    )?;
    request.cancel.check()?;
    data.require_fit_supported(model, diagnosis.reference.position_rms, || {
        super::nominal_worst_row(model, data)
    })?;
    let failed = diagnosis.refusal(model, data, front.write_failed());
    let mut calibration = diagnosis.calibration(&model.robot, data.task(), model.units);
    calibration.targets = request.targets;
    calibration.flange = model.flange;
    let sessions_held_out = sessions_held_out(model, observations, &diagnosis, &options);
    request.cancel.check()?;
    Ok(Diagnosed {
        weighting,
        sessions_held_out,
        model: fitted,
        gravity,
        diagnosis,
        options,
        calibration,
        failed,
    })
}

/// Each session of `data` left out in turn (its blunders set aside), the
/// others calibrated as `diagnosis` chose: its geometry and prior, its
/// effects and tilts.
fn sessions_held_out(
    model: &RobotModel,
    data: &[Observation],
    diagnosis: &Diagnosis,
    options: &DiagnoseOptions,
) -> Vec<SessionHeldOut> {
    if diagnosis.fit.sessions.len() < 2 {
        return Vec::new();
    }
    let kept: Vec<usize> = (0..data.len())
        .filter(|i| diagnosis.blunders.binary_search(i).is_err())
        .collect();
    let at = options.fit.at_noise_of(&diagnosis.fit);
    let effects = diagnosis.fit.fitted_effects();
    let extra: Vec<Param> = diagnosis
        .findings
        .iter()
        .flat_map(|f| f.candidate.extra.iter().copied())
        .collect();
    let calibrate = |rows: &[Observation]| match diagnosis.choice {
        Choice::Nominal => Ok(Trained {
            robot: model.robot.clone(),
            effects: Vec::new(),
            noise: None,
        }),
        Choice::Calibrated {
            geometry, prior, ..
        } => {
            let chosen = FullOptions {
                geometry,
                prior,
                ..at
            };
            FitRequest::new(&model.robot, rows, &chosen)
                .extended(Extension {
                    effects: &effects,
                    extra: &extra,
                })
                .run()
                .map(|f| Trained::of(&f))
        }
    };
    held_out_by_session(
        Rows::picked(data, &kept),
        &calibrate,
        options.fit.sessions,
        &at,
    )
}

impl Diagnosed {
    /// The sessions of `data` left out that do not reconcile with the
    /// others ([`sessions::warnings`]), one warning each.
    pub fn session_warnings(&self, data: &Measurements) -> Vec<String> {
        sessions::warnings(
            &self.sessions_held_out,
            data,
            sessions::sharing_of(&self.diagnosis.fit),
            &self.model.units,
        )
    }

    /// The HTML page of the diagnosis of `data` (`--html`): its `report`'s
    /// text and tables ([`Diagnosed::report`]), the masses' fit to the
    /// measured torques first, if any, as the summary gives it; the plots
    /// from the diagnosis and the rows.
    pub fn html(&self, report: &DiagnoseReport, data: &Measurements) -> String {
        crate::calibration::diagnose::html::html(
            report,
            &self.model,
            &self.diagnosis,
            identify::observations(data),
        )
    }

    /// The report of the diagnosis of `data` (`lines`: each pose's line or
    /// row): the diagnosis' own, with `gravity`, the masses' fit to the
    /// measured torques, when the session has them, the weights, and
    /// `sessions` and each outlier's file when there are several.
    pub fn report(&self, data: &Measurements, lines: &[usize]) -> DiagnoseReport {
        let rows = RowPlaces::of(lines, data);
        let fit = &self.diagnosis.fit;
        DiagnoseReport {
            data: data.file.clone(),
            poses: data.len(),
            diagnosis: self.diagnosis.report(&self.model, rows, &self.options),
            // Each outlier's file: a line is its own file's.
            outlier_files: rows.sessions.is_some().then(|| {
                let file = |i: usize| rows.file(i).map(str::to_string);
                self.diagnosis.blunders.iter().map(|&i| file(i)).collect()
            }),
            gravity: self.gravity.as_ref().map(GravityFit::report),
            approach_order: if data.times.iter().all(Option::is_some) {
                ApproachOrder::Times
            } else {
                ApproachOrder::Rows
            },
            weights: self.weighting.reports(fit),
            sessions: sessions::reports(fit, &self.sessions_held_out, data, &self.model.units),
        }
    }
}
