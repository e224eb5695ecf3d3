//! `plan`: the poses to measure, as `armcal plan` chooses them
//! (`armcal::calibration::plan`), with numpy arrays in and out.

use armcal::commands::choices::{self, CriterionArg};
use armcal::commands::plan::{Request, run, within_limits};
use armcal::io::arrays;
use pyo3::prelude::*;

use crate::errors::PYTHON;
use crate::errors::{self, ArrayLike, Owned, args};
use crate::interrupt::{OnInterrupt, interruptible};
use crate::model::Model;

/// The joint rows of the array `a` (named `name`), SI.
fn joint_rows(
    py: Python<'_>,
    model: &Model,
    name: &str,
    a: &ArrayLike<'_>,
) -> PyResult<Vec<Vec<f64>>> {
    let m = &model.inner;
    let table = Owned::rows(py, name, a)?;
    let rows = arrays::joints(&m.robot, &m.units, &table.table(), &Default::default())
        .map_err(|e| errors::input(py, &e, true))?;
    Ok(rows.rows.into_iter().map(|r| r.q).collect())
}

/// Plans the measurement of `model`, as `armcal plan` does: `poses` joint
/// configurations chosen so that the calibration from them predicts the
/// workspace best (`targets`, an `(N, M)` array of the configurations the
/// robot will work at; random ones within the limits otherwise), among
/// `candidates` (an `(N, M)` array; random ones within the joint limits less
/// `margin` otherwise), their tool points within `within` (`(x_min, y_min,
/// z_min, x_max, y_max, z_max)`) and above `above` (model length unit), for an
/// instrument of `noise` per axis (and `orientation_noise`, with
/// `orientation=True`); `effects=["backlash"]` measures each pose approached
/// from both sides, `effects=["compliance"]` spreads the joints' gravity
/// torques and identifies each compliance; `sockets` (the path of a sockets
/// file) plans a session seating a ball in them (the report's `socket_of`
/// names each row's socket); `singularity_margin`: the least conditioning of
/// a planned pose (as `--singularity-margin`); `criterion`: `"i-optimal"` (the default) or
/// `"d-optimal"`, as `--criterion` (the report's `compared` gives the other's
/// plan of as many poses). Returns the poses, an `(poses, M)` array in the
/// model's units in measurement order, and the report (`--json`'s) as a dict.
///
/// Ctrl-C stops the plan within a step of its loops (a pass over the
/// candidates) and raises `KeyboardInterrupt`.
#[pyfunction]
#[pyo3(signature = (model, poses = 30, *, orientation = false, noise = None, orientation_noise = None, within = None, above = None, margin = None, candidates = None, targets = None, effects = Vec::new(), sockets = None, singularity_margin = None, criterion = String::from("i-optimal"), seed = 1))]
#[expect(
    clippy::too_many_arguments,
    reason = "a parameter per Python keyword argument, as the signature above lists them"
)]
pub fn plan<'py>(
    py: Python<'py>,
    #[pyo3(from_py_with = crate::model::argument)] model: Bound<'py, Model>,
    #[pyo3(from_py_with = args::poses)] poses: usize,
    #[pyo3(from_py_with = args::orientation)] orientation: bool,
    #[pyo3(from_py_with = args::noise)] noise: Option<f64>,
    #[pyo3(from_py_with = args::orientation_noise)] orientation_noise: Option<f64>,
    #[pyo3(from_py_with = args::within)] within: Option<Vec<f64>>,
    #[pyo3(from_py_with = args::above)] above: Option<f64>,
    #[pyo3(from_py_with = args::margin)] margin: Option<f64>,
    candidates: Option<ArrayLike<'py>>,
    targets: Option<ArrayLike<'py>>,
    #[pyo3(from_py_with = args::plan_effects)] effects: Vec<String>,
    #[pyo3(from_py_with = args::sockets)] sockets: Option<String>,
    #[pyo3(from_py_with = args::singularity_margin)] singularity_margin: Option<f64>,
    #[pyo3(from_py_with = args::criterion)] criterion: String,
    #[pyo3(from_py_with = args::seed)] seed: u64,
) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyAny>)> {
    let model = model.get();
    let m = &model.inner;
    let request = Request {
        poses,
        orientation,
        noise,
        orientation_noise,
        within,
        above,
        margin,
        candidates: None,
        effects,
        sockets: sockets
            .map(|path| armcal::io::sockets::load_sockets(&path, &m.units))
            .transpose()
            .map_err(|e| errors::input(py, &e, true))?,
        singularity_margin,
        criterion: errors::choice(py, "criterion", &criterion, choices::parse::<CriterionArg>)?,
        seed,
    };
    let options = request
        .options(PYTHON, m)
        .map_err(|e| errors::input(py, &e, true))?;
    let from = candidates
        .map(|a| joint_rows(py, model, "candidates", &a))
        .transpose()?
        .map(|rows| within_limits(m, rows, options.margin).0);
    let targets = targets
        .map(|a| joint_rows(py, model, "targets", &a))
        .transpose()?;
    let model_of_run = m.clone();
    let (plan, options) = interruptible(py, OnInterrupt::Stops, move |cancel| {
        run(
            PYTHON,
            &model_of_run,
            &request,
            from.as_deref(),
            targets.as_deref(),
            &|| cancel.requested(),
        )
    })?
    .map_err(|e| errors::command(py, e, true))?;
    let joints: Vec<Vec<f64>> = plan
        .q
        .iter()
        .map(|q| {
            q.iter()
                .zip(&m.robot.links)
                .map(|(v, l)| m.units.joint_from_si(l.joint, *v))
                .collect()
        })
        .collect();
    let report = errors::to_python(py, &plan.report(&m.name, &options, &m.units))?;
    Ok((errors::to_numpy(py, joints, m.robot.dof(), false)?, report))
}
