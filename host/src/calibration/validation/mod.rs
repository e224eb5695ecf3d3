//! Validation: how good a calibration is, on rows it was not fitted to and on
//! its own — the floor under both `identify` and `diagnose`.
//!
//! | module | idea |
//! | --- | --- |
//! | [`folds`] | k-fold cross-validation by linearisation about one fit; the interleaved folds, a configuration held out whole |
//! | [`blunders`] | deleted residuals (Cook & Weisberg) against a robust scale: the rows a blunder explains |
//! | [`stats`] | Fisher's F distribution and its quantiles, the paired test of held-out errors |
//! | [`replicates`] | repeated configurations: the noise the repeats show, the lack-of-fit test |
//! | [`contact_check`] | a session without a tracker: the spread at each fixed point, the flatness of each plane, the error of each known distance |
//! | [`acceptance`] | whether a calibration may be written: it converged and fits its own rows no worse than nominal |
//!
//! Everything here reads a fit ([`crate::calibration::fit`]) and the session's
//! rows; nothing here chooses a model or identifies one (the test `layers::no_import_runs_back_up`
//! keeps it so).

pub mod acceptance;
pub mod blunders;
pub mod contact_check;
pub mod folds;
pub mod replicates;
pub mod stats;
