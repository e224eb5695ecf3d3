//! # armcal: the robot calibrator (library part of the `armcal` binary)
//!
//! The library is in five layers, in the order data flows through a session;
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
//! | [`io::input_error`] | [`InputError`](io::input_error::InputError): a refused file, `file:line:column: message` |
//! | [`io::model_file`] | the robot model TOML (§1) into an SI [`armcal_shared::Robot`], with the file's [`Units`](io::model_file::Units) |
//! | [`io::measurements`] | the measurement CSV (§2), read against a model, into the SI [`Observation`](session::measurements::Observation)s of a [`Measurements`](session::measurements::Measurements); joint readings alone into [`JointRows`](session::joints::JointRows) |
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
//! ## [`calibration`]: the science
//!
//! | module | idea |
//! | --- | --- |
//! | [`calibration::check`] | `armcal check`: what was read, and the error of the nominal model against the data |
//! | [`calibration::identify`] | `armcal identify`: the paper's iterative regression and the full model, report and calibration |
//! | [`calibration::diagnose`] | `armcal diagnose`: the model chosen on held-out poses (geometry, prior, effects), never worse than nominal; blunders; held-out gain |
//! | [`calibration::validation::replicates`] | repeated configurations (the partition itself is [`session::configurations`]): the instrument noise the repeats show, the lack-of-fit test |
//! | [`calibration::report`] | the self-contained HTML page of `armcal diagnose --html` (inline SVG) |
//! | [`calibration::sweep`] | `armcal sweep`: detection and false-positive rates of the diagnosis over many simulated sessions |
//! | [`calibration::validation::stats`] | Fisher's F distribution and its quantiles, for the diagnosis' tests |
//! | [`calibration::simulate`] | true robots with built-in errors and their noisy measurements |
//! | [`calibration::reproduce`] | `armcal reproduce`: the seed papers' examples |
//! | [`calibration::demo`] | `armcal demo`: a simulated PUMA with a hidden effect, diagnosed, compensated, reported |
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
pub mod commands;
pub mod io;
pub mod report;
pub mod session;

#[cfg(test)]
mod layers;
#[cfg(test)]
mod test_support;
