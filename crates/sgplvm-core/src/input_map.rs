//! The human → latent mapping of models without input back constraints: a GP regression
//! (see `regression`) of the centred training latent points on the human data, its
//! hyperparameters trained by L-BFGS after the model (`TrainOptions::map_max_iters`).

use faer::Mat;

use crate::error::Result;
use crate::kernel::KernelParams;
use crate::model::SharedGplvm;
use crate::regression::{fit_kernel, starting_kernel};
use crate::train::{Control, Limits, TrainOptions};

/// GP regression human → latent (for `None` and `Output` back constraints).
#[derive(Clone, Debug)]
pub(crate) struct InputMap {
    pub kernel: KernelParams,
    pub x_mean: Vec<f64>,
}

impl SharedGplvm {
    /// Fits the GP regression human → latent (targets: X minus its mean) within `limits` and
    /// stores it.
    pub(crate) fn fit_map(
        &mut self,
        options: &TrainOptions,
        limits: &Limits,
        warm: Option<KernelParams>,
    ) -> Result<()> {
        self.map = Some(self.fitted_map(options, limits, warm)?);
        self.map_stale = false;
        Ok(())
    }

    /// The GP regression human → latent at the current latent points (see [`Self::fit_map`]).
    pub(crate) fn fitted_map(
        &self,
        options: &TrainOptions,
        limits: &Limits,
        warm: Option<KernelParams>,
    ) -> Result<InputMap> {
        // Every training frame, or a sparse model's spread subset of them.
        let (h, x) = self.map_pairs();
        let h = h.as_ref();
        let (n, dh, q) = (h.nrows(), h.ncols(), self.q());
        let x_mean: Vec<f64> = (0..q)
            .map(|j| (0..n).map(|i| x[(i, j)]).sum::<f64>() / n as f64)
            .collect();
        let y = Mat::from_fn(n, q, |i, j| x[(i, j)] - x_mean[j]);
        let start = match warm {
            Some(k) if k.lengthscale.len() == dh && k.is_valid() => k,
            _ => starting_kernel(h, y.as_ref()),
        };
        let opts = TrainOptions {
            max_iters: options.map_max_iters,
            ..options.clone()
        };
        let kernel = fit_kernel(h, y.as_ref(), start, &opts, limits, "input map", |_, _| {
            Control::Continue
        })?;
        Ok(InputMap { kernel, x_mean })
    }
}
