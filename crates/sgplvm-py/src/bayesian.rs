//! The Bayesian GP-LVM's bound for checks against other implementations (GPy's `MRD` and
//! `BayesianGPLVM`): `_sgplvm.bayesian_bound`.

use numpy::PyReadonlyArray2;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use sgplvm_core::{Jitter, KernelParams, MatRef};

use crate::guard::guarded;
use crate::model::{model_error, to_mat, to_numpy};

/// The negative variational bound of a shared Bayesian GP-LVM (MRD; one space: the Bayesian
/// GP-LVM) and its gradient at q(X)'s means `mean` and variances `variance` (N×Q), inducing
/// inputs `z` (M×Q), data `ys` (one N×D array per space, used as given) and per space
/// `(variance, lengthscales, noise)`; `absolute_jitter` is added to each K_mm's diagonal (GPy:
/// 1e-8). Returns a dict: `value`, `kl`, `d_mean`, `d_variance`, `d_inducing` and `d_spaces`
/// (per space a dict of `variance`, `lengthscale`, `noise`), all in natural units.
#[pyfunction]
#[pyo3(signature = (mean, variance, z, ys, kernels, absolute_jitter))]
pub(crate) fn bayesian_bound<'py>(
    py: Python<'py>,
    mean: PyReadonlyArray2<'_, f64>,
    variance: PyReadonlyArray2<'_, f64>,
    z: PyReadonlyArray2<'_, f64>,
    ys: Vec<PyReadonlyArray2<'_, f64>>,
    kernels: Vec<(f64, Vec<f64>, f64)>,
    absolute_jitter: f64,
) -> PyResult<Bound<'py, PyDict>> {
    let bound = guarded(|| {
        let ys: Vec<_> = ys.iter().map(to_mat).collect();
        let views: Vec<MatRef<'_, f64>> = ys.iter().map(|y| y.as_ref()).collect();
        let kernels: Vec<KernelParams> = kernels
            .into_iter()
            .map(|(variance, lengthscale, noise)| KernelParams {
                variance,
                lengthscale,
                noise,
            })
            .collect();
        sgplvm_core::bayesian_bound(
            to_mat(&mean).as_ref(),
            to_mat(&variance).as_ref(),
            to_mat(&z).as_ref(),
            &views,
            &kernels,
            Jitter::Absolute(absolute_jitter),
        )
        .map_err(model_error)
    })?;
    let out = PyDict::new(py);
    out.set_item("value", bound.value)?;
    out.set_item("kl", bound.kl)?;
    out.set_item("d_mean", to_numpy(py, &bound.d_mean))?;
    out.set_item("d_variance", to_numpy(py, &bound.d_variance))?;
    out.set_item("d_inducing", to_numpy(py, &bound.d_inducing))?;
    let spaces = bound
        .spaces
        .iter()
        .map(|s| {
            let d = PyDict::new(py);
            d.set_item("variance", s.variance)?;
            d.set_item("lengthscale", s.lengthscale.clone())?;
            d.set_item("noise", s.noise)?;
            Ok(d)
        })
        .collect::<PyResult<Vec<_>>>()?;
    out.set_item("d_spaces", spaces)?;
    Ok(out)
}
