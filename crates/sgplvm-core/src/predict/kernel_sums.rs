//! The kernel sums prediction is made of: training and query rows scaled for [`rbf_block`], the
//! blocked kernel rows of the batch paths, and one frame's kernel-weighted sum laid out for
//! vectorised loops ([`FrameKernel`], [`add_kernel_weighted`]). Used by the exact, sparse and
//! regression predictions alike.

use faer::reborrow::ReborrowMut;
use faer::{Mat, MatRef};

use super::BATCH;
use crate::kernel::rbf_block;
use crate::simd::{exp_neg, vectorized};

/// Training rows (row-major, `dim` columns) and `m` query rows `query(r, t)`, both centred on
/// the training mean and multiplied by `1/(√2 ℓ_t)` (from `half_inv_l2` = −1/(2ℓ²)): the form
/// [`rbf_block`] takes. Centring on the training mean gives smaller norms, so less
/// cancellation in `|a|² + |b|² − 2 a·b`.
pub(crate) fn scaled_about_mean(
    rows: &[f64],
    dim: usize,
    half_inv_l2: &[f64],
    m: usize,
    query: impl Fn(usize, usize) -> f64,
) -> (Mat<f64>, Mat<f64>) {
    let n = rows.len() / dim.max(1);
    let sc: Vec<f64> = half_inv_l2.iter().map(|v| (-v).sqrt()).collect();
    let mu: Vec<f64> = (0..dim)
        .map(|t| (0..n).map(|i| rows[i * dim + t]).sum::<f64>() / n.max(1) as f64)
        .collect();
    let train = Mat::from_fn(n, dim, |i, t| (rows[i * dim + t] - mu[t]) * sc[t]);
    let queries = Mat::from_fn(m, dim, |r, t| (query(r, t) - mu[t]) * sc[t]);
    (train, queries)
}

/// The batch loop of [`SharedGplvm::latent`] and [`SharedGplvm::predict`]: kernel rows between
/// the (pre-scaled) `queries` and `train` rows, [`BATCH`] queries at a time, each block handed
/// to `f` with the index of its first query.
pub(crate) fn for_each_kernel_block(
    queries: MatRef<'_, f64>,
    train: MatRef<'_, f64>,
    mut f: impl FnMut(usize, MatRef<'_, f64>),
) {
    let total = queries.nrows();
    let mut k = Mat::zeros(BATCH.min(total), train.nrows());
    let mut r0 = 0;
    while r0 < total {
        let m = BATCH.min(total - r0);
        let mut kb = k.as_mut().subrows_mut(0, m);
        rbf_block(queries.subrows(r0, m), train, kb.rb_mut());
        f(r0, kb.as_ref());
        r0 += m;
    }
}

/// Training inputs and weights of a kernel-weighted sum laid out for one frame at a time:
/// the inputs dimension by dimension and the weights output by output, each contiguous over
/// the training points, so that every loop of [`add_kernel_weighted`] runs over a slice (8
/// wide with AVX-512) instead of over a row of a few dimensions.
#[derive(Clone, Debug, Default)]
pub(crate) struct FrameKernel {
    /// Inputs, `cols[s * n + i]` = dimension s of training point i.
    cols: Vec<f64>,
    /// Weights, `weights[t * n + i]` = output t of training point i.
    weights: Vec<f64>,
    /// Training points.
    n: usize,
}

impl FrameKernel {
    /// From inputs row-major n×`dim` and weights row-major n×`wdim`.
    pub(crate) fn new(rows: &[f64], dim: usize, weights: &[f64], wdim: usize) -> Self {
        let n = rows.len() / dim.max(1);
        let transpose = |m: &[f64], c: usize| {
            let mut out = vec![0.0; m.len()];
            for i in 0..n {
                for t in 0..c {
                    out[t * n + i] = m[i * c + t];
                }
            }
            out
        };
        Self {
            cols: transpose(rows, dim),
            weights: transpose(weights, wdim),
            n,
        }
    }

    /// Sets weight `t` of training point `i` (tests: a corrupted cache).
    #[cfg(test)]
    pub(crate) fn set_weight(&mut self, i: usize, t: usize, v: f64) {
        self.weights[t * self.n + i] = v;
    }
}

/// Training points per block of [`add_kernel_weighted`] (kernel values on the stack).
const FRAME_BLOCK: usize = 128;

/// `out[t] += scale · Σ_i exp(Σ_s (p_s − x_is)² h_s) w_it` over the training points of `fk`,
/// `h` = −1/(2ℓ²) per dimension: one frame's kernel-weighted sum, allocation-free. Blocks of
/// [`FRAME_BLOCK`] training points: distances dimension by dimension, the exp, then one dot
/// product per output with eight partial sums — all over contiguous slices, vectorised.
pub(crate) fn add_kernel_weighted(
    p: &[f64],
    fk: &FrameKernel,
    half_inv_l2: &[f64],
    scale: f64,
    out: &mut [f64],
) {
    let n = fk.n;
    vectorized(
        #[inline(always)]
        || {
            let mut kb = [0.0f64; FRAME_BLOCK];
            let mut start = 0;
            while start < n {
                let end = (start + FRAME_BLOCK).min(n);
                let k = &mut kb[..end - start];
                k.fill(0.0);
                for (s, (&ps, &hs)) in p.iter().zip(half_inv_l2).enumerate() {
                    let col = &fk.cols[s * n + start..s * n + end];
                    for (v, &c) in k.iter_mut().zip(col) {
                        let d = c - ps;
                        *v += d * d * hs;
                    }
                }
                for v in k.iter_mut() {
                    *v = exp_neg(*v);
                }
                for (t, o) in out.iter_mut().enumerate() {
                    let w = &fk.weights[t * n + start..t * n + end];
                    *o += scale * dot(k, w);
                }
                start = end;
            }
        },
    );
}

/// Σ a_i b_i with eight partial sums (a loop the compiler vectorises; one running sum would
/// stay scalar without reassociation).
#[inline(always)]
fn dot(a: &[f64], b: &[f64]) -> f64 {
    let mut lanes = [0.0f64; 8];
    let (ac, bc) = (a.chunks_exact(8), b.chunks_exact(8));
    let (ar, br) = (ac.remainder(), bc.remainder());
    for (x, y) in ac.zip(bc) {
        for l in 0..8 {
            lanes[l] += x[l] * y[l];
        }
    }
    for (l, (x, y)) in ar.iter().zip(br).enumerate() {
        lanes[l] += x * y;
    }
    ((lanes[0] + lanes[4]) + (lanes[2] + lanes[6]))
        + ((lanes[1] + lanes[5]) + (lanes[3] + lanes[7]))
}
