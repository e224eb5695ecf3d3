//! The calibration itself: identification, diagnosis, the plan of a
//! measurement, simulation and the papers.
//!
//! These modules work on SI values read by [`crate::io`]; none of them opens a
//! file of its own (the HTML pages are returned as text).

pub mod check;
pub mod demo;
pub mod dense;
pub mod diagnose;
pub mod fit;
pub mod gravity;
pub mod holdout;
pub mod identify;
pub mod parallel;
pub mod plan;
pub mod reproduce;
pub mod simulate;
pub mod sweep;
pub mod validation;
