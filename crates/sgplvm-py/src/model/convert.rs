//! Conversions between Python and the core: a core error as the Python exception a user
//! expects, numpy arrays as faer matrices and back, and Python's spelling of a back
//! constraint.

use numpy::ndarray::Array2;
use numpy::{PyArray2, PyReadonlyArray2};
use pyo3::exceptions::{PyMemoryError, PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use sgplvm_core::{BackConstraint, Mat};

/// Converts a core error into the Python exception a user expects: `OSError` for files,
/// `MemoryError` for a model too large for memory (refused before allocating), `RuntimeError`
/// for a kernel that cannot be factorised, `ValueError` for the rest.
pub(crate) fn model_error(e: sgplvm_core::Error) -> PyErr {
    match e {
        sgplvm_core::Error::Io { .. } => pyo3::exceptions::PyOSError::new_err(e.to_string()),
        sgplvm_core::Error::NotPositiveDefinite { .. } => PyRuntimeError::new_err(e.to_string()),
        sgplvm_core::Error::TooLarge { .. } | sgplvm_core::Error::TooLargeSparse { .. } => {
            PyMemoryError::new_err(e.to_string())
        }
        _ => PyValueError::new_err(e.to_string()),
    }
}

/// [`model_error`] for reading `source` (a path, or "bytes"/"pickle"): the message names it.
pub(crate) fn read_error(source: &str, e: sgplvm_core::Error) -> PyErr {
    match e {
        sgplvm_core::Error::Io { .. } => model_error(e),
        sgplvm_core::Error::TooLarge { .. } | sgplvm_core::Error::TooLargeSparse { .. } => {
            PyMemoryError::new_err(format!("{source}: {e}"))
        }
        other => PyValueError::new_err(format!("{source}: {other}")),
    }
}

/// A (rows × cols) faer matrix from a 2-D float64 numpy array of any memory order.
pub(crate) fn to_mat(a: &PyReadonlyArray2<'_, f64>) -> Mat<f64> {
    let view = a.as_array();
    Mat::from_fn(view.nrows(), view.ncols(), |i, j| view[[i, j]])
}

/// A 2-D numpy array from a faer matrix.
pub(crate) fn to_numpy<'py>(py: Python<'py>, m: &Mat<f64>) -> Bound<'py, PyArray2<f64>> {
    let array = Array2::from_shape_fn((m.nrows(), m.ncols()), |(i, j)| m[(i, j)]);
    PyArray2::from_owned_array(py, array)
}

/// Python's spelling of a back constraint: `None` (or "none") for free latent points, else the
/// core's names ("input", "output"; see [`BackConstraint`]'s `FromStr`).
pub(crate) fn parse_back_constraint(value: Option<&str>) -> PyResult<BackConstraint> {
    value.map_or(Ok(BackConstraint::None), |name| {
        name.parse().map_err(|_| {
            PyValueError::new_err(format!(
                "back_constraint is {name:?}; expected \"input\", \"output\" or None"
            ))
        })
    })
}

/// The Python value of a back constraint: `None` for free latent points, else its name.
pub(super) fn back_constraint_name(bc: BackConstraint) -> Option<&'static str> {
    (bc != BackConstraint::None).then(|| bc.name())
}

/// Checks a `back_constraint` argument of any Python type and returns its canonical value
/// ("input", "output" or None); anything else is a ValueError that names what is accepted.
#[pyfunction]
pub(crate) fn canonical_back_constraint(
    value: &Bound<'_, PyAny>,
) -> PyResult<Option<&'static str>> {
    if value.is_none() {
        return Ok(None);
    }
    match value
        .extract::<String>()
        .ok()
        .map(|s| s.parse::<BackConstraint>())
    {
        Some(Ok(bc)) => Ok(back_constraint_name(bc)),
        _ => Err(PyValueError::new_err(format!(
            "back_constraint is {}; expected 'input', 'output' or None",
            value.repr()?
        ))),
    }
}
