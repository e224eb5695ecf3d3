//! Robot models: a TOML file (`docs/file-formats.md` §1), any other format
//! `armcal::io::model_file::load_model` reads, or the name of a built-in model.

use armcal::io::{builtin, model_file, urdf};
use armcal_shared::{JointType, Robot, units::Units};
use nalgebra::{IsometryMatrix3, UnitQuaternion};
use pyo3::prelude::*;

use crate::errors::{self, ArrayLike, Owned, args};

/// A robot model: its name, units and nominal geometry. Lengths and angles in
/// and out are in its units (`length_unit`, `angle_unit`).
#[pyclass(module = "armcal", frozen)]
pub struct Model {
    pub(crate) inner: armcal::session::model::RobotModel,
}

/// Loads a robot model: a built-in one (`builtin_models()`) or the file at
/// `name_or_path`, as `armcal --model` does; of a URDF, the chain from
/// `base_link` (default: its root) to `tip_link` (default: found walking down
/// from the base), as `--base-link` and `--tip-link`, with the measured
/// point at `tip_point` (`x, y, z` in m in the tip link's frame; default its
/// origin), as `--tip-point`. Raises `InputError` naming the file, line and
/// column of what is wrong.
#[pyfunction]
#[pyo3(signature = (name_or_path, *, base_link = None, tip_link = None, tip_point = None))]
pub fn load_model(
    py: Python<'_>,
    #[pyo3(from_py_with = args::name_or_path)] name_or_path: String,
    #[pyo3(from_py_with = args::base_link)] base_link: Option<String>,
    #[pyo3(from_py_with = args::tip_link)] tip_link: Option<String>,
    #[pyo3(from_py_with = args::tip_point)] tip_point: Option<[f64; 3]>,
) -> PyResult<Model> {
    if tip_point.is_some_and(|p| p.iter().any(|v| !v.is_finite())) {
        return Err(errors::argument(
            py,
            "tip_point",
            "x, y, z must be finite numbers in m",
        ));
    }
    let spec = urdf::ChainSpec {
        base_link,
        tip_link,
        tip_point: tip_point.map(nalgebra::Vector3::from),
    };
    model_file::load_model_with(&name_or_path, &spec)
        .map(|inner| Model { inner })
        .map_err(|e| errors::input(py, &e, false))
}

/// Parses the text of a model file (TOML); `file` names it in error messages.
#[pyfunction]
#[pyo3(signature = (text, file = String::from("<string>")))]
pub fn parse_model(
    py: Python<'_>,
    #[pyo3(from_py_with = args::text)] text: String,
    #[pyo3(from_py_with = args::file)] file: String,
) -> PyResult<Model> {
    model_file::parse_model(&text, &file)
        .map(|inner| Model { inner })
        .map_err(|e| errors::input(py, &e, false))
}

/// The names of the built-in robot models.
#[pyfunction]
pub fn builtin_models() -> Vec<&'static str> {
    builtin::MODEL_NAMES.to_vec()
}

/// The names of the built-in data sets (each with the built-in model of its name).
#[pyfunction]
pub fn builtin_data() -> Vec<&'static str> {
    builtin::DATA_NAMES.to_vec()
}

#[pymethods]
impl Model {
    /// The model's name.
    #[getter]
    fn name(&self) -> &str {
        &self.inner.name
    }

    /// The model's description.
    #[getter]
    fn description(&self) -> &str {
        &self.inner.description
    }

    /// Where it came from: the path, or `built-in NAME`.
    #[getter]
    fn source(&self) -> &str {
        &self.inner.source
    }

    /// The number of joints.
    #[getter]
    fn dof(&self) -> usize {
        self.inner.dof()
    }

    /// The length unit of the model and its data: `m`, `mm` or `in`.
    #[getter]
    fn length_unit(&self) -> &'static str {
        self.inner.units.length.name()
    }

    /// The angle unit of the model and its data: `rad` or `deg`.
    #[getter]
    fn angle_unit(&self) -> &'static str {
        self.inner.units.angle.name()
    }

    /// `revolute` or `prismatic`, per joint.
    #[getter]
    fn joint_types(&self) -> Vec<&'static str> {
        self.inner
            .robot
            .links
            .iter()
            .map(|l| match l.joint {
                JointType::Revolute => "revolute",
                JointType::Prismatic => "prismatic",
            })
            .collect()
    }

    /// The nominal model's tool point for joint readings `q` (`(N, M)`, or one
    /// row `(M,)`), model units: `(N, 3)` `x, y, z` in the measurement frame, or
    /// with `orientation` `(N, 7)` `x, y, z, qw, qx, qy, qz` (`qw ≥ 0`).
    #[pyo3(signature = (q, orientation = false))]
    fn forward<'py>(
        &self,
        py: Python<'py>,
        q: ArrayLike<'py>,
        #[pyo3(from_py_with = args::orientation)] orientation: bool,
    ) -> PyResult<Bound<'py, PyAny>> {
        let q = Owned::rows(py, "q", &q)?;
        let rows = armcal::io::arrays::joints(
            &self.inner.robot,
            &self.inner.units,
            &q.table(),
            &Default::default(),
        )
        .map_err(|e| errors::input(py, &e, true))?;
        let units = &self.inner.units;
        let robot = &self.inner.robot;
        let frames = rows
            .rows
            .iter()
            .map(|r| {
                robot
                    .forward(&r.q)
                    .map(|f| pose_row(&f, orientation, units))
                    .map_err(|e| errors::failure(format!("joints row {}: {e}", r.line - 1)))
            })
            .collect::<PyResult<Vec<_>>>()?;
        errors::to_numpy(py, frames, if orientation { 7 } else { 3 }, q.single)
    }

    /// The model as the library reads it, in SI, for debugging.
    fn __repr__(&self) -> String {
        format!(
            "Model(name={:?}, dof={}, length_unit={:?}, angle_unit={:?}, source={:?})",
            self.inner.name,
            self.inner.dof(),
            self.length_unit(),
            self.angle_unit(),
            self.inner.source
        )
    }
}

/// A frame as a row: `x, y, z` in the length unit of `units`, then with
/// `orientation` the quaternion `qw, qx, qy, qz` with `qw ≥ 0`.
pub fn pose_row(frame: &IsometryMatrix3<f64>, orientation: bool, units: &Units) -> Vec<f64> {
    let t = frame.translation.vector;
    let rotation = orientation.then(|| UnitQuaternion::from_rotation_matrix(&frame.rotation));
    pose_values(&t.into(), rotation.as_ref(), units)
}

/// `x, y, z` in the length unit of `units`, then the quaternion if any, `qw ≥ 0`.
pub fn pose_values(
    p: &nalgebra::Point3<f64>,
    q: Option<&UnitQuaternion<f64>>,
    units: &Units,
) -> Vec<f64> {
    let mut row: Vec<f64> = p.iter().map(|x| units.length_from_si(*x)).collect();
    if let Some(q) = q {
        let sign = if q.w < 0.0 { -1.0 } else { 1.0 };
        row.extend([q.w, q.i, q.j, q.k].map(|v| sign * v));
    }
    row
}

/// Joint values, SI, in `units` (the angle unit for revolute joints, the
/// length unit for prismatic ones).
pub fn joints_in_units(q: &[f64], robot: &Robot<f64>, units: &Units) -> Vec<f64> {
    q.iter()
        .zip(&robot.links)
        .map(|(v, l)| units.joint_from_si(l.joint, *v))
        .collect()
}

/// The argument `model`: a model (`armcal.load_model`), as the calls
/// that take one first refuse anything else.
pub fn argument<'py>(ob: &Bound<'py, PyAny>) -> PyResult<Bound<'py, Model>> {
    reference(ob, "model")
}

/// The argument `reference`: a model, or None.
pub fn reference_argument<'py>(ob: &Bound<'py, PyAny>) -> PyResult<Option<Bound<'py, Model>>> {
    if ob.is_none() {
        Ok(None)
    } else {
        reference(ob, "reference").map(Some)
    }
}

/// The model `ob`, the argument `name`.
fn reference<'py>(ob: &Bound<'py, PyAny>, name: &str) -> PyResult<Bound<'py, Model>> {
    ob.cast::<Model>().cloned().map_err(|_| {
        let shown = ob
            .repr()
            .map_or_else(|_| "the value".to_owned(), |r| r.to_string());
        errors::argument(
            ob.py(),
            name,
            format!("{shown}: expected a Model (armcal.load_model)"),
        )
    })
}
