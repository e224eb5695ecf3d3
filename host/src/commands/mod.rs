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
//! One module a verb that computes, each with its `Request` (what was asked,
//! in the model's units as the user states them) and its `run`, which checks
//! the request against the model and the data, computes, and returns the
//! outcome as typed values (a calibration, a report, what refuses it to be
//! written): [`identify`], [`diagnose`], [`holdout`], [`simulate`],
//! [`export`], [`plan`]; the working tool a front end names is checked by [`tool`].
//! Turning
//! an outcome into text, files and warnings is the front end's. The rules
//! every verb shares are here: several sessions read as one ([`sessions`]),
//! a session's checks ([`require_session`]), the
//! fit's stated scales ([`fit_options`]), the folds ([`folds`]), and which
//! errors refuse the input (exit status 2) rather than fail
//! ([`is_refusal`]).

pub mod choices;
pub mod diagnose;
pub mod export;
pub mod holdout;
pub mod identify;
pub mod plan;
pub mod simulate;
pub mod tool;

use crate::calibration::fit::independent_parameter_count;
use crate::calibration::fit::{FullError, FullOptions};
use crate::calibration::identify::paper::PaperError;
use crate::calibration::identify::{IdentifyError, StatedScales};
use crate::calibration::validation::folds::DEFAULT_FOLDS;
use crate::session::input_error::InputError;
use crate::session::measurements::{Measurements, WorstRow};
use crate::session::model::RobotModel;
use crate::session::registration::FrameSharing;

/// Which front end asked.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Front {
    /// The `armcal` command line: arguments are flags (`--folds`).
    CommandLine,
    /// The Python package: arguments are keywords (`folds`).
    Python,
}

impl Front {
    /// How a reason tells the user to write a failed calibration anyway.
    pub fn write_failed(self) -> &'static str {
        match self {
            Self::CommandLine => "--write-failed",
            Self::Python => "write_failed=True",
        }
    }

    /// The name in this front end of a flag of the command line
    /// (`--position-noise` is the keyword `position_noise`).
    pub fn flag(self, flag: &'static str) -> String {
        match self {
            Self::CommandLine => flag.to_owned(),
            Self::Python => flag.trim_start_matches("--").replace('-', "_"),
        }
    }
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
    /// The poses `simulate` measures.
    Poses,
    /// The position noise `simulate` draws.
    Noise,
    /// The orientation noise `simulate` draws.
    OrientationNoise,
    /// `simulate`'s fixed orientation bias.
    OrientationBias,
    /// `simulate`'s orientation bias growing with distance.
    OrientationBiasGrowth,
    /// The noise of the joint torques `simulate` reports.
    TorqueNoise,
    /// The hidden effects `simulate` builds in.
    Effects,
    /// The hidden tilts `simulate` builds in.
    Tilts,
    /// The payloads `simulate` measures with.
    Payloads,
    /// The sessions `simulate` measures in.
    SimulatedSessions,
    /// The true robot's D-H errors `simulate` draws.
    LinkErrors,
    /// The true base frame's errors `simulate` draws.
    BaseErrors,
    /// The true tool frame's errors `simulate` draws.
    ToolErrors,
    /// The model a calibration is exported against or into.
    Model,
    /// The calibration file exported.
    Calibration,
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
            (Self::Poses, Front::CommandLine) => "--poses",
            (Self::Poses, Front::Python) => "poses",
            (Self::Noise, Front::CommandLine) => "--noise",
            (Self::Noise, Front::Python) => "noise",
            (Self::OrientationNoise, Front::CommandLine) => "--orientation-noise",
            (Self::OrientationNoise, Front::Python) => "orientation_noise",
            (Self::OrientationBias, Front::CommandLine) => "--orientation-bias",
            (Self::OrientationBias, Front::Python) => "orientation_bias",
            (Self::OrientationBiasGrowth, Front::CommandLine) => "--orientation-bias-growth",
            (Self::OrientationBiasGrowth, Front::Python) => "orientation_bias_growth",
            (Self::TorqueNoise, Front::CommandLine) => "--torque-noise",
            (Self::TorqueNoise, Front::Python) => "torque_noise",
            (Self::Effects, Front::CommandLine) => "--effect",
            (Self::Effects, Front::Python) => "effects",
            (Self::Tilts, Front::CommandLine) => "--tilt",
            (Self::Tilts, Front::Python) => "tilts",
            (Self::Payloads, Front::CommandLine) => "--payloads",
            (Self::Payloads, Front::Python) => "payloads",
            (Self::SimulatedSessions, Front::CommandLine) => "--sessions",
            (Self::SimulatedSessions, Front::Python) => "sessions",
            (Self::LinkErrors, Front::CommandLine) => "--link-errors",
            (Self::LinkErrors, Front::Python) => "link_errors",
            (Self::BaseErrors, Front::CommandLine) => "--base-errors",
            (Self::BaseErrors, Front::Python) => "base_errors",
            (Self::ToolErrors, Front::CommandLine) => "--tool-errors",
            (Self::ToolErrors, Front::Python) => "tool_errors",
            (Self::Model, Front::CommandLine) => "--model",
            (Self::Model, Front::Python) => "model",
            (Self::Calibration, Front::CommandLine) => "--calibration",
            (Self::Calibration, Front::Python) => "calibration",
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

/// The checks of a session of measured poses before any fit: enough
/// equations for the model's independent parameters
/// ([`Measurements::require_poses`]); with several sessions, enough in each
/// for the frames `frames` makes its own
/// ([`Measurements::require_own_frames`]); and rows that can be
/// measurements of this robot, each session's against its own points unless
/// they share one base frame ([`Measurements::require_plausible_sessions`]).
/// Every refusal names the file and line of the row concerned.
pub fn require_session(
    model: &RobotModel,
    data: &Measurements,
    frames: FrameSharing,
) -> Result<(), InputError> {
    data.require_poses(
        &model.robot,
        independent_parameter_count(&model.robot, data.has_orientation()),
    )?;
    data.require_own_frames(&model.robot, frames)?;
    data.require_plausible_sessions(model, frames.base)
}

/// The row of `data` the nominal `model` misses most, for
/// [`Measurements::require_fit_supported`] to name when it alone holds most
/// of the misfit (as `armcal check` names it: `check::nominal_error`, each
/// session in its own frames registered); none for a session of contacts.
pub fn nominal_worst_row(model: &RobotModel, data: &Measurements) -> Option<WorstRow> {
    if data.is_constrained() {
        return None;
    }
    let e = crate::calibration::check::nominal_error(model, data);
    let total = e.position_rms.powi(2) * data.len() as f64;
    (total > 0.0).then(|| WorstRow {
        pose: e.position_max_pose,
        error: e.position_max,
        share: e.position_max.powi(2) / total,
    })
}

/// Several sessions of one robot as one calibration's rows
/// ([`Measurements::sessions`]), refused when one is given twice (the same
/// file, or the same rows: [`crate::session::distinct::require_distinct`]).
pub fn sessions(parts: Vec<Measurements>) -> Result<Measurements, InputError> {
    use crate::session::distinct::{SESSION_TWICE, require_distinct};
    require_distinct(&parts.iter().collect::<Vec<_>>(), SESSION_TWICE)?;
    Measurements::sessions(parts)
}

/// The fit's options from the model's prior and the `scales` stated (model
/// units), refused when one is not a positive number, named as `front`
/// names it.
pub fn fit_options(
    front: Front,
    model: &RobotModel,
    scales: &StatedScales,
) -> Result<FullOptions, InputError> {
    scales.options(model).map_err(|e| {
        InputError::argument(
            front.flag(e.flag),
            format!(
                "{}: must be a positive number",
                crate::session::input_error::number(e.value)
            ),
        )
    })
}

/// Whether `err` refuses what the user gave (a file, an argument, data that
/// cannot carry the computation): exit status 2 on the command line,
/// `armcal.InputError` in Python. Anything else is a failure of the program
/// or the machine.
pub fn is_refusal(err: &anyhow::Error) -> bool {
    use crate::calibration::plan::PlanError;
    err.downcast_ref::<InputError>().is_some()
        || err
            .downcast_ref::<FullError>()
            .is_some_and(|e| !matches!(e, FullError::Cancelled(_)))
        || err.downcast_ref::<PaperError>().is_some()
        || err
            .downcast_ref::<PlanError>()
            .is_some_and(|e| !matches!(e, PlanError::Cancelled))
        || err.downcast_ref::<IdentifyError>().is_some_and(|e| {
            !matches!(
                e,
                IdentifyError::Calibration(_) | IdentifyError::Full(FullError::Cancelled(_))
            )
        })
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
        assert_eq!(Front::Python.flag("--prior-length"), "prior_length");
        assert_eq!(Front::CommandLine.flag("--prior-length"), "--prior-length");
    }

    /// A stated scale that is not positive is refused before any fit, named
    /// as each front end names it; a positive one is converted to SI with
    /// the model's units (the PUMA 560 model is in inches: 0.1 in = 2.54 mm).
    #[test]
    fn a_stated_scale_is_checked_once_and_named_by_each_front_end() {
        let model = crate::io::model_file::load_model("puma560").unwrap();
        let bad = StatedScales {
            prior_length: Some(-1.0),
            ..Default::default()
        };
        for (front, name) in [
            (Front::CommandLine, "--prior-length"),
            (Front::Python, "prior_length"),
        ] {
            let e = fit_options(front, &model, &bad).unwrap_err();
            assert_eq!(e.file, name);
            assert!(
                e.to_string().contains("-1: must be a positive number"),
                "{e}"
            );
        }
        let good = StatedScales {
            prior_length: Some(0.1),
            ..Default::default()
        };
        let options = fit_options(Front::Python, &model, &good).unwrap();
        assert!((options.prior.length - 2.54e-3).abs() < 1e-15);
    }

    /// `export`'s rules on what it must be given, before anything is read: a
    /// UR format needs its UR model; a URDF chain is named only with its
    /// URDF.
    #[test]
    fn export_names_the_model_it_needs() {
        use crate::io::urdf::ChainSpec;
        let ur = export::Request {
            format: export::Format::UrDeltas,
            model: None,
            chain: ChainSpec::default(),
            tool: None,
        };
        let e = ur.check(Front::CommandLine).unwrap_err();
        assert_eq!(e.file, "--model");
        let chain = export::Request {
            format: export::Format::Urdf,
            model: None,
            chain: ChainSpec {
                tip_link: Some("ball_link".into()),
                ..ChainSpec::default()
            },
            tool: None,
        };
        assert!(
            chain
                .check(Front::CommandLine)
                .unwrap_err()
                .to_string()
                .contains("give it")
        );
        let generated = export::Request {
            chain: ChainSpec::default(),
            ..chain
        };
        generated.check(Front::CommandLine).unwrap();
    }
}
