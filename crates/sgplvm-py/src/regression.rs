//! The native class behind `sgplvm.GPRegression`: the direct GP regression human → robot that
//! the shared model is measured against (see `sgplvm_core::GpRegression`).

use numpy::{PyArray2, PyReadonlyArray2};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use sgplvm_core::{GpRegression, TrainOptions};

use crate::guard::guarded;
use crate::model::{kernel_to_dict, model_error, to_mat, to_numpy};

/// A trained GP regression (native part; use `sgplvm.GPRegression`).
#[pyclass(module = "sgplvm._sgplvm", name = "NativeRegression", frozen)]
pub struct NativeRegression {
    inner: GpRegression,
}

#[pymethods]
impl NativeRegression {
    /// Fits outputs `y` (n × D_y) on inputs `x` (n × D_x), at most `max_iters` L-BFGS
    /// iterations for the hyperparameters; the GIL is released while training.
    #[staticmethod]
    fn fit(
        py: Python<'_>,
        x: PyReadonlyArray2<'_, f64>,
        y: PyReadonlyArray2<'_, f64>,
        max_iters: usize,
    ) -> PyResult<Self> {
        guarded(|| {
            let (x, y) = (to_mat(&x), to_mat(&y));
            let options = TrainOptions::default().with_max_iters(max_iters);
            py.detach(|| GpRegression::fit(x.as_ref(), y.as_ref(), &options))
                .map(|inner| NativeRegression { inner })
                .map_err(model_error)
        })
    }

    /// Posterior mean at the input frames `x` (n × D_x).
    fn predict<'py>(
        &self,
        py: Python<'py>,
        x: PyReadonlyArray2<'_, f64>,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        guarded(|| {
            let x = to_mat(&x);
            let mean = py
                .detach(|| self.inner.predict(x.as_ref()))
                .map_err(model_error)?;
            Ok(to_numpy(py, &mean))
        })
    }

    /// The trained hyperparameters: {"variance", "lengthscale", "noise"}.
    fn kernel<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        kernel_to_dict(py, self.inner.kernel())
    }
}
