//! Calibrations: read and written as the postcard bytes the firmware loads;
//! `predict` and `compensate` with numpy arrays in and out.

use std::ffi::CString;

use armcal::apply::ranges::{self, Resolutions, RowNames};
use armcal::apply::{compensate as comp, predict as pred};
use armcal::commands::Front;
use armcal::commands::tool::Tool;
use armcal::io::arrays::{self, Conditions};
use armcal::session::joints::JointRows;
use armcal_shared::compensation::{Pacing, Task};
use armcal_shared::{Calibration as Cal, TargetFrame};
use pyo3::exceptions::PyUserWarning;
use pyo3::prelude::*;
use pyo3::types::PyBytes;

use crate::errors::{self, ArrayLike, Owned, args};
use crate::interrupt::{OnInterrupt, interruptible};
use crate::model::{joints_in_units, pose_values};

/// A calibration: the nominal model, its identified errors and effects, in
/// the model's units. What `identify`, `diagnose` and the calibration files
/// give; `predict` and `compensate` take and return numpy arrays.
#[pyclass(module = "armcal", frozen)]
pub struct Calibration {
    cal: Cal,
    /// Why it must not be written (a fit that did not converge, or worse
    /// than the nominal model on its own data), as the command line says it.
    failed: Option<String>,
    /// With a working tool: what of the measured tool it left, as the
    /// command line's note says it.
    tool_note: Option<String>,
}

impl From<Cal> for Calibration {
    fn from(cal: Cal) -> Self {
        Self {
            cal,
            failed: None,
            tool_note: None,
        }
    }
}

impl Calibration {
    /// A calibration that `write` and `to_bytes` refuse with `failed` unless
    /// asked with `write_failed=True`.
    pub(crate) fn failed(cal: Cal, failed: Option<String>) -> Self {
        Self {
            cal,
            failed,
            tool_note: None,
        }
    }

    /// This calibration with the working tool `tool` (`armcal::commands::tool`).
    fn working_with(&self, py: Python<'_>, tool: &Tool) -> PyResult<Self> {
        let change = tool
            .apply(Front::Python, &self.cal)
            .map_err(|e| errors::input(py, &e, false))?;
        Ok(Self {
            tool_note: Some(change.note()),
            cal: change.calibration,
            failed: self.failed.clone(),
        })
    }

    /// Its bytes, refused as the command line refuses to write a failed fit.
    fn bytes(&self, write_failed: bool) -> PyResult<Vec<u8>> {
        if let (Some(why), false) = (&self.failed, write_failed) {
            return Err(errors::failure(why));
        }
        self.cal.to_bytes().map_err(errors::failure)
    }
}

/// Reads and checks the calibration file at `path` (as `armcal predict
/// --calibration` does).
#[pyfunction]
pub fn load_calibration(
    py: Python<'_>,
    #[pyo3(from_py_with = args::path)] path: String,
) -> PyResult<Calibration> {
    let path = path.as_str();
    armcal::io::calibration_file::load_calibration(path)
        .map(Calibration::from)
        .map_err(|e| errors::input(py, &e, false))
}

/// The joint arrays `q` (`(N, M)` or one row `(M,)`) and their conditions,
/// read against the calibration's nominal model; whether `q` was one row,
/// and the precision each was given in (float32 arrays are held to the
/// identified ranges at float32's resolution).
fn joint_rows(
    py: Python<'_>,
    cal: &Cal,
    q: &ArrayLike<'_>,
    temp: Option<ArrayLike<'_>>,
    load: Option<ArrayLike<'_>>,
) -> PyResult<(JointRows, bool, Resolutions)> {
    let q = Owned::rows(py, "q", q)?;
    let temp = temp.map(|a| Owned::column(py, "temp", &a)).transpose()?;
    let load = load.map(|a| Owned::column(py, "load", &a)).transpose()?;
    let resolutions = Resolutions {
        joints: q.resolution,
        temp: temp.as_ref().map_or_else(Default::default, |(_, r)| *r),
        load: load.as_ref().map_or_else(Default::default, |(_, r)| *r),
    };
    let conditions = Conditions {
        t: None,
        temp: temp.as_ref().map(|(v, _)| v.as_slice()),
        load: load.as_ref().map(|(v, _)| v.as_slice()),
    };
    let rows = arrays::joints(&cal.nominal, &cal.units, &q.table(), &conditions)
        .map_err(|e| errors::input(py, &e, true))?;
    Ok((rows, q.single, resolutions))
}

/// Each of `messages` as a Python `UserWarning`.
fn warn_all(py: Python<'_>, messages: impl IntoIterator<Item = String>) -> PyResult<()> {
    for message in messages {
        let message = CString::new(message).map_err(errors::failure)?;
        PyErr::warn(py, &py.get_type::<PyUserWarning>(), &message, 1)?;
    }
    Ok(())
}

#[pymethods]
impl Calibration {
    /// Reads and checks the calibration file at `path`.
    #[staticmethod]
    fn read(py: Python<'_>, #[pyo3(from_py_with = args::path)] path: String) -> PyResult<Self> {
        load_calibration(py, path)
    }

    /// Decodes and checks calibration bytes (postcard, as on file).
    #[staticmethod]
    fn from_bytes(
        py: Python<'_>,
        #[pyo3(from_py_with = args::bytes)] data: Vec<u8>,
    ) -> PyResult<Self> {
        let data = data.as_slice();
        Cal::decode(data).map(Self::from).map_err(|e| {
            errors::input(
                py,
                &armcal::session::input_error::InputError::new("bytes", 0, 0, e.to_string()),
                false,
            )
        })
    }

    /// The calibration's bytes: what the file holds and the firmware loads.
    /// A calibration whose fit did not converge, or that fits its own data
    /// worse than the nominal model (`failure`), raises `ArmcalError` with
    /// the reason unless `write_failed=True`.
    #[pyo3(signature = (*, write_failed = false))]
    fn to_bytes<'py>(
        &self,
        py: Python<'py>,
        #[pyo3(from_py_with = args::write_failed)] write_failed: bool,
    ) -> PyResult<Bound<'py, PyBytes>> {
        Ok(PyBytes::new(py, &self.bytes(write_failed)?))
    }

    fn __bytes__<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyBytes>> {
        self.to_bytes(py, false)
    }

    /// This calibration working with another tool than the one it was
    /// measured with (an SMR, a ball): `xyz` and optionally `rpy` (roll,
    /// pitch, yaw) of the working tool in the robot's flange frame (a model
    /// file's last link frame, as its `[tool]`; a URDF's tip link; a UR's
    /// flange), model units. It keeps what the
    /// data separate from the measured tool; the measured tool's identified
    /// offset is not applied to the working tool (`tool_note` says what was
    /// left and what one measured tool cannot separate), as `armcal
    /// compensate --tool`. Its `predict`, `compensate`, `write` and
    /// `to_bytes` are the working tool's; `held_out` is None (it was the
    /// measured tool's).
    #[pyo3(signature = (xyz, rpy = None))]
    fn with_tool(
        &self,
        py: Python<'_>,
        #[pyo3(from_py_with = args::xyz)] xyz: [f64; 3],
        #[pyo3(from_py_with = args::rpy)] rpy: Option<[f64; 3]>,
    ) -> PyResult<Self> {
        let rpy = rpy.unwrap_or([0.0; 3]);
        if xyz.iter().chain(&rpy).any(|v| !v.is_finite()) {
            return Err(errors::argument(
                py,
                "xyz",
                "the working tool's xyz and rpy must be finite",
            ));
        }
        self.working_with(py, &Tool::Frame { xyz, rpy })
    }

    /// `with_tool` for the working tool `tool_link`, a link of the URDF
    /// `model` the calibration's model was read from (from the same
    /// `base_link`), carried by the last joint; as `armcal compensate
    /// --tool-link`.
    #[pyo3(signature = (model, tool_link, *, base_link = None))]
    fn with_tool_link(
        &self,
        py: Python<'_>,
        #[pyo3(from_py_with = args::urdf)] model: String,
        #[pyo3(from_py_with = args::tool_link)] tool_link: String,
        #[pyo3(from_py_with = args::base_link)] base_link: Option<String>,
    ) -> PyResult<Self> {
        let tool = Tool::Link {
            model,
            base_link,
            link: tool_link,
        };
        self.working_with(py, &tool)
    }

    /// With a working tool (`with_tool`, `with_tool_link`): the working tool,
    /// the measured tool's offset left out and what one measured tool cannot
    /// separate from its mount; None otherwise.
    #[getter]
    fn tool_note(&self) -> Option<&str> {
        self.tool_note.as_deref()
    }

    /// Why this calibration is not written (its fit did not converge, or it
    /// fits its own data worse than the nominal model), or None.
    #[getter]
    fn failure(&self) -> Option<&str> {
        self.failed.as_deref()
    }

    /// Writes the calibration file `path` (its bytes); refused as `to_bytes`.
    #[pyo3(signature = (path, *, write_failed = false))]
    fn write(
        &self,
        #[pyo3(from_py_with = args::path)] path: String,
        #[pyo3(from_py_with = args::write_failed)] write_failed: bool,
    ) -> PyResult<()> {
        let path = path.as_str();
        let bytes = self.bytes(write_failed)?;
        std::fs::write(path, bytes)
            .map_err(|e| errors::failure(format!("{path}: cannot write the calibration: {e}")))
    }

    /// Where the calibrated robot puts its tool point for joint readings `q`
    /// (`(N, M)`, or one row `(M,)`, model units, rows in motion order), with
    /// optional `temp` (°C) and `load` (kg) per row: `(N, 3)` `x, y, z`, or
    /// `(N, 7)` with `qw, qx, qy, qz` when the calibration has orientation.
    /// Rows outside the ranges the calibration was identified on (a joint, the
    /// temperature or the payload), and a `temp` or `load` its effects need but
    /// not given, are named in a `UserWarning` each.
    #[pyo3(signature = (q, temp = None, load = None))]
    fn predict<'py>(
        &self,
        py: Python<'py>,
        q: ArrayLike<'py>,
        temp: Option<ArrayLike<'py>>,
        load: Option<ArrayLike<'py>>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let (rows, single, resolutions) = joint_rows(py, &self.cal, &q, temp, load)?;
        warn_all(
            py,
            ranges::check_at(&self.cal, &rows, RowNames::ArrayRows, resolutions),
        )?;
        // On a thread of its own: Ctrl-C raises at once (it runs on).
        let cal = self.cal.clone();
        let predictions =
            interruptible(py, OnInterrupt::RunsOn, move |_| pred::predict(&cal, &rows))?
                .map_err(|e| errors::input(py, &e, true))?;
        let out: Vec<Vec<f64>> = predictions
            .rows
            .iter()
            .map(|p| pose_values(&p.position, p.orientation.as_ref(), &self.cal.units))
            .collect();
        errors::to_numpy(
            py,
            out,
            if self.cal.task == Task::Pose { 7 } else { 3 },
            single,
        )
    }

    /// For joint commands `q` that the nominal model computed (`(N, M)` or one
    /// row, model units, rows in the order sent), the commands that make the
    /// calibrated robot reach the pose the nominal model intended; same
    /// shape. `servo`: the rows are consecutive servo ticks, as on the
    /// controller. A row whose correction was bounded or did not converge is
    /// named in a `UserWarning`, and so are rows outside the identified ranges
    /// (as for `predict`).
    #[pyo3(signature = (q, temp = None, load = None, servo = false))]
    fn compensate<'py>(
        &self,
        py: Python<'py>,
        q: ArrayLike<'py>,
        temp: Option<ArrayLike<'py>>,
        load: Option<ArrayLike<'py>>,
        #[pyo3(from_py_with = args::servo)] servo: bool,
    ) -> PyResult<Bound<'py, PyAny>> {
        let (rows, single, resolutions) = joint_rows(py, &self.cal, &q, temp, load)?;
        let pacing = if servo {
            Pacing::Servo
        } else {
            Pacing::Program
        };
        let cal = &self.cal;
        warn_all(
            py,
            ranges::check_at(cal, &rows, RowNames::ArrayRows, resolutions),
        )?;
        // On a thread of its own: Ctrl-C raises at once (it runs on).
        let of_run = cal.clone();
        let result = interruptible(py, OnInterrupt::RunsOn, move |_| {
            comp::compensate(&of_run, &rows, pacing)
        })?;
        // One warning per kind of report, with its rows.
        let messages = comp::RowWarning::grouped(
            &result.warnings(cal),
            result.rows.len(),
            arrays::JOINTS,
            RowNames::ArrayRows,
        );
        warn_all(py, messages)?;
        let out: Vec<Vec<f64>> = result
            .rows
            .iter()
            .map(|(_, c)| joints_in_units(&c.q, &cal.nominal, &cal.units))
            .collect();
        errors::to_numpy(py, out, cal.nominal.dof(), single)
    }

    /// The number of joints.
    #[getter]
    fn dof(&self) -> usize {
        self.cal.nominal.dof()
    }

    /// Whether the calibration was identified from full poses (predictions
    /// then have orientation).
    #[getter]
    fn orientation(&self) -> bool {
        self.cal.task == Task::Pose
    }

    /// The model's length unit.
    #[getter]
    fn length_unit(&self) -> &'static str {
        self.cal.units.length.name()
    }

    /// The model's angle unit.
    #[getter]
    fn angle_unit(&self) -> &'static str {
        self.cal.units.angle.name()
    }

    /// The frame the compensation's targets are given in: `world` or `base`.
    #[getter]
    fn targets(&self) -> &'static str {
        match self.cal.targets {
            TargetFrame::World => "world",
            TargetFrame::Base => "base",
        }
    }

    /// The identified errors by parameter name, model units.
    #[getter]
    fn errors(&self) -> std::collections::BTreeMap<String, f64> {
        let u = &self.cal.units;
        self.cal
            .errors
            .iter()
            .map(|e| {
                let v = if e.param.is_angle() {
                    u.angle_from_si(e.error)
                } else {
                    u.length_from_si(e.error)
                };
                (e.param.to_string(), v)
            })
            .collect()
    }

    /// The names of the calibration's non-geometric effects.
    #[getter]
    fn effects(&self) -> Vec<&'static str> {
        self.cal.effects.iter().map(|e| e.name()).collect()
    }

    /// The tool-point error (RMS, model length unit) the calibration is
    /// expected to make on poses it was not fitted to, from the
    /// cross-validation of `diagnose`; None when unknown (a file before
    /// format version 5, or `identify`).
    #[getter]
    fn held_out(&self) -> Option<f64> {
        self.cal.held_out.map(|h| self.cal.units.length_from_si(h))
    }

    /// With effects, the geometry refitted without them, as a calibration
    /// without effects (its `held_out` its own): what a format that cannot
    /// carry the effects (a URDF, UR deltas) should hold; None without
    /// effects or from a file before format version 5.
    #[getter]
    fn geometric(&self) -> Option<Calibration> {
        self.cal.geometric_only().map(Calibration::from)
    }

    fn __eq__(&self, other: &Self) -> bool {
        self.cal == other.cal
    }

    fn __repr__(&self) -> String {
        format!(
            "Calibration(dof={}, errors={}, effects={:?}, orientation={}, targets={:?})",
            self.dof(),
            self.cal.errors.len(),
            self.effects(),
            self.cal.task == Task::Pose,
            self.targets()
        )
    }
}
