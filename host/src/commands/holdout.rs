//! `holdout`: sessions without a tracker, each left out in turn (or each
//! predicted from training sessions), as
//! [`crate::calibration::contact_check::held_out`] computes it, with the
//! sessions checked the same way whichever front end asks.
//!
//! Scales are in the model's units as the user states them; the figures are
//! SI.

use super::{Argument, Front, fit_options};
use crate::calibration::cancel::Cancel;
use crate::calibration::contact_check::{self, HeldOut, Selection};
use crate::calibration::diagnose::cross_validation::DEFAULT_FOLDS;
use crate::calibration::identify::StatedScales;
use crate::calibration::fit::FullOptions;
use crate::io::input_error::InputError;
use crate::io::model_file::RobotModel;
use crate::session::measurements::Measurements;

/// How each training set is calibrated.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Calibrate {
    /// `identify` at the stated prior (`--prior-scale stated`).
    Stated,
    /// `identify` at the prior's scale it chooses (its default).
    Prior,
    /// What `diagnose` chooses (`--diagnose`).
    Diagnosis,
}

impl Calibrate {
    /// The selection of [`contact_check::held_out`], with the default folds
    /// of the cross-validations.
    pub fn selection(self) -> Selection {
        let folds = DEFAULT_FOLDS;
        match self {
            Self::Stated => Selection::Stated,
            Self::Prior => Selection::Prior { folds },
            Self::Diagnosis => Selection::Diagnosis { folds },
        }
    }
}

/// What `holdout` is asked.
#[derive(Clone, Copy, Debug)]
pub struct Request {
    /// How each training set is calibrated.
    pub calibrate: Calibrate,
    /// The noise and prior scales stated (model units).
    pub scales: StatedScales,
    /// The caller's request to stop, asked at the computation's step
    /// boundaries ([`crate::calibration::cancel`]); [`Cancel::NEVER`] on the
    /// command line, which SIGINT ends.
    pub cancel: Cancel,
}

/// The sessions of a `holdout`, each read and accepted as a session without
/// a tracker ([`contact_check::require_session`]).
#[derive(Clone, Copy, Debug)]
pub struct Sessions<'a> {
    /// The sessions left out (or predicted), each in turn.
    pub held_out: &'a [Measurements],
    /// The sessions trained on instead, when given.
    pub training: &'a [Measurements],
    /// Another model of the same chain checked on the same rows.
    pub reference: Option<&'a RobotModel>,
}

/// The held-out figures of every session: refused when the sessions cannot
/// make a holdout ([`require_sessions`]) or a scale is not positive.
pub fn run(
    front: Front,
    model: &RobotModel,
    sessions: Sessions<'_>,
    request: &Request,
) -> anyhow::Result<Vec<HeldOut>> {
    require_sessions(front, model, sessions)?;
    let options = FullOptions {
        cancel: request.cancel,
        ..fit_options(front, model, &request.scales)?
    };
    let reference = sessions.reference.map(|r| &r.robot);
    let held_out = contact_check::held_out(
        model,
        sessions.held_out,
        sessions.training,
        reference,
        &options,
        request.calibrate.selection(),
    )?;
    // What a computation asked to stop part way found is not returned.
    request.cancel.check()?;
    Ok(held_out)
}

/// `holdout`'s sessions: two or more to leave out in turn unless training
/// sessions are given, none given twice among both, and a reference model
/// (when given) of as many joints as `model`.
pub fn require_sessions(
    front: Front,
    model: &RobotModel,
    sessions: Sessions<'_>,
) -> Result<(), InputError> {
    let Sessions {
        held_out,
        training,
        reference,
    } = sessions;
    contact_check::require_distinct(
        &held_out.iter().chain(training).collect::<Vec<_>>(),
        contact_check::HOLDOUT_TWICE,
    )?;
    if training.is_empty() && held_out.len() < 2 {
        return Err(Argument::Sessions.refused(
            front,
            format!(
                "give two or more sessions to leave out in turn, or the training sessions with {}",
                Argument::Training.given(front)
            ),
        ));
    }
    if let Some(r) = reference
        && r.robot.dof() != model.robot.dof()
    {
        return Err(Argument::Reference.refused(
            front,
            format!(
                "{} joints, the model has {}",
                r.robot.dof(),
                model.robot.dof()
            ),
        ));
    }
    Ok(())
}
