//! `holdout`: sessions without a tracker, each left out in turn, as `armcal
//! holdout` composes it (`armcal::calibration::holdout`).
//!
//! A session without a tracker measures no coordinate, so a calibration is
//! judged on one it was not fitted to by what needs none: the *spread* of the
//! predicted tool points at each unknown fixed point (RMS distance to their
//! mean, RMS over the points) and the *distance error* of each known distance
//! (the distance between the predicted points' means less the stated one).
//! Both in the model's length unit, in the model's base frame, which they do
//! not depend on.

use armcal::calibration::identify::StatedScales;
use armcal::cancel::Cancel;
use armcal::commands::holdout::{Calibrate, Request, Sessions, run};
use pyo3::prelude::*;

use crate::errors::PYTHON;
use crate::errors::{self, args};
use crate::fit::measurements_of;
use crate::interrupt::{OnInterrupt, interruptible};
use crate::model::Model;

/// Leaves each of `sessions` (Measurements, or paths, of sessions without a
/// tracker: rows naming their fixed point or plane) out in turn, calibrates
/// `model` on the others, and returns, for each session left out, what the
/// nominal model, `reference` (another Model of the same chain, such as
/// another tool's calibrated URDF) and the calibration predict of it. With
/// `train` (a list as `sessions`), calibrates once on those and predicts each
/// of `sessions`.
///
/// `select`: how a training set is calibrated, as the command line's flags:
/// `"prior"` (identify, every parameter, the prior's scale chosen by the
/// cross-validation of the training rows: `identify`'s default), `"stated"`
/// (`--prior-scale stated`: at the stated prior) or `"diagnose"`
/// (`--diagnose`: blunders, geometric model and prior, effects, as `diagnose`
/// chooses; the effects applied in the prediction). Noise and prior scales in
/// the model's units, as `identify`.
///
/// Each item is a dict: `file`, `choice` (what the calibration chose; empty
/// for the stated prior), `training_rms` (the training rows' RMS distance to
/// their fitted points or planes), and `nominal`, `reference` (None without
/// one), `calibrated`, each a dict: `spread` (RMS over the points),
/// `distance_error` (the largest in magnitude, signed), `flatness` (of the
/// predicted touches of each plane, RMS distance to their least-squares
/// plane, RMS over the planes), each None where the session has none of
/// that kind; `points` (`name`, `rows`, `centre` [x, y, z], `spread`),
/// `planes` (`name`, `rows`, unit `normal`, `offset` along it, `flatness`)
/// and `distances` (`points` [a, b], `stated`, `error`). Lengths in the
/// model's unit.
#[pyfunction]
#[pyo3(signature = (model, sessions, *, train = None, reference = None, select = String::from("prior"), position_noise = None, point_noise = None, plane_noise = None, prior_length = None, prior_angle = None))]
#[expect(
    clippy::too_many_arguments,
    reason = "a parameter per Python keyword argument, as the signature above lists them"
)]
pub fn holdout<'py>(
    py: Python<'py>,
    #[pyo3(from_py_with = crate::model::argument)] model: Bound<'py, Model>,
    #[pyo3(from_py_with = args::sessions_list)] sessions: Vec<Bound<'py, PyAny>>,
    #[pyo3(from_py_with = args::train_list)] train: Option<Vec<Bound<'py, PyAny>>>,
    #[pyo3(from_py_with = crate::model::reference_argument)] reference: Option<Bound<'py, Model>>,
    #[pyo3(from_py_with = args::select)] select: String,
    #[pyo3(from_py_with = args::position_noise)] position_noise: Option<f64>,
    #[pyo3(from_py_with = args::point_noise)] point_noise: Option<f64>,
    #[pyo3(from_py_with = args::plane_noise)] plane_noise: Option<f64>,
    #[pyo3(from_py_with = args::prior_length)] prior_length: Option<f64>,
    #[pyo3(from_py_with = args::prior_angle)] prior_angle: Option<f64>,
) -> PyResult<Vec<Bound<'py, PyAny>>> {
    let model = model.get();
    let m = &model.inner;
    let calibrate = match select.as_str() {
        "stated" => Calibrate::Stated,
        "prior" => Calibrate::Prior,
        "diagnose" => Calibrate::Diagnosis,
        other => {
            return Err(errors::argument(
                py,
                "select",
                format!("{other:?}: expected \"stated\", \"prior\" or \"diagnose\""),
            ));
        }
    };
    let request = Request {
        calibrate,
        scales: StatedScales {
            position_noise,
            orientation_noise: None,
            point_noise,
            plane_noise,
            prior_length,
            prior_angle,
        },
        // The computation's own, given on its thread.
        cancel: Cancel::NEVER,
    };
    let load = |argument: &str, list: &[Bound<'py, PyAny>]| {
        list.iter()
            .map(|d| {
                let d = measurements_of(py, model, d, argument)?;
                d.data
                    .require_contacts()
                    .map_err(|e| errors::input(py, &e, d.arrays))?;
                Ok(d.data)
            })
            .collect::<PyResult<Vec<armcal::session::measurements::Measurements>>>()
    };
    let sessions = load("sessions", &sessions)?;
    let training = load("train", train.as_deref().unwrap_or(&[]))?;
    // On a thread of its own: Ctrl-C stops it at its next fit's step.
    let (of_run, reference) = (m.clone(), reference.map(|r| r.get().inner.clone()));
    let rows = interruptible(py, OnInterrupt::Stops, move |cancel| {
        let given = Sessions {
            held_out: &sessions,
            training: &training,
            reference: reference.as_ref(),
        };
        run(PYTHON, &of_run, given, &Request { cancel, ..request })
    })?
    .map_err(|e| errors::command(py, e, false))?;
    rows.iter()
        .map(|h| errors::to_python(py, &h.report(&m.units)))
        .collect()
}
