//! Measurements: a CSV file (`docs/file-formats.md` §2) or built-in data set, numpy
//! arrays, or a simulated session.

use armcal::calibration::gravity::TorqueSign;
use armcal::commands::simulate as simulate_cmd;
use armcal::io::arrays::{self, Conditions, PoseArrays};
use armcal::io::measurements;
use armcal::session::observation::Contact;
use pyo3::prelude::*;

use crate::errors::PYTHON;
use crate::errors::{self, ArrayLike, Owned, args};
use crate::interrupt::{OnInterrupt, interruptible};
use crate::model::{Model, joints_in_units, pose_values};

/// Measured poses read against a model. Rows are in measurement order; values
/// read back are in the model's units.
#[pyclass(module = "armcal", frozen)]
pub struct Measurements {
    pub(crate) data: armcal::session::measurements::Measurements,
    /// The model the data were read against.
    pub(crate) model: armcal::session::model::RobotModel,
    /// Whether the rows came from arrays (rows numbered from 0) rather than a
    /// file (rows named by their line).
    pub(crate) arrays: bool,
}

/// `model` as the model of a call that takes it first, or a `TypeError`
/// that says so when the caller gave the other argument first.
fn model_first<'a, 'py>(model: &'a Bound<'py, PyAny>, call: &str) -> PyResult<PyRef<'py, Model>> {
    model.extract::<PyRef<'py, Model>>().map_err(|_| {
        errors::argument(
            model.py(),
            "model",
            format!("{call} takes the model first, as every armcal call does: {call}(model, ...)"),
        )
    })
}

/// Loads measurements: a built-in data set (`builtin_data()`) or the CSV file
/// at `name_or_path`, read against `model`, as `armcal --data` does.
#[pyfunction]
pub fn load_measurements(
    py: Python<'_>,
    model: &Bound<'_, PyAny>,
    name_or_path: &Bound<'_, PyAny>,
) -> PyResult<Measurements> {
    let model = model_first(model, "load_measurements")?;
    read(py, &model, &args::name_or_path(name_or_path)?)
}

/// The measurements `name_or_path` names (a built-in set or a CSV file),
/// read against `model`.
pub(crate) fn read(py: Python<'_>, model: &Model, name_or_path: &str) -> PyResult<Measurements> {
    measurements::load_measurements(name_or_path, &model.inner)
        .map(|data| Measurements::from_file(data, model))
        .map_err(|e| errors::input(py, &e, false))
}

/// Parses the text of a measurement CSV read against `model`; `file` names it
/// in error messages.
#[pyfunction]
#[pyo3(signature = (model, text, file = String::from("<string>")))]
pub fn parse_measurements(
    py: Python<'_>,
    model: &Bound<'_, PyAny>,
    text: &Bound<'_, PyAny>,
    #[pyo3(from_py_with = args::file)] file: String,
) -> PyResult<Measurements> {
    let model = model_first(model, "parse_measurements")?;
    let model = &*model;
    let text = args::text(text)?;
    measurements::parse_measurements(&text, &file, &model.inner)
        .map(|data| Measurements::from_file(data, model))
        .map_err(|e| errors::input(py, &e, false))
}

/// Measurements from arrays, in the model's units as in a file: `q` `(N, M)`
/// joint readings, `xyz` `(N, 3)` measured tool points, optionally `quat`
/// `(N, 4)` orientations (`qw, qx, qy, qz`), `t` (s), `temp` (°C), `load`
/// (kg) with `N` values each, `tau` `(N, M)` the joint torques the robot
/// reported (N·m, as a file's `tau1..tauM`). Refused as a file is, naming the
/// row (from 0).
#[pyfunction(name = "measurements")]
#[pyo3(signature = (model, q, xyz, quat = None, t = None, temp = None, load = None, tau = None))]
#[expect(
    clippy::too_many_arguments,
    reason = "a parameter per Python keyword argument, as the signature above lists them"
)]
pub fn from_arrays<'py>(
    py: Python<'py>,
    #[pyo3(from_py_with = crate::model::argument)] model: Bound<'py, Model>,
    q: ArrayLike<'py>,
    xyz: ArrayLike<'py>,
    quat: Option<ArrayLike<'py>>,
    t: Option<ArrayLike<'py>>,
    temp: Option<ArrayLike<'py>>,
    load: Option<ArrayLike<'py>>,
    tau: Option<ArrayLike<'py>>,
) -> PyResult<Measurements> {
    let model = model.get();
    let q = Owned::rows(py, "q", &q)?;
    let xyz = Owned::rows(py, "xyz", &xyz)?;
    let quat = quat.map(|a| Owned::rows(py, "quat", &a)).transpose()?;
    let tau = tau.map(|a| Owned::rows(py, "tau", &a)).transpose()?;
    // Their precision has no bound to be held to here.
    let column = |name: &str, a: Option<ArrayLike<'py>>| {
        a.map(|a| Owned::column(py, name, &a).map(|(values, _)| values))
            .transpose()
    };
    let (t, temp, load) = (
        column("t", t)?,
        column("temp", temp)?,
        column("load", load)?,
    );
    let a = PoseArrays {
        q: q.table(),
        xyz: xyz.table(),
        quat: quat.as_ref().map(Owned::table),
        tau: tau.as_ref().map(Owned::table),
        conditions: Conditions {
            t: t.as_deref(),
            temp: temp.as_deref(),
            load: load.as_deref(),
        },
    };
    let data = arrays::measurements(&model.inner, &a).map_err(|e| errors::input(py, &e, true))?;
    Ok(Measurements {
        data,
        model: model.inner.clone(),
        arrays: true,
    })
}

/// Simulates a measurement session on `model`, as `armcal simulate` does: a
/// true robot (nominal plus random geometric errors of ±1 mm and ±1 mrad,
/// hidden `effects` `"NAME[:JOINT[:VALUE]]"`, Hayati `tilts` `(joint, beta)`)
/// measured at `poses` random configurations with `noise` (model length unit,
/// default 20 µm) and, with `orientation_noise` (model angle unit), orientations;
/// with `torque_noise` (N·m), the joint torques the robot reports (`tau`,
/// with `torque_sign` `"drive"`, armcal's, or `"load"`, the sensors' load
/// torques: the drives' negated);
/// `payloads` (kg) of consecutive blocks of rows (default 0 and 5); the true
/// robot off nominal by `link_errors`, `base_errors`, `tool_errors`
/// (`(length, angle)` in the model's units, as `armcal simulate
/// --link-errors` etc.) in place of ±1 mm / ±1 mrad;
/// `orientation_bias` (model angle unit) and `orientation_bias_growth` (per
/// model length unit) bias the orientations as `--orientation-bias`,
/// `--orientation-bias-growth` do; in
/// `sessions` sessions, each after the first with the instrument moved and
/// the point remounted (one Measurements holding them all: `identify` and
/// `diagnose` read its sessions as several files'). Returns the
/// measurements (rows numbered from 0) and the truth as a dict.
#[pyfunction]
#[pyo3(signature = (model, poses = 200, seed = 1, noise = None, orientation_noise = None, effects = Vec::new(), tilts = Vec::new(), torque_noise = None, *, payloads = Vec::new(), sessions = 1, torque_sign = String::from("drive"), link_errors = None, base_errors = None, tool_errors = None, orientation_bias = None, orientation_bias_growth = None))]
#[expect(
    clippy::too_many_arguments,
    reason = "a parameter per Python keyword argument, as the signature above lists them"
)]
pub fn simulate<'py>(
    py: Python<'py>,
    #[pyo3(from_py_with = crate::model::argument)] model: Bound<'py, Model>,
    #[pyo3(from_py_with = args::poses)] poses: usize,
    #[pyo3(from_py_with = args::seed)] seed: u64,
    #[pyo3(from_py_with = args::noise)] noise: Option<f64>,
    #[pyo3(from_py_with = args::orientation_noise)] orientation_noise: Option<f64>,
    #[pyo3(from_py_with = args::effects)] effects: Vec<String>,
    #[pyo3(from_py_with = args::tilts)] tilts: Vec<(usize, f64)>,
    #[pyo3(from_py_with = args::torque_noise)] torque_noise: Option<f64>,
    #[pyo3(from_py_with = args::payloads)] payloads: Vec<f64>,
    #[pyo3(from_py_with = args::sessions)] sessions: usize,
    #[pyo3(from_py_with = args::simulated_torque_sign)] torque_sign: String,
    #[pyo3(from_py_with = args::link_errors)] link_errors: Option<(f64, f64)>,
    #[pyo3(from_py_with = args::base_errors)] base_errors: Option<(f64, f64)>,
    #[pyo3(from_py_with = args::tool_errors)] tool_errors: Option<(f64, f64)>,
    #[pyo3(from_py_with = args::orientation_bias)] orientation_bias: Option<f64>,
    #[pyo3(from_py_with = args::orientation_bias_growth)] orientation_bias_growth: Option<f64>,
) -> PyResult<(Measurements, Bound<'py, PyAny>)> {
    let model = model.get();
    let m = &model.inner;
    let u = m.units;
    let request = simulate_cmd::Request {
        poses,
        seed,
        noise,
        orientation_noise,
        orientation_bias,
        orientation_bias_growth,
        torque_noise,
        torque_sign: crate::errors::torque_sign(py, Some(&torque_sign))?
            .unwrap_or(TorqueSign::Drive),
        effects,
        tilts,
        payloads,
        sessions,
        errors: simulate_cmd::ErrorRequest {
            link: link_errors.map(|(l, a)| [l, a]),
            base: base_errors.map(|(l, a)| [l, a]),
            tool: tool_errors.map(|(l, a)| [l, a]),
        },
    };
    // On a thread of its own: Ctrl-C raises at once (it runs on).
    let of_run = m.clone();
    let session = interruptible(py, OnInterrupt::RunsOn, move |_| {
        simulate_cmd::run(PYTHON, &of_run, &request)
    })?
    .map_err(|e| errors::command(py, e, false))?;
    let n = session.observations.len();
    let data = armcal::session::measurements::Measurements {
        file: arrays::DATA.to_owned(),
        lines: (1..=n).collect(),
        times: (0..n).map(|i| session.t.get(i).copied()).collect(),
        poses: session.observations.clone(),
        columns_used: Vec::new(),
        columns_ignored: Vec::new(),
        warnings: Vec::new(),
        constraints: Default::default(),
        // Several sessions: named in order (the rows carry their session).
        sessions: if session.sessions() > 1 {
            (1..=session.sessions())
                .map(|k| format!("session {k}"))
                .collect()
        } else {
            Vec::new()
        },
    };
    let truth = errors::to_python(py, &session.truth(&m.robot, &u))?;
    Ok((
        Measurements {
            data,
            model: m.clone(),
            arrays: true,
        },
        truth,
    ))
}

impl Measurements {
    fn from_file(data: armcal::session::measurements::Measurements, model: &Model) -> Self {
        Self {
            data,
            model: model.inner.clone(),
            arrays: false,
        }
    }

    /// The value of an optional per-pose column, NaN where a pose has none;
    /// `None` when no pose has one.
    fn optional<'py>(
        &self,
        py: Python<'py>,
        values: impl Iterator<Item = Option<f64>>,
    ) -> Option<Bound<'py, PyAny>> {
        use numpy::IntoPyArray as _;
        let values: Vec<Option<f64>> = values.collect();
        values.iter().any(Option::is_some).then(|| {
            let v: Vec<f64> = values.iter().map(|v| v.unwrap_or(f64::NAN)).collect();
            v.into_pyarray(py).into_any()
        })
    }
}

#[pymethods]
impl Measurements {
    /// The number of poses.
    fn __len__(&self) -> usize {
        self.data.len()
    }

    /// The file as named (or `data` for arrays and simulated sessions).
    #[getter]
    fn file(&self) -> &str {
        &self.data.file
    }

    /// The line of each pose in its file; for arrays, the row (from 0).
    #[getter]
    fn rows(&self) -> Vec<usize> {
        let from = usize::from(self.arrays);
        self.data.lines.iter().map(|line| line - from).collect()
    }

    /// Joint readings, `(N, M)`, model units.
    #[getter]
    fn q<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let (robot, units) = (&self.model.robot, &self.model.units);
        let rows = self
            .data
            .poses
            .iter()
            .map(|p| joints_in_units(&p.q, robot, units));
        errors::to_numpy(py, rows.collect(), self.model.dof(), false)
    }

    /// Measured tool points, `(N, 3)`, model length unit; NaN on the rows of
    /// a session without a tracker, which measure none (see `contacts`).
    #[getter]
    fn xyz<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let rows = self.data.poses.iter().map(|p| match p.contact {
            Contact::Measured => pose_values(&p.position, None, &self.model.units),
            Contact::Point(_) | Contact::Plane(_) => vec![f64::NAN; 3],
        });
        errors::to_numpy(py, rows.collect(), 3, false)
    }

    /// What each row's tool point touches in a session without a tracker:
    /// `("point", name)` (an unknown fixed point), `("plane", name)` (an
    /// unknown plane), or None where the row measures its position.
    #[getter]
    fn contacts(&self) -> Vec<Option<(&'static str, String)>> {
        let c = &self.data.constraints;
        let name = |named: &[armcal::session::constraints::Named], k: usize| {
            named.get(k).map_or_else(String::new, |n| n.name.clone())
        };
        self.data
            .poses
            .iter()
            .map(|p| match p.contact {
                Contact::Measured => None,
                Contact::Point(k) => Some(("point", name(&c.points, k))),
                Contact::Plane(k) => Some(("plane", name(&c.planes, k))),
            })
            .collect()
    }

    /// The known distances between fixed points of a session without a
    /// tracker: `(point, point, length, std)`, model length unit.
    #[getter]
    fn distances(&self) -> Vec<(String, String, f64, f64)> {
        let c = &self.data.constraints;
        let u = &self.model.units;
        let name = |k: usize| c.points.get(k).map_or_else(String::new, |p| p.name.clone());
        c.distances
            .iter()
            .map(|d| {
                (
                    name(d.points[0]),
                    name(d.points[1]),
                    u.length_from_si(d.length),
                    u.length_from_si(d.std),
                )
            })
            .collect()
    }

    /// Whether the rows carry constraints (unknown fixed points or planes,
    /// known distances) instead of measured coordinates.
    #[getter]
    fn is_constrained(&self) -> bool {
        self.data.is_constrained()
    }

    /// Measured orientations, `(N, 4)` `qw, qx, qy, qz` (`qw ≥ 0`), or None
    /// unless every pose has one.
    #[getter]
    fn quat<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyAny>>> {
        if !self.data.has_orientation() {
            return Ok(None);
        }
        let rows = self.data.poses.iter().map(|p| {
            pose_values(&p.position, p.orientation.as_ref(), &self.model.units).split_off(3)
        });
        errors::to_numpy(py, rows.collect(), 4, false).map(Some)
    }

    /// The joint torques the robot reported at each pose (`tau1..tauM`,
    /// N·m, N for a prismatic joint), `(N, M)`; None when the session has
    /// none.
    #[getter]
    fn tau<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyAny>>> {
        let rows: Option<Vec<Vec<f64>>> =
            self.data.poses.iter().map(|p| p.torque.clone()).collect();
        match rows {
            Some(rows) if !rows.is_empty() => {
                errors::to_numpy(py, rows, self.model.robot.dof(), false).map(Some)
            }
            _ => Ok(None),
        }
    }

    /// Time of each pose (s), NaN where not recorded; None when no pose has one.
    #[getter]
    fn t<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyAny>> {
        self.optional(py, self.data.times.iter().copied())
    }

    /// Temperature of each pose (°C), as `t`.
    #[getter]
    fn temp<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyAny>> {
        self.optional(py, self.data.poses.iter().map(|p| p.context.temperature))
    }

    /// Payload of each pose (kg), as `t`.
    #[getter]
    fn load<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyAny>> {
        self.optional(py, self.data.poses.iter().map(|p| p.context.payload))
    }

    /// Whether every pose has a measured orientation.
    #[getter]
    fn has_orientation(&self) -> bool {
        self.data.has_orientation()
    }

    /// The columns read.
    #[getter]
    fn columns_used(&self) -> Vec<String> {
        self.data.columns_used.clone()
    }

    /// What the reader warns of (columns not read, readings outside limits).
    #[getter]
    fn warnings(&self) -> Vec<String> {
        self.data.warnings.clone()
    }

    fn __repr__(&self) -> String {
        let c = &self.data.constraints;
        let constraints = if self.data.is_constrained() {
            format!(
                ", points={}, planes={}, distances={}",
                c.points.len(),
                c.planes.len(),
                c.distances.len()
            )
        } else {
            String::new()
        };
        format!(
            "Measurements(file={:?}, poses={}, orientation={}{constraints}, model={:?})",
            self.data.file,
            self.data.len(),
            self.data.has_orientation(),
            self.model.name
        )
    }
}
