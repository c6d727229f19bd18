//! Prediction: human frame h → latent point x → robot joints r.
//! `x = k_bc(h, H) W` (input back constraints) or the input map's GP mean; then the robot's
//! posterior mean `r = k(x, X) K⁻¹ Y` and variance `k(x, x) − k(x, X) K⁻¹ k(X, x)`, in original
//! units. Single frames allocation-free; batches by blocked matrix products. The kernel sums
//! themselves are in `kernel_sums`; this file holds the caches and the prediction paths.

use faer::reborrow::ReborrowMut;
use faer::{Accum, Mat, MatRef, Par};

use rayon::prelude::*;
use std::sync::OnceLock;

use crate::config::BackConstraint;
use crate::error::{check_buffer, Error, Result};
use crate::input_map::InputMap;
use crate::kernel::{row_major, KernelParams};
use crate::likelihood::{eval_space, SpaceWork, Wanted};
use crate::model::{Latent, SharedGplvm, Space};
use crate::pool::{in_pool, par_for};
use crate::preprocess::check_finite;
use crate::simd::clear_upper_simd_state;
use crate::train::{Limits, TrainOptions};

mod kernel_sums;

pub(crate) use kernel_sums::{
    add_kernel_weighted, for_each_kernel_block, scaled_about_mean, FrameKernel,
};

/// Frames per block in the batch paths ([`SharedGplvm::latent`], [`SharedGplvm::predict`]).
pub(crate) const BATCH: usize = 256;

/// Frames per parallel task of [`SharedGplvm::predict`], a multiple of [`BATCH`].
pub(crate) const PARALLEL_CHUNK: usize = 4 * BATCH;

/// Result of [`SharedGplvm::predict`].
#[derive(Clone, Debug, PartialEq)]
pub struct Prediction {
    /// Posterior mean in the space's original units (offsets and scales undone), n×D.
    pub mean: Mat<f64>,
    /// Posterior variance of the latent function `k** − kᵀK⁻¹k` in original units (×scale²),
    /// n×D, identical across the columns of a space; add the space's `noise` (× scale²) for
    /// GPy's `include_likelihood=True` semantics. Uncertainty of the latent point is not
    /// propagated.
    pub variance: Option<Mat<f64>>,
    /// The frames' latent points, n×Q (what [`SharedGplvm::latent`] gives for them).
    pub latent: Mat<f64>,
}

/// Prediction caches of one space.
#[derive(Clone, Debug)]
pub(crate) struct SpaceCache {
    /// K⁻¹Y, N×D.
    alpha: Mat<f64>,
    /// The training latent points and K⁻¹Y laid out for one frame at a time.
    pub(crate) frame: FrameKernel,
    /// Cholesky factor of K (lower).
    factor: Mat<f64>,
    /// −1/(2 l²) per latent dimension.
    half_inv_l2: Vec<f64>,
    pub(crate) jitter: f64,
    /// The space's negative log marginal likelihood at these parameters (what
    /// `Space::factorise` returns; reused as a transfer's frozen constant).
    pub(crate) nll: f64,
}

/// Caches of the human → latent step.
#[derive(Clone, Debug)]
pub(crate) struct LatentCache {
    /// Training inputs of the mapping (centred/scaled H) row-major N×D_H.
    h_rows: Vec<f64>,
    /// Weights N×Q (W, or K⁻¹(X − mean) for the regression).
    weights: Mat<f64>,
    /// −1/(2 l²) per input dimension.
    half_inv_l2: Vec<f64>,
    /// `h_rows` and `weights` laid out for one frame at a time.
    frame: FrameKernel,
    /// Kernel amplitude (1 for back constraints).
    amplitude: f64,
    /// Added to every latent point.
    offset: Vec<f64>,
}

impl LatentCache {
    fn new(
        h_rows: Vec<f64>,
        weights: Vec<f64>,
        half_inv_l2: Vec<f64>,
        amplitude: f64,
        offset: Vec<f64>,
    ) -> Self {
        let q = offset.len();
        let frame = FrameKernel::new(&h_rows, half_inv_l2.len(), &weights, q);
        let n = weights.len() / q.max(1);
        Self {
            h_rows,
            weights: Mat::from_fn(n, q, |i, t| weights[i * q + t]),
            frame,
            half_inv_l2,
            amplitude,
            offset,
        }
    }
}

impl SpaceCache {
    /// The caches of `space` at latent points `x_rows` (row-major, `q` columns): one
    /// factorisation of its kernel matrix.
    fn new(space: &Space, x_rows: &[f64], q: usize) -> Result<Self> {
        let mut w = SpaceWork::new(x_rows.len() / q, space.data.ncols());
        let e = space.factorise(x_rows, q, &mut w)?;
        Ok(SpaceCache {
            frame: FrameKernel::new(x_rows, q, &row_major(w.alpha()), space.data.ncols()),
            alpha: w.alpha().to_owned(),
            factor: w.factor().to_owned(),
            half_inv_l2: half_inv_l2(&space.kernel),
            jitter: e.jitter,
            nll: e.nll,
        })
    }
}

/// `−1/(2ℓ²)` per lengthscale of `kernel`.
pub(crate) fn half_inv_l2(kernel: &KernelParams) -> Vec<f64> {
    kernel.lengthscale.iter().map(|l| -0.5 / (l * l)).collect()
}

/// Everything prediction needs that is derived from the parameters: one cache per space, the
/// human → latent cache and, after `set_params`, the input map refitted to the new latent
/// points.
#[derive(Clone, Debug)]
pub(crate) struct Prepared {
    pub(crate) caches: Vec<SpaceCache>,
    pub(crate) latent_cache: LatentCache,
    /// Largest jitter the spaces' factorisations needed.
    pub(crate) training_jitter: f64,
    /// The refitted input map when the stored one was stale (`map_stale`), else `None`.
    pub(crate) map: Option<InputMap>,
}

impl SharedGplvm {
    /// Recomputes every prediction cache from the stored parameters now (after training and on
    /// load, so that errors surface there and a loaded model predicts bit-identically).
    pub(crate) fn rebuild(&mut self) -> Result<()> {
        self.update_latent_points();
        if self.sparse.is_some() {
            let training_jitter = self.rebuild_sparse()?;
            let latent_cache = self.new_latent_cache(self.map.as_ref())?;
            self.prepared = OnceLock::from(Prepared {
                caches: Vec::new(),
                latent_cache,
                training_jitter,
                map: None,
            });
            return Ok(());
        }
        let prepared = self.build_prepared()?;
        self.prepared = OnceLock::from(prepared);
        Ok(())
    }

    /// [`SharedGplvm::rebuild`] after training that changed only the kernels of the spaces
    /// `changed` (a transfer): the latent points, the input map and every other space's cache
    /// are kept from the caches the model already has (the source model's, for a transfer),
    /// so only the changed spaces are factorised. The same caches as `rebuild`, bit for bit
    /// (each is the same computation on the same parameters); `rebuild` itself when the model
    /// has no caches to keep.
    pub(crate) fn rebuild_kernels(&mut self, changed: &[usize]) -> Result<()> {
        if self.sparse.is_some() || self.map_stale {
            return self.rebuild();
        }
        let Some(old) = self.prepared.take() else {
            return self.rebuild();
        };
        let mut kept = old.caches.into_iter().map(Some).collect::<Vec<_>>();
        let caches = self
            .spaces
            .iter()
            .enumerate()
            .map(|(s, space)| match kept.get_mut(s).and_then(Option::take) {
                Some(c) if !changed.contains(&s) => Ok(c),
                _ => SpaceCache::new(space, &self.x_rows, self.q()),
            })
            .collect::<Result<Vec<_>>>()?;
        self.prepared = OnceLock::from(Prepared {
            training_jitter: caches.iter().fold(0.0, |m, c| m.max(c.jitter)),
            caches,
            latent_cache: old.latent_cache,
            map: old.map,
        });
        Ok(())
    }

    /// The prediction caches, built on first use after `set_params`.
    pub(crate) fn prepared(&self) -> Result<&Prepared> {
        if let Some(p) = self.prepared.get() {
            return Ok(p);
        }
        let p = self.build_prepared()?;
        // Two threads racing here build the same caches (deterministic); one is kept.
        Ok(self.prepared.get_or_init(|| p))
    }

    /// The input map at the current latent points: the stored one, or after `set_params` the
    /// one refitted (warm-started from it, default options) on first use.
    pub(crate) fn current_map(&self) -> Result<Option<&InputMap>> {
        if self.map_stale {
            Ok(self.prepared()?.map.as_ref())
        } else {
            Ok(self.map.as_ref())
        }
    }

    fn build_prepared(&self) -> Result<Prepared> {
        let refitted = if self.map_stale && self.needs_map() {
            let warm = self.map.as_ref().map(|m| m.kernel.clone());
            Some(self.fitted_map(&TrainOptions::default(), &Limits::default(), warm)?)
        } else {
            None
        };
        let map = if self.map_stale {
            refitted.as_ref()
        } else {
            self.map.as_ref()
        };
        let caches = self
            .spaces
            .iter()
            .map(|s| SpaceCache::new(s, &self.x_rows, self.q()))
            .collect::<Result<Vec<_>>>()?;
        let latent_cache = self.new_latent_cache(map)?;
        Ok(Prepared {
            training_jitter: caches.iter().fold(0.0, |m, c| m.max(c.jitter)),
            caches,
            latent_cache,
            map: refitted,
        })
    }

    /// The human → latent cache: the back-constraint mapping `x = k_bc(h, H) W` for input back
    /// constraints, else the input map's GP mean `x = x̄ + α² k(h, H) K⁻¹ (X − x̄)`.
    fn new_latent_cache(&self, map: Option<&InputMap>) -> Result<LatentCache> {
        let q = self.q();
        let h = self.spaces[0].data.as_ref();
        match (&self.latent, map) {
            (
                Latent::Back {
                    weights,
                    bandwidth,
                    data,
                },
                _,
            ) if self.config.back_constraint == BackConstraint::Input => Ok(LatentCache::new(
                // The constrained data: every training frame, or a sparse model's centres.
                row_major(data.as_ref()),
                row_major(weights.as_ref()),
                vec![-0.5 / (bandwidth * bandwidth); h.ncols()],
                1.0,
                vec![0.0; q],
            )),
            (_, Some(map)) => {
                let (h, x) = self.map_pairs();
                let h = h.as_ref();
                let n = h.nrows();
                let y = Mat::from_fn(n, q, |i, j| x[(i, j)] - map.x_mean[j]);
                let mut w = SpaceWork::new(n, q);
                let hr = row_major(h);
                eval_space(
                    &hr,
                    h.ncols(),
                    y.as_ref(),
                    &map.kernel,
                    &mut w,
                    1,
                    Wanted::Objective,
                )
                .map_err(|e| e.in_space("input map"))?;
                Ok(LatentCache::new(
                    hr,
                    row_major(w.alpha()),
                    half_inv_l2(&map.kernel),
                    map.kernel.variance,
                    map.x_mean.clone(),
                ))
            }
            _ => Err(Error::Corrupt {
                reason: "model without input back constraint has no input map".into(),
            }),
        }
    }

    pub(crate) fn output_index(&self, space: &str) -> Result<usize> {
        match self.spaces.iter().position(|s| s.name == space) {
            Some(i) if i > 0 => Ok(i),
            _ => Err(Error::NotAnOutput {
                name: space.into(),
                known: self.output_names().iter().map(|s| s.to_string()).collect(),
            }),
        }
    }

    pub(crate) fn check_input_row(&self, h: &[f64]) -> Result<()> {
        let dh = self.spaces[0].data.ncols();
        if h.len() != dh {
            return Err(Error::DimensionMismatch {
                what: format!("input frame for '{}'", self.spaces[0].name),
                expected: dh,
                found: h.len(),
            });
        }
        for (c, &v) in h.iter().enumerate() {
            if !v.is_finite() {
                return Err(Error::NonFinite {
                    space: self.spaces[0].name.clone(),
                    row: 0,
                    col: c,
                    value: v,
                });
            }
        }
        Ok(())
    }

    /// Latent point of one raw input frame into `x` (length Q). Allocation-free for
    /// D_H ≤ 64: training points are processed in blocks of [`FRAME_BLOCK`] (distances, then a
    /// vectorised exp, then the weighted sum).
    pub(crate) fn latent_into(&self, h: &[f64], x: &mut [f64]) -> Result<()> {
        let lc = &self.prepared()?.latent_cache;
        clear_upper_simd_state();
        let s0 = &self.spaces[0];
        let dh = h.len();
        let mut hs_stack = [0.0f64; 64];
        let mut hs_heap;
        let hs: &mut [f64] = if dh <= 64 {
            &mut hs_stack[..dh]
        } else {
            hs_heap = vec![0.0; dh];
            &mut hs_heap
        };
        for t in 0..dh {
            hs[t] = (h[t] - s0.offset[t]) / s0.scale[t];
        }
        x.copy_from_slice(&lc.offset);
        add_kernel_weighted(hs, &lc.frame, &lc.half_inv_l2, lc.amplitude, x);
        Ok(())
    }

    /// Mean (original units) of space `si` at latent point `x` into `out`. Allocation-free.
    pub(crate) fn mean_into(&self, si: usize, x: &[f64], out: &mut [f64]) -> Result<()> {
        let s = &self.spaces[si];
        let d = out.len();
        out.iter_mut().for_each(|v| *v = 0.0);
        if let Some(st) = &self.sparse {
            Self::sparse_mean_into(st, si, s.kernel.variance, x, out);
            for t in 0..d {
                out[t] = out[t] * s.scale[t] + s.offset[t];
            }
            return Ok(());
        }
        let c = &self.prepared()?.caches[si];
        add_kernel_weighted(x, &c.frame, &c.half_inv_l2, s.kernel.variance, out);
        for t in 0..d {
            out[t] = out[t] * s.scale[t] + s.offset[t];
        }
        Ok(())
    }

    /// Posterior mean of robot `space` for one raw human frame `h`, written to `out` (length
    /// D of the space). Costs O(N(D_H + Q + D)); allocates nothing for Q ≤ 32 and D_H ≤ 64.
    pub fn predict_frame(&self, h: &[f64], space: &str, out: &mut [f64]) -> Result<()> {
        self.check_input_row(h)?;
        let si = self.output_index(space)?;
        let d = self.spaces[si].data.ncols();
        check_buffer("output", space, d, out.len())?;
        let q = self.q();
        let mut stack = [0.0f64; 32];
        let mut heap;
        let x: &mut [f64] = if q <= 32 {
            &mut stack[..q]
        } else {
            heap = vec![0.0; q];
            &mut heap
        };
        self.latent_into(h, x)?;
        self.mean_into(si, x, out)?;
        check_prediction(space, 0, out)
    }

    pub(crate) fn check_input_matrix(&self, h: MatRef<'_, f64>) -> Result<()> {
        let dh = self.spaces[0].data.ncols();
        if h.ncols() != dh {
            return Err(Error::DimensionMismatch {
                what: format!("input columns for '{}'", self.spaces[0].name),
                expected: dh,
                found: h.ncols(),
            });
        }
        check_finite(&self.spaces[0].name, h)
    }

    /// Latent points of raw human frames (rows of `h`), n×Q. Frames are processed in blocks
    /// of 256 with matrix products.
    pub fn latent(&self, h: MatRef<'_, f64>) -> Result<Mat<f64>> {
        self.check_input_matrix(h)?;
        self.latent_batch(h)
    }

    /// [`SharedGplvm::latent`] without the input checks (the output is checked).
    pub(crate) fn latent_batch(&self, h: MatRef<'_, f64>) -> Result<Mat<f64>> {
        let lc = &self.prepared()?.latent_cache;
        let s0 = &self.spaces[0];
        let (dh, q, m_all) = (h.ncols(), self.q(), h.nrows());
        let (train, hs) = scaled_about_mean(&lc.h_rows, dh, &lc.half_inv_l2, m_all, |r, t| {
            (h[(r, t)] - s0.offset[t]) / s0.scale[t]
        });
        let mut out = Mat::from_fn(m_all, q, |_, t| lc.offset[t]);
        for_each_kernel_block(hs.as_ref(), train.as_ref(), |r0, kb| {
            faer::linalg::matmul::matmul(
                out.as_mut().subrows_mut(r0, kb.nrows()),
                Accum::Add,
                kb,
                lc.weights.as_ref(),
                lc.amplitude,
                Par::Seq,
            );
        });
        check_prediction_matrix("latent", out.as_ref())?;
        Ok(out)
    }

    /// Posterior mean (and optionally variance, see [`Prediction`]) of robot `space` for the
    /// raw human frames in the rows of `h`. Frames go in blocks of 256: kernel blocks
    /// from matrix products, the mean as `K* (K⁻¹Y)`, the variance as
    /// `k** − |L⁻¹k*|²` with one multi-right-hand-side triangular solve per block. From
    /// 2,048 frames, chunks of 1,024 frames run on the pool's threads (the same blocks as on
    /// one thread: the same results).
    pub fn predict(
        &self,
        h: MatRef<'_, f64>,
        space: &str,
        with_variance: bool,
    ) -> Result<Prediction> {
        self.check_input_matrix(h)?;
        let si = self.output_index(space)?;
        let n_new = h.nrows();
        if n_new < 2 * PARALLEL_CHUNK {
            return self.predict_rows(h, si, with_variance);
        }
        let starts: Vec<usize> = (0..n_new).step_by(PARALLEL_CHUNK).collect();
        let parts: Result<Vec<Prediction>> = in_pool(|| {
            starts
                .par_iter()
                .map(|&r0| {
                    let rows = PARALLEL_CHUNK.min(n_new - r0);
                    self.predict_rows(h.subrows(r0, rows), si, with_variance)
                })
                .collect()
        });
        let Ok(parts) = parts else {
            // The error the whole matrix gives (its first bad frame, numbered in it).
            return self.predict_rows(h, si, with_variance);
        };
        let d = self.spaces[si].data.ncols();
        let mut mean = Mat::zeros(n_new, d);
        let mut variance = with_variance.then(|| Mat::zeros(n_new, d));
        let mut latent = Mat::zeros(n_new, self.q());
        for (p, &r0) in parts.iter().zip(&starts) {
            let rows = p.mean.nrows();
            mean.as_mut().subrows_mut(r0, rows).copy_from(&p.mean);
            latent.as_mut().subrows_mut(r0, rows).copy_from(&p.latent);
            if let (Some(v), Some(pv)) = (variance.as_mut(), p.variance.as_ref()) {
                v.as_mut().subrows_mut(r0, rows).copy_from(pv);
            }
        }
        Ok(Prediction {
            mean,
            variance,
            latent,
        })
    }

    /// [`SharedGplvm::predict`] of output space `si` on one thread, inputs checked.
    pub(crate) fn predict_rows(
        &self,
        h: MatRef<'_, f64>,
        si: usize,
        with_variance: bool,
    ) -> Result<Prediction> {
        let xs = self.latent_batch(h)?;
        self.predict_latent_rows(xs, si, with_variance)
    }

    /// [`SharedGplvm::predict_rows`] from the latent points `xs` (one row per frame).
    pub(crate) fn predict_latent_rows(
        &self,
        xs: Mat<f64>,
        si: usize,
        with_variance: bool,
    ) -> Result<Prediction> {
        let space = self.spaces[si].name.as_str();
        if let Some(st) = &self.sparse {
            return self.predict_sparse(st, si, xs, with_variance);
        }
        let (n_new, q, n) = (xs.nrows(), self.q(), self.n());
        let s = &self.spaces[si];
        let c = &self.prepared()?.caches[si];
        let d = s.data.ncols();
        let (train, xsc) =
            scaled_about_mean(&self.x_rows, q, &c.half_inv_l2, n_new, |r, t| xs[(r, t)]);
        let mut mean = Mat::zeros(n_new, d);
        let mut variance = if with_variance {
            Some(Mat::zeros(n_new, d))
        } else {
            None
        };
        let mut kt = Mat::zeros(if with_variance { n } else { 0 }, BATCH.min(n_new));
        for_each_kernel_block(xsc.as_ref(), train.as_ref(), |r0, kb| {
            let m = kb.nrows();
            faer::linalg::matmul::matmul(
                mean.as_mut().subrows_mut(r0, m),
                Accum::Replace,
                kb,
                c.alpha.as_ref(),
                s.kernel.variance,
                Par::Seq,
            );
            if let Some(var) = variance.as_mut() {
                let mut ks = kt.as_mut().subcols_mut(0, m);
                ks.copy_from(kb.transpose());
                faer::linalg::triangular_solve::solve_lower_triangular_in_place(
                    c.factor.as_ref(),
                    ks.rb_mut(),
                    par_for(n),
                );
                clear_upper_simd_state();
                for f in 0..m {
                    let explained: f64 = (0..n).map(|i| ks[(i, f)] * ks[(i, f)]).sum::<f64>()
                        * s.kernel.variance
                        * s.kernel.variance;
                    let v = (s.kernel.variance - explained).max(0.0);
                    for t in 0..d {
                        var[(r0 + f, t)] = v * s.scale[t] * s.scale[t];
                    }
                }
            }
        });
        for t in 0..d {
            for r in 0..n_new {
                mean[(r, t)] = mean[(r, t)] * s.scale[t] + s.offset[t];
            }
        }
        check_prediction_matrix(space, mean.as_ref())?;
        if let Some(v) = &variance {
            check_prediction_matrix(space, v.as_ref())?;
        }
        Ok(Prediction {
            mean,
            variance,
            latent: xs,
        })
    }
}

/// [`Error::NonFinitePrediction`] for the first non-finite value of one predicted frame.
fn check_prediction(space: &str, row: usize, values: &[f64]) -> Result<()> {
    match values.iter().position(|v| !v.is_finite()) {
        None => Ok(()),
        Some(col) => Err(Error::NonFinitePrediction {
            space: space.into(),
            row,
            col,
            value: values[col],
        }),
    }
}

/// [`check_prediction`] for every frame (row) of `m`.
pub(crate) fn check_prediction_matrix(space: &str, m: MatRef<'_, f64>) -> Result<()> {
    for j in 0..m.ncols() {
        if let Some(row) = (0..m.nrows()).find(|&i| !m[(i, j)].is_finite()) {
            return Err(Error::NonFinitePrediction {
                space: space.into(),
                row,
                col: j,
                value: m[(row, j)],
            });
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_support::*;

    /// A model whose parameters overflow in prediction is refused with a typed error, on every
    /// path, instead of handing NaN or infinity on as joint commands.
    #[test]
    fn non_finite_predictions_are_an_error() {
        let (h, _, _, _) = demo(30, 2);
        let mut m = fit(BackConstraint::Input, 30, 5, 0);
        let cache = &mut m.prepared.get_mut().expect("caches").caches[1];
        cache.alpha[(0, 3)] = f64::INFINITY;
        cache.frame.set_weight(0, 3, f64::INFINITY);
        let is_refused = |r: Result<()>| matches!(r, Err(Error::NonFinitePrediction { ref space, .. }) if space == "walkman");
        assert!(is_refused(
            m.predict(h.as_ref(), "walkman", false).map(|_| ())
        ));
        let mut out = vec![0.0; 4];
        assert!(is_refused(m.predict_frame(
            &h.as_ref().row(0).iter().copied().collect::<Vec<_>>(),
            "walkman",
            &mut out
        )));
        let mut m = fit(BackConstraint::Input, 30, 5, 0);
        m.prepared.get_mut().expect("caches").latent_cache.weights[(0, 0)] = f64::NAN;
        let err = m.latent(h.as_ref()).expect_err("NaN latent points");
        assert!(err.to_string().contains("prediction for 'latent'"), "{err}");
    }

    #[test]
    fn prediction_paths_agree_and_variance_matches_dense_formula() {
        let (mut worst_mean, mut worst_var) = (0.0f64, 0.0f64);
        for (bc, scale) in [
            (BackConstraint::Input, false),
            (BackConstraint::Output, false),
            (BackConstraint::Input, true),
            (BackConstraint::Output, true),
        ] {
            let (h0, r1, _, _) = demo(30, 7);
            let config = ModelConfig::default()
                .with_latent_dim(2)
                .with_back_constraint(bc)
                .with_scale(scale);
            let spaces = [("human", h0.as_ref()), ("walkman", r1.as_ref())];
            let m = SharedGplvm::fit(&config, &spaces, "human", &quick(15), None).expect("fit");
            let s = &m.spaces[1];
            if scale {
                // Per-column scales that differ from 1 and from each other, so that a missing
                // or single scale factor shows.
                assert!(
                    s.scale.iter().all(|&c| (c - 1.0).abs() > 0.05),
                    "{:?}",
                    s.scale
                );
            }
            let (h, _, _, _) = demo(30, 9);
            let p = m.predict(h.as_ref(), "walkman", true).expect("predict");
            let variance = p.variance.as_ref().expect("variance");
            let mut out = vec![0.0; 4];
            let mut row = vec![0.0; 6];
            let lat = m.latent(h.as_ref()).expect("latent");
            // Dense reference from the public latent points: K = k(X, X) + σ² I inverted by LLᵀ,
            // mean = k*ᵀ K⁻¹ Y · scale + offset, var = (k** − k*ᵀ K⁻¹ k*) · scale².
            let x = m.latent_points();
            let n = m.n();
            let kx = |a: &[f64], b: &[f64]| {
                let r2: f64 = (0..2)
                    .map(|t| (a[t] - b[t]).powi(2) / s.kernel.lengthscale[t].powi(2))
                    .sum();
                s.kernel.variance * (-0.5 * r2).exp()
            };
            let xi = |i: usize| [x[(i, 0)], x[(i, 1)]];
            let kmat = Mat::from_fn(n, n, |i, j| {
                kx(&xi(i), &xi(j)) + if i == j { s.kernel.noise } else { 0.0 }
            });
            let kinv = {
                use faer::linalg::solvers::DenseSolveCore;
                kmat.llt(faer::Side::Lower).expect("pd").inverse()
            };
            for r in [0, 11, 29] {
                for c in 0..6 {
                    row[c] = h[(r, c)];
                }
                m.predict_frame(&row, "walkman", &mut out).expect("frame");
                // The batch path sums in another order (blocked matrix products).
                for c in 0..4 {
                    let diff = (out[c] - p.mean[(r, c)]).abs();
                    assert!(diff <= 1e-12 * out[c].abs().max(1.0), "{diff:e}");
                }
                let xs = [lat[(r, 0)], lat[(r, 1)]];
                let kstar = Mat::from_fn(n, 1, |i, _| kx(&xs, &xi(i)));
                let mean = kstar.transpose() * &kinv * &s.data;
                let var = s.kernel.variance - (kstar.transpose() * &kinv * &kstar)[(0, 0)];
                for c in 0..4 {
                    let want = mean[(0, c)] * s.scale[c] + s.offset[c];
                    worst_mean = worst_mean.max((want - out[c]).abs() / want.abs().max(1.0));
                    // Relative to the prior variance α²·scale²: the posterior variance is a
                    // difference of numbers of that size.
                    let s2 = s.scale[c] * s.scale[c];
                    let want = var * s2;
                    let err = (variance[(r, c)] - want).abs() / (s.kernel.variance * s2);
                    worst_var = worst_var.max(err);
                }
            }
            // Training frames are reproduced well.
            let p = m.predict(h0.as_ref(), "walkman", true).expect("predict");
            let mse: f64 = (0..30)
                .flat_map(|i| (0..4).map(move |j| (i, j)))
                .map(|(i, j)| (p.mean[(i, j)] - r1[(i, j)]).powi(2))
                .sum::<f64>()
                / 120.0;
            assert!(mse < 0.05, "{bc:?} scale {scale} mse {mse}");
        }
        // Measured 2.5e-13 (mean, relative) and 1.9e-13 (variance, relative to α²·scale²).
        assert!(worst_mean < 3e-12, "mean off by {worst_mean:e} (relative)");
        assert!(
            worst_var < 2e-12,
            "variance off by {worst_var:e} (relative)"
        );
    }

    #[test]
    fn batch_prediction_matches_the_per_frame_path() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
        for bc in [BackConstraint::Input, BackConstraint::None] {
            let m = fit(bc, 40, 20, 0);
            // 300 random frames (more than one block of 256), around and beyond the data.
            let (h, _, _, _) = demo(40, 7);
            let hn = Mat::from_fn(300, h.ncols(), |r, c| {
                h[(r % 40, c)] + rng.random_range(-0.5..0.5)
            });
            // Norm-wise relative: differences over the largest magnitude of the quantity (the
            // summation order differs, and the sums over weights of both signs cancel).
            let rel = |a: f64, b: f64, scale: f64| (a - b).abs() / scale;
            let lat = m.latent(hn.as_ref()).expect("latent");
            let amax = |a: &Mat<f64>| {
                (0..a.nrows())
                    .flat_map(|r| (0..a.ncols()).map(move |c| (r, c)))
                    .map(|(r, c)| a[(r, c)].abs())
                    .fold(0.0f64, f64::max)
            };
            let lscale = amax(&lat);
            for with_var in [false, true] {
                let p = m
                    .predict(hn.as_ref(), "walkman", with_var)
                    .expect("predict");
                let mut out = vec![0.0; p.mean.ncols()];
                let mut row = vec![0.0; hn.ncols()];
                let mut worst: f64 = 0.0;
                let mscale = amax(&p.mean);
                for r in 0..300 {
                    for (c, v) in row.iter_mut().enumerate() {
                        *v = hn[(r, c)];
                    }
                    m.predict_frame(&row, "walkman", &mut out).expect("frame");
                    for (t, &o) in out.iter().enumerate() {
                        worst = worst.max(rel(p.mean[(r, t)], o, mscale));
                    }
                    let mut x = vec![0.0; m.latent_points().ncols()];
                    m.latent_into(&row, &mut x).expect("latent_into");
                    for (t, &xv) in x.iter().enumerate() {
                        worst = worst.max(rel(lat[(r, t)], xv, lscale));
                    }
                }
                assert!(
                    worst < 1e-12,
                    "{bc:?} var={with_var}: worst rel diff {worst:e}"
                );
                assert_eq!(p.variance.is_some(), with_var);
            }
            // Variances of the blocked path are finite and non-negative everywhere.
            let p = m.predict(hn.as_ref(), "walkman", true).expect("predict");
            let v = p.variance.expect("variance");
            assert!((0..300).all(|r| v[(r, 0)] >= 0.0 && v[(r, 0)].is_finite()));
        }
    }
}
