//! The command layer: what a verb is asked, checked once, whichever front end
//! asks it.
//!
//! The command line (`main.rs`, `verbs.rs`) and the Python package
//! (`python/`) read their arguments each in their own way (clap options,
//! numpy arrays and keywords) and hand them here: every rule an argument must
//! keep (its range, what it must agree with) is written once, and a refusal
//! names the argument as the front end that asked calls it ([`Front`],
//! [`Argument`]). A refusal is an [`InputError`] of that argument: exit status
//! 2 on the command line, `armcal.InputError` in Python.
//!
//! Built verb by verb: `diagnose`'s folds ([`folds`]) and `holdout`'s
//! sessions ([`holdout_sessions`]) so far.

use crate::calibration::diagnose::cross_validation::DEFAULT_FOLDS;
use crate::io::input_error::InputError;
use crate::io::model_file::RobotModel;
use crate::session::measurements::Measurements;

/// Which front end asked.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Front {
    /// The `armcal` command line: arguments are flags (`--folds`).
    CommandLine,
    /// The Python package: arguments are keywords (`folds`).
    Python,
}

/// An argument a rule of this layer checks.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Argument {
    /// The sessions `holdout` leaves out in turn.
    Sessions,
    /// The sessions `holdout` trains on instead.
    Training,
    /// The reference model `holdout` checks beside the calibration.
    Reference,
    /// The folds of a cross-validation.
    Folds,
}

impl Argument {
    /// Its name in `front`: `--data`, `sessions`, …
    pub fn name(self, front: Front) -> &'static str {
        match (self, front) {
            (Self::Sessions, Front::CommandLine) => "--data",
            (Self::Sessions, Front::Python) => "sessions",
            (Self::Training, Front::CommandLine) => "--train",
            (Self::Training, Front::Python) => "train",
            (Self::Reference, Front::CommandLine) => "--reference",
            (Self::Reference, Front::Python) => "reference",
            (Self::Folds, Front::CommandLine) => "--folds",
            (Self::Folds, Front::Python) => "folds",
        }
    }

    /// How a sentence tells the user to give it: `--train`, `train=`.
    pub fn given(self, front: Front) -> String {
        match front {
            Front::CommandLine => self.name(front).to_owned(),
            Front::Python => format!("{}=", self.name(front)),
        }
    }

    /// The refusal of this argument as `front` names it.
    pub fn refused(self, front: Front, message: impl Into<String>) -> InputError {
        InputError::argument(self.name(front), message)
    }
}

/// The folds of a cross-validation of `poses` poses: `requested`, from 2 to
/// the number of poses (leave-one-out), or [`DEFAULT_FOLDS`] and at most one
/// per pose.
pub fn folds(front: Front, requested: Option<usize>, poses: usize) -> Result<usize, InputError> {
    match requested {
        None => Ok(DEFAULT_FOLDS.min(poses)),
        Some(k) if (2..=poses).contains(&k) => Ok(k),
        Some(k) => Err(Argument::Folds.refused(
            front,
            format!("{k}: from 2 to the number of poses ({poses}: leave-one-out)"),
        )),
    }
}

/// `holdout`'s sessions, each read and checked as a session without a
/// tracker: two or more to leave out in turn unless training sessions are
/// given, none given twice among both, and a reference model (when given) of
/// as many joints as `model`.
pub fn holdout_sessions(
    front: Front,
    model: &RobotModel,
    sessions: &[Measurements],
    training: &[Measurements],
    reference: Option<&RobotModel>,
) -> Result<(), InputError> {
    crate::calibration::contact_check::require_distinct(
        &sessions.iter().chain(training).collect::<Vec<_>>(),
    )?;
    if training.is_empty() && sessions.len() < 2 {
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

#[cfg(test)]
mod tests {
    use super::*;

    /// One rule, two front ends: the same folds accepted, the same refused,
    /// the refusal naming the flag on the command line and the keyword in
    /// Python.
    #[test]
    fn folds_are_checked_once_and_named_by_each_front_end() {
        for front in [Front::CommandLine, Front::Python] {
            assert_eq!(folds(front, None, 100).unwrap(), DEFAULT_FOLDS);
            assert_eq!(folds(front, None, 7).unwrap(), 7);
            assert_eq!(folds(front, Some(2), 7).unwrap(), 2);
            assert_eq!(folds(front, Some(7), 7).unwrap(), 7);
            for k in [0, 1, 8] {
                let e = folds(front, Some(k), 7).unwrap_err().to_string();
                assert!(e.contains(Argument::Folds.name(front)), "{e}");
                assert!(e.contains("from 2 to the number of poses (7"), "{e}");
            }
        }
        assert_eq!(Argument::Folds.name(Front::CommandLine), "--folds");
        assert_eq!(Argument::Training.given(Front::Python), "train=");
    }
}
