//! # armcal: the robot calibrator (library part of the `armcal` binary)
//!
//! The input layer reads the two interchange formats of `FORMAT.md` and refuses,
//! with file, line and column, anything it cannot use:
//!
//! | module | idea |
//! | --- | --- |
//! | [`arrays`] | measurements and joint readings given as arrays (the Python package's numpy input), checked as the CSV reader checks its file |
//! | [`input_error`] | [`InputError`](input_error::InputError): a refused file, `file:line:column: message` |
//! | [`model_file`] | the robot model TOML (§1) into an SI [`armcal_shared::Robot`], with the file's [`Units`](model_file::Units) |
//! | [`measurements`] | the measurement CSV (§2), read against a model, into SI [`Observation`](measurements::Observation)s; joint readings alone into [`JointRow`](measurements::JointRow)s |
//! | [`builtin`] | the models of `models/` and the real data sets of `data/`, built into the binary |
//! | [`identify`] | `armcal identify`: the paper's iterative regression and the full model, report and calibration |
//! | [`output`] | a run's result files: all or none, never over an input, never replacing a device |
//! | [`predict`] | `armcal predict`: the calibrated model's tool point (and frame) for each row of joint readings |
//! | [`sweep`] | `armcal sweep`: detection and false-positive rates of the diagnosis over many simulated sessions |
//! | [`simulate`] | true robots with built-in errors and their noisy measurements |
//! | [`report`] | the self-contained HTML page of `armcal diagnose --html` (inline SVG) |
//! | [`reproduce`] | `armcal reproduce`: the seed papers' examples |
//! | [`link`] | `armcal stream`: the serial link to the controller (TCP or serial port), calibration load and command stream |
//! | [`compensate`] | `armcal compensate`: corrected joint commands for the calibrated robot |
//! | [`diagnose`] | `armcal diagnose`: the model chosen on held-out poses (geometry, prior, effects), never worse than nominal; blunders; held-out gain |
//! | [`demo`] | `armcal demo`: a simulated PUMA with a hidden effect, diagnosed, compensated, reported |
//! | [`stats`] | Fisher's F distribution and its quantiles, for the diagnosis' tests |
//! | [`urdf`] | URDF chains in (modified D-H with Hayati's tilt, exact) and calibrations out (`armcal export`) |
//! | [`check`] | `armcal check`: what was read, and the error of the nominal model against the data |
//!
//! Units: inside the program everything is SI (m, rad, kg), as in `armcal-shared`;
//! the model file's `length_unit` and `angle_unit` apply to the model and to its
//! data files, and are converted on reading.

pub mod arrays;
pub mod builtin;
pub mod check;
pub mod compensate;
pub mod demo;
pub mod diagnose;
pub mod identify;
pub mod input_error;
pub mod link;
pub mod measurements;
pub mod model_file;
pub mod output;
pub mod predict;
pub mod report;
pub mod reproduce;
pub mod simulate;
pub mod stats;
pub mod sweep;
pub mod ur;
pub mod urdf;

#[cfg(test)]
mod test_support;
