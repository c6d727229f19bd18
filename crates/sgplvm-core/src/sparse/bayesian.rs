//! The Bayesian GP-LVM's bound (Titsias & Lawrence 2010) and its shared, multi-view form
//! (manifold relevance determination, Damianou et al. 2012; GPy's `BayesianGPLVM` and `MRD`):
//! the latent points get a Gaussian posterior q(X) = ∏ₙ N(μₙ, diag Sₙ), each space its own
//! RBF-ARD kernel and noise, all spaces the inducing inputs Z.
//!
//! The negative bound is `Σ_s L_s + KL(q(X) ‖ N(0, I))`, `KL = ½ Σ (μ² + S − log S − 1)`, and
//! per space, with the Ψ statistics of `psi`, `β = 1/σ²`, `K_mm = L_m L_mᵀ`,
//! `C = L_m⁻¹ Ψ₂ L_m⁻ᵀ`, `B = I + β C = L_B L_Bᵀ`, `c = L_B⁻¹ L_m⁻¹ Ψ₁ᵀ Y`:
//!
//! `L_s = N D/2 log 2π + N D/2 log σ² + D Σ log diag L_B + β/2 ‖Y‖² − β²/2 ‖c‖²
//!        + D β/2 (ψ₀ − tr C)`.
//!
//! With point latent positions (S = 0) it is the sparse model's bound (`likelihood`). Gradient:
//! with `K̃ = K_mm + β Ψ₂` and `v = K̃⁻¹ Ψ₁ᵀ Y`,
//! `∂L/∂ψ₀ = D β/2`, `∂L/∂Ψ₁ = −β² Y vᵀ`,
//! `∂L/∂Ψ₂ = D β/2 (K̃⁻¹ − K_mm⁻¹) + β³/2 v vᵀ`,
//! `∂L/∂K_mm = D/2 (K̃⁻¹ − K_mm⁻¹) + β²/2 v vᵀ + D β/2 K_mm⁻¹ Ψ₂ K_mm⁻¹`,
//! `∂L/∂β = −N D/(2β) + D/2 tr(K̃⁻¹ Ψ₂) + ‖Y‖²/2 − β ‖c‖² + β²/2 tr(vᵀ Ψ₂ v)
//!          + D/2 (ψ₀ − tr(K_mm⁻¹ Ψ₂))`;
//! the Ψ statistics' chain rule (`psi::psi_chain`) and K_mm's give the rest. One space costs
//! O(N M² Q + M³ + N M D) time and O(N M + M² Q) memory.

use faer::linalg::matmul::matmul;
use faer::linalg::triangular_solve::solve_lower_triangular_in_place;
use faer::{Accum, Mat, MatRef, Par};

use super::psi::{psi_chain, psi_stats, Psi};
use crate::error::{Error, Result};
use crate::kernel::{rbf_lower, row_major, KernelParams};
use crate::likelihood::{cholesky_with_jitter, NotPd};
use crate::simd::clear_upper_simd_state;

const LN_2PI: f64 = 1.837_877_066_409_345_5;

/// What is added to K_mm's diagonal.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Jitter {
    /// `c × α²`: the same at every data scale, and `∂K_mm/∂α² = K_mm/α²` holds exactly (the
    /// model's choice, as the sparse model's).
    Relative(f64),
    /// A constant (GPy's `VarDTC` adds 1e-8), not differentiated.
    Absolute(f64),
}

impl Jitter {
    fn amount(self, variance: f64) -> f64 {
        match self {
            Jitter::Relative(c) => c * variance,
            Jitter::Absolute(a) => a,
        }
    }
}

/// One space's negative bound and, when asked, its gradient.
#[derive(Clone, Debug)]
pub(crate) struct BayesSpaceEval {
    /// The space's term L_s (the KL term is not in it).
    pub nll: f64,
    /// Jitter added to K_mm beyond [`Jitter`] because a factorisation failed (0 normally).
    pub extra_jitter: f64,
    /// ∂L_s/∂α², ∂L_s/∂ℓ_q, ∂L_s/∂σ².
    pub d_variance: f64,
    pub d_lengthscale: Vec<f64>,
    pub d_noise: f64,
    /// ∂L_s/∂μ, ∂L_s/∂S (N×Q) and ∂L_s/∂Z (M×Q), row-major; empty without the gradient.
    pub d_mean: Vec<f64>,
    pub d_var: Vec<f64>,
    pub d_z: Vec<f64>,
    /// The prediction weights `β v` (M×D): the mean at a latent point x* is `k(x*, Z)ᵀ β v`.
    pub mean_weights: Mat<f64>,
    /// `K_mm⁻¹ − K̃⁻¹` (M×M): the variance at x* is `α² − k*ᵀ (K_mm⁻¹ − K̃⁻¹) k*`.
    pub var_matrix: Mat<f64>,
}

/// `L⁻¹` of a lower-triangular `l`.
fn lower_inverse(l: MatRef<'_, f64>) -> Mat<f64> {
    let mut inv = Mat::<f64>::identity(l.nrows(), l.nrows());
    solve_lower_triangular_in_place(l, inv.as_mut(), Par::Seq);
    clear_upper_simd_state();
    inv
}

/// `a b` (or with `ta`/`tb` the transposes).
fn mul(a: MatRef<'_, f64>, b: MatRef<'_, f64>) -> Mat<f64> {
    let mut out = Mat::zeros(a.nrows(), b.ncols());
    matmul(out.as_mut(), Accum::Replace, a, b, 1.0, Par::Seq);
    clear_upper_simd_state();
    out
}

/// `Lᵀ L` for the inverse factor L: `(L_orig L_origᵀ)⁻¹ = L_orig⁻ᵀ L_orig⁻¹`.
fn inverse_from_lower_inverse(linv: MatRef<'_, f64>) -> Mat<f64> {
    mul(linv.transpose(), linv)
}

fn trace_product(a: MatRef<'_, f64>, b: MatRef<'_, f64>) -> f64 {
    let mut t = 0.0;
    for j in 0..a.ncols() {
        for i in 0..a.nrows() {
            t += a[(i, j)] * b[(j, i)];
        }
    }
    t
}

/// Evaluates one space at means `mean`, variances `var` (N×Q row-major) and inducing inputs
/// `zr` (M×Q row-major) for data `y` (N×D, used as given).
#[allow(clippy::too_many_arguments)]
pub(crate) fn eval_bayes_space(
    mean: &[f64],
    var: &[f64],
    zr: &[f64],
    q: usize,
    y: MatRef<'_, f64>,
    kern: &KernelParams,
    jitter: Jitter,
    grad: bool,
) -> Result<BayesSpaceEval, NotPd> {
    let (n, d) = (y.nrows(), y.ncols());
    let m = zr.len() / q.max(1);
    let (nf, df) = (n as f64, d as f64);
    let beta = 1.0 / kern.noise;

    // K_mm (both triangles) and its factor.
    let mut kz = Mat::zeros(m, m);
    rbf_lower(zr, q, kern, &mut kz, Par::Seq);
    for j in 0..m {
        for i in 0..j {
            kz[(i, j)] = kz[(j, i)];
        }
    }
    let jit = jitter.amount(kern.variance);
    let mut lm = Mat::zeros(m, m);
    let extra_jitter = cholesky_with_jitter(kz.as_ref(), jit, lm.as_mut(), Par::Seq)?;
    for j in 0..m {
        for i in 0..j {
            lm[(i, j)] = 0.0;
        }
    }
    let linv = lower_inverse(lm.as_ref());

    let Psi {
        psi0,
        psi1,
        psi2,
        pairs,
    } = psi_stats(mean, var, zr, q, kern);
    // C = L_m⁻¹ Ψ₂ L_m⁻ᵀ, B = I + β C.
    let c = mul(mul(linv.as_ref(), psi2.as_ref()).as_ref(), linv.transpose());
    let mut b = Mat::from_fn(m, m, |i, j| beta * 0.5 * (c[(i, j)] + c[(j, i)]));
    for i in 0..m {
        b[(i, i)] += 1.0;
    }
    let mut lb = Mat::zeros(m, m);
    cholesky_with_jitter(b.as_ref(), 0.0, lb.as_mut(), Par::Seq)?;
    for j in 0..m {
        for i in 0..j {
            lb[(i, j)] = 0.0;
        }
    }
    let lbinv = lower_inverse(lb.as_ref());
    // P = L_m⁻¹ Ψ₁ᵀ Y, c_y = L_B⁻¹ P.
    let psi1y = mul(psi1.transpose(), y);
    let p = mul(linv.as_ref(), psi1y.as_ref());
    let cy = mul(lbinv.as_ref(), p.as_ref());
    let yy: f64 = y
        .col_iter()
        .map(|c| c.iter().map(|v| v * v).sum::<f64>())
        .sum();
    let cc: f64 = cy
        .col_iter()
        .map(|c| c.iter().map(|v| v * v).sum::<f64>())
        .sum();
    let trace_c: f64 = (0..m).map(|i| c[(i, i)]).sum();
    let log_det_b: f64 = (0..m).map(|i| lb[(i, i)].ln()).sum();
    let nll = 0.5 * nf * df * (LN_2PI + kern.noise.ln()) + df * log_det_b + 0.5 * beta * yy
        - 0.5 * beta * beta * cc
        + 0.5 * df * beta * (psi0 - trace_c);

    // K̃⁻¹ = L_m⁻ᵀ B⁻¹ L_m⁻¹, K_mm⁻¹, v = K̃⁻¹ Ψ₁ᵀ Y.
    let l_full = mul(lbinv.as_ref(), linv.as_ref()); // (L_m L_B)⁻¹
    let ktinv = inverse_from_lower_inverse(l_full.as_ref());
    let kinv = inverse_from_lower_inverse(linv.as_ref());
    let v = mul(l_full.transpose(), cy.as_ref());
    let mean_weights = Mat::from_fn(m, d, |i, j| beta * v[(i, j)]);
    let var_matrix = Mat::from_fn(m, m, |i, j| kinv[(i, j)] - ktinv[(i, j)]);
    let mut out = BayesSpaceEval {
        nll,
        extra_jitter,
        d_variance: 0.0,
        d_lengthscale: vec![0.0; q],
        d_noise: 0.0,
        d_mean: Vec::new(),
        d_var: Vec::new(),
        d_z: Vec::new(),
        mean_weights,
        var_matrix,
    };
    if !grad {
        return Ok(out);
    }

    let vvt = mul(v.as_ref(), v.transpose());
    let kpk = mul(mul(kinv.as_ref(), psi2.as_ref()).as_ref(), kinv.as_ref());
    let g0 = 0.5 * df * beta;
    let yv = mul(y, v.transpose());
    let g1 = Mat::from_fn(n, m, |i, j| -beta * beta * yv[(i, j)]);
    let g2 = Mat::from_fn(m, m, |i, j| {
        0.5 * df * beta * (ktinv[(i, j)] - kinv[(i, j)]) + 0.5 * beta.powi(3) * vvt[(i, j)]
    });
    let gk = Mat::from_fn(m, m, |i, j| {
        0.5 * df * (ktinv[(i, j)] - kinv[(i, j)])
            + 0.5 * beta * beta * vvt[(i, j)]
            + 0.5 * df * beta * kpk[(i, j)]
    });
    let vpv = trace_product(v.transpose(), mul(psi2.as_ref(), v.as_ref()).as_ref());
    let d_beta =
        -0.5 * nf * df / beta + 0.5 * df * trace_product(ktinv.as_ref(), psi2.as_ref()) + 0.5 * yy
            - beta * cc
            + 0.5 * beta * beta * vpv
            + 0.5 * df * (psi0 - trace_product(kinv.as_ref(), psi2.as_ref()));
    out.d_noise = -beta * beta * d_beta;

    let pg = psi_chain(
        mean,
        var,
        zr,
        q,
        kern,
        psi1.as_ref(),
        &pairs,
        g0,
        g1.as_ref(),
        g2.as_ref(),
    );
    out.d_mean = pg.d_mean;
    out.d_var = pg.d_var;
    out.d_z = pg.d_z;
    out.d_variance = pg.d_variance;
    out.d_lengthscale = pg.d_lengthscale;
    add_kmm_share(&mut out, gk.as_ref(), kz.as_ref(), zr, kern, jitter);
    Ok(out)
}

/// Adds K_mm's share of the gradient, given `gk = ∂L/∂K_mm` and `kz = k(Z, Z)` (without the
/// jitter): `k(Z, Z) = α² exp(−½ Σ Δ²/u)` gives ∂/∂α², ∂/∂ℓ and ∂/∂Z; a relative jitter adds
/// its own ∂/∂α².
fn add_kmm_share(
    out: &mut BayesSpaceEval,
    gk: MatRef<'_, f64>,
    kz: MatRef<'_, f64>,
    zr: &[f64],
    kern: &KernelParams,
    jitter: Jitter,
) {
    let (m, q) = (kz.nrows(), kern.lengthscale.len());
    let mut weighted = 0.0;
    for a in 0..m {
        for bb in 0..m {
            let w = gk[(a, bb)] * kz[(a, bb)];
            weighted += w;
            if a == bb {
                continue;
            }
            for t in 0..q {
                let l = kern.lengthscale[t];
                let u = l * l;
                let dl = zr[a * q + t] - zr[bb * q + t];
                out.d_lengthscale[t] += w * dl * dl / (2.0 * u * u) * 2.0 * l;
                out.d_z[a * q + t] -= 2.0 * w * dl / u;
            }
        }
    }
    out.d_variance += weighted / kern.variance;
    if let Jitter::Relative(c) = jitter {
        out.d_variance += c * (0..m).map(|i| gk[(i, i)]).sum::<f64>();
    }
}

/// `KL(q(X) ‖ N(0, I)) = ½ Σ (μ² + S − log S − 1)`, and its gradient added to `d_mean`,
/// `d_var` when given.
pub(crate) fn kl_divergence(
    mean: &[f64],
    var: &[f64],
    grad: Option<(&mut [f64], &mut [f64])>,
) -> f64 {
    let kl = 0.5
        * mean
            .iter()
            .zip(var)
            .map(|(m, s)| m * m + s - s.ln() - 1.0)
            .sum::<f64>();
    if let Some((dm, ds)) = grad {
        for (g, m) in dm.iter_mut().zip(mean) {
            *g += m;
        }
        for (g, s) in ds.iter_mut().zip(var) {
            *g += 0.5 * (1.0 - 1.0 / s);
        }
    }
    kl
}

/// One space's part of [`BayesianBound`]: the derivatives of the negative bound with respect to
/// its kernel and noise.
#[derive(Clone, Debug, PartialEq)]
pub struct SpaceGradient {
    /// ∂/∂α².
    pub variance: f64,
    /// ∂/∂ℓ_q.
    pub lengthscale: Vec<f64>,
    /// ∂/∂σ².
    pub noise: f64,
}

/// The negative variational bound of a shared Bayesian GP-LVM and its gradient, in natural
/// units (GPy's parametrisation: means, variances, inducing inputs, per space α², ℓ, σ²).
#[derive(Clone, Debug)]
pub struct BayesianBound {
    /// `Σ_s L_s + KL`: GPy's `objective_function()` of `MRD` (or `BayesianGPLVM` for one space).
    pub value: f64,
    /// The KL term alone.
    pub kl: f64,
    /// ∂/∂μ (N×Q).
    pub d_mean: Mat<f64>,
    /// ∂/∂S (N×Q).
    pub d_variance: Mat<f64>,
    /// ∂/∂Z (M×Q).
    pub d_inducing: Mat<f64>,
    /// Per space, its kernel's and noise's derivatives.
    pub spaces: Vec<SpaceGradient>,
}

/// The negative bound of the Bayesian GP-LVM (one space) or MRD (several, sharing q(X) and Z)
/// and its gradient, at means `mean` and variances `variance` of q(X) (N×Q), inducing inputs
/// `z` (M×Q), data `ys` (each N×D_s, used as given: not centred) and one RBF-ARD kernel with
/// Gaussian noise per space; `jitter` is added to each K_mm's diagonal (GPy: absolute 1e-8).
/// For checks against other implementations; O(N M² Q) per space.
pub fn bayesian_bound(
    mean: MatRef<'_, f64>,
    variance: MatRef<'_, f64>,
    z: MatRef<'_, f64>,
    ys: &[MatRef<'_, f64>],
    kernels: &[KernelParams],
    jitter: Jitter,
) -> Result<BayesianBound> {
    let (n, q) = (mean.nrows(), mean.ncols());
    let mut dims = vec![
        ("variance rows", variance.nrows(), n),
        ("variance columns", variance.ncols(), q),
        ("z columns", z.ncols(), q),
        ("kernels", kernels.len(), ys.len()),
    ];
    for (y, k) in ys.iter().zip(kernels) {
        dims.push(("y rows", y.nrows(), n));
        dims.push(("kernel lengthscales", k.lengthscale.len(), q));
    }
    for (what, found, expected) in dims {
        if found != expected {
            return Err(Error::DimensionMismatch {
                what: format!("bayesian_bound: {what}"),
                expected,
                found,
            });
        }
    }
    let jitter_ok = match jitter {
        Jitter::Relative(c) | Jitter::Absolute(c) => c.is_finite() && c >= 0.0,
    };
    if ys.is_empty() || !kernels.iter().all(KernelParams::is_valid) || !jitter_ok {
        return Err(Error::InvalidValue {
            what: "bayesian_bound".into(),
            reason:
                "expected at least one space, kernels of finite values > 0 and a finite jitter ≥ 0"
                    .into(),
        });
    }
    for (name, m) in [("mean", mean), ("variance", variance), ("z", z)] {
        crate::preprocess::check_finite(name, m)?;
    }
    for y in ys {
        crate::preprocess::check_finite("y", *y)?;
    }
    if variance.col_iter().any(|c| c.iter().any(|&s| s <= 0.0)) {
        return Err(Error::InvalidValue {
            what: "bayesian_bound: variance".into(),
            reason: "expected every variance of q(X) > 0".into(),
        });
    }
    let (mr, sr, zr) = (row_major(mean), row_major(variance), row_major(z));
    let mut d_mean = vec![0.0; n * q];
    let mut d_var = vec![0.0; n * q];
    let mut d_z = vec![0.0; zr.len()];
    let mut value = 0.0;
    let mut spaces = Vec::with_capacity(ys.len());
    for (s, (y, k)) in ys.iter().zip(kernels).enumerate() {
        let e = eval_bayes_space(&mr, &sr, &zr, q, *y, k, jitter, true)
            .map_err(|e| e.in_space(&format!("space {s}")))?;
        value += e.nll;
        for (a, b) in d_mean.iter_mut().zip(&e.d_mean) {
            *a += b;
        }
        for (a, b) in d_var.iter_mut().zip(&e.d_var) {
            *a += b;
        }
        for (a, b) in d_z.iter_mut().zip(&e.d_z) {
            *a += b;
        }
        spaces.push(SpaceGradient {
            variance: e.d_variance,
            lengthscale: e.d_lengthscale,
            noise: e.d_noise,
        });
    }
    let kl = kl_divergence(&mr, &sr, Some((&mut d_mean, &mut d_var)));
    let from_rows = |r: &[f64], rows: usize| Mat::from_fn(rows, q, |i, t| r[i * q + t]);
    Ok(BayesianBound {
        value: value + kl,
        kl,
        d_mean: from_rows(&d_mean, n),
        d_variance: from_rows(&d_var, n),
        d_inducing: from_rows(&d_z, z.nrows()),
        spaces,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_support::{ChaCha8Rng, Rng, SeedableRng};

    struct Case {
        mean: Mat<f64>,
        var: Mat<f64>,
        z: Mat<f64>,
        ys: Vec<Mat<f64>>,
        kernels: Vec<KernelParams>,
    }

    fn case(n: usize, m: usize, q: usize, dims: &[usize], seed: u64) -> Case {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut r = |a: f64, b: f64| rng.random_range(a..b);
        let mean = Mat::from_fn(n, q, |_, _| r(-1.5, 1.5));
        let var = Mat::from_fn(n, q, |_, _| r(0.05, 0.6));
        let z = Mat::from_fn(m, q, |_, _| r(-1.5, 1.5));
        let ys = dims
            .iter()
            .map(|&d| {
                Mat::from_fn(n, d, |i, j| {
                    (mean[(i, 0)] * (j as f64 + 1.0)).sin() + r(-0.3, 0.3)
                })
            })
            .collect();
        let kernels = dims
            .iter()
            .map(|_| KernelParams {
                variance: r(0.5, 2.0),
                lengthscale: (0..q).map(|_| r(0.7, 2.0)).collect(),
                noise: r(0.05, 0.4),
            })
            .collect();
        Case {
            mean,
            var,
            z,
            ys,
            kernels,
        }
    }

    fn value(c: &Case, jitter: Jitter) -> f64 {
        let ys: Vec<MatRef<'_, f64>> = c.ys.iter().map(|y| y.as_ref()).collect();
        bayesian_bound(
            c.mean.as_ref(),
            c.var.as_ref(),
            c.z.as_ref(),
            &ys,
            &c.kernels,
            jitter,
        )
        .unwrap()
        .value
    }

    /// Every derivative against central differences, for both jitter kinds.
    #[test]
    fn gradient_matches_finite_differences() {
        for jitter in [Jitter::Relative(1e-6), Jitter::Absolute(1e-8)] {
            let c = case(12, 5, 3, &[4, 2], 5);
            let ys: Vec<MatRef<'_, f64>> = c.ys.iter().map(|y| y.as_ref()).collect();
            let g = bayesian_bound(
                c.mean.as_ref(),
                c.var.as_ref(),
                c.z.as_ref(),
                &ys,
                &c.kernels,
                jitter,
            )
            .unwrap();
            let h = 1e-6;
            let fd = |edit: &dyn Fn(&mut Case, f64)| {
                let mut a = Case {
                    mean: c.mean.clone(),
                    var: c.var.clone(),
                    z: c.z.clone(),
                    ys: c.ys.clone(),
                    kernels: c.kernels.clone(),
                };
                edit(&mut a, h);
                let plus = value(&a, jitter);
                edit(&mut a, -2.0 * h);
                let minus = value(&a, jitter);
                (plus - minus) / (2.0 * h)
            };
            let close = |an: f64, fd: f64, what: String| {
                assert!(
                    (an - fd).abs() <= 1e-5 * (1.0 + fd.abs()),
                    "{what}: {an} vs {fd} ({jitter:?})"
                );
            };
            for i in 0..12 {
                for t in 0..3 {
                    close(
                        g.d_mean[(i, t)],
                        fd(&|c, h| c.mean[(i, t)] += h),
                        format!("mean {i} {t}"),
                    );
                    close(
                        g.d_variance[(i, t)],
                        fd(&|c, h| c.var[(i, t)] += h),
                        format!("var {i} {t}"),
                    );
                }
            }
            for i in 0..5 {
                for t in 0..3 {
                    close(
                        g.d_inducing[(i, t)],
                        fd(&|c, h| c.z[(i, t)] += h),
                        format!("z {i} {t}"),
                    );
                }
            }
            for s in 0..2 {
                close(
                    g.spaces[s].variance,
                    fd(&|c, h| c.kernels[s].variance += h),
                    format!("α² {s}"),
                );
                close(
                    g.spaces[s].noise,
                    fd(&|c, h| c.kernels[s].noise += h),
                    format!("σ² {s}"),
                );
                for t in 0..3 {
                    close(
                        g.spaces[s].lengthscale[t],
                        fd(&|c, h| c.kernels[s].lengthscale[t] += h),
                        format!("ℓ {s} {t}"),
                    );
                }
            }
        }
    }

    /// With vanishing variances the space terms are the sparse model's bound at X = μ.
    #[test]
    fn with_point_latents_it_is_the_sparse_bound() {
        let mut c = case(15, 6, 2, &[3], 11);
        c.var = Mat::from_fn(15, 2, |_, _| 1e-13);
        let ys = [c.ys[0].as_ref()];
        let b = bayesian_bound(
            c.mean.as_ref(),
            c.var.as_ref(),
            c.z.as_ref(),
            &ys,
            &c.kernels,
            Jitter::Relative(1e-6),
        )
        .unwrap();
        let sparse =
            super::super::sparse_bound(c.mean.as_ref(), c.z.as_ref(), ys[0], &c.kernels[0], 1e-6)
                .unwrap();
        assert!(
            ((b.value - b.kl) - sparse).abs() <= 1e-9 * sparse.abs(),
            "{} vs {sparse}",
            b.value - b.kl
        );
    }

    #[test]
    fn bad_input_is_refused_by_name() {
        let c = case(6, 3, 2, &[2], 1);
        let ys = [c.ys[0].as_ref()];
        let zero_var = Mat::from_fn(6, 2, |i, _| if i == 2 { 0.0 } else { 0.1 });
        let e = bayesian_bound(
            c.mean.as_ref(),
            zero_var.as_ref(),
            c.z.as_ref(),
            &ys,
            &c.kernels,
            Jitter::Absolute(1e-8),
        )
        .unwrap_err();
        assert!(e.to_string().contains("variance"), "{e}");
        let short = Mat::<f64>::zeros(5, 2);
        let e = bayesian_bound(
            c.mean.as_ref(),
            c.var.as_ref(),
            c.z.as_ref(),
            &[short.as_ref()],
            &c.kernels,
            Jitter::Absolute(1e-8),
        )
        .unwrap_err();
        assert!(e.to_string().contains("y rows"), "{e}");
    }
}
