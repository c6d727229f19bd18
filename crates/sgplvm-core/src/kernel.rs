//! The RBF-ARD kernel of one observation space, in GPy's parametrisation:
//! `k(x, x') = α² exp(−½ Σ_q (x_q − x'_q)² / ℓ_q²)`, plus `σ² I` on the training diagonal
//! (GPy's `RBF(Q, ARD=True)` with a Gaussian likelihood).
//!
//! Kernel matrices between training points ([`rbf_lower`], lower triangle only) and between two
//! sets of points ([`rbf_block`], by one matrix product) are built here; what is done with them
//! lives in `likelihood` (training) and `predict` (prediction).

use faer::reborrow::ReborrowMut;
use faer::{Accum, Mat, MatRef, Par};
use serde::{Deserialize, Serialize};

use crate::simd::{clear_upper_simd_state, exp_neg, exp_neg_slice, vectorized};

/// Hyperparameters of one space's kernel, in GPy's natural parametrisation.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct KernelParams {
    /// Signal variance α² of the RBF part (GPy `rbf.variance`).
    pub variance: f64,
    /// One lengthscale per latent dimension (GPy `rbf.lengthscale`, ARD).
    pub lengthscale: Vec<f64>,
    /// Gaussian noise variance σ² (GPy `Gaussian_noise.variance`).
    pub noise: f64,
}

impl KernelParams {
    /// True when every value is finite and strictly positive.
    pub(crate) fn is_valid(&self) -> bool {
        let ok = |v: f64| v.is_finite() && v > 0.0;
        ok(self.variance) && ok(self.noise) && self.lengthscale.iter().all(|&l| ok(l))
    }
}

/// Row-major copy of a matrix: row `i` is `out[i*c..(i+1)*c]`.
pub(crate) fn row_major(m: MatRef<'_, f64>) -> Vec<f64> {
    let (r, c) = (m.nrows(), m.ncols());
    let mut out = vec![0.0; r * c];
    for j in 0..c {
        for i in 0..r {
            out[i * c + j] = m[(i, j)];
        }
    }
    out
}

/// Fills the lower triangle (diagonal included) of `out` with the noise-free RBF kernel matrix
/// of the rows of `x` (given row-major, `q` columns). The strict upper triangle is untouched.
pub(crate) fn rbf_lower(xr: &[f64], q: usize, kern: &KernelParams, out: &mut Mat<f64>) {
    let var = kern.variance;
    map_sqdist_lower(
        xr,
        q,
        &kern.lengthscale,
        out,
        #[inline(always)]
        |d2| d2,
    );
    // The exp in a pass of its own: inlined into the distance loop above it was not
    // vectorised (LLVM kept it scalar; 270 against 90 µs at N = 300).
    let n = out.nrows();
    vectorized(
        #[inline(always)]
        || {
            for j in 0..n {
                for v in &mut out.col_as_slice_mut(j)[j..] {
                    *v = var * exp_neg(-0.5 * *v);
                }
            }
        },
    );
}

/// Fills the lower triangle (diagonal included) of `out` with `f(|x_i/ℓ − x_j/ℓ|²)` for the
/// rows of `x` (row-major, `q` columns) scaled by `lengthscale`.
///
/// Column by column: the squared scaled distances of rows `j..n` to row `j` are summed one
/// dimension at a time over contiguous columns of `X / ℓ`, then mapped by `f` — loops over
/// slices that [`vectorized`] compiles for the widest SIMD available (`f` is inlined into
/// them; mark it `#[inline(always)]`). Blocks of eight rows kept in registers measured
/// slower here.
#[inline(always)]
pub(crate) fn map_sqdist_lower(
    xr: &[f64],
    q: usize,
    lengthscale: &[f64],
    out: &mut Mat<f64>,
    f: impl Fn(f64) -> f64,
) {
    let n = out.nrows();
    let mut scaled = vec![0.0; n * q];
    for (t, l) in lengthscale.iter().enumerate().take(q) {
        for i in 0..n {
            scaled[t * n + i] = xr[i * q + t] / l;
        }
    }
    vectorized(
        #[inline(always)]
        || {
            for j in 0..n {
                let c = &mut out.col_as_slice_mut(j)[j..];
                c.fill(0.0);
                for t in 0..q {
                    let xt = &scaled[t * n + j..(t + 1) * n];
                    let xj = xt[0];
                    for (v, &xi) in c.iter_mut().zip(xt) {
                        let d = xi - xj;
                        *v += d * d;
                    }
                }
                for v in c.iter_mut() {
                    *v = f(*v);
                }
            }
        },
    );
}

/// `out[(r, i)] = exp(−|a_r − b_i|²)` for pre-scaled rows (columns already multiplied by
/// `1/(√2 ℓ)`), via `|a|² + |b|² − 2 A Bᵀ` (one matrix product), clamped to ≤ 0, then the
/// vectorised exp column by column.
pub(crate) fn rbf_block(a: MatRef<'_, f64>, b: MatRef<'_, f64>, mut out: faer::MatMut<'_, f64>) {
    let na: Vec<f64> = (0..a.nrows())
        .map(|r| (0..a.ncols()).map(|t| a[(r, t)] * a[(r, t)]).sum())
        .collect();
    faer::linalg::matmul::matmul(
        out.rb_mut(),
        Accum::Replace,
        a,
        b.transpose(),
        2.0,
        Par::Seq,
    );
    clear_upper_simd_state();
    for i in 0..b.nrows() {
        let nb: f64 = (0..b.ncols()).map(|t| b[(i, t)] * b[(i, t)]).sum();
        let mut col = out.rb_mut().col_mut(i);
        if let Some(col) = col.rb_mut().try_as_col_major_mut() {
            let col = col.as_slice_mut();
            for (v, &na) in col.iter_mut().zip(&na) {
                *v = (*v - na - nb).min(0.0);
            }
            exp_neg_slice(col);
        } else {
            for (r, &na) in na.iter().enumerate() {
                col[r] = exp_neg((col[r] - na - nb).min(0.0));
            }
        }
    }
}
