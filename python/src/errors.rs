//! The exceptions, and conversions between numpy arrays and the library's rows.
//!
//! Every argument a call refuses raises `armcal.InputError` naming it:
//! arrays by their dtype ([`Owned`]: float64 as is, float32 and integers
//! widened, booleans and complex numbers refused), other arguments by their
//! type ([`args`]: a negative count, a string where a list is taken).

use armcal::apply::ranges;
use armcal::calibration::gravity::TorqueSign;
use armcal::commands;
use armcal::commands::Front;
use armcal::commands::choices::{self, TorqueSignArg};
use armcal::io::arrays;
use numpy::ndarray::Array2;
use numpy::{IntoPyArray, PyArray2, PyArrayDyn, PyArrayMethods};
use pyo3::conversion::FromPyObjectOwned;
use pyo3::prelude::*;

pyo3::create_exception!(
    armcal,
    ArmcalError,
    pyo3::exceptions::PyException,
    "A failure of armcal: the base of its exceptions."
);
pyo3::create_exception!(
    armcal,
    InputError,
    ArmcalError,
    "A refused input (a file, an argument, arrays): the message names the file, line and column, or the array and row, as the command line does. Attributes: file, line, column (0 when there is no place), row (the array row, for arrays; else None)."
);

/// The Python package's front end, as the command layer names its
/// arguments.
pub(crate) const PYTHON: Front = Front::Python;

/// The choice the keyword argument `name` names (`word`), as the command
/// line's flag takes it ([`choices`]): `T` is the flag's words, `U` the
/// library's type. Another word is an `armcal.InputError` naming `name`
/// with the words it takes.
pub(crate) fn choice<T, U: From<T>>(
    py: Python<'_>,
    name: &str,
    word: &str,
    parse: fn(&str) -> Result<T, String>,
) -> PyResult<U> {
    parse(word)
        .map(U::from)
        .map_err(|why| argument(py, name, why))
}

/// The sign of the `tau` columns `torque_sign` names: `"drive"`, `"load"`,
/// or `None` (read from the data).
pub(crate) fn torque_sign(
    py: Python<'_>,
    torque_sign: Option<&str>,
) -> PyResult<Option<TorqueSign>> {
    torque_sign
        .map(|word| {
            choices::parse::<TorqueSignArg>(word)
                .map(TorqueSign::from)
                .map_err(|_| {
                    let mut words = choices::words::<TorqueSignArg>();
                    words.push("None (read from the data)".into());
                    argument(py, "torque_sign", choices::expected(word, &words))
                })
        })
        .transpose()
}

/// A refused input as an `armcal.InputError`; with `arrays`, an error of data
/// read from arrays ([`arrays::DATA`], [`arrays::JOINTS`]) names the row.
pub fn input(py: Python<'_>, e: &armcal::session::input_error::InputError, arrays: bool) -> PyErr {
    let from_arrays = arrays && (e.file == arrays::DATA || e.file == arrays::JOINTS);
    let message = if from_arrays {
        arrays::describe(e)
    } else {
        e.to_string()
    };
    let row = (from_arrays && e.line > 0).then(|| e.line - 1);
    refusal(py, message, Some(e), row)
}

/// A refusal of the data that has no place in it (the fit cannot be made
/// from them): an `armcal.InputError` with `message` alone.
pub fn refused(py: Python<'_>, message: impl std::fmt::Display) -> PyErr {
    refusal(py, message.to_string(), None, None)
}

fn refusal(
    py: Python<'_>,
    message: String,
    place: Option<&armcal::session::input_error::InputError>,
    row: Option<usize>,
) -> PyErr {
    let err = InputError::new_err(message);
    let value = err.value(py);
    let set = || -> PyResult<()> {
        value.setattr("file", place.map(|e| e.file.as_str()))?;
        value.setattr("line", place.map_or(0, |e| e.line))?;
        value.setattr("column", place.map_or(0, |e| e.column))?;
        value.setattr("row", row)
    };
    match set() {
        Ok(()) => err,
        Err(e) => e,
    }
}

/// A verb's error (`armcal::commands`) as the command line classes it
/// ([`commands::is_refusal`]): a refused input is an `armcal.InputError`
/// (naming the array row of data read from arrays, with `arrays`), anything
/// else an `armcal.ArmcalError`.
pub fn command(py: Python<'_>, e: anyhow::Error, arrays: bool) -> PyErr {
    match e.downcast_ref::<armcal::session::input_error::InputError>() {
        Some(place) => input(py, place, arrays),
        None if commands::is_refusal(&e) => refused(py, e),
        None => failure(e),
    }
}

/// Any other failure as an `armcal.ArmcalError` with its message.
pub fn failure(e: impl std::fmt::Display) -> PyErr {
    ArmcalError::new_err(e.to_string())
}

/// A refused argument (`name`: the Python parameter).
pub fn argument(py: Python<'_>, name: &str, message: impl Into<String>) -> PyErr {
    input(
        py,
        &armcal::session::input_error::InputError::argument(name, message),
        false,
    )
}

/// A numpy array, or anything numpy turns into one (a list of numbers): an
/// argument that [`Owned::rows`] and [`Owned::column`] read, refusing what is
/// not numbers with an `InputError` naming it.
pub type ArrayLike<'py> = Bound<'py, PyAny>;

/// The precision an array's values were given in: what a check against a
/// bound may hold them to ([`ranges::Resolution`]).
fn resolution_of(kind: u8, itemsize: usize) -> Option<ranges::Resolution> {
    match (kind, itemsize) {
        (b'f', 8) | (b'i' | b'u', _) => Some(ranges::Resolution::Exact),
        (b'f', 4) => Some(ranges::Resolution::Float32),
        _ => None,
    }
}

/// The values of the array-like `a` (the argument `name`) as float64, and the
/// precision they were given in: float64 as is; float32 and integers
/// widened exactly; booleans, complex numbers, float16, strings, objects and
/// anything else refused, naming the argument (numpy's casts would take a
/// boolean for 0 or 1 and drop an imaginary part without a word).
fn floats<'py>(
    name: &str,
    a: &Bound<'py, PyAny>,
) -> PyResult<(Bound<'py, PyArrayDyn<f64>>, ranges::Resolution)> {
    let py = a.py();
    let numpy = py.import("numpy")?;
    let array = numpy
        .call_method1("asarray", (a,))
        .map_err(|e| argument(py, name, format!("not an array of numbers: {e}")))?;
    let dtype = array.getattr("dtype")?;
    let kind: String = dtype.getattr("kind")?.extract()?;
    let itemsize: usize = dtype.getattr("itemsize")?.extract()?;
    let refuse = |why: &str| {
        argument(
            py,
            name,
            format!(
                "dtype {}: {why}; give float64 (float32 and integers are widened)",
                dtype.str().map_or_else(|_| kind.clone(), |s| s.to_string())
            ),
        )
    };
    let resolution = match kind.as_bytes() {
        [b'b'] => return Err(refuse("booleans are not joint values or coordinates")),
        [b'c'] => return Err(refuse("complex numbers have no place here")),
        [b'f'] if itemsize < 4 => {
            return Err(refuse(
                "too few digits for joint values or coordinates (a thousandth of a radian)",
            ));
        }
        [k] => resolution_of(*k, itemsize).ok_or_else(|| refuse("not a dtype armcal reads"))?,
        _ => return Err(refuse("not a dtype armcal reads")),
    };
    let widened = array.call_method1("astype", ("float64",))?;
    let widened = widened
        .cast_into::<PyArrayDyn<f64>>()
        .map_err(|e| failure(format!("{name}: {e}")))?;
    Ok((widened, resolution))
}

/// The values of a 1-D or 2-D array, row-major, its shape as `(rows, cols)`,
/// and whether it was 1-D (a single row of `cols` values).
pub struct Owned {
    /// The values, row after row.
    pub values: Vec<f64>,
    /// Rows.
    pub rows: usize,
    /// Columns.
    pub cols: usize,
    /// Whether the array was one row, 1-D.
    pub single: bool,
    /// The precision the values were given in (float32: a value on a bound
    /// may be off it by float32's rounding).
    pub resolution: ranges::Resolution,
}

impl Owned {
    /// The array `a`, named `name` in errors; 1-D is one row. Its dtype as
    /// [`floats`] takes it.
    pub fn rows(py: Python<'_>, name: &str, a: &ArrayLike<'_>) -> PyResult<Self> {
        let (array, resolution) = floats(name, a)?;
        let array = array.readonly();
        let view = array.as_array();
        let values: Vec<f64> = view.iter().copied().collect();
        match *view.shape() {
            [cols] => Ok(Self {
                values,
                rows: 1,
                cols,
                single: true,
                resolution,
            }),
            [rows, cols] => Ok(Self {
                values,
                rows,
                cols,
                single: false,
                resolution,
            }),
            ref shape => Err(argument(
                py,
                name,
                format!(
                    "{} dimensions (shape {shape:?}): expected 1 (one row) or 2 (rows × columns)",
                    shape.len()
                ),
            )),
        }
    }

    /// The values of a 1-D array (one per row), named `name` in errors, and
    /// the precision they were given in.
    pub fn column(
        py: Python<'_>,
        name: &str,
        a: &ArrayLike<'_>,
    ) -> PyResult<(Vec<f64>, ranges::Resolution)> {
        let (array, resolution) = floats(name, a)?;
        let array = array.readonly();
        let view = array.as_array();
        match *view.shape() {
            [_] => Ok((view.iter().copied().collect(), resolution)),
            ref shape => Err(argument(
                py,
                name,
                format!("shape {shape:?}: expected one value per row, 1-D"),
            )),
        }
    }

    /// The library's view of the array.
    pub fn table(&self) -> arrays::Table<'_> {
        arrays::Table {
            values: &self.values,
            rows: self.rows,
            cols: self.cols,
        }
    }
}

/// Rows of `cols` values as a numpy array: `(N, cols)`, or `(cols,)` when the
/// input was a `single` row.
pub fn to_numpy<'py>(
    py: Python<'py>,
    rows: Vec<Vec<f64>>,
    cols: usize,
    single: bool,
) -> PyResult<Bound<'py, PyAny>> {
    let n = rows.len();
    let flat: Vec<f64> = rows.into_iter().flatten().collect();
    if single && n == 1 {
        return Ok(flat.into_pyarray(py).into_any());
    }
    let array = Array2::from_shape_vec((n, cols), flat).map_err(failure)?;
    let array: Bound<'py, PyArray2<f64>> = array.into_pyarray(py);
    Ok(array.into_any())
}

/// A report as Python objects: dicts, lists, floats, None, made from the
/// value itself (no JSON text between), as `--json` serialises it: a float
/// that is not finite is None, as JSON's `null`.
pub fn to_python<'py>(
    py: Python<'py>,
    value: &impl serde::Serialize,
) -> PyResult<Bound<'py, PyAny>> {
    pythonize::pythonize(py, &armcal::report::to_json(value)).map_err(failure)
}

/// The value of the argument `name` as `T`, refused with an
/// `armcal.InputError` that names it and says what it takes (`expected`):
/// the `TypeError`, `OverflowError` or `ValueError` of Python's conversion
/// never reaches the caller.
pub fn extract<'py, T: FromPyObjectOwned<'py>>(
    ob: &Bound<'py, PyAny>,
    name: &str,
    expected: &str,
) -> PyResult<T> {
    ob.extract::<T>().map_err(|_| {
        let shown = ob
            .repr()
            .map_or_else(|_| "the value".to_owned(), |r| r.to_string());
        argument(ob.py(), name, format!("{shown}: expected {expected}"))
    })
}

/// Declares one extractor per argument for `#[pyo3(from_py_with = …)]`:
/// `function: Type = "name", "what it takes";`.
macro_rules! arguments {
    ($($function:ident: $t:ty = $name:literal, $expected:literal;)*) => {$(
        #[doc = concat!("The argument `", $name, "`: ", $expected, " ([`extract`]).")]
        pub fn $function(ob: &Bound<'_, PyAny>) -> PyResult<$t> {
            super::extract(ob, $name, $expected)
        }
    )*};
}

/// The extractors of the calls' arguments, each refusing a value of the
/// wrong type with an `armcal.InputError` naming the argument.
pub mod args {
    use pyo3::prelude::*;

    arguments! {
        poses: usize = "poses", "a whole number of poses, 0 or more";
        seed: u64 = "seed", "a whole number, 0 or more";
        folds: Option<usize> = "folds", "a whole number of folds, or None";
        sessions: usize = "sessions", "a whole number of sessions, 1 or more";
        orientation: bool = "orientation", "True or False";
        same_base: bool = "same_base", "True or False";
        same_tool: bool = "same_tool", "True or False";
        noise: Option<f64> = "noise", "a number in the model's length unit, or None";
        orientation_noise: Option<f64> = "orientation_noise", "a number in the model's angle unit, or None";
        position_noise: Option<f64> = "position_noise", "a number in the model's length unit, or None";
        point_noise: Option<f64> = "point_noise", "a number in the model's length unit, or None";
        plane_noise: Option<f64> = "plane_noise", "a number in the model's length unit, or None";
        prior_length: Option<f64> = "prior_length", "a number in the model's length unit, or None";
        prior_angle: Option<f64> = "prior_angle", "a number in the model's angle unit, or None";
        torque_noise: Option<f64> = "torque_noise", "a number in N·m, or None";
        above: Option<f64> = "above", "a height in the model's length unit, or None";
        margin: Option<f64> = "margin", "a share of each joint's range from 0 to below 0.5, or None";
        within: Option<Vec<f64>> = "within", "six numbers (x_min, y_min, z_min, x_max, y_max, z_max), or None";
        effects: Vec<String> = "effects", "a list of effect names, as [\"backlash\"]";
        plan_effects: Vec<String> = "effects", "a list of effect names, as [\"backlash\"] or [\"compliance\"]";
        tilts: Vec<(usize, f64)> = "tilts", "a list of (joint, beta) pairs";
        payloads: Vec<f64> = "payloads", "a list of payloads in kg";
        link_errors: Option<(f64, f64)> = "link_errors", "a (length, angle) pair, or None";
        base_errors: Option<(f64, f64)> = "base_errors", "a (length, angle) pair, or None";
        tool_errors: Option<(f64, f64)> = "tool_errors", "a (length, angle) pair, or None";
        sockets: Option<String> = "sockets", "the path of a sockets file, or None";
        params: String = "params", "\"full\" or \"paper\"";
        prior_scale: String = "prior_scale", "\"chosen\" or \"stated\"";
        orientation_weight: String = "orientation_weight", "\"chosen\", \"estimated\", \"0.1\", \"0.01\" or \"none\"";
        point_weight: String = "point_weight", "\"chosen\", \"estimated\", \"0.1\", \"0.01\" or \"none\"";
        plane_weight: String = "plane_weight", "\"chosen\", \"estimated\", \"0.1\", \"0.01\" or \"none\"";
        orientation_bias: Option<f64> = "orientation_bias", "an angle in the model's angle unit, or None";
        orientation_bias_growth: Option<f64> = "orientation_bias_growth", "an angle per length in the model's units, or None";
        targets: String = "targets", "\"world\" or \"base\"";
        select: String = "select", "\"stated\", \"prior\" or \"diagnose\"";
        criterion: String = "criterion", "\"i-optimal\" or \"d-optimal\"";
        singularity_margin: Option<f64> = "singularity_margin", "a conditioning from 0 to below 1, or None";
        name_or_path: String = "name_or_path", "a path or a built-in name";
        base_link: Option<String> = "base_link", "a link's name, or None";
        tip_link: Option<String> = "tip_link", "a link's name, or None";
        tool_link: String = "tool_link", "a link's name";
        urdf: String = "model", "the path of the URDF the calibration's model was read from";
        tip_point: Option<[f64; 3]> = "tip_point", "three numbers (x, y, z) in m, or None";
        xyz: [f64; 3] = "xyz", "three numbers (x, y, z) in the model's length unit";
        rpy: Option<[f64; 3]> = "rpy", "three angles (roll, pitch, yaw) in the model's angle unit, or None";
        text: String = "text", "the text of a file";
        file: String = "file", "the name errors give the text";
        path: String = "path", "a path";
        bytes: Vec<u8> = "data", "the bytes of a calibration file";
        write_failed: bool = "write_failed", "True or False";
        servo: bool = "servo", "True or False";
        torque_sign: Option<String> = "torque_sign", "\"drive\", \"load\" or None";
        simulated_torque_sign: String = "torque_sign", "\"drive\" or \"load\"";
    }

    /// The argument `sessions`: a list of sessions ([`super::extract`]).
    pub fn sessions_list<'py>(ob: &Bound<'py, PyAny>) -> PyResult<Vec<Bound<'py, PyAny>>> {
        super::extract(ob, "sessions", "a list of sessions (Measurements, paths)")
    }

    /// The argument `train`: a list of sessions, or None ([`super::extract`]).
    pub fn train_list<'py>(ob: &Bound<'py, PyAny>) -> PyResult<Option<Vec<Bound<'py, PyAny>>>> {
        super::extract(
            ob,
            "train",
            "a list of sessions (Measurements, paths), or None",
        )
    }
}
