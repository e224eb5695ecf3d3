//! `identify` and `diagnose`, composed as `armcal identify` and `armcal
//! diagnose` compose them: the same checks of the data, the same options, the
//! same report (the JSON of `docs/file-formats.md` §6, as Python dicts), the same refusals.

use armcal::calibration::diagnose::report::DiagnoseReport;
use armcal::calibration::identify::channel_weight::ChannelWeights;
use armcal::calibration::identify::prior_scale::PriorScale;
use armcal::calibration::identify::report::IdentifyReport;
use armcal::calibration::identify::{ParamSet, StatedScales};
use armcal::commands::choices::{self, Params, PriorScaleArg, Targets, WeightArg};
use armcal::commands::{self, diagnose as diagnose_cmd, identify as identify_cmd};
use armcal::session::channel::Weighed;
use armcal::session::model::RobotModel;
use armcal::session::registration::FrameSharing;
use pyo3::prelude::*;

use std::sync::{Arc, OnceLock};

use armcal::cancel::Cancel;

use crate::calibration::Calibration;
use crate::data::Measurements;
use crate::errors::{self, PYTHON, args};
use crate::interrupt::{OnInterrupt, interruptible};
use crate::model::Model;

/// What `identify` and `diagnose` give: the report of `--json` as a dict
/// (`report`), the human summary the command prints (`summary`) and the
/// calibration (what `--out` writes).
#[pyclass(module = "armcal", frozen, subclass)]
pub struct Outcome {
    report: Report,
    summary: String,
    calibration: armcal_shared::Calibration,
    /// Why the calibration must not be written, as the command line says.
    failed: Option<String>,
}

/// The report of `identify` or `diagnose`: the value `--json` serialises.
enum Report {
    /// `identify`'s.
    Identify(Box<IdentifyReport>),
    /// `diagnose`'s.
    Diagnose(Box<DiagnoseReport>),
}

impl Report {
    /// `identify`'s report (the `Identification`'s own).
    fn identify(&self) -> Option<&IdentifyReport> {
        match self {
            Self::Identify(r) => Some(r),
            Self::Diagnose(_) => None,
        }
    }

    /// `diagnose`'s report (the `Diagnosis`'s own).
    fn diagnose(&self) -> Option<&DiagnoseReport> {
        match self {
            Self::Diagnose(r) => Some(r),
            Self::Identify(_) => None,
        }
    }
}

/// The outcome of `identify` (see `Outcome`), with its residuals.
#[pyclass(module = "armcal", frozen, extends = Outcome)]
pub struct Identification {
    position_rms: f64,
    orientation_rms: f64,
}

/// The outcome of `diagnose` (see `Outcome`), with the HTML page.
#[pyclass(module = "armcal", frozen, extends = Outcome)]
pub struct Diagnosis {
    /// What the page is made of.
    page: Arc<Page>,
    /// The page, made when first asked for (seconds and hundreds of MB for
    /// 10⁵ rows: a point per row in each of its two dozen plots).
    html: OnceLock<String>,
}

/// What the HTML page of a diagnosis is made of: the diagnosis, its data,
/// and its report.
struct Page {
    diagnosed: diagnose_cmd::Diagnosed,
    data: Arc<armcal::session::measurements::Measurements>,
    report: DiagnoseReport,
}

/// The data of a fit: given, or loaded from a path or built-in name against
/// `model` ([`measurements_of`]); refused, as the command line refuses it,
/// when it gives fewer equations than the model's independent parameters, a
/// session fewer than the frames `frames` makes its own, or cannot be
/// measurements of this robot.
fn session(
    py: Python<'_>,
    model: &Model,
    data: &Bound<'_, PyAny>,
    frames: FrameSharing,
) -> PyResult<(Measurements, bool)> {
    // A list (or tuple) of sessions: several sessions of one calibration.
    let several = !data.is_instance_of::<pyo3::types::PyString>()
        && (data.is_instance_of::<pyo3::types::PyList>()
            || data.is_instance_of::<pyo3::types::PyTuple>());
    let data = if several {
        if data.len()? == 0 {
            return Err(errors::argument(
                py,
                "data",
                "an empty list: give one session (Measurements, a path or a built-in data set \
                 name) or a list of one or more",
            ));
        }
        let parts = data
            .try_iter()?
            .map(|d| measurements_of(py, model, &d?, "data"))
            .collect::<PyResult<Vec<Measurements>>>()?;
        let arrays = parts.iter().any(|p| p.arrays);
        let joined = commands::sessions(parts.into_iter().map(|p| p.data).collect())
            .map_err(|e| errors::input(py, &e, arrays))?;
        Measurements {
            data: joined,
            model: model.inner.clone(),
            arrays,
        }
    } else {
        measurements_of(py, model, data, "data")?
    };
    commands::require_session(&model.inner, &data.data, frames)
        .map_err(|e| errors::input(py, &e, data.arrays))?;
    let arrays = data.arrays;
    Ok((data, arrays))
}

/// The measurements `data` (the argument `argument`): given, read against
/// `model` (refused otherwise), or loaded from a path or built-in name
/// against it.
pub(crate) fn measurements_of(
    py: Python<'_>,
    model: &Model,
    data: &Bound<'_, PyAny>,
    argument: &str,
) -> PyResult<Measurements> {
    let m = &model.inner;
    if let Ok(d) = data.cast::<Measurements>() {
        let d = d.get();
        if d.model.robot != m.robot || d.model.units != m.units {
            return Err(errors::argument(
                py,
                argument,
                format!(
                    "read against the model {:?} ({}), not {:?} ({}): load it against this model",
                    d.model.name, d.model.source, m.name, m.source
                ),
            ));
        }
        Ok(Measurements {
            data: d.data.clone(),
            model: d.model.clone(),
            arrays: d.arrays,
        })
    } else {
        let name: String = data.extract().map_err(|_| {
            errors::argument(
                py,
                argument,
                "expected Measurements, or a path or built-in data set name",
            )
        })?;
        crate::data::read(py, model, &name)
    }
}

/// `work` on `model` and the session's `rows` on a thread of its own
/// ([`interruptible`]; it stops at its next step boundary when interrupted,
/// asking the [`Cancel`] it is given); its result and the rows, back.
fn on_rows<T: Send + 'static>(
    py: Python<'_>,
    model: &Model,
    rows: armcal::session::measurements::Measurements,
    work: impl FnOnce(&RobotModel, &armcal::session::measurements::Measurements, Cancel) -> T
    + Send
    + 'static,
) -> PyResult<(T, Arc<armcal::session::measurements::Measurements>)> {
    let (m, rows) = (model.inner.clone(), Arc::new(rows));
    let shared = rows.clone();
    let result = interruptible(py, OnInterrupt::Stops, move |cancel| {
        work(&m, &shared, cancel)
    })?;
    Ok((result, rows))
}

/// Identifies the geometric errors of `model` from `data` (Measurements, or a
/// CSV path or built-in data set name; a list of them: several sessions of
/// one robot, each with its own base frame and tool unless `same_base`,
/// `same_tool`), as `armcal identify` does. `params`:
/// `full` (every identifiable parameter, base and tool included) or `paper`
/// (Mirman & Gupta's 3M model; needs orientations). Noise and prior scales in
/// the model's units (`point_noise`, `plane_noise`: of the contacts of a
/// session without a tracker, as `--point-noise`, `--plane-noise`);
/// `prior_scale`: `chosen` (the stated prior times the factor that predicts
/// held-out poses best, as `--prior-scale chosen`, the default) or `stated`;
/// `orientation_weight`: of the orientation rows, `chosen` (the weight that
/// predicts held-out positions best, as `--orientation-weight chosen`, the
/// default), `estimated`, `0.1`, `0.01` or `none`; `point_weight`,
/// `plane_weight`: of the contacts beside another kind that locates the tool
/// point, likewise (as `--point-weight`, `--plane-weight`);
/// `targets`: `world` or `base`; `torque_sign`: of the `tau` columns,
/// `drive` or `load` (as `--torque-sign`; default: read from the data).
#[pyfunction(name = "identify")]
#[pyo3(signature = (model, data, params = String::from("full"), *, position_noise = None, orientation_noise = None, point_noise = None, plane_noise = None, prior_length = None, prior_angle = None, prior_scale = String::from("chosen"), orientation_weight = String::from("chosen"), point_weight = String::from("chosen"), plane_weight = String::from("chosen"), targets = String::from("world"), same_base = false, same_tool = false, torque_sign = None))]
#[expect(
    clippy::too_many_arguments,
    reason = "a parameter per Python keyword argument, as the signature above lists them"
)]
pub fn identify_py<'py>(
    py: Python<'py>,
    #[pyo3(from_py_with = crate::model::argument)] model: Bound<'py, Model>,
    data: &Bound<'_, PyAny>,
    #[pyo3(from_py_with = args::params)] params: String,
    #[pyo3(from_py_with = args::position_noise)] position_noise: Option<f64>,
    #[pyo3(from_py_with = args::orientation_noise)] orientation_noise: Option<f64>,
    #[pyo3(from_py_with = args::point_noise)] point_noise: Option<f64>,
    #[pyo3(from_py_with = args::plane_noise)] plane_noise: Option<f64>,
    #[pyo3(from_py_with = args::prior_length)] prior_length: Option<f64>,
    #[pyo3(from_py_with = args::prior_angle)] prior_angle: Option<f64>,
    #[pyo3(from_py_with = args::prior_scale)] prior_scale: String,
    #[pyo3(from_py_with = args::orientation_weight)] orientation_weight: String,
    #[pyo3(from_py_with = args::point_weight)] point_weight: String,
    #[pyo3(from_py_with = args::plane_weight)] plane_weight: String,
    #[pyo3(from_py_with = args::targets)] targets: String,
    #[pyo3(from_py_with = args::same_base)] same_base: bool,
    #[pyo3(from_py_with = args::same_tool)] same_tool: bool,
    #[pyo3(from_py_with = args::torque_sign)] torque_sign: Option<String>,
) -> PyResult<Py<Identification>> {
    let model = model.get();
    let prior_scale: PriorScale = errors::choice(
        py,
        "prior_scale",
        &prior_scale,
        choices::parse::<PriorScaleArg>,
    )?;
    let params: ParamSet = errors::choice(py, "params", &params, choices::parse::<Params>)?;
    let request = identify_cmd::Request {
        params,
        scales: StatedScales {
            position_noise,
            orientation_noise,
            point_noise,
            plane_noise,
            prior_length,
            prior_angle,
        },
        prior_scale,
        channel_weights: self::channel_weights(
            py,
            [&orientation_weight, &point_weight, &plane_weight],
        )?,
        targets: errors::choice(py, "targets", &targets, choices::parse::<Targets>)?,
        frames: FrameSharing::stated(same_base, same_tool),
        torque_sign: errors::torque_sign(py, torque_sign.as_deref())?,
        // The computation's own, given on its thread ([`on_rows`]).
        cancel: Cancel::NEVER,
    };
    let (data, arrays) = session(py, model, data, request.frames)?;
    // The reports composed on the computation's thread too: Ctrl-C is
    // answered while they are.
    let (outcome, _) = on_rows(py, model, data.data, move |m, rows, cancel| {
        let request = identify_cmd::Request { cancel, ..request };
        let identified = identify_cmd::run(PYTHON, m, rows, &request)?;
        let (m, result) = (&identified.model, identified.result);
        let report = result.report(m, rows);
        let outcome = Outcome {
            summary: report.summary(),
            report: Report::Identify(Box::new(report)),
            calibration: result.calibration.clone(),
            failed: identified.failed.map(|f| f.to_string()),
        };
        let identification = Identification {
            position_rms: m.units.length_from_si(result.position_rms),
            orientation_rms: m.units.angle_from_si(result.orientation_rms),
        };
        anyhow::Ok((outcome, identification))
    })?;
    let (outcome, identification) = outcome.map_err(|e| errors::command(py, e, arrays))?;
    Py::new(
        py,
        PyClassInitializer::from(outcome).add_subclass(identification),
    )
}

/// The weights the keywords `orientation_weight`, `point_weight` and
/// `plane_weight` name, in that order.
fn channel_weights(py: Python<'_>, texts: [&str; 3]) -> PyResult<ChannelWeights> {
    let mut weights = ChannelWeights::default();
    for (kind, word) in Weighed::ALL.into_iter().zip(texts) {
        let name = format!("{}_weight", kind.key());
        weights[kind] = errors::choice(py, &name, word, choices::parse::<WeightArg>)?;
    }
    Ok(weights)
}

/// Fits the geometry, analyses the residuals, names what geometry misses,
/// extends the model and measures the gain on held-out poses, as `armcal
/// diagnose` does, for measured coordinates and for a session without a
/// tracker alike. `folds`: of the cross-validation (default 10, or one per
/// pose with fewer poses). Other options as `identify` (`torque_sign`
/// included).
#[pyfunction]
#[pyo3(signature = (model, data, *, folds = None, position_noise = None, orientation_noise = None, point_noise = None, plane_noise = None, prior_length = None, prior_angle = None, orientation_weight = String::from("chosen"), point_weight = String::from("chosen"), plane_weight = String::from("chosen"), targets = String::from("world"), same_base = false, same_tool = false, torque_sign = None))]
#[expect(
    clippy::too_many_arguments,
    reason = "a parameter per Python keyword argument, as the signature above lists them"
)]
pub fn diagnose<'py>(
    py: Python<'py>,
    #[pyo3(from_py_with = crate::model::argument)] model: Bound<'py, Model>,
    data: &Bound<'_, PyAny>,
    #[pyo3(from_py_with = args::folds)] folds: Option<usize>,
    #[pyo3(from_py_with = args::position_noise)] position_noise: Option<f64>,
    #[pyo3(from_py_with = args::orientation_noise)] orientation_noise: Option<f64>,
    #[pyo3(from_py_with = args::point_noise)] point_noise: Option<f64>,
    #[pyo3(from_py_with = args::plane_noise)] plane_noise: Option<f64>,
    #[pyo3(from_py_with = args::prior_length)] prior_length: Option<f64>,
    #[pyo3(from_py_with = args::prior_angle)] prior_angle: Option<f64>,
    #[pyo3(from_py_with = args::orientation_weight)] orientation_weight: String,
    #[pyo3(from_py_with = args::point_weight)] point_weight: String,
    #[pyo3(from_py_with = args::plane_weight)] plane_weight: String,
    #[pyo3(from_py_with = args::targets)] targets: String,
    #[pyo3(from_py_with = args::same_base)] same_base: bool,
    #[pyo3(from_py_with = args::same_tool)] same_tool: bool,
    #[pyo3(from_py_with = args::torque_sign)] torque_sign: Option<String>,
) -> PyResult<Py<Diagnosis>> {
    let model = model.get();
    let request = diagnose_cmd::Request {
        folds,
        scales: StatedScales {
            position_noise,
            orientation_noise,
            point_noise,
            plane_noise,
            prior_length,
            prior_angle,
        },
        channel_weights: self::channel_weights(
            py,
            [&orientation_weight, &point_weight, &plane_weight],
        )?,
        targets: errors::choice(py, "targets", &targets, choices::parse::<Targets>)?,
        frames: FrameSharing::stated(same_base, same_tool),
        torque_sign: errors::torque_sign(py, torque_sign.as_deref())?,
        // The computation's own, given on its thread ([`on_rows`]).
        cancel: Cancel::NEVER,
    };
    let (data, arrays) = session(py, model, data, request.frames)?;
    // The reports composed on the computation's thread too: Ctrl-C is
    // answered while they are.
    let (outcome, data) = on_rows(py, model, data.data, move |m, rows, cancel| {
        let request = diagnose_cmd::Request { cancel, ..request };
        let mut diagnosed = diagnose_cmd::run(PYTHON, m, rows, &request, &mut |_, _, _| {})?;
        // Arrays name their rows from 0, files by line.
        let from = usize::from(arrays);
        let lines: Vec<usize> = rows.lines.iter().map(|line| line - from).collect();
        let report = diagnosed.report(rows, &lines);
        let outcome = Outcome {
            summary: report.summary(),
            report: Report::Diagnose(Box::new(report.clone())),
            calibration: diagnosed.calibration.clone(),
            failed: diagnosed.failed.take().map(|f| f.to_string()),
        };
        anyhow::Ok((outcome, (diagnosed, report)))
    })?;
    let (outcome, (diagnosed, report)) = outcome.map_err(|e| errors::command(py, e, arrays))?;
    let page = Diagnosis {
        page: Arc::new(Page {
            diagnosed,
            data,
            report,
        }),
        html: OnceLock::new(),
    };
    Py::new(py, PyClassInitializer::from(outcome).add_subclass(page))
}

#[pymethods]
impl Outcome {
    /// The report of `--json` (`docs/file-formats.md` §6), model units: for `identify`
    /// `params`, `iterations`, `converged`, `parameters` (name, nominal,
    /// error, std, status, reason), `residual`, `condition_number`; for
    /// `diagnose` `noise_estimate_mm`, `holdout`, `effects`, `outlier_rows`
    /// (file lines, or rows from 0 for arrays) and more.
    #[getter]
    fn report<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        match &self.report {
            Report::Identify(r) => errors::to_python(py, r),
            Report::Diagnose(r) => errors::to_python(py, r),
        }
    }

    /// The human summary the command prints.
    #[getter]
    fn summary(&self) -> &str {
        &self.summary
    }

    /// The calibration: what `--out` writes. When its fit did not converge,
    /// or it fits its own data worse than the nominal model, its `write` and
    /// `to_bytes` raise `ArmcalError` with the reason (`failure`) unless
    /// given `write_failed=True`, as the command line exits 1 without
    /// `--write-failed`.
    #[getter]
    fn calibration(&self) -> Calibration {
        Calibration::failed(self.calibration.clone(), self.failed.clone())
    }

    /// Why the calibration is not written (the fit did not converge, or it
    /// fits its own data worse than the nominal model), or None.
    #[getter]
    fn failure(&self) -> Option<&str> {
        self.failed.as_deref()
    }
}

#[pymethods]
impl Identification {
    /// Identified minus nominal, by parameter name (`theta1`, `base.x`, …),
    /// model units; parameters held at nominal are left out.
    #[getter]
    fn errors(slf: &Bound<'_, Self>) -> std::collections::BTreeMap<String, f64> {
        slf.as_super()
            .get()
            .report
            .identify()
            .into_iter()
            .flat_map(|r| &r.parameters)
            .filter(|p| p.status == "identified")
            .map(|p| (p.name.clone(), p.error))
            .collect()
    }

    /// Whether the iterations converged.
    #[getter]
    fn converged(slf: &Bound<'_, Self>) -> bool {
        slf.as_super()
            .get()
            .report
            .identify()
            .is_some_and(|r| r.converged)
    }

    /// RMS position residual of the calibrated model, model length unit.
    #[getter]
    fn position_rms(&self) -> f64 {
        self.position_rms
    }

    /// RMS orientation residual, model angle unit (0 without orientations).
    #[getter]
    fn orientation_rms(&self) -> f64 {
        self.orientation_rms
    }

    fn __repr__(slf: &Bound<'_, Self>) -> String {
        format!(
            "Identification(params={}, converged={}, position_rms={})",
            slf.as_super()
                .get()
                .report
                .identify()
                .map_or("?", |r| r.params),
            Self::converged(slf),
            slf.get().position_rms
        )
    }
}

impl Diagnosis {
    /// The page, made on first asking on a thread of its own: Ctrl-C raises
    /// at once (the page has no steps to stop at: it is made on in the
    /// background and dropped).
    fn page(&self, py: Python<'_>) -> PyResult<&str> {
        if let Some(html) = self.html.get() {
            return Ok(html);
        }
        let page = self.page.clone();
        let html = interruptible(py, OnInterrupt::RunsOn, move |_| {
            page.diagnosed.html(&page.report, &page.data)
        })?;
        Ok(self.html.get_or_init(|| html))
    }
}

#[pymethods]
impl Diagnosis {
    /// The self-contained HTML page of `armcal diagnose --html` (made when
    /// first asked for).
    #[getter]
    fn html(&self, py: Python<'_>) -> PyResult<&str> {
        self.page(py)
    }

    /// Jupyter shows the HTML page.
    fn _repr_html_(&self, py: Python<'_>) -> PyResult<&str> {
        self.page(py)
    }

    fn __repr__(slf: &Bound<'_, Self>) -> String {
        let outcome = slf.as_super().get();
        let effects: Vec<&str> = outcome
            .report
            .diagnose()
            .into_iter()
            .flat_map(|r| &r.diagnosis.effects)
            .map(|e| e.name)
            .collect();
        format!("Diagnosis(effects={effects:?})")
    }
}
