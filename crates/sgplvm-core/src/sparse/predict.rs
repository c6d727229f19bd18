//! Prediction caches of the sparse model: per space the M×D mean weights `w = L_m⁻ᵀ β / σ`
//! and the M×M matrix `C = L_m⁻ᵀ (I − B⁻¹) L_m⁻¹ = K_mm⁻¹ − (K_mm + σ⁻² K_mn K_nm)⁻¹`, so
//! that the mean is `k*ᵀ w` and the variance `α² − k*ᵀ C k*` (k* = k(Z, x*)). The Bayesian
//! model's are the same with `K_mn K_nm` replaced by Ψ₂ and `K_mn Y` by `Ψ₁ᵀ Y` (`bayesian`).

use faer::linalg::matmul::matmul;
use faer::linalg::triangular_solve::{
    solve_lower_triangular_in_place, solve_upper_triangular_in_place,
};
use faer::{Accum, Mat, Par};

use super::bayesian::{eval_bayes_space, Jitter};
use super::likelihood::{eval_sparse_space, RELATIVE_JITTER};
use super::SparseState;
use crate::error::Result;
use crate::kernel::row_major;
use crate::model::{SharedGplvm, Space};
use crate::predict::{
    add_kernel_weighted, check_prediction_matrix, for_each_kernel_block, half_inv_l2,
    scaled_about_mean, FrameKernel, Prediction,
};
use crate::simd::clear_upper_simd_state;

/// Prediction cache of one space of a sparse model.
#[derive(Clone, Debug)]
pub(crate) struct SparseCache {
    /// Mean weights row-major M×D.
    weights_rows: Vec<f64>,
    /// Z and the mean weights laid out for one frame at a time.
    frame: FrameKernel,
    /// `K_mm⁻¹ − (K_mm + σ⁻² K_mn K_nm)⁻¹` (M×M).
    cvar: Mat<f64>,
    /// −1/(2ℓ²) per latent dimension.
    half_inv_l2: Vec<f64>,
    /// Jitter beyond the constant relative one that K_mm needed.
    pub(crate) jitter: f64,
}

impl SparseCache {
    /// The cache of `space` at latent points `x_rows` and inducing inputs `z_rows`; with
    /// `var_rows` (q(X)'s variances) the Bayesian model's, `x_rows` then q(X)'s means.
    pub(crate) fn new(
        space: &Space,
        x_rows: &[f64],
        var_rows: Option<&[f64]>,
        z_rows: &[f64],
        q: usize,
    ) -> Result<Self> {
        if let Some(var_rows) = var_rows {
            return Self::bayesian(space, x_rows, var_rows, z_rows, q);
        }
        let e = eval_sparse_space(
            x_rows,
            z_rows,
            q,
            space.data.as_ref(),
            &space.kernel,
            RELATIVE_JITTER,
            false,
            None,
            None,
        )
        .map_err(|e| e.in_space(&space.name))?;
        let f = &e.factors;
        let m = f.lm.nrows();
        let sigma = space.kernel.noise.sqrt();
        let mut w = f.beta.clone();
        solve_upper_triangular_in_place(f.lm.transpose(), w.as_mut(), Par::Seq);
        w.col_iter_mut()
            .for_each(|c| c.iter_mut().for_each(|v| *v /= sigma));
        // I − B⁻¹, then L_m⁻ᵀ (·) L_m⁻¹.
        let mut binv = Mat::<f64>::identity(m, m);
        solve_lower_triangular_in_place(f.lb.as_ref(), binv.as_mut(), Par::Seq);
        solve_upper_triangular_in_place(f.lb.transpose(), binv.as_mut(), Par::Seq);
        let mut c = Mat::from_fn(m, m, |i, j| {
            (if i == j { 1.0 } else { 0.0 }) - 0.5 * (binv[(i, j)] + binv[(j, i)])
        });
        solve_upper_triangular_in_place(f.lm.transpose(), c.as_mut(), Par::Seq);
        let mut ct = c.transpose().to_owned();
        solve_upper_triangular_in_place(f.lm.transpose(), ct.as_mut(), Par::Seq);
        clear_upper_simd_state();
        let cvar = Mat::from_fn(m, m, |i, j| 0.5 * (ct[(i, j)] + ct[(j, i)]));
        let weights_rows = row_major(w.as_ref());
        Ok(Self {
            frame: FrameKernel::new(z_rows, q, &weights_rows, w.ncols()),
            weights_rows,
            cvar,
            half_inv_l2: half_inv_l2(&space.kernel),
            jitter: e.jitter,
        })
    }
}

impl SparseCache {
    /// The Bayesian model's cache: mean weights `β K̃⁻¹ Ψ₁ᵀ Y`, variance matrix
    /// `K_mm⁻¹ − (K_mm + β Ψ₂)⁻¹` (`bayesian`).
    fn bayesian(
        space: &Space,
        mean_rows: &[f64],
        var_rows: &[f64],
        z_rows: &[f64],
        q: usize,
    ) -> Result<Self> {
        let e = eval_bayes_space(
            mean_rows,
            var_rows,
            z_rows,
            q,
            space.data.as_ref(),
            &space.kernel,
            Jitter::Relative(RELATIVE_JITTER),
            false,
        )
        .map_err(|e| e.in_space(&space.name))?;
        let m = e.var_matrix.nrows();
        let cvar = Mat::from_fn(m, m, |i, j| {
            0.5 * (e.var_matrix[(i, j)] + e.var_matrix[(j, i)])
        });
        let weights_rows = row_major(e.mean_weights.as_ref());
        Ok(Self {
            frame: FrameKernel::new(z_rows, q, &weights_rows, e.mean_weights.ncols()),
            weights_rows,
            cvar,
            half_inv_l2: half_inv_l2(&space.kernel),
            jitter: e.extra_jitter,
        })
    }
}

impl SharedGplvm {
    /// Rebuilds the sparse caches (one per space); returns the largest extra jitter.
    pub(crate) fn rebuild_sparse(&mut self) -> Result<f64> {
        let q = self.q();
        let Some(st) = &self.sparse else {
            return Ok(0.0);
        };
        let caches = self
            .spaces
            .iter()
            .map(|s| {
                let var = st.latent_var.as_ref().map(|_| &st.var_rows[..]);
                SparseCache::new(s, &self.x_rows, var, &st.z_rows, q)
            })
            .collect::<Result<Vec<_>>>()?;
        let jitter = caches.iter().fold(0.0f64, |m, c| m.max(c.jitter));
        if let Some(st) = &mut self.sparse {
            st.caches = caches;
        }
        Ok(jitter)
    }

    /// Mean (preprocessed units) of space `si` at latent point `x`, added to `out` (zeroed by
    /// the caller). O(M(Q + D)), allocation-free.
    pub(crate) fn sparse_mean_into(
        st: &SparseState,
        si: usize,
        variance: f64,
        x: &[f64],
        out: &mut [f64],
    ) {
        let c = &st.caches[si];
        add_kernel_weighted(x, &c.frame, &c.half_inv_l2, variance, out);
    }

    /// Batch prediction of space `si` of a sparse model at latent points `xs` (n×Q).
    pub(crate) fn predict_sparse(
        &self,
        st: &SparseState,
        si: usize,
        xs: Mat<f64>,
        with_variance: bool,
    ) -> Result<Prediction> {
        let (n_new, q, m) = (xs.nrows(), self.q(), st.m());
        let s = &self.spaces[si];
        let c = &st.caches[si];
        let d = s.data.ncols();
        let alpha2 = s.kernel.variance;
        let (train, xsc) =
            scaled_about_mean(&st.z_rows, q, &c.half_inv_l2, n_new, |r, t| xs[(r, t)]);
        let w = Mat::from_fn(m, d, |i, t| c.weights_rows[i * d + t]);
        let mut mean = Mat::zeros(n_new, d);
        let mut variance = with_variance.then(|| Mat::zeros(n_new, d));
        let mut kc = Mat::zeros(
            if with_variance {
                crate::predict::BATCH.min(n_new)
            } else {
                0
            },
            m,
        );
        for_each_kernel_block(xsc.as_ref(), train.as_ref(), |r0, kb| {
            let rows = kb.nrows();
            matmul(
                mean.as_mut().subrows_mut(r0, rows),
                Accum::Replace,
                kb,
                w.as_ref(),
                alpha2,
                Par::Seq,
            );
            if let Some(var) = variance.as_mut() {
                let mut t = kc.as_mut().subrows_mut(0, rows);
                matmul(
                    t.as_mut(),
                    Accum::Replace,
                    kb,
                    c.cvar.as_ref(),
                    1.0,
                    Par::Seq,
                );
                clear_upper_simd_state();
                for f in 0..rows {
                    let explained: f64 =
                        (0..m).map(|i| t[(f, i)] * kb[(f, i)]).sum::<f64>() * alpha2 * alpha2;
                    let v = (alpha2 - explained).max(0.0);
                    for j in 0..d {
                        var[(r0 + f, j)] = v * s.scale[j] * s.scale[j];
                    }
                }
            }
        });
        clear_upper_simd_state();
        for j in 0..d {
            for r in 0..n_new {
                mean[(r, j)] = mean[(r, j)] * s.scale[j] + s.offset[j];
            }
        }
        check_prediction_matrix(&s.name, mean.as_ref())?;
        if let Some(v) = &variance {
            check_prediction_matrix(&s.name, v.as_ref())?;
        }
        Ok(Prediction {
            mean,
            variance,
            latent: xs,
        })
    }
}
