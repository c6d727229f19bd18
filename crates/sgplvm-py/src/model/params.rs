//! A model's parameters as Python sees them: nested dicts of numpy arrays and floats, read
//! back with every key and shape checked against the model's current parameters.

use numpy::{PyArray1, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use sgplvm_core::{KernelParams, LatentParams, Mat, Params};

use super::{to_mat, to_numpy};

pub(crate) fn kernel_to_dict<'py>(
    py: Python<'py>,
    k: &KernelParams,
) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("variance", k.variance)?;
    d.set_item("lengthscale", PyArray1::from_slice(py, &k.lengthscale))?;
    d.set_item("noise", k.noise)?;
    Ok(d)
}

pub(super) fn params_to_dict<'py>(py: Python<'py>, p: &Params) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    match &p.latent {
        LatentParams::Free { x } => d.set_item("latent", to_numpy(py, x))?,
        LatentParams::BackConstrained { weights, bandwidth } => {
            let l = PyDict::new(py);
            l.set_item("weights", to_numpy(py, weights))?;
            l.set_item("bandwidth", *bandwidth)?;
            d.set_item("latent", l)?;
        }
    }
    let spaces = PyDict::new(py);
    for (name, k) in &p.spaces {
        spaces.set_item(name, kernel_to_dict(py, k)?)?;
    }
    d.set_item("spaces", spaces)?;
    Ok(d)
}

fn get_item<'py>(d: &Bound<'py, PyDict>, key: &str, context: &str) -> PyResult<Bound<'py, PyAny>> {
    d.get_item(key)?
        .ok_or_else(|| PyValueError::new_err(format!("{context}: missing key {key:?}")))
}

fn matrix_from_any(
    value: &Bound<'_, PyAny>,
    context: &str,
    rows: usize,
    cols: usize,
) -> PyResult<Mat<f64>> {
    let array: PyReadonlyArray2<'_, f64> = value
        .extract()
        .map_err(|_| PyValueError::new_err(format!("{context}: expected a 2-D float64 array")))?;
    if array.shape() != [rows, cols] {
        return Err(PyValueError::new_err(format!(
            "{context}: shape {:?}, expected ({rows}, {cols})",
            array.shape()
        )));
    }
    Ok(to_mat(&array))
}

pub(super) fn params_from_dict(d: &Bound<'_, PyDict>, current: &Params) -> PyResult<Params> {
    let latent_value = get_item(d, "latent", "params")?;
    let latent = match &current.latent {
        LatentParams::Free { x } => LatentParams::Free {
            x: matrix_from_any(&latent_value, "params['latent']", x.nrows(), x.ncols())?,
        },
        LatentParams::BackConstrained { weights, bandwidth } => {
            let l = latent_value.cast::<PyDict>().map_err(|_| {
                PyValueError::new_err(
                    "params['latent']: expected a dict with 'weights' (back-constrained model)",
                )
            })?;
            let w = get_item(l, "weights", "params['latent']")?;
            let bandwidth = match l.get_item("bandwidth")? {
                Some(b) => b.extract()?,
                None => *bandwidth,
            };
            LatentParams::BackConstrained {
                weights: matrix_from_any(
                    &w,
                    "params['latent']['weights']",
                    weights.nrows(),
                    weights.ncols(),
                )?,
                bandwidth,
            }
        }
    };
    let spaces_value = get_item(d, "spaces", "params")?;
    let spaces_dict = spaces_value
        .cast::<PyDict>()
        .map_err(|_| PyValueError::new_err("params['spaces']: expected a dict of spaces"))?;
    let mut spaces = Vec::with_capacity(current.spaces.len());
    for (name, k) in &current.spaces {
        let context = format!("params['spaces'][{name:?}]");
        let s = get_item(spaces_dict, name, "params['spaces']")?;
        let s = s
            .cast::<PyDict>()
            .map_err(|_| PyValueError::new_err(format!("{context}: expected a dict")))?;
        let lengthscale: Vec<f64> =
            get_item(s, "lengthscale", &context)?
                .extract()
                .map_err(|_| {
                    PyValueError::new_err(format!(
                        "{context}['lengthscale']: expected a sequence of floats"
                    ))
                })?;
        if lengthscale.len() != k.lengthscale.len() {
            return Err(PyValueError::new_err(format!(
                "{context}['lengthscale']: {} values, expected {}",
                lengthscale.len(),
                k.lengthscale.len()
            )));
        }
        spaces.push((
            name.clone(),
            KernelParams {
                variance: get_item(s, "variance", &context)?.extract()?,
                lengthscale,
                noise: get_item(s, "noise", &context)?.extract()?,
            },
        ));
    }
    Ok(Params { latent, spaces })
}
