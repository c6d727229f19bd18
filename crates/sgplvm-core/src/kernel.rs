//! The RBF-ARD kernel of one observation space, in GPy's parametrisation:
//! `k(x, x') = α² exp(−½ Σ_q (x_q − x'_q)² / ℓ_q²)`, plus `σ² I` on the training diagonal
//! (GPy's `RBF(Q, ARD=True)` with a Gaussian likelihood).
//!
//! Kernel matrices between training points ([`rbf_lower`], lower triangle only) and between two
//! sets of points ([`rbf_block`], by one matrix product) are built here; what is done with them
//! lives in `likelihood` (training) and `predict` (prediction).

use faer::reborrow::ReborrowMut;
use faer::{Accum, Mat, MatMut, MatRef, Par};
use serde::{Deserialize, Serialize};

use crate::pool::both;
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
/// With `par` of two threads or more the columns are split between two threads at equal work;
/// every column is computed as on one thread, so the result is the same bit for bit.
pub(crate) fn rbf_lower(xr: &[f64], q: usize, kern: &KernelParams, out: &mut Mat<f64>, par: Par) {
    let n = out.nrows();
    let scaled = scaled_columns(xr, q, &kern.lengthscale, n);
    let var = kern.variance;
    let fill = |mut cols: MatMut<'_, f64>, first: usize| {
        vectorized(
            #[inline(always)]
            || {
                for c in 0..cols.ncols() {
                    sqdist_column(
                        lower_column(cols.rb_mut(), c, first + c),
                        &scaled,
                        n,
                        first + c,
                    );
                }
                // The exp in a pass of its own: inlined into the distance loop above it was not
                // vectorised (LLVM kept it scalar; 270 against 90 µs at N = 300).
                for c in 0..cols.ncols() {
                    for v in lower_column(cols.rb_mut(), c, first + c) {
                        *v = var * exp_neg(-0.5 * *v);
                    }
                }
            },
        )
    };
    // Column j holds n − j entries: the first n − n/√2 columns hold half of them.
    let split = n - (n as f64 / std::f64::consts::SQRT_2) as usize;
    let (left, right) = out.as_mut().split_at_col_mut(split);
    both(par, || fill(left, 0), || fill(right, split));
}

/// Rows `j..` of column `c` of `cols` (a matrix with contiguous columns), as a slice.
#[inline(always)]
fn lower_column<'a>(cols: MatMut<'a, f64>, c: usize, j: usize) -> &'a mut [f64] {
    let col = cols.col_mut(c).try_as_col_major_mut();
    &mut col.expect("a Mat's columns are contiguous").as_slice_mut()[j..]
}

/// The columns of `X / ℓ` (`xr` row-major, `q` columns, `n` rows), one after another.
fn scaled_columns(xr: &[f64], q: usize, lengthscale: &[f64], n: usize) -> Vec<f64> {
    let mut scaled = vec![0.0; n * q];
    for (t, l) in lengthscale.iter().enumerate().take(q) {
        for i in 0..n {
            scaled[t * n + i] = xr[i * q + t] / l;
        }
    }
    scaled
}

/// `c` (rows `j..n` of a column) ← the squared distances of those rows of `scaled` (from
/// [`scaled_columns`]) to row `j`, summed one dimension at a time over contiguous slices.
#[inline(always)]
fn sqdist_column(c: &mut [f64], scaled: &[f64], n: usize, j: usize) {
    c.fill(0.0);
    for xt in scaled.chunks_exact(n) {
        let xt = &xt[j..];
        let xj = xt[0];
        for (v, &xi) in c.iter_mut().zip(xt) {
            let d = xi - xj;
            *v += d * d;
        }
    }
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
    let scaled = scaled_columns(xr, q, lengthscale, n);
    vectorized(
        #[inline(always)]
        || {
            for j in 0..n {
                let c = &mut out.col_as_slice_mut(j)[j..];
                sqdist_column(c, &scaled, n, j);
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

#[cfg(test)]
mod tests {
    use super::*;

    /// Split between two threads, the kernel matrix is the one-thread matrix bit for bit, for
    /// sizes where the split leaves one side nearly empty too; the upper triangle is untouched.
    #[test]
    fn kernel_matrix_on_two_threads_is_the_one_thread_matrix() {
        let two = rayon::ThreadPoolBuilder::new()
            .num_threads(2)
            .build()
            .expect("pool");
        let k = KernelParams {
            variance: 1.7,
            lengthscale: vec![0.8, 1.3, 2.1],
            noise: 0.1,
        };
        for n in [1, 2, 3, 4, 17, 301] {
            let xr: Vec<f64> = (0..n * 3).map(|i| (i as f64 * 0.37).sin()).collect();
            let mut one = Mat::full(n, n, -1.0);
            rbf_lower(&xr, 3, &k, &mut one, Par::Seq);
            let mut both = Mat::full(n, n, -1.0);
            two.install(|| rbf_lower(&xr, 3, &k, &mut both, Par::rayon(2)));
            for j in 0..n {
                for i in 0..n {
                    assert_eq!(
                        one[(i, j)].to_bits(),
                        both[(i, j)].to_bits(),
                        "n {n} ({i}, {j})"
                    );
                    if i < j {
                        assert_eq!(one[(i, j)], -1.0, "upper triangle written");
                    }
                }
                let xi = &xr[j * 3..j * 3 + 3];
                let want = k.variance
                    * (-0.5
                        * (0..3)
                            .map(|t| ((xi[t] - xr[(n - 1) * 3 + t]) / k.lengthscale[t]).powi(2))
                            .sum::<f64>())
                    .exp();
                let got = one[(n - 1, j)];
                assert!(
                    (got - want).abs() <= 1e-14 * want.max(1.0),
                    "n {n}: {got} vs {want}"
                );
            }
        }
    }
}
