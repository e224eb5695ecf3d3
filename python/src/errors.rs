//! The exceptions, and conversions between numpy arrays and the library's rows.

use armcal::commands;
use armcal::io::arrays;
use armcal::io::input_error;
use numpy::ndarray::Array2;
use numpy::{AllowTypeChange, IntoPyArray, PyArray2, PyArrayLikeDyn};
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

/// A refused input as an `armcal.InputError`; with `arrays`, an error of data
/// read from arrays ([`arrays::DATA`], [`arrays::JOINTS`]) names the row.
pub fn input(py: Python<'_>, e: &input_error::InputError, arrays: bool) -> PyErr {
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
    place: Option<&input_error::InputError>,
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
    match e.downcast_ref::<input_error::InputError>() {
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
    input(py, &input_error::InputError::argument(name, message), false)
}

/// A numpy array (or anything numpy turns into one) of floats, 1-D or 2-D.
pub type ArrayLike<'py> = PyArrayLikeDyn<'py, f64, AllowTypeChange>;

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
}

impl Owned {
    /// The array `a`, named `name` in errors; 1-D is one row.
    pub fn rows(py: Python<'_>, name: &str, a: &ArrayLike<'_>) -> PyResult<Self> {
        let view = a.as_array();
        let values: Vec<f64> = view.iter().copied().collect();
        match *view.shape() {
            [cols] => Ok(Self {
                values,
                rows: 1,
                cols,
                single: true,
            }),
            [rows, cols] => Ok(Self {
                values,
                rows,
                cols,
                single: false,
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

    /// The values of a 1-D array (one per row), named `name` in errors.
    pub fn column(py: Python<'_>, name: &str, a: &ArrayLike<'_>) -> PyResult<Vec<f64>> {
        let view = a.as_array();
        match *view.shape() {
            [_] => Ok(view.iter().copied().collect()),
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

/// A JSON value (a report) as Python objects: dicts, lists, floats, None.
pub fn to_python<'py>(py: Python<'py>, value: &serde_json::Value) -> PyResult<Bound<'py, PyAny>> {
    let text = serde_json::to_string(value).map_err(failure)?;
    py.import("json")?.call_method1("loads", (text,))
}
