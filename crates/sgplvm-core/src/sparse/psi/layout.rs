//! How the Ψ statistics lay out their work (`psi`): what every frame shares (Z by columns, the
//! pairwise distances), one frame's Ψ₁ quantities, a block of frames laid out by latent
//! dimension for Ψ₂ₙ, and the vectorised sums and block loop they are computed with.

use rayon::prelude::*;

use super::BLOCK;
use crate::kernel::KernelParams;
use crate::simd::{exp_neg, vectorized};

/// What every frame shares: Z by columns, its squares, `Σ_q (z_m − z_m')²/(4u_q)` (M×M).
pub(super) struct Shared {
    pub(super) m: usize,
    pub(super) q: usize,
    pub(super) u: Vec<f64>,
    /// Zᵀ row-major (Q×M): `zt[t*m + j] = z_jt`.
    pub(super) zt: Vec<f64>,
    /// (Zᵀ)² element-wise.
    pub(super) zt2: Vec<f64>,
    /// `Σ_q (z_mq − z_m'q)²/(4u_q)`, M×M row-major.
    pub(super) dist: Vec<f64>,
    pub(super) variance: f64,
}

impl Shared {
    pub(super) fn new(zr: &[f64], q: usize, kern: &KernelParams) -> Self {
        let m = zr.len() / q.max(1);
        let u: Vec<f64> = kern.lengthscale.iter().map(|l| l * l).collect();
        let mut zt = vec![0.0; q * m];
        for j in 0..m {
            for t in 0..q {
                zt[t * m + j] = zr[j * q + t];
            }
        }
        let zt2 = zt.iter().map(|z| z * z).collect();
        let quarter: Vec<f64> = u.iter().map(|u| 0.25 / u).collect();
        let mut dist = vec![0.0; m * m];
        for a in 0..m {
            for b in 0..a {
                let d: f64 = (0..q)
                    .map(|t| (zr[a * q + t] - zr[b * q + t]).powi(2) * quarter[t])
                    .sum();
                dist[a * m + b] = d;
                dist[b * m + a] = d;
            }
        }
        Shared {
            m,
            q,
            u,
            zt,
            zt2,
            dist,
            variance: kern.variance,
        }
    }

    /// Column t of Z (all M values).
    #[inline(always)]
    pub(super) fn zcol(&self, t: usize) -> &[f64] {
        &self.zt[t * self.m..(t + 1) * self.m]
    }
}

/// One frame's Ψ₁ quantities: `b = 1/(u + S)` and `∏(1 + S/u)^(−½)`.
pub(super) struct Frame {
    pub(super) b: Vec<f64>,
    pub(super) c1: f64,
}

impl Frame {
    #[inline(always)]
    pub(super) fn new(sh: &Shared, s: &[f64]) -> Self {
        let b: Vec<f64> = (0..sh.q).map(|t| 1.0 / (sh.u[t] + s[t])).collect();
        // (1 + S/u)^(−½) = √(u/(u+S)).
        let c1 = (0..sh.q).map(|t| (sh.u[t] * b[t]).sqrt()).product();
        Frame { b, c1 }
    }

    /// Ψ₁'s row of this frame (M values) into `out`.
    #[inline(always)]
    pub(super) fn psi1_row(&self, sh: &Shared, mu: &[f64], out: &mut [f64]) {
        let m = sh.m;
        let base: f64 = (0..sh.q).map(|t| self.b[t] * mu[t] * mu[t]).sum();
        out.iter_mut().for_each(|v| *v = base);
        for t in 0..sh.q {
            let (c_sq, c_lin) = (self.b[t], -2.0 * self.b[t] * mu[t]);
            let (z, z2) = (sh.zcol(t), &sh.zt2[t * m..(t + 1) * m]);
            for j in 0..m {
                out[j] += c_sq * z2[j] + c_lin * z[j];
            }
        }
        let scale = sh.variance * self.c1;
        for v in out.iter_mut() {
            *v = scale * exp_neg(-0.5 * v.max(0.0));
        }
    }
}

/// Frames of a block are padded to a multiple of this (the vector width of the loops over
/// frames); padded frames have Ψ₂ₙ = 0 and contribute nothing.
pub(super) const LANE: usize = 8;

/// A block of frames laid out by latent dimension, so that Ψ₂ₙ[a, j] is computed for every
/// frame of the block at once (loops over the frames: long, contiguous, vectorised): `a = 1/(u +
/// 2S)`, `α⁴ ∏(1 + 2S/u)^(−½)`, `h = Σ_q a_q μ_q²`, `g[m] = Σ_q a_q (¼ z_mq² − μ_q z_mq)`.
pub(super) struct Lanes {
    /// Frames in the block, and that rounded up to [`LANE`] (the stride of the arrays).
    pub(super) len: usize,
    pub(super) padded: usize,
    /// μ, S and a by dimension: `x[t*padded + k]` for frame k of the block.
    pub(super) mu: Vec<f64>,
    pub(super) s: Vec<f64>,
    pub(super) a: Vec<f64>,
    pub(super) scale: Vec<f64>,
    pub(super) h: Vec<f64>,
    /// `g[j*padded + k]`.
    pub(super) g: Vec<f64>,
}

impl Lanes {
    #[inline(always)]
    pub(super) fn new(sh: &Shared, mean: &[f64], var: &[f64], start: usize, len: usize) -> Self {
        let (m, q) = (sh.m, sh.q);
        let padded = len.div_ceil(LANE) * LANE;
        let mut l = Lanes {
            len,
            padded,
            mu: vec![0.0; q * padded],
            s: vec![0.0; q * padded],
            a: vec![0.0; q * padded],
            scale: vec![0.0; padded],
            h: vec![0.0; padded],
            g: vec![0.0; m * padded],
        };
        for k in 0..len {
            let i = start + k;
            l.scale[k] = sh.variance * sh.variance;
            for t in 0..q {
                let (mu, s) = (mean[i * q + t], var[i * q + t]);
                let a = 1.0 / (sh.u[t] + 2.0 * s);
                l.mu[t * padded + k] = mu;
                l.s[t * padded + k] = s;
                l.a[t * padded + k] = a;
                l.scale[k] *= (sh.u[t] * a).sqrt();
                l.h[k] += a * mu * mu;
            }
        }
        for t in 0..q {
            let a = &l.a[t * padded..(t + 1) * padded];
            let mu = &l.mu[t * padded..(t + 1) * padded];
            for j in 0..m {
                let (z, z2) = (sh.zt[t * m + j], sh.zt2[t * m + j]);
                let g = &mut l.g[j * padded..(j + 1) * padded];
                for k in 0..padded {
                    g[k] += a[k] * (0.25 * z2 - mu[k] * z);
                }
            }
        }
        l
    }

    /// Ψ₂ₙ[a, j] of every frame of the block into `out[..padded]` (0 for padded frames);
    /// `c` is scratch of Q values.
    #[inline(always)]
    pub(super) fn psi2_pair(
        &self,
        sh: &Shared,
        a: usize,
        j: usize,
        c: &mut [f64],
        out: &mut [f64],
    ) {
        let (m, q, p) = (sh.m, sh.q, self.padded);
        for t in 0..q {
            c[t] = 0.5 * sh.zt[t * m + a] * sh.zt[t * m + j];
        }
        let d = sh.dist[a * m + j];
        let (ga, gj) = (&self.g[a * p..(a + 1) * p], &self.g[j * p..(j + 1) * p]);
        let out = &mut out[..p];
        for k in 0..p {
            out[k] = self.h[k] + ga[k] + gj[k] + d;
        }
        for (t, ct) in c[..q].iter().enumerate() {
            let at = &self.a[t * p..(t + 1) * p];
            for k in 0..p {
                out[k] += ct * at[k];
            }
        }
        for (o, sc) in out.iter_mut().zip(&self.scale) {
            *o = sc * exp_neg(-o.max(0.0));
        }
    }
}

/// `Σ aᵢ bᵢ` in eight interleaved partial sums, so that the loop vectorises (a sum in one
/// accumulator cannot be reordered, and stays scalar); the order is fixed, the result
/// deterministic.
#[inline(always)]
pub(super) fn dot(a: &[f64], b: &[f64]) -> f64 {
    let mut acc = [0.0; 8];
    let (ca, cb) = (a.chunks_exact(8), b.chunks_exact(8));
    let (ra, rb) = (ca.remainder(), cb.remainder());
    for (x, y) in ca.zip(cb) {
        for k in 0..8 {
            acc[k] += x[k] * y[k];
        }
    }
    let tail: f64 = ra.iter().zip(rb).map(|(x, y)| x * y).sum();
    acc.iter().sum::<f64>() + tail
}

/// `Σ aᵢ`, as [`dot`].
#[inline(always)]
pub(super) fn sum(a: &[f64]) -> f64 {
    let mut acc = [0.0; 8];
    let c = a.chunks_exact(8);
    let tail: f64 = c.remainder().iter().sum();
    for x in c {
        for k in 0..8 {
            acc[k] += x[k];
        }
    }
    acc.iter().sum::<f64>() + tail
}

/// Runs `f` on each block of frames (start, length) and returns the results in block order, on
/// the pool's threads when the caller is on one and there is more than one block.
pub(super) fn over_blocks<R: Send>(
    n: usize,
    f: impl Fn(usize, usize) -> R + Sync + Send,
) -> Vec<R> {
    let blocks: Vec<(usize, usize)> = (0..n.div_ceil(BLOCK))
        .map(|b| (b * BLOCK, BLOCK.min(n - b * BLOCK)))
        .collect();
    let run = |(s, l): (usize, usize)| {
        vectorized(
            #[inline(always)]
            || f(s, l),
        )
    };
    if blocks.len() > 1 && crate::pool::on_pool_thread() {
        blocks.into_par_iter().map(run).collect()
    } else {
        blocks.into_iter().map(run).collect()
    }
}
