//! # armcal: the robot calibrator (library part of the `armcal` binary)
//!
//! The library is in six layers, in the order data flows through a session,
//! over [`cancel`] (stopping a long computation);
//! a newcomer looking for a verb's science starts in [`calibration`], for a file
//! format in [`io`], for what a verb is asked in [`commands`]. The command line
//! is in the binary: `host/src/cli.rs` (the flags, turned into the requests of
//! [`commands`]), `host/src/verbs.rs` (one function per verb: inputs read,
//! request run, outcome printed and written) and `host/src/terminal.rs` (what
//! they print and write with).
//!
//! ## [`io`]: files in and out
//!
//! Reads the two interchange formats of `docs/file-formats.md` (§1, §2) and the vendors' formats, and
//! refuses, with file, line and column, anything it cannot use:
//!
//! | module | idea |
//! | --- | --- |
//! | [`io::input_error`] | [`InputError`](session::input_error::InputError): a refused file, `file:line:column: message` |
//! | [`io::model_file`] | the robot model TOML (§1) into an SI [`armcal_shared::Robot`], with the file's [`Units`](armcal_shared::units::Units) |
//! | [`io::measurements`] | the measurement CSV (§2), read against a model, into the SI [`Observation`](session::observation::Observation)s of a [`Measurements`](session::measurements::Measurements); joint readings alone into [`JointRows`](session::joints::JointRows) |
//! | [`io::arrays`] | measurements and joint readings given as arrays (the Python package's numpy input), checked as the CSV reader checks its file |
//! | [`io::builtin`] | the models of `models/` and the real data sets of `data/`, built into the binary |
//! | [`io::urdf`] | URDF chains in (modified D-H with Hayati's tilt, exact) and calibrations out (`armcal export`) |
//! | [`io::ur`] | Universal Robots' controller calibration (D-H deltas, `ur_calibration` YAML), in and out |
//! | [`io::output`] | a run's result files: all or none, never over an input, never replacing a device |
//!
//! ## [`commands`]: what a verb is asked
//!
//! Each verb's checked `Request` and its `run`, returning the outcome as
//! typed values (the calibration, the report, why it is not written), for the
//! command line and the Python package alike: every argument rule written
//! once, its refusals naming the argument as each front end does, and the one
//! rule of which errors refuse the input (exit status 2) and which fail.
//!
//! ## [`session`]: what a calibration is made from
//!
//! The measured rows, joint rows, constraints, configurations, channels and
//! the prior, with the checks that rows can carry a calibration
//! ([`session`]'s table). [`io`] parses into them and imports nothing of
//! [`calibration`]; [`calibration`] reads them.
//!
//! ## [`cancel`]: stopping a long computation
//!
//! The [`Cancel`](cancel::Cancel) handle a computation asks between its steps
//! and the [`Interrupt`](cancel::Interrupt) that raises it (the Python
//! package's Ctrl-C); under every other layer, so that [`session`]'s passes
//! over the rows ask it as [`calibration`]'s do.
//!
//! ## [`calibration`]: the science, in floors
//!
//! Each floor uses only the floors under it (the test `layers` checks it):
//!
//! | floor | module | idea |
//! | --- | --- | --- |
//! | ground | [`calibration::gravity`], [`calibration::dense`], [`calibration::parallel`] | the arm's masses from measured torques; faer's matrices; independent pieces on every core |
//! | simulator | [`calibration::simulate`] | true robots with built-in errors and their noisy measurements |
//! | fit | [`calibration::fit`] | the weighted least-squares fit of the full model (Mirman & Gupta's columns, the prior, each channel's noise) |
//! | validation | [`calibration::validation`] | cross-validation folds, deleted residuals, the F tests, the repeats' lack of fit, a session without a tracker's figures, whether a calibration may be written |
//! | verbs | [`calibration::identify`], [`calibration::check`], [`calibration::plan`] | `armcal identify` (the paper's regression and the full model, its prior's scale and channel weights chosen held-out), `check`, `plan` |
//! | | [`calibration::diagnose`], [`calibration::reproduce`] | `armcal diagnose` (the model chosen held-out, blunders, effects, its HTML page); the seed papers' examples |
//! | | [`calibration::holdout`], [`calibration::sweep`], [`calibration::demo`] | sessions left out in turn; the diagnosis' rates over simulated sessions; the demo |
//!
//! ## [`report`]: how reports are written
//!
//! Numbers as the summaries give them, the HTML pages' head and escaping, and
//! the scatter plots as inline SVG with real axes; under both [`calibration`]
//! and [`apply`].
//!
//! ## [`apply`]: using a calibration
//!
//! | module | idea |
//! | --- | --- |
//! | [`apply::predict`] | `armcal predict`: the calibrated model's tool point (and frame) for each row of joint readings |
//! | [`apply::compensate`] | `armcal compensate`: corrected joint commands for the calibrated robot |
//! | [`apply::ranges`] | the warnings of `predict`, `compensate` and `stream` where rows lie outside the ranges a calibration was identified on, or lack a condition its effects need |
//! | [`apply::export`] | what `armcal export` writes of a calibration with effects into a format that cannot carry them (the geometry refitted without them), and its expected held-out error |
//! | [`apply::link`] | `armcal stream`: the serial link to the controller (TCP or serial port), calibration load and command stream |
//!
//! The Python package, the fuzz targets, the benchmarks and the tests reach
//! every module through its layer (`armcal::io::measurements`,
//! `armcal::calibration::identify`, …), as the binary does.
//!
//! Units: inside the program everything is SI (m, rad, kg), as in `armcal-shared`;
//! the model file's `length_unit` and `angle_unit` apply to the model and to its
//! data files, and are converted on reading.

pub mod apply;
pub mod calibration;
pub mod cancel;
pub mod commands;
pub mod io;
pub mod report;
pub mod session;

#[cfg(test)]
mod layers;
#[cfg(test)]
mod test_support;
