//! `diagnose`: the geometry fitted, what it misses named, the model extended
//! and the gain measured held out, as [`crate::calibration::diagnose`]
//! computes it, checked and judged the same way whichever front end asks.
//!
//! Scales are in the model's units as the user states them; the calibration
//! is SI (docs/file-formats.md §5).

use armcal_shared::units::Units;
use armcal_shared::{Calibration, TargetFrame};

use super::{Front, fit_options, folds};
use crate::calibration::acceptance::{FailedCalibration, diagnosis_refusal};
use crate::calibration::diagnose::{DiagnoseOptions, Diagnosis, diagnose_with_progress};
use crate::calibration::gravity::{GravityFit, with_measured_gravity};
use crate::calibration::identify::full::FullOptions;
use crate::calibration::identify::{self, StatedScales, sessions};
use crate::io::model_file::RobotModel;
use crate::session::measurements::Measurements;
use crate::session::registration::FrameSharing;

/// What `diagnose` is asked.
#[derive(Clone, Copy, Debug)]
pub struct Request {
    /// Folds of the cross-validation; `None` for the default
    /// ([`super::folds`]).
    pub folds: Option<usize>,
    /// The noise and prior scales stated (model units).
    pub scales: StatedScales,
    /// The frame the compensation's targets will be given in.
    pub targets: TargetFrame,
    /// With several sessions, which frames are each session's own.
    pub frames: FrameSharing,
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
    let (fitted, gravity) = with_measured_gravity(model, data);
    let model = &fitted;
    let folds = folds(front, request.folds, data.len())?;
    let options = DiagnoseOptions {
        folds,
        fit: FullOptions {
            sessions: request.frames,
            ..fit_options(front, model, &request.scales)?
        },
        ..Default::default()
    };
    let observations = identify::observations(data);
    let diagnosis = diagnose_with_progress(
        &model.robot,
        observations,
        &data.constraints,
        &options,
        progress,
    )?;
    data.require_fit_supported(model, diagnosis.reference.position_rms)?;
    let failed = diagnosis_refusal(model, data, &diagnosis, front.write_failed());
    let mut calibration = diagnosis.calibration(&model.robot, data.has_orientation(), model.units);
    calibration.targets = request.targets;
    Ok(Diagnosed {
        model: fitted,
        gravity,
        diagnosis,
        options,
        calibration,
        failed,
    })
}

/// The summary of a diagnosis of `data`: the masses' fit to the measured
/// torques, if any, each session's figures when there are several, then the
/// diagnosis' own (`lines`: each pose's line or row).
pub fn summary(
    gravity: Option<&GravityFit>,
    diagnosis: &Diagnosis,
    data: &Measurements,
    lines: &[usize],
    options: &DiagnoseOptions,
    units: &Units,
) -> String {
    let head = gravity.map(|g| format!("{}\n", g.summary()));
    head.unwrap_or_default()
        + &sessions::summary(&diagnosis.fit, data, units)
        + &diagnosis.summary(lines, options, units)
}

/// The JSON report of a diagnosis: the diagnosis' own, with `gravity`, the
/// masses' fit to the measured torques, when the session has them.
pub fn json(
    gravity: Option<&GravityFit>,
    diagnosis: &Diagnosis,
    model: &RobotModel,
    data: &Measurements,
    lines: &[usize],
    options: &DiagnoseOptions,
) -> serde_json::Value {
    let mut report = diagnosis.to_json(model, lines, options);
    if let Some(s) = sessions::json(&diagnosis.fit, data, &model.units) {
        report["sessions"] = s;
    }
    if let Some(g) = gravity {
        report["gravity"] = g.to_json();
    }
    report
}
