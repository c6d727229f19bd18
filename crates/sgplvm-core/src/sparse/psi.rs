//! The Ψ statistics of an RBF-ARD kernel under a Gaussian q(X) = ∏ₙ N(μₙ, diag Sₙ) (Titsias &
//! Lawrence 2010; GPy's `rbf_psi_comp`), and their chain rule: what the Bayesian GP-LVM's bound
//! uses in place of K_nn's trace, K_nm and K_mn K_nm.
//!
//! With `u_q = ℓ_q²`, `z̄ = (z_m + z_m')/2`:
//! - `ψ₀ = N α²`;
//! - `Ψ₁[n, m] = α² ∏_q (1 + S_nq/u_q)^(−½) exp(−½ Σ_q b_q (μ_nq − z_mq)²)`, `b_q = 1/(u_q + S_nq)`
//!   (N×M);
//! - `Ψ₂ = Σₙ Ψ₂ₙ`, `Ψ₂ₙ[m, m'] = α⁴ ∏_q (1 + 2S_nq/u_q)^(−½)
//!   exp(−Σ_q (z_mq − z_m'q)²/(4u_q) − Σ_q a_q (μ_nq − z̄_q)²)`, `a_q = 1/(u_q + 2S_nq)` (M×M).
//!
//! **How it is computed.** Expanding the square, `Σ_q a_q (μ_q − z̄_q)² = h + g_m + g_m' +
//! ½ Σ_q a_q z_mq z_m'q` with `h = Σ_q a_q μ_q²` and `g_m = Σ_q a_q (¼ z_mq² − μ_q z_mq)`: each
//! frame's Ψ₂ₙ is a row-by-row sum of Q scaled copies of Zᵀ's rows (contiguous, so the loops
//! vectorise) and one `exp` per entry, O(M² Q) per frame; GPy forms the same as an N×M×M×Q
//! array (480 MB at N = 3,000, M = 50, Q = 8). Ψ₁ likewise, O(M Q) per frame.
//!
//! **The chain rule** ([`psi_chain`]), given `∂L/∂ψ₀`, `∂L/∂Ψ₁`, `∂L/∂Ψ₂` (symmetric): with
//! `W = ∂L/∂Ψ₂ ∘ Ψ₂ₙ`, its row sums `r`, `s = Σ r` and `WZ` (M×Q), every derivative of frame n
//! is a few sums over them, because `Σ_{m,m'} W (μ − z̄)² = μ² s − 2μ rᵀz + ½ rᵀz² + ½ zᵀ W z`
//! per latent dimension:
//! - `∂/∂μ_q = −2 a_q (μ_q s − rᵀ z_q)`, `∂/∂S_q = −a_q s + 2 a_q² P_q` with `P_q` that sum;
//! - `∂/∂u_q`: `s S_q/(u_q (u_q + 2S_q)) + a_q² P_q` per frame, plus `Σ W̄ (z_m − z_m')²/(4u²)`
//!   with `W̄ = Σₙ W` once;
//! - `∂/∂z_kq`: `a_q (2μ_q r_k − z_kq r_k − (WZ)_kq)` per frame, plus
//!   `−(z_kq r̄_k − (W̄ Z)_kq)/u_q` once (`r̄` the row sums of `W̄`);
//! - `∂/∂α² = 2 s/α²`; and Ψ₁'s the same way with `b_q`, `w = ∂L/∂Ψ₁ ∘ Ψ₁` (below). Every
//!   derivative is checked against central differences in the tests.
//!
//! The frames are processed in fixed blocks (on the pool's threads when called on one) whose
//! partial sums are added in order: the results do not depend on the number of threads. Memory
//! beyond the inputs: Ψ₁ (N×M), per block a few M×M sums, and the first pass's Ψ₂ₙ values for
//! the second when they take at most [`PSI2_CACHE_BYTES`] (else the second pass forms them
//! again): no more than that of any N×M×M array.

use faer::{Mat, MatRef};

use crate::kernel::KernelParams;

mod layout;

use layout::{dot, over_blocks, sum, Frame, Lanes, Shared, LANE};

/// Frames per block of the N-dimension: the unit of parallel work and of partial sums.
const BLOCK: usize = 128;

/// Ψ statistics of one space's kernel.
#[derive(Clone, Debug)]
pub(crate) struct Psi {
    /// ψ₀ = N α².
    pub psi0: f64,
    /// Ψ₁ (N×M).
    pub psi1: Mat<f64>,
    /// Ψ₂ (M×M, symmetric, both triangles filled).
    pub psi2: Mat<f64>,
    /// Per block of frames, every Ψ₂ₙ[a, j] (a ≥ j, pair-major, the block's padded frames
    /// within), kept for [`psi_chain`] when all of them take at most [`PSI2_CACHE_BYTES`];
    /// empty otherwise (the chain rule then forms them again).
    pub pairs: Vec<Vec<f64>>,
}

/// The most memory the Ψ₂ₙ values of one space's first pass may keep for the second
/// (N·M(M+1)/2 values: every frame up to N ≈ 6,500 at M = 50); beyond it they are formed again.
pub(crate) const PSI2_CACHE_BYTES: u64 = 64 << 20;

/// Derivatives of a scalar through the Ψ statistics ([`psi_chain`]).
#[derive(Clone, Debug)]
pub(crate) struct PsiGrad {
    /// ∂/∂μ (N×Q, row-major).
    pub d_mean: Vec<f64>,
    /// ∂/∂S (N×Q, row-major).
    pub d_var: Vec<f64>,
    /// ∂/∂Z (M×Q, row-major).
    pub d_z: Vec<f64>,
    /// ∂/∂α².
    pub d_variance: f64,
    /// ∂/∂ℓ_q.
    pub d_lengthscale: Vec<f64>,
}

/// Ψ₀, Ψ₁ and Ψ₂ for means `mean` and variances `var` (N×Q, row-major), inducing inputs `zr`
/// (M×Q, row-major) and the RBF-ARD part of `kern` (its noise is not used).
pub(crate) fn psi_stats(
    mean: &[f64],
    var: &[f64],
    zr: &[f64],
    q: usize,
    kern: &KernelParams,
) -> Psi {
    crate::simd::clear_upper_simd_state();
    let n = mean.len() / q.max(1);
    let sh = Shared::new(zr, q, kern);
    let m = sh.m;
    let pair_count = m * (m + 1) / 2;
    // Every block is padded to a multiple of LANE frames: at most n + LANE per block.
    let padded_frames = (n + LANE * n.div_ceil(BLOCK)) as u64;
    let cache = padded_frames * pair_count as u64 * 8 <= PSI2_CACHE_BYTES;
    let parts = over_blocks(
        n,
        #[inline(always)]
        |start, len| {
            let mut psi1 = vec![0.0; len * m];
            for (k, i) in (start..start + len).enumerate() {
                let (mu, s) = (&mean[i * q..(i + 1) * q], &var[i * q..(i + 1) * q]);
                Frame::new(&sh, s).psi1_row(&sh, mu, &mut psi1[k * m..(k + 1) * m]);
            }
            let lanes = Lanes::new(&sh, mean, var, start, len);
            let p = lanes.padded;
            let mut psi2 = vec![0.0; m * m];
            let mut kept = if cache {
                vec![0.0; pair_count * p]
            } else {
                Vec::new()
            };
            let mut pair = vec![0.0; p];
            let mut c = vec![0.0; q];
            let mut index = 0;
            for a in 0..m {
                for j in 0..=a {
                    lanes.psi2_pair(&sh, a, j, &mut c, &mut pair);
                    psi2[a * m + j] = sum(&pair);
                    if cache {
                        kept[index * p..(index + 1) * p].copy_from_slice(&pair);
                    }
                    index += 1;
                }
            }
            (psi1, psi2, kept)
        },
    );
    let mut psi1 = Mat::zeros(n, m);
    let mut sum2 = vec![0.0; m * m];
    let mut pairs = Vec::new();
    for (b, (p1, p2, kept)) in parts.into_iter().enumerate() {
        if cache {
            pairs.push(kept);
        }
        let start = b * BLOCK;
        for k in 0..p1.len() / m.max(1) {
            for j in 0..m {
                psi1[(start + k, j)] = p1[k * m + j];
            }
        }
        for (s, v) in sum2.iter_mut().zip(p2) {
            *s += v;
        }
    }
    // The lower triangle was summed; the upper is its mirror.
    let psi2 = Mat::from_fn(m, m, |a, b| sum2[a.max(b) * m + a.min(b)]);
    Psi {
        psi0: n as f64 * kern.variance,
        psi1,
        psi2,
        pairs,
    }
}

/// One block's share of [`psi_chain`] beyond its frames' ∂μ and ∂S: its sums of ∂Z, ∂α², ∂u
/// and W̄ (M×M).
struct BlockGrad {
    d_z: Vec<f64>,
    d_variance: f64,
    d_u: Vec<f64>,
    w_sum: Vec<f64>,
}

/// What every block of [`psi_chain`] reads: the statistics' inputs, the derivatives it is
/// given (∂L/∂Ψ₂ symmetrised, row-major) and the kept Ψ₂ₙ values.
struct Chain<'a> {
    sh: Shared,
    mean: &'a [f64],
    var: &'a [f64],
    psi1: MatRef<'a, f64>,
    pairs: &'a [Vec<f64>],
    g1: MatRef<'a, f64>,
    g2s: Vec<f64>,
}

impl Chain<'_> {
    /// Ψ₁'s share for the frames `start..start + len`: w = ∂L/∂Ψ₁ ∘ Ψ₁ row by row, into the
    /// frames' ∂μ and ∂S (`dm`, `ds`, the block's rows) and the block's sums.
    #[inline(always)]
    fn psi1_block(
        &self,
        start: usize,
        len: usize,
        dm: &mut [f64],
        ds: &mut [f64],
        out: &mut BlockGrad,
    ) {
        let (sh, mean, var, g1, psi1) = (&self.sh, self.mean, self.var, self.g1, self.psi1);
        let (m, q, u) = (sh.m, sh.q, &sh.u);
        let mut w = vec![0.0; m];
        for (k, i) in (start..start + len).enumerate() {
            let (mu, s) = (&mean[i * q..(i + 1) * q], &var[i * q..(i + 1) * q]);
            let (dmu, dsn) = (&mut dm[k * q..(k + 1) * q], &mut ds[k * q..(k + 1) * q]);
            let f = Frame::new(sh, s);
            // Ψ₁: w = ∂L/∂Ψ₁ ∘ Ψ₁ over the row.
            for j in 0..m {
                w[j] = g1[(i, j)] * psi1[(i, j)];
            }
            let w1 = sum(&w);
            out.d_variance += w1 / sh.variance;
            for t in 0..q {
                let (z, z2) = (sh.zcol(t), &sh.zt2[t * m..(t + 1) * m]);
                let (wz1, wzz) = (dot(&w, z), dot(&w, z2));
                let (bt, mt) = (f.b[t], mu[t]);
                // Σ w (μ − z)².
                let p = mt * mt * w1 - 2.0 * mt * wz1 + wzz;
                dmu[t] -= bt * (mt * w1 - wz1);
                dsn[t] += 0.5 * (bt * bt * p - bt * w1);
                out.d_u[t] += w1 * s[t] / (2.0 * u[t] * (u[t] + s[t])) + 0.5 * bt * bt * p;
                for j in 0..m {
                    out.d_z[j * q + t] += w[j] * bt * (mt - z[j]);
                }
            }
        }
    }

    /// Ψ₂'s share for the block, pair by pair for all its frames at once.
    #[inline(always)]
    fn psi2_block(
        &self,
        start: usize,
        len: usize,
        dm: &mut [f64],
        ds: &mut [f64],
        out: &mut BlockGrad,
    ) {
        let (sh, mean, var, pairs, g2s) = (&self.sh, self.mean, self.var, self.pairs, &self.g2s);
        let (m, q, u) = (sh.m, sh.q, &sh.u);
        // Ψ₂ₙ for the whole block, pair by pair (a ≥ j; W is symmetric, so a pair off the
        // diagonal stands for (a, j) and (j, a)): W = ∂L/∂Ψ₂ ∘ Ψ₂ₙ, its row sums r[a] and
        // WZ[t][a], per frame of the block.
        let lanes = Lanes::new(sh, mean, var, start, len);
        // Arrays over the block's frames have the padded length.
        let len = lanes.padded;
        let mut c = vec![0.0; q];
        let mut r = vec![0.0; m * len];
        // zᵀ W z per dimension and frame: zwz[t*len + k].
        let mut zwz = vec![0.0; q * len];
        let mut pair = vec![0.0; len];
        let kept = pairs.get(start / BLOCK);
        let mut index = 0;
        for a in 0..m {
            for j in 0..=a {
                match kept {
                    Some(k) => pair.copy_from_slice(&k[index * len..(index + 1) * len]),
                    None => lanes.psi2_pair(sh, a, j, &mut c, &mut pair),
                }
                index += 1;
                let g = g2s[a * m + j];
                pair.iter_mut().for_each(|v| *v *= g);
                out.w_sum[a * m + j] += sum(&pair);
                let twice = if a == j { 1.0 } else { 2.0 };
                for (x, p) in r[a * len..(a + 1) * len].iter_mut().zip(&pair) {
                    *x += p;
                }
                if a != j {
                    for (x, p) in r[j * len..(j + 1) * len].iter_mut().zip(&pair) {
                        *x += p;
                    }
                }
                for t in 0..q {
                    let (za, zj) = (sh.zt[t * m + a], sh.zt[t * m + j]);
                    let c2 = twice * za * zj;
                    for (x, p) in zwz[t * len..(t + 1) * len].iter_mut().zip(&pair) {
                        *x += c2 * p;
                    }
                    // −Σ_k a_t W_k[a, j] z_j (and its mirror) of ∂/∂Z.
                    let d = dot(&lanes.a[t * len..(t + 1) * len], &pair);
                    out.d_z[a * q + t] -= zj * d;
                    if a != j {
                        out.d_z[j * q + t] -= za * d;
                    }
                }
            }
        }
        // Per frame: s = Σ r, and per dimension rᵀz, rᵀz² (vectorised over frames).
        let mut s_tot = vec![0.0; len];
        for a in 0..m {
            for (x, v) in s_tot.iter_mut().zip(&r[a * len..(a + 1) * len]) {
                *x += v;
            }
        }
        for x in &s_tot {
            out.d_variance += 2.0 * x / sh.variance;
        }
        let (mut rz, mut rzz) = (vec![0.0; len], vec![0.0; len]);
        for t in 0..q {
            rz.iter_mut().for_each(|v| *v = 0.0);
            rzz.iter_mut().for_each(|v| *v = 0.0);
            for a in 0..m {
                let (za, za2) = (sh.zt[t * m + a], sh.zt2[t * m + a]);
                let ra = &r[a * len..(a + 1) * len];
                for k in 0..len {
                    rz[k] += ra[k] * za;
                    rzz[k] += ra[k] * za2;
                }
            }
            let zwz = &zwz[t * len..(t + 1) * len];
            let (at, mu_t, s_t) = (
                &lanes.a[t * len..(t + 1) * len],
                &lanes.mu[t * len..(t + 1) * len],
                &lanes.s[t * len..(t + 1) * len],
            );
            for k in 0..lanes.len {
                let (a, mt, st, sk) = (at[k], mu_t[k], s_t[k], s_tot[k]);
                // Σ W (μ − z̄)².
                let p = mt * mt * sk - 2.0 * mt * rz[k] + 0.5 * rzz[k] + 0.5 * zwz[k];
                dm[k * q + t] -= 2.0 * a * (mt * sk - rz[k]);
                ds[k * q + t] += 2.0 * a * a * p - a * sk;
                out.d_u[t] += sk * st / (u[t] * (u[t] + 2.0 * st)) + a * a * p;
            }
            // ∂/∂z_jt += Σ_k a_k (2μ_k − z_jt) r_k[j] (the W z part was added pair by pair).
            let mut am = vec![0.0; len];
            for k in 0..len {
                am[k] = 2.0 * at[k] * mu_t[k];
            }
            for j in 0..m {
                let zj = sh.zt[t * m + j];
                let rj = &r[j * len..(j + 1) * len];
                out.d_z[j * q + t] += dot(&am, rj) - zj * dot(at, rj);
            }
        }
    }
}

/// The derivatives of a scalar L through the Ψ statistics of [`psi_stats`], given `g0 = ∂L/∂ψ₀`,
/// `g1 = ∂L/∂Ψ₁` (N×M) and `g2 = ∂L/∂Ψ₂` (M×M; symmetrised here). Ψ₁ is taken from `psi1` (it
/// was computed already), and Ψ₂ₙ from `pairs` ([`Psi::pairs`]) or, when that is empty, formed
/// again.
#[allow(clippy::too_many_arguments)]
pub(crate) fn psi_chain(
    mean: &[f64],
    var: &[f64],
    zr: &[f64],
    q: usize,
    kern: &KernelParams,
    psi1: MatRef<'_, f64>,
    pairs: &[Vec<f64>],
    g0: f64,
    g1: MatRef<'_, f64>,
    g2: MatRef<'_, f64>,
) -> PsiGrad {
    crate::simd::clear_upper_simd_state();
    let n = mean.len() / q.max(1);
    let sh = Shared::new(zr, q, kern);
    let m = sh.m;
    let g2s: Vec<f64> = (0..m * m)
        .map(|i| 0.5 * (g2[(i / m, i % m)] + g2[(i % m, i / m)]))
        .collect();
    let chain = Chain {
        sh,
        mean,
        var,
        psi1,
        pairs,
        g1,
        g2s,
    };
    let mut d_mean = vec![0.0; n * q];
    let mut d_var = vec![0.0; n * q];
    let chunks: Vec<std::sync::Mutex<(&mut [f64], &mut [f64])>> = d_mean
        .chunks_mut(BLOCK * q)
        .zip(d_var.chunks_mut(BLOCK * q))
        .map(std::sync::Mutex::new)
        .collect();
    let parts = over_blocks(
        n,
        #[inline(always)]
        |start, len| {
            let mut guard = crate::pool::lock(&chunks[start / BLOCK]);
            let (dm, ds) = &mut *guard;
            let mut out = BlockGrad {
                d_z: vec![0.0; m * q],
                d_variance: 0.0,
                d_u: vec![0.0; q],
                w_sum: vec![0.0; m * m],
            };
            chain.psi1_block(start, len, dm, ds, &mut out);
            chain.psi2_block(start, len, dm, ds, &mut out);
            out
        },
    );
    drop(chunks);
    finish_chain(&chain.sh, kern, parts, g0 * n as f64, d_mean, d_var)
}

/// [`psi_chain`]'s end: the blocks' sums added in order, then the frame-independent terms
/// (W̄'s Δ² and Δ), and ∂/∂ℓ from ∂/∂u.
fn finish_chain(
    sh: &Shared,
    kern: &KernelParams,
    parts: Vec<BlockGrad>,
    d_psi0: f64,
    d_mean: Vec<f64>,
    d_var: Vec<f64>,
) -> PsiGrad {
    let (m, q, u) = (sh.m, sh.q, &sh.u);
    let mut d_z = vec![0.0; m * q];
    let mut d_variance = d_psi0;
    let mut d_u = vec![0.0; q];
    let mut w_sum = vec![0.0; m * m];
    for part in parts {
        d_z.iter_mut().zip(&part.d_z).for_each(|(a, b)| *a += b);
        d_variance += part.d_variance;
        d_u.iter_mut().zip(&part.d_u).for_each(|(a, b)| *a += b);
        w_sum.iter_mut().zip(&part.w_sum).for_each(|(a, b)| *a += b);
    }
    // W̄ was summed on its lower triangle: mirror it. Then the frame-independent terms: W̄'s Δ²
    // and Δ.
    for a in 0..m {
        for b in 0..a {
            w_sum[b * m + a] = w_sum[a * m + b];
        }
    }
    for t in 0..q {
        let z = sh.zcol(t);
        for a in 0..m {
            let row = &w_sum[a * m..(a + 1) * m];
            let (mut ra, mut wz, mut dd) = (0.0, 0.0, 0.0);
            for j in 0..m {
                let dl = z[a] - z[j];
                ra += row[j];
                wz += row[j] * z[j];
                dd += row[j] * dl * dl;
            }
            d_u[t] += dd / (4.0 * u[t] * u[t]);
            d_z[a * q + t] -= (z[a] * ra - wz) / u[t];
        }
    }
    let d_lengthscale = d_u
        .iter()
        .zip(&kern.lengthscale)
        .map(|(g, l)| 2.0 * l * g)
        .collect();
    PsiGrad {
        d_mean,
        d_var,
        d_z,
        d_variance,
        d_lengthscale,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_support::{ChaCha8Rng, Rng, SeedableRng};

    struct Case {
        mean: Vec<f64>,
        var: Vec<f64>,
        z: Vec<f64>,
        q: usize,
        kern: KernelParams,
    }

    fn case(n: usize, m: usize, q: usize, seed: u64) -> Case {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut r = |a: f64, b: f64| rng.random_range(a..b);
        Case {
            mean: (0..n * q).map(|_| r(-1.5, 1.5)).collect(),
            var: (0..n * q).map(|_| r(0.05, 0.6)).collect(),
            z: (0..m * q).map(|_| r(-1.5, 1.5)).collect(),
            q,
            kern: KernelParams {
                variance: r(0.5, 2.0),
                lengthscale: (0..q).map(|_| r(0.7, 2.0)).collect(),
                noise: 0.1,
            },
        }
    }

    /// With S → 0 the statistics become K_nm and K_mn K_nm, written out here as plain loops
    /// (with S > 0 they are checked against GPy through the bound, in `bayesian`'s tests).
    #[test]
    fn with_vanishing_variances_psi_becomes_the_kernel() {
        let mut c = case(7, 4, 3, 1);
        c.var.iter_mut().for_each(|v| *v = 1e-14);
        let p = psi_stats(&c.mean, &c.var, &c.z, c.q, &c.kern);
        let k = |a: &[f64], b: &[f64]| {
            let s: f64 = (0..c.q)
                .map(|t| (a[t] - b[t]).powi(2) / c.kern.lengthscale[t].powi(2))
                .sum();
            c.kern.variance * (-0.5 * s).exp()
        };
        let (n, m, q) = (7, 4, 3);
        for i in 0..n {
            for j in 0..m {
                let want = k(&c.mean[i * q..(i + 1) * q], &c.z[j * q..(j + 1) * q]);
                assert!((p.psi1[(i, j)] - want).abs() < 1e-12);
            }
        }
        for a in 0..m {
            for b in 0..m {
                let want: f64 = (0..n)
                    .map(|i| {
                        let x = &c.mean[i * q..(i + 1) * q];
                        k(x, &c.z[a * q..(a + 1) * q]) * k(x, &c.z[b * q..(b + 1) * q])
                    })
                    .sum();
                assert!((p.psi2[(a, b)] - want).abs() < 1e-12, "{a} {b}");
            }
        }
        assert_eq!(p.psi0, 7.0 * c.kern.variance);
    }

    /// A scalar of all three statistics with fixed random weights; its chain-rule gradient
    /// against central differences in every mean, variance, inducing input and kernel value.
    #[test]
    fn chain_rule_matches_finite_differences() {
        let (n, m, q) = (9, 5, 3);
        let c = case(n, m, q, 7);
        let mut rng = ChaCha8Rng::seed_from_u64(99);
        let g0 = 0.7;
        let g1 = Mat::from_fn(n, m, |_, _| rng.random_range(-0.5..0.5));
        let g2r = Mat::from_fn(m, m, |_, _| rng.random_range(-0.5..0.5));
        let g2 = Mat::from_fn(m, m, |i, j| g2r[(i, j)] + g2r[(j, i)]);
        let value = |mean: &[f64], var: &[f64], z: &[f64], kern: &KernelParams| {
            let p = psi_stats(mean, var, z, q, kern);
            let mut v = g0 * p.psi0;
            for i in 0..n {
                for j in 0..m {
                    v += g1[(i, j)] * p.psi1[(i, j)];
                }
            }
            for i in 0..m {
                for j in 0..m {
                    v += g2[(i, j)] * p.psi2[(i, j)];
                }
            }
            v
        };
        let p = psi_stats(&c.mean, &c.var, &c.z, q, &c.kern);
        let g = psi_chain(
            &c.mean,
            &c.var,
            &c.z,
            q,
            &c.kern,
            p.psi1.as_ref(),
            &p.pairs,
            g0,
            g1.as_ref(),
            g2.as_ref(),
        );
        assert!(!p.pairs.is_empty(), "a small problem keeps its Ψ₂ₙ values");
        // Formed again instead of kept: the same numbers.
        let again = psi_chain(
            &c.mean,
            &c.var,
            &c.z,
            q,
            &c.kern,
            p.psi1.as_ref(),
            &[],
            g0,
            g1.as_ref(),
            g2.as_ref(),
        );
        assert!(again.d_mean == g.d_mean && again.d_var == g.d_var && again.d_z == g.d_z);
        assert!(again.d_lengthscale == g.d_lengthscale && again.d_variance == g.d_variance);
        let h = 1e-6;
        let check = |analytic: f64, plus: f64, minus: f64, what: &str| {
            let fd = (plus - minus) / (2.0 * h);
            assert!(
                (analytic - fd).abs() <= 1e-6 * (1.0 + fd.abs()),
                "{what}: analytic {analytic} fd {fd}"
            );
        };
        for k in 0..n * q {
            let (mut a, mut b) = (c.mean.clone(), c.mean.clone());
            a[k] += h;
            b[k] -= h;
            check(
                g.d_mean[k],
                value(&a, &c.var, &c.z, &c.kern),
                value(&b, &c.var, &c.z, &c.kern),
                "mean",
            );
            let (mut a, mut b) = (c.var.clone(), c.var.clone());
            a[k] += h;
            b[k] -= h;
            check(
                g.d_var[k],
                value(&c.mean, &a, &c.z, &c.kern),
                value(&c.mean, &b, &c.z, &c.kern),
                "var",
            );
        }
        for k in 0..m * q {
            let (mut a, mut b) = (c.z.clone(), c.z.clone());
            a[k] += h;
            b[k] -= h;
            check(
                g.d_z[k],
                value(&c.mean, &c.var, &a, &c.kern),
                value(&c.mean, &c.var, &b, &c.kern),
                "z",
            );
        }
        let (mut a, mut b) = (c.kern.clone(), c.kern.clone());
        a.variance += h;
        b.variance -= h;
        check(
            g.d_variance,
            value(&c.mean, &c.var, &c.z, &a),
            value(&c.mean, &c.var, &c.z, &b),
            "variance",
        );
        for t in 0..q {
            let (mut a, mut b) = (c.kern.clone(), c.kern.clone());
            a.lengthscale[t] += h;
            b.lengthscale[t] -= h;
            check(
                g.d_lengthscale[t],
                value(&c.mean, &c.var, &c.z, &a),
                value(&c.mean, &c.var, &c.z, &b),
                "lengthscale",
            );
        }
    }

    /// More frames than one block, on the pool: the same numbers as on one thread.
    #[test]
    fn blocks_on_threads_give_the_same_numbers() {
        let (n, m, q) = (3 * BLOCK + 5, 6, 2);
        let c = case(n, m, q, 3);
        let serial = psi_stats(&c.mean, &c.var, &c.z, q, &c.kern);
        let pooled = crate::pool::in_pool(|| psi_stats(&c.mean, &c.var, &c.z, q, &c.kern));
        assert!(serial.psi1 == pooled.psi1 && serial.psi2 == pooled.psi2);
    }
}
