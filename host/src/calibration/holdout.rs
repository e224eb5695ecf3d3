//! `armcal holdout`: sessions without a tracker, each left out in turn (or
//! predicted from training sessions), by the figures of
//! [`crate::calibration::validation::contact_check`].
//!
//! [`leave_one_out`] is the held-out evaluation: calibrate on every session
//! but one (merged, their points kept apart by name), predict the one left out,
//! for each in turn; beside the nominal model and, optionally, a reference
//! model (another calibration of the same chain) on the same held-out rows.
//! [`Selection`] says how each training set is calibrated: `identify --params
//! full` at the stated prior or at the scale it chooses by cross-validation
//! ([`crate::calibration::identify::prior_scale`]), or the model `armcal
//! diagnose` chooses (its effects applied in the prediction).

use armcal_shared::Robot;
use armcal_shared::compensation::Task;
use armcal_shared::effects::EffectModel;
use armcal_shared::units::Units;

use crate::calibration::diagnose::{DiagnoseOptions, diagnose_session};
use crate::calibration::fit::FullOptions;
use crate::calibration::identify::prior_scale::PriorScale;
use crate::calibration::identify::{self, IdentifyError};
use crate::calibration::validation::contact_check::{
    ContactCheck, ContactCheckReport, contact_check, geometric,
};
use crate::session::measurements::Measurements;
use crate::session::model::RobotModel;

/// How a held-out evaluation calibrates each training set.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Selection {
    /// `armcal identify --params full` at the stated prior.
    Stated,
    /// The same at the prior's scale `armcal identify` chooses with `folds`
    /// folds ([`PriorScale::Chosen`]).
    Prior {
        /// Folds of the cross-validation.
        folds: usize,
    },
    /// What `armcal diagnose` chooses with `folds` folds: blunders set aside,
    /// the geometric model and its prior's scale, the effects the data name;
    /// the nominal model when nothing beats it held-out.
    Diagnosis {
        /// Folds of the cross-validation.
        folds: usize,
    },
}

/// One calibration of a training set ([`calibrate`]).
#[derive(Clone, Debug)]
pub struct Calibrated {
    /// The calibrated model, its effects included.
    pub model: EffectModel<f64>,
    /// The RMS distance of the training rows' tool points to their fitted
    /// points (or planes), m.
    pub training_rms: f64,
    /// What was chosen, as reports name it (`prior ×10`; the diagnosis'
    /// model); empty for the stated prior.
    pub choice: String,
}

/// Calibrates `model` on `data` as `selection` says.
pub fn calibrate(
    model: &RobotModel,
    data: &Measurements,
    options: &FullOptions,
    selection: Selection,
) -> Result<Calibrated, IdentifyError> {
    // As identify and diagnose: the masses fitted to measured torques, if
    // any, their sign read from the data.
    let (fitted, _) = crate::calibration::gravity::with_measured_gravity(model, data, None)
        .map_err(IdentifyError::from)?;
    let model = &fitted;
    let identified = |scale: PriorScale| -> Result<Calibrated, IdentifyError> {
        let fit = identify::identify(
            model,
            data,
            &identify::IdentifyRequest {
                scale,
                ..identify::IdentifyRequest::new(*options)
            },
        )?;
        Ok(Calibrated {
            model: geometric(&fit.calibrated()),
            training_rms: fit.position_rms,
            choice: match fit.prior.as_ref().map(|c| c.factor()) {
                Some(f) if f != 1.0 => format!("prior ×{f}"),
                _ => String::new(),
            },
        })
    };
    match selection {
        Selection::Stated => identified(PriorScale::Stated),
        Selection::Prior { folds } => identified(PriorScale::Chosen { folds }),
        Selection::Diagnosis { folds } => {
            let options = DiagnoseOptions {
                folds: folds.min(data.len()),
                fit: *options,
                ..DiagnoseOptions::default()
            };
            let d = diagnose_session(&model.robot, &data.poses, &data.constraints, &options)?;
            // The model of the calibration `diagnose --out` writes (the
            // nominal model when nothing beats it held-out).
            let calibration = d.calibration(&model.robot, Task::Position, model.units);
            Ok(Calibrated {
                model: calibration.model(),
                training_rms: d.fit.position_rms,
                choice: d.chosen_label(),
            })
        }
    }
}

/// One held-out session of [`leave_one_out`].
#[derive(Clone, Debug)]
pub struct HeldOut {
    /// The session left out (its file).
    pub file: String,
    /// The nominal model's figures on it.
    pub nominal: ContactCheck,
    /// The reference model's, when one is given.
    pub reference: Option<ContactCheck>,
    /// The calibration's from the other sessions.
    pub calibrated: ContactCheck,
    /// The RMS distance of the training rows' tool points to their fitted points, m.
    pub training_rms: f64,
    /// What the calibration chose ([`Calibrated::choice`]).
    pub choice: String,
}

/// A session held out as the reports give it ([`HeldOut::report`]),
/// lengths in the model's unit.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct HeldOutReport {
    /// The session's file.
    pub file: String,
    /// How its training set was calibrated.
    pub choice: String,
    /// The calibration's residual RMS on its training rows.
    pub training_rms: f64,
    /// The nominal model's figures on the session.
    pub nominal: ContactCheckReport,
    /// The reference model's, when given.
    pub reference: Option<ContactCheckReport>,
    /// The calibration's.
    pub calibrated: ContactCheckReport,
}

impl HeldOut {
    /// The session's figures, lengths in `units`.
    pub fn report(&self, units: &Units) -> HeldOutReport {
        HeldOutReport {
            file: self.file.clone(),
            choice: self.choice.clone(),
            training_rms: units.length_from_si(self.training_rms),
            nominal: self.nominal.report(units),
            reference: self.reference.as_ref().map(|c| c.report(units)),
            calibrated: self.calibrated.report(units),
        }
    }
}

impl HeldOut {
    /// The figures of the nominal model, `reference` and `calibration` on
    /// `held`, the session left out.
    pub fn of(
        held: &Measurements,
        nominal: &Robot<f64>,
        reference: Option<&Robot<f64>>,
        calibration: &Calibrated,
    ) -> Self {
        Self {
            file: held.file.clone(),
            nominal: contact_check(&geometric(nominal), held),
            reference: reference.map(|r| contact_check(&geometric(r), held)),
            calibrated: contact_check(&calibration.model, held),
            training_rms: calibration.training_rms,
            choice: calibration.choice.clone(),
        }
    }
}

/// The held-out figures of `sessions`, as `armcal holdout` gives them:
/// without `training`, each left out in turn ([`leave_one_out`]); with it,
/// `model` calibrated once on `training` (merged) and each of `sessions`
/// predicted.
pub fn held_out(
    model: &RobotModel,
    sessions: &[Measurements],
    training: &[Measurements],
    reference: Option<&Robot<f64>>,
    options: &FullOptions,
    selection: Selection,
) -> Result<Vec<HeldOut>, IdentifyError> {
    if training.is_empty() {
        return leave_one_out(model, sessions, reference, options, selection);
    }
    let parts: Vec<&Measurements> = training.iter().collect();
    let calibration = calibrate(model, &Measurements::merged(&parts), options, selection)?;
    Ok(sessions
        .iter()
        .map(|s| HeldOut::of(s, &model.robot, reference, &calibration))
        .collect())
}

/// Leaves each of `sessions` out in turn, calibrates `model` on the others
/// as `selection` says (with `options`) and checks the nominal model,
/// `reference` and the calibration on the one left out.
pub fn leave_one_out(
    model: &RobotModel,
    sessions: &[Measurements],
    reference: Option<&Robot<f64>>,
    options: &FullOptions,
    selection: Selection,
) -> Result<Vec<HeldOut>, IdentifyError> {
    let mut out = Vec::new();
    for (i, held) in sessions.iter().enumerate() {
        let training: Vec<&Measurements> = sessions
            .iter()
            .enumerate()
            .filter(|(j, _)| *j != i)
            .map(|(_, s)| s)
            .collect();
        let merged = Measurements::merged(&training);
        let calibration = calibrate(model, &merged, options, selection)?;
        out.push(HeldOut::of(held, &model.robot, reference, &calibration));
    }
    Ok(out)
}
