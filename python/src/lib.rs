//! `armcal._native`: the Python extension of armcal (PyO3).
//!
//! The Python package `armcal` re-exports what this module defines: robot
//! models ([`model::Model`]), measurements from files or numpy arrays
//! ([`data::Measurements`]), identification and diagnosis with their reports
//! ([`fit`]), the held-out check of sessions without a tracker ([`holdout`]),
//! the plan of a measurement ([`plan`]),
//! and calibrations that predict and compensate with numpy arrays in
//! and out ([`calibration::Calibration`]). Every computation is the library's
//! (`armcal`), composed as the command line composes it; lengths and angles in
//! and out are in the model's units, as in the files.
//!
//! Errors are Python exceptions carrying the command line's messages: a refused
//! input is `armcal.InputError` (`file:line:column: message`, or for numpy
//! arrays `data row 17: message` with the row as numpy indexes it), any other
//! failure `armcal.ArmcalError`, of which `InputError` is a subclass.

use pyo3::prelude::*;

mod calibration;
mod data;
mod errors;
mod fit;
mod holdout;
mod interrupt;
mod model;
mod plan;

/// The module `armcal._native`.
#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add("ArmcalError", py.get_type::<errors::ArmcalError>())?;
    m.add("InputError", py.get_type::<errors::InputError>())?;
    m.add_class::<model::Model>()?;
    m.add_class::<data::Measurements>()?;
    m.add_class::<fit::Outcome>()?;
    m.add_class::<fit::Identification>()?;
    m.add_class::<fit::Diagnosis>()?;
    m.add_class::<calibration::Calibration>()?;
    m.add_function(wrap_pyfunction!(model::load_model, m)?)?;
    m.add_function(wrap_pyfunction!(model::parse_model, m)?)?;
    m.add_function(wrap_pyfunction!(model::builtin_models, m)?)?;
    m.add_function(wrap_pyfunction!(model::builtin_data, m)?)?;
    m.add_function(wrap_pyfunction!(data::load_measurements, m)?)?;
    m.add_function(wrap_pyfunction!(data::parse_measurements, m)?)?;
    m.add_function(wrap_pyfunction!(data::from_arrays, m)?)?;
    m.add_function(wrap_pyfunction!(data::simulate, m)?)?;
    m.add_function(wrap_pyfunction!(fit::identify_py, m)?)?;
    m.add_function(wrap_pyfunction!(fit::diagnose, m)?)?;
    m.add_function(wrap_pyfunction!(holdout::holdout, m)?)?;
    m.add_function(wrap_pyfunction!(plan::plan, m)?)?;
    m.add_function(wrap_pyfunction!(calibration::load_calibration, m)?)?;
    Ok(())
}
