//! The human → latent mapping of models without input back constraints: a GP regression
//! (RBF-ARD over the human columns + noise) of the centred training latent points on the human
//! data, its hyperparameters trained by L-BFGS after the model (`TrainOptions::map_max_iters`).

use std::sync::Mutex;

use faer::Mat;

use crate::back_constraint::median_distance;
use crate::error::{Error, Result};
use crate::kernel::{row_major, KernelParams};
use crate::likelihood::{eval_space, SpaceWork};
use crate::model::SharedGplvm;
use crate::objective::{decode_kernel, encode_kernel, kernel_grad_log};
use crate::pool::{in_pool, lock, PARALLEL_FROM};
use crate::preprocess::mean_col_var;
use crate::train::{minimise, Control, Objective, TrainOptions};

/// GP regression human → latent (for `None` and `Output` back constraints).
#[derive(Clone, Debug)]
pub(crate) struct InputMap {
    pub kernel: KernelParams,
    pub x_mean: Vec<f64>,
}

/// GP regression objective (inputs fixed, one output block), θ = log kernel params.
pub(crate) struct MapObjective {
    h_rows: Vec<f64>,
    dh: usize,
    y: Mat<f64>,
    work: Mutex<SpaceWork>,
}

impl Objective for MapObjective {
    fn eval(&self, theta: &[f64], grad: &mut [f64]) -> Result<f64> {
        if self.y.nrows() >= PARALLEL_FROM {
            in_pool(|| self.eval_here(theta, grad))
        } else {
            self.eval_here(theta, grad)
        }
    }
}

impl MapObjective {
    /// [`Objective::eval`] on the calling thread.
    pub(crate) fn eval_here(&self, theta: &[f64], grad: &mut [f64]) -> Result<f64> {
        let k = decode_kernel(theta, self.dh);
        if !k.is_valid() {
            return Err(Error::InvalidValue {
                what: "input map kernel".into(),
                reason: "overflow".into(),
            });
        }
        let mut w = lock(&self.work);
        let e = eval_space(
            &self.h_rows,
            self.dh,
            self.y.as_ref(),
            &k,
            &mut w,
            true,
            None,
        )
        .map_err(|e| e.in_space("input map"))?;
        kernel_grad_log(&k, &e, grad);
        Ok(e.nll)
    }
}

impl SharedGplvm {
    /// Fits the GP regression human → latent (targets: X minus its mean).
    pub(crate) fn fit_map(
        &mut self,
        options: &TrainOptions,
        warm: Option<KernelParams>,
    ) -> Result<()> {
        let h = self.spaces[0].data.as_ref();
        let (n, dh, q) = (self.n(), h.ncols(), self.q());
        let x_mean: Vec<f64> = (0..q)
            .map(|j| (0..n).map(|i| self.x[(i, j)]).sum::<f64>() / n as f64)
            .collect();
        let y = Mat::from_fn(n, q, |i, j| self.x[(i, j)] - x_mean[j]);
        let kernel0 = match warm {
            Some(k) if k.lengthscale.len() == dh && k.is_valid() => k,
            _ => {
                let v = mean_col_var(y.as_ref());
                KernelParams {
                    variance: v,
                    lengthscale: vec![median_distance(h); dh],
                    noise: 0.01 * v,
                }
            }
        };
        let obj = MapObjective {
            h_rows: row_major(h),
            dh,
            y: y.clone(),
            work: Mutex::new(SpaceWork::new(n, q)),
        };
        let mut theta0 = Vec::new();
        encode_kernel(&kernel0, &mut theta0);
        let opts = TrainOptions {
            max_iters: options.map_max_iters,
            ..options.clone()
        };
        let out = minimise(&obj, theta0, 1.0 / (n * q) as f64, &opts, |_, _| {
            Control::Continue
        })?;
        self.map = Some(InputMap {
            kernel: decode_kernel(&out.theta, dh),
            x_mean,
        });
        Ok(())
    }
}
