//! The native class behind `sgplvm.GPRegression`: the direct GP regression human → robot that
//! the shared model is measured against (see `sgplvm_core::GpRegression`).

use std::sync::{Arc, Mutex};

use numpy::{PyArray2, PyReadonlyArray2};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use sgplvm_core::{GpRegression, TrainOptions};

use crate::guard::guarded;
use crate::model::{
    finish_training, kernel_to_dict, model_error, settle, signal_interrupt, to_mat, to_numpy,
};

/// A trained GP regression (native part; use `sgplvm.GPRegression`).
#[pyclass(module = "sgplvm._sgplvm", name = "NativeRegression", frozen)]
pub struct NativeRegression {
    inner: GpRegression,
}

#[pymethods]
impl NativeRegression {
    /// Fits outputs `y` (n × D_y) on inputs `x` (n × D_x), at most `max_iters` L-BFGS
    /// iterations and `max_seconds` seconds for the hyperparameters; the GIL is released while
    /// training. A signal handler's exception (Ctrl-C) stops training, as for the shared model,
    /// and is raised carrying the regression trained so far as its `_sgplvm_native` attribute.
    #[staticmethod]
    #[pyo3(signature = (x, y, max_iters, max_seconds=None))]
    fn fit(
        py: Python<'_>,
        x: PyReadonlyArray2<'_, f64>,
        y: PyReadonlyArray2<'_, f64>,
        max_iters: usize,
        max_seconds: Option<f64>,
    ) -> PyResult<Self> {
        guarded(|| {
            let (x, y) = (to_mat(&x), to_mat(&y));
            let signal = Arc::new(Mutex::new(None));
            let options = TrainOptions::default()
                .with_max_iters(max_iters)
                .with_max_seconds(max_seconds)
                .with_interrupt(signal_interrupt(Arc::clone(&signal)));
            let result = py.detach(|| GpRegression::fit(x.as_ref(), y.as_ref(), &options));
            let (inner, signal) = settle(py, None, &signal, result)?;
            finish_training(py, NativeRegression { inner }, signal)
        })
    }

    /// Why training stopped (`StopReason::name`: e.g. `time_limit`, `interrupted`).
    #[getter]
    fn stop_reason(&self) -> Option<&'static str> {
        self.inner.stop_reason().map(|r| r.name())
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
