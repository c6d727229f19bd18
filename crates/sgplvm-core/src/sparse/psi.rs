//! The Ψ statistics of an RBF-ARD kernel under a Gaussian q(X) = ∏ₙ N(μₙ, diag Sₙ) (Titsias &
//! Lawrence 2010; GPy's `rbf_psi_comp`), and their chain rule: what the Bayesian GP-LVM's bound
//! uses in place of K_nn's trace, K_nm and K_mn K_nm.
//!
//! With `u_q = ℓ_q²`, `z̄ = (z_m + z_m')/2`:
//! - `ψ₀ = N α²`;
//! - `Ψ₁[n, m] = α² ∏_q (1 + S_nq/u_q)^(−½) exp(−½ (μ_nq − z_mq)² / (u_q + S_nq))` (N×M);
//! - `Ψ₂ = Σₙ Ψ₂ₙ`, `Ψ₂ₙ[m, m'] = α⁴ ∏_q (1 + 2S_nq/u_q)^(−½)
//!   exp(−(z_mq − z_m'q)²/(4u_q) − (μ_nq − z̄_q)²/(u_q + 2S_nq))` (M×M).
//!
//! Given `∂L/∂ψ₀`, `∂L/∂Ψ₁`, `∂L/∂Ψ₂` ([`psi_chain`]) the derivatives of log Ψ (below, per q)
//! give those with respect to μ, S, Z, α² and ℓ:
//! - Ψ₁: `∂/∂μ = −d/(u+S)`, `∂/∂z = d/(u+S)`, `∂/∂S = −½/(u+S) + ½ d²/(u+S)²`,
//!   `∂/∂u = S/(2u(u+S)) + d²/(2(u+S)²)` with `d = μ − z`;
//! - Ψ₂ₙ: `∂/∂μ = −2e/(u+2S)`, `∂/∂S = −1/(u+2S) + 2e²/(u+2S)²`,
//!   `∂/∂u = S/(u(u+2S)) + Δ²/(4u²) + e²/(u+2S)²`, `∂/∂z_m = −Δ/(2u) + e/(u+2S)` with
//!   `e = μ − z̄`, `Δ = z_m − z_m'` (and `+Δ/(2u) + e/(u+2S)` for z_m').
//!
//! The frames are processed in fixed blocks (on the pool's threads when called on one) whose
//! partial sums are added in order: the results do not depend on the number of threads. Memory
//! beyond the inputs: Ψ₁ (N×M) and per block one M×M sum; no N×M×M array is formed (GPy's is
//! 480 MB at N = 3,000, M = 50, Q = 8).

use faer::{Mat, MatRef};
use rayon::prelude::*;

use crate::kernel::KernelParams;

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
}

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

/// The frame-independent parts of Ψ₂ for every pair m ≤ m' (`pair` indexes them row by row of
/// the lower triangle): z̄ and `α⁴ exp(−Σ_q Δ²/(4u_q))`, and for the chain rule Δ.
struct Pairs {
    /// (m, m') with m' ≤ m, in order.
    index: Vec<(usize, usize)>,
    /// z̄ per pair (pairs × Q).
    mid: Vec<f64>,
    /// Δ = z_m − z_m' per pair (pairs × Q).
    delta: Vec<f64>,
    /// α⁴ exp(−Σ_q Δ²/(4u_q)) per pair.
    scale: Vec<f64>,
}

impl Pairs {
    fn new(zr: &[f64], q: usize, kern: &KernelParams) -> Self {
        let m = zr.len() / q.max(1);
        let a4 = kern.variance * kern.variance;
        let mut p = Pairs {
            index: Vec::with_capacity(m * (m + 1) / 2),
            mid: Vec::with_capacity(m * (m + 1) / 2 * q),
            delta: Vec::with_capacity(m * (m + 1) / 2 * q),
            scale: Vec::with_capacity(m * (m + 1) / 2),
        };
        for a in 0..m {
            for b in 0..=a {
                let mut s = 0.0;
                for t in 0..q {
                    let (za, zb) = (zr[a * q + t], zr[b * q + t]);
                    let u = kern.lengthscale[t] * kern.lengthscale[t];
                    let dl = za - zb;
                    p.mid.push(0.5 * (za + zb));
                    p.delta.push(dl);
                    s += dl * dl / (4.0 * u);
                }
                p.index.push((a, b));
                p.scale.push(a4 * (-s).exp());
            }
        }
        p
    }
}

/// Per frame, the factors every Ψ term of that frame shares: `1/(u_q + S_nq)`,
/// `1/(u_q + 2S_nq)` and the two products `∏(1 + S/u)^(−½)`, `∏(1 + 2S/u)^(−½)`.
struct FrameTerms {
    inv1: Vec<f64>,
    inv2: Vec<f64>,
    c1: f64,
    c2: f64,
}

impl FrameTerms {
    fn new(s: &[f64], u: &[f64]) -> Self {
        let inv1: Vec<f64> = s.iter().zip(u).map(|(s, u)| 1.0 / (u + s)).collect();
        let inv2: Vec<f64> = s.iter().zip(u).map(|(s, u)| 1.0 / (u + 2.0 * s)).collect();
        // (1 + S/u)^(−½) = √(u/(u+S)).
        let c1 = s.iter().zip(u).map(|(s, u)| (u / (u + s)).sqrt()).product();
        let c2 = s
            .iter()
            .zip(u)
            .map(|(s, u)| (u / (u + 2.0 * s)).sqrt())
            .product();
        FrameTerms { inv1, inv2, c1, c2 }
    }
}

/// Runs `f` on each block of frames (start, length) and returns the results in block order, on
/// the pool's threads when the caller is on one and there is more than one block.
fn over_blocks<R: Send>(n: usize, f: impl Fn(usize, usize) -> R + Sync + Send) -> Vec<R> {
    let blocks: Vec<(usize, usize)> = (0..n.div_ceil(BLOCK))
        .map(|b| (b * BLOCK, BLOCK.min(n - b * BLOCK)))
        .collect();
    if blocks.len() > 1 && crate::pool::on_pool_thread() {
        blocks.into_par_iter().map(|(s, l)| f(s, l)).collect()
    } else {
        blocks.into_iter().map(|(s, l)| f(s, l)).collect()
    }
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
    let n = mean.len() / q.max(1);
    let m = zr.len() / q.max(1);
    let u: Vec<f64> = kern.lengthscale.iter().map(|l| l * l).collect();
    let pairs = Pairs::new(zr, q, kern);
    let parts = over_blocks(n, |start, len| {
        let mut psi1 = vec![0.0; len * m];
        let mut psi2 = vec![0.0; pairs.index.len()];
        for (k, i) in (start..start + len).enumerate() {
            let (mu, s) = (&mean[i * q..(i + 1) * q], &var[i * q..(i + 1) * q]);
            let f = FrameTerms::new(s, &u);
            for j in 0..m {
                let z = &zr[j * q..(j + 1) * q];
                let e: f64 = (0..q).map(|t| (mu[t] - z[t]).powi(2) * f.inv1[t]).sum();
                psi1[k * m + j] = kern.variance * f.c1 * (-0.5 * e).exp();
            }
            for (p, out) in psi2.iter_mut().enumerate() {
                let mid = &pairs.mid[p * q..(p + 1) * q];
                let e: f64 = (0..q).map(|t| (mu[t] - mid[t]).powi(2) * f.inv2[t]).sum();
                *out += pairs.scale[p] * f.c2 * (-e).exp();
            }
        }
        (psi1, psi2)
    });
    let mut psi1 = Mat::zeros(n, m);
    let mut sum2 = vec![0.0; pairs.index.len()];
    for (b, (p1, p2)) in parts.into_iter().enumerate() {
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
    let mut psi2 = Mat::zeros(m, m);
    for (p, &(a, b)) in pairs.index.iter().enumerate() {
        psi2[(a, b)] = sum2[p];
        psi2[(b, a)] = sum2[p];
    }
    Psi {
        psi0: n as f64 * kern.variance,
        psi1,
        psi2,
    }
}

/// One block's share of [`psi_chain`]: its frames' ∂μ and ∂S (written in place), and its sums
/// of ∂Z, ∂α² and ∂u.
struct BlockGrad {
    d_z: Vec<f64>,
    d_variance: f64,
    d_u: Vec<f64>,
}

/// The derivatives of a scalar L through the Ψ statistics of [`psi_stats`], given `g0 = ∂L/∂ψ₀`,
/// `g1 = ∂L/∂Ψ₁` (N×M) and `g2 = ∂L/∂Ψ₂` (M×M; symmetrised here). Ψ₁ is taken from `psi1` (it
/// was computed already); Ψ₂ₙ is formed again frame by frame.
#[allow(clippy::too_many_arguments)]
pub(crate) fn psi_chain(
    mean: &[f64],
    var: &[f64],
    zr: &[f64],
    q: usize,
    kern: &KernelParams,
    psi1: MatRef<'_, f64>,
    g0: f64,
    g1: MatRef<'_, f64>,
    g2: MatRef<'_, f64>,
) -> PsiGrad {
    let n = mean.len() / q.max(1);
    let m = zr.len() / q.max(1);
    let u: Vec<f64> = kern.lengthscale.iter().map(|l| l * l).collect();
    let pairs = Pairs::new(zr, q, kern);
    // Each unordered pair once: off-diagonal pairs stand for (m, m') and (m', m).
    let weight: Vec<f64> = pairs
        .index
        .iter()
        .map(|&(a, b)| match a == b {
            true => g2[(a, a)],
            false => g2[(a, b)] + g2[(b, a)],
        })
        .collect();
    let mut d_mean = vec![0.0; n * q];
    let mut d_var = vec![0.0; n * q];
    let chunks: Vec<(&mut [f64], &mut [f64])> = d_mean
        .chunks_mut(BLOCK * q)
        .zip(d_var.chunks_mut(BLOCK * q))
        .collect();
    let chunks: Vec<std::sync::Mutex<(&mut [f64], &mut [f64])>> =
        chunks.into_iter().map(std::sync::Mutex::new).collect();
    let parts = over_blocks(n, |start, len| {
        let mut guard = crate::pool::lock(&chunks[start / BLOCK]);
        let (dm, ds) = &mut *guard;
        let mut out = BlockGrad {
            d_z: vec![0.0; m * q],
            d_variance: 0.0,
            d_u: vec![0.0; q],
        };
        for (k, i) in (start..start + len).enumerate() {
            let (mu, s) = (&mean[i * q..(i + 1) * q], &var[i * q..(i + 1) * q]);
            let f = FrameTerms::new(s, &u);
            let (dmu, dsn) = (&mut dm[k * q..(k + 1) * q], &mut ds[k * q..(k + 1) * q]);
            // Ψ₁.
            let mut w1_sum = 0.0;
            for j in 0..m {
                let w = g1[(i, j)] * psi1[(i, j)];
                if w == 0.0 {
                    continue;
                }
                w1_sum += w;
                let z = &zr[j * q..(j + 1) * q];
                for t in 0..q {
                    let d = mu[t] - z[t];
                    let a = f.inv1[t];
                    dmu[t] -= w * d * a;
                    out.d_z[j * q + t] += w * d * a;
                    dsn[t] += w * 0.5 * (d * d * a * a - a);
                    out.d_u[t] += w * 0.5 * d * d * a * a;
                }
            }
            out.d_variance += w1_sum / kern.variance;
            // Ψ₂ₙ.
            let mut w2_sum = 0.0;
            for (p, &(a, b)) in pairs.index.iter().enumerate() {
                let mid = &pairs.mid[p * q..(p + 1) * q];
                let e2: f64 = (0..q).map(|t| (mu[t] - mid[t]).powi(2) * f.inv2[t]).sum();
                let w = weight[p] * pairs.scale[p] * f.c2 * (-e2).exp();
                if w == 0.0 {
                    continue;
                }
                w2_sum += w;
                let delta = &pairs.delta[p * q..(p + 1) * q];
                for t in 0..q {
                    let e = mu[t] - mid[t];
                    let c = f.inv2[t];
                    dmu[t] -= 2.0 * w * e * c;
                    dsn[t] += w * (2.0 * e * e * c * c - c);
                    out.d_u[t] += w * (delta[t] * delta[t] / (4.0 * u[t] * u[t]) + e * e * c * c);
                    let dz = delta[t] / (2.0 * u[t]);
                    out.d_z[a * q + t] += w * (e * c - dz);
                    out.d_z[b * q + t] += w * (e * c + dz);
                }
            }
            out.d_variance += 2.0 * w2_sum / kern.variance;
            // The determinant factors' ∂/∂u, shared by every term of the frame.
            for t in 0..q {
                let st = s[t];
                out.d_u[t] += w1_sum * st / (2.0 * u[t] * (u[t] + st))
                    + w2_sum * st / (u[t] * (u[t] + 2.0 * st));
            }
        }
        out
    });
    let mut d_z = vec![0.0; m * q];
    let mut d_variance = g0 * n as f64;
    let mut d_u = vec![0.0; q];
    for part in parts {
        for (a, b) in d_z.iter_mut().zip(&part.d_z) {
            *a += b;
        }
        d_variance += part.d_variance;
        for (a, b) in d_u.iter_mut().zip(&part.d_u) {
            *a += b;
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

    fn lcg(seed: &mut u64) -> f64 {
        *seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((*seed >> 11) as f64) / ((1u64 << 53) as f64)
    }

    struct Case {
        mean: Vec<f64>,
        var: Vec<f64>,
        z: Vec<f64>,
        q: usize,
        kern: KernelParams,
    }

    fn case(n: usize, m: usize, q: usize, seed: u64) -> Case {
        let mut s = seed;
        let mut r = |a: f64, b: f64| a + (b - a) * lcg(&mut s);
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
        let mut seed = 99;
        let g0 = 0.7;
        let g1 = Mat::from_fn(n, m, |_, _| lcg(&mut seed) - 0.5);
        let g2r = Mat::from_fn(m, m, |_, _| lcg(&mut seed) - 0.5);
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
            g0,
            g1.as_ref(),
            g2.as_ref(),
        );
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
