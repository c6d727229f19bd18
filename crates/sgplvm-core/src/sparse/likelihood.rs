//! One space's collapsed variational bound (Titsias 2009; GPy's `VarDTC`) with inducing
//! inputs Z (M×Q) and latent points X (N×Q) as point estimates, and its analytic gradient.
//!
//! With `K_mm = k(Z, Z) + c α² I` (c the relative jitter), `Φ = K_mn = k(Z, X)`,
//! `K_mm = L_m L_mᵀ`, `A = L_m⁻¹ Φ / σ`, `B = I + A Aᵀ = L_B L_Bᵀ`, `c_Y = L_B⁻¹ A Y`:
//!
//! `L = N D/2 log 2π + N D/2 log σ² + D Σ log diag L_B + (‖Y‖² − ‖c_Y‖²)/(2σ²)
//!      + D/(2σ²) (N α² − σ² tr A Aᵀ)`,
//!
//! the negative of `log N(Y | 0, Q_nn + σ² I) − D/(2σ²) tr(K_nn − Q_nn)`. Every step costs
//! O(N M² + M³ + N M (Q + D)); no N×N matrix is formed.
//!
//! Gradient: with `β = B⁻¹ A Y` and `G_w = D/2 B⁻¹ + β βᵀ/(2σ²)` (whitened),
//! `∂L/∂K_mm = L_m⁻ᵀ (G_w − D/2 I + D/2 A Aᵀ) L_m⁻¹`,
//! `∂L/∂Φ = σ⁻¹ L_m⁻ᵀ ((2 G_w − D I) A − β Yᵀ/σ²)`,
//! `∂L/∂σ² = N D/(2σ²) − ‖Y‖²/(2σ⁴) + ‖c_Y‖²/σ⁴ − D N α²/(2σ⁴) + D tr(AAᵀ)/(2σ²)
//!           − tr(G_w A Aᵀ)/σ²`,
//! and the diagonal of K_nn adds `D N/(2σ²)` to ∂L/∂α². The kernel matrices' derivatives then
//! give ∂L/∂α², ∂L/∂ℓ, ∂L/∂X and ∂L/∂Z by weighted sums (`chain`). The gradient's steps are in
//! `likelihood/gradient.rs`.

mod gradient;

use faer::linalg::matmul::matmul;
use faer::linalg::matmul::triangular::BlockStructure;
use faer::linalg::triangular_solve::{
    solve_lower_triangular_in_place, solve_upper_triangular_in_place,
};
use faer::{Accum, Mat, MatRef, Par};
use rayon::prelude::*;

use crate::kernel::{rbf_lower, KernelParams};
use crate::likelihood::{cholesky_with_jitter, NotPd};
use crate::simd::{clear_upper_simd_state, exp_neg, vectorized};
use gradient::gradient;

const LN_2PI: f64 = 1.837_877_066_409_345_5;

/// Jitter added to K_mm's diagonal, relative to the kernel variance α², so that it means the
/// same at every data scale (GPy's `VarDTC` adds an absolute `const_jitter` = 1e-8). Because it scales with α², `∂K_mm/∂α² = K_mm/α²`
/// holds exactly and the gradient stays consistent.
pub(crate) const RELATIVE_JITTER: f64 = 1e-6;

/// What one evaluation leaves behind for prediction.
#[derive(Clone, Debug)]
pub(crate) struct SparseFactors {
    /// Cholesky factor of K_mm (lower).
    pub lm: Mat<f64>,
    /// Cholesky factor of B (lower).
    pub lb: Mat<f64>,
    /// β = B⁻¹ A Y (M×D).
    pub beta: Mat<f64>,
}

/// Result of evaluating one space's bound.
#[derive(Clone, Debug)]
pub(crate) struct SparseEval {
    /// The negative bound.
    pub nll: f64,
    /// Jitter added to K_mm's diagonal beyond the constant relative one (0 normally).
    pub jitter: f64,
    /// ∂L/∂variance.
    pub d_variance: f64,
    /// ∂L/∂lengthscale_q.
    pub d_lengthscale: Vec<f64>,
    /// ∂L/∂noise.
    pub d_noise: f64,
    /// The factors, for prediction.
    pub factors: SparseFactors,
}

/// Columns of Φ per block. A block's Φ, A and ∂L/∂Φ (M×BLOCK each, 400 kB at M = 100) stay in
/// the core's cache between the steps that use them, and blocks are the unit of parallel work.
/// Results do not depend on the number of threads: the blocks and the order in which their
/// partial sums are added are fixed.
const BLOCK: usize = 512;

/// Buffers one space's evaluations keep between calls: Φ = K_mn (M×N, column-major), which
/// the gradient pass reads again (allocated anew per evaluation it cost page faults: 16 MB at
/// N = 20,000, M = 100).
#[derive(Debug, Default)]
pub(crate) struct SparseWork {
    phi: Vec<f64>,
}

/// Evaluates one space. `xr` (N×Q) and `zr` (M×Q) are row-major; `y` is the centred data;
/// `rel_jitter` times α² is added to K_mm's diagonal. With `grad` the kernel derivatives are
/// computed, and ∂L/∂X, ∂L/∂Z are *added* to `dx`, `dz` (row-major) when given.
#[allow(clippy::too_many_arguments)]
pub(crate) fn eval_sparse_space(
    xr: &[f64],
    zr: &[f64],
    q: usize,
    y: MatRef<'_, f64>,
    kern: &KernelParams,
    rel_jitter: f64,
    grad: bool,
    dx: Option<&mut [f64]>,
    dz: Option<&mut [f64]>,
) -> Result<SparseEval, NotPd> {
    eval_sparse_space_in(
        xr,
        zr,
        q,
        y,
        kern,
        rel_jitter,
        grad,
        dx,
        dz,
        &mut SparseWork::default(),
    )
}

/// Runs `f` on every item with its index, on the pool's threads when `parallel`; results in
/// the items' order either way.
fn map_blocks<T: Send, R: Send>(
    items: Vec<T>,
    parallel: bool,
    f: impl Fn(usize, T) -> R + Sync + Send,
) -> Vec<R> {
    if parallel {
        items
            .into_par_iter()
            .enumerate()
            .map(|(b, t)| f(b, t))
            .collect()
    } else {
        items
            .into_iter()
            .enumerate()
            .map(|(b, t)| f(b, t))
            .collect()
    }
}

/// [`eval_sparse_space`] with buffers kept in `work`. The N-dimension is processed in blocks
/// of [`BLOCK`] columns (on the pool's threads when called on one): a first pass forms Φ, A =
/// L_m⁻¹Φ/σ and the partial sums of AAᵀ and AY block by block; after the M×M algebra a second
/// pass forms ∂L/∂Φ ∘ Φ block by block and reduces it at once to the X, Z and lengthscale
/// gradients, so that no M×N matrix but Φ is ever formed.
#[allow(clippy::too_many_arguments)]
pub(crate) fn eval_sparse_space_in(
    xr: &[f64],
    zr: &[f64],
    q: usize,
    y: MatRef<'_, f64>,
    kern: &KernelParams,
    rel_jitter: f64,
    grad: bool,
    dx: Option<&mut [f64]>,
    dz: Option<&mut [f64]>,
    work: &mut SparseWork,
) -> Result<SparseEval, NotPd> {
    let blocks = y.nrows().div_ceil(BLOCK);
    let space = Space {
        xr,
        zr,
        q,
        m: zr.len() / q.max(1),
        y,
        kern,
        blocks,
        parallel: blocks > 1 && crate::pool::on_pool_thread(),
    };
    let (kmm, lm, jitter) = factor_kmm(&space, rel_jitter)?;
    let linv = scaled_inverse_factor(&lm, kern.noise.sqrt());
    let (aat, ay) = first_pass(&space, &linv, grad, &mut work.phi);
    let lb = factor_b(&aat)?;
    let (mut out, sums) = bound(&space, aat, ay, lm, lb, jitter);
    if !grad {
        return Ok(out);
    }
    gradient(&space, &mut out, &kmm, &sums, &work.phi, dx, dz);
    Ok(out)
}

/// What every step of one space's evaluation reads: the inputs of [`eval_sparse_space_in`]
/// and the number of inducing inputs and of blocks derived from them.
struct Space<'a> {
    /// Latent points X (N×Q, row-major).
    xr: &'a [f64],
    /// Inducing inputs Z (M×Q, row-major).
    zr: &'a [f64],
    /// Latent dimension Q.
    q: usize,
    /// Number of inducing inputs M.
    m: usize,
    /// The centred data Y (N×D).
    y: MatRef<'a, f64>,
    kern: &'a KernelParams,
    /// Blocks of [`BLOCK`] columns of Φ.
    blocks: usize,
    /// Whether the blocks run on the pool's threads.
    parallel: bool,
}

/// What the bound leaves for the gradient: AAᵀ (both triangles), ‖Y‖², ‖c_Y‖² and tr AAᵀ.
struct BoundSums {
    aat: Mat<f64>,
    yy: f64,
    cc: f64,
    tr_aat: f64,
}

/// K_mm with its jitter (both triangles), its Cholesky factor L_m (upper triangle zeroed) and
/// the jitter added beyond the relative one.
fn factor_kmm(space: &Space<'_>, rel_jitter: f64) -> Result<(Mat<f64>, Mat<f64>, f64), NotPd> {
    let (m, var, par) = (space.m, space.kern.variance, Par::Seq);
    let mut kmm = Mat::zeros(m, m);
    rbf_lower(space.zr, space.q, space.kern, &mut kmm, Par::Seq);
    let mut lm = Mat::zeros(m, m);
    let jitter = cholesky_with_jitter(kmm.as_ref(), rel_jitter * var, lm.as_mut(), par)?;
    for j in 0..m {
        kmm[(j, j)] += rel_jitter * var + jitter;
        for i in 0..j {
            kmm[(i, j)] = kmm[(j, i)];
            lm[(i, j)] = 0.0;
        }
    }
    Ok((kmm, lm, jitter))
}

/// L_m⁻¹/σ, lower triangular: A = L_m⁻¹ Φ/σ is then a triangular matrix product per block
/// (forming ΦΦᵀ first, as GPy does, would square K_mm's condition number in the objective:
/// the central-difference check of ∂L/∂X then failed at 1e-6).
fn scaled_inverse_factor(lm: &Mat<f64>, sigma: f64) -> Mat<f64> {
    let (m, par) = (lm.nrows(), Par::Seq);
    let mut linv = Mat::<f64>::identity(m, m);
    solve_lower_triangular_in_place(lm.as_ref(), linv.as_mut(), par);
    clear_upper_simd_state();
    for j in 0..m {
        for i in 0..m {
            linv[(i, j)] = if i >= j { linv[(i, j)] / sigma } else { 0.0 };
        }
    }
    linv
}

/// First pass: Φ (kept in `phi` for the second when `grad`), and per block AAᵀ (lower) and AY
/// with A = `linv` Φ; returns their sums, AAᵀ with both triangles.
fn first_pass(
    space: &Space<'_>,
    linv: &Mat<f64>,
    grad: bool,
    phi: &mut Vec<f64>,
) -> (Mat<f64>, Mat<f64>) {
    let Space {
        xr, q, m, y, kern, ..
    } = *space;
    let (n, d) = (y.nrows(), y.ncols());
    let var = kern.variance;
    let scaled = ScaledZ::new(space.zr, q, kern);
    let chunks: Vec<Option<&mut [f64]>> = if grad {
        phi.resize(m * n, 0.0);
        phi.chunks_mut(m * BLOCK).map(Some).collect()
    } else {
        (0..space.blocks).map(|_| None).collect()
    };
    let first = |b: usize, chunk: Option<&mut [f64]>| {
        let (j0, nb) = (b * BLOCK, BLOCK.min(n - b * BLOCK));
        let mut local = Vec::new();
        let phi_b = match chunk {
            Some(c) => c,
            None => {
                local.resize(m * nb, 0.0);
                &mut local[..]
            }
        };
        scaled.fill(&xr[j0 * q..(j0 + nb) * q], var, phi_b);
        let phi_b = MatRef::from_column_major_slice(&phi_b[..m * nb], m, nb);
        let mut a = Mat::zeros(m, nb);
        faer::linalg::matmul::triangular::matmul(
            a.as_mut(),
            BlockStructure::Rectangular,
            Accum::Replace,
            linv.as_ref(),
            BlockStructure::TriangularLower,
            phi_b,
            BlockStructure::Rectangular,
            1.0,
            Par::Seq,
        );
        let mut aat = Mat::zeros(m, m);
        faer::linalg::matmul::triangular::matmul(
            aat.as_mut(),
            BlockStructure::TriangularLower,
            Accum::Replace,
            a.as_ref(),
            BlockStructure::Rectangular,
            a.transpose(),
            BlockStructure::Rectangular,
            1.0,
            Par::Seq,
        );
        let mut ay = Mat::zeros(m, d);
        matmul(
            ay.as_mut(),
            Accum::Replace,
            a.as_ref(),
            y.subrows(j0, nb),
            1.0,
            Par::Seq,
        );
        clear_upper_simd_state();
        (aat, ay)
    };
    let parts = map_blocks(chunks, space.parallel, first);
    let mut aat = Mat::<f64>::zeros(m, m);
    let mut ay = Mat::<f64>::zeros(m, d);
    for (pa, py) in &parts {
        for j in 0..m {
            for i in j..m {
                aat[(i, j)] += pa[(i, j)];
            }
        }
        ay += py;
    }
    drop(parts);
    for j in 0..m {
        for i in 0..j {
            aat[(i, j)] = aat[(j, i)];
        }
    }
    (aat, ay)
}

/// The Cholesky factor L_B of B = I + AAᵀ (upper triangle zeroed).
fn factor_b(aat: &Mat<f64>) -> Result<Mat<f64>, NotPd> {
    let (m, par) = (aat.nrows(), Par::Seq);
    let mut lb = Mat::zeros(m, m);
    let b = Mat::from_fn(m, m, |i, j| aat[(i, j)] + if i == j { 1.0 } else { 0.0 });
    if cholesky_with_jitter(b.as_ref(), 0.0, lb.as_mut(), par)? > 0.0 {
        // B ≥ I is always positive definite in exact arithmetic: a failure means overflow.
        return Err(NotPd { jitter: 0.0 });
    }
    for j in 0..m {
        for i in 0..j {
            lb[(i, j)] = 0.0;
        }
    }
    Ok(lb)
}

/// The negative bound from AAᵀ, AY and the factors L_m, L_B (its gradient still zero), and
/// what the gradient needs of it.
fn bound(
    space: &Space<'_>,
    aat: Mat<f64>,
    ay: Mat<f64>,
    lm: Mat<f64>,
    lb: Mat<f64>,
    jitter: f64,
) -> (SparseEval, BoundSums) {
    let Space { q, m, y, kern, .. } = *space;
    let (n, d) = (y.nrows(), y.ncols());
    let (df, nf) = (d as f64, n as f64);
    let var = kern.variance;
    let s2 = kern.noise;
    let par = Par::Seq;
    // c = L_B⁻¹ A Y, β = L_B⁻ᵀ c.
    let mut cy = ay;
    solve_lower_triangular_in_place(lb.as_ref(), cy.as_mut(), par);
    let mut beta = cy.clone();
    solve_upper_triangular_in_place(lb.transpose(), beta.as_mut(), par);
    clear_upper_simd_state();

    let yy: f64 = (0..d)
        .map(|j| (0..n).map(|i| y[(i, j)] * y[(i, j)]).sum::<f64>())
        .sum();
    let cc: f64 = (0..d)
        .map(|j| (0..m).map(|i| cy[(i, j)] * cy[(i, j)]).sum::<f64>())
        .sum();
    let log_det_b: f64 = 2.0 * (0..m).map(|i| lb[(i, i)].ln()).sum::<f64>();
    let tr_aat: f64 = (0..m).map(|i| aat[(i, i)]).sum();
    let nll = 0.5 * nf * df * LN_2PI
        + 0.5 * nf * df * s2.ln()
        + 0.5 * df * log_det_b
        + 0.5 * (yy - cc) / s2
        + 0.5 * df * (nf * var - s2 * tr_aat) / s2;
    let factors = SparseFactors { lm, lb, beta };
    let out = SparseEval {
        nll,
        jitter,
        d_variance: 0.0,
        d_lengthscale: vec![0.0; q],
        d_noise: 0.0,
        factors,
    };
    (
        out,
        BoundSums {
            aat,
            yy,
            cc,
            tr_aat,
        },
    )
}

/// Inducing inputs divided by the lengthscales, dimension by dimension (contiguous over the
/// inducing inputs: the distance loops vectorise), for filling columns of Φ.
struct ScaledZ {
    zs: Vec<f64>,
    inv_l: Vec<f64>,
    m: usize,
}

impl ScaledZ {
    fn new(zr: &[f64], q: usize, kern: &KernelParams) -> Self {
        let m = zr.len() / q.max(1);
        let inv_l: Vec<f64> = kern.lengthscale.iter().map(|l| 1.0 / l).collect();
        let mut zs = vec![0.0; m * q];
        for i in 0..m {
            for t in 0..q {
                zs[t * m + i] = zr[i * q + t] * inv_l[t];
            }
        }
        Self { zs, inv_l, m }
    }

    /// Writes `k(Z, x_j)` (no noise, variance `var`) into column j of `out` (M rows,
    /// column-major) for every row x_j of `xr` (row-major).
    fn fill(&self, xr: &[f64], var: f64, out: &mut [f64]) {
        let (m, q) = (self.m, self.inv_l.len());
        let cols = xr.len() / q.max(1);
        vectorized(
            #[inline(always)]
            || {
                for (j, col) in out.chunks_exact_mut(m).take(cols).enumerate() {
                    col.fill(0.0);
                    for t in 0..q {
                        let xj = xr[j * q + t] * self.inv_l[t];
                        for (v, &z) in col.iter_mut().zip(&self.zs[t * m..(t + 1) * m]) {
                            let dd = z - xj;
                            *v += dd * dd;
                        }
                    }
                    for v in col.iter_mut() {
                        *v = var * exp_neg(-0.5 * *v);
                    }
                }
            },
        );
    }
}

/// `Φ = k(Z, X)` (M×N) without noise: squared scaled distances, then the vectorised exp.
pub(crate) fn cross_kernel(
    zr: &[f64],
    xr: &[f64],
    q: usize,
    kern: &KernelParams,
    m: usize,
    n: usize,
) -> Mat<f64> {
    let mut phi = vec![0.0; m * n];
    ScaledZ::new(zr, q, kern).fill(&xr[..n * q], kern.variance, &mut phi);
    MatRef::from_column_major_slice(&phi, m, n).to_owned()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kernel::row_major;
    use crate::likelihood::{eval_space, SpaceWork, Wanted};
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn random(n: usize, c: usize, rng: &mut ChaCha8Rng) -> Mat<f64> {
        Mat::from_fn(n, c, |_, _| rng.random_range(-1.0..1.0))
    }

    fn kernel(q: usize, rng: &mut ChaCha8Rng) -> KernelParams {
        KernelParams {
            variance: rng.random_range(0.5..2.0),
            lengthscale: (0..q).map(|_| rng.random_range(0.5..2.0)).collect(),
            noise: rng.random_range(0.05..0.3),
        }
    }

    fn rel(a: f64, b: f64) -> f64 {
        (a - b).abs() / b.abs().max(1e-300)
    }

    #[test]
    fn with_z_equal_to_x_the_bound_is_the_exact_likelihood() {
        // M = N, Z = X, no jitter: Q_nn = K_nn, the trace term vanishes and the bound is the
        // exact marginal likelihood; ∂L/∂X + ∂L/∂Z is the exact ∂L/∂X (X moves Z with it).
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let mut worst = 0.0f64;
        for (n, q, d) in [(12, 2, 3), (18, 3, 4)] {
            // Well-spread points keep K_mm well conditioned without jitter.
            let x = Mat::from_fn(n, q, |i, t| {
                3.0 * (i as f64 * (0.9 + 0.37 * t as f64)).sin() + 0.1 * rng.random_range(-1.0..1.0)
            });
            let y = random(n, d, &mut rng);
            let k = kernel(q, &mut rng);
            let xr = row_major(x.as_ref());
            let mut w = SpaceWork::new(n, d);
            let mut dx_exact = vec![0.0; n * q];
            let e = eval_space(
                &xr,
                q,
                y.as_ref(),
                &k,
                &mut w,
                1,
                Wanted::AllGradients(&mut dx_exact),
            )
            .expect("pd");
            let (mut dx, mut dz) = (vec![0.0; n * q], vec![0.0; n * q]);
            let s = eval_sparse_space(
                &xr,
                &xr,
                q,
                y.as_ref(),
                &k,
                0.0,
                true,
                Some(&mut dx),
                Some(&mut dz),
            )
            .expect("pd");
            assert_eq!(s.jitter, 0.0);
            let mut pairs = vec![
                (s.nll, e.nll),
                (s.d_variance, e.d_variance),
                (s.d_noise, e.d_noise),
            ];
            pairs.extend(
                s.d_lengthscale
                    .iter()
                    .copied()
                    .zip(e.d_lengthscale.iter().copied()),
            );
            pairs.extend(
                dx.iter()
                    .zip(&dz)
                    .map(|(a, b)| a + b)
                    .zip(dx_exact.iter().copied()),
            );
            for (a, b) in pairs {
                let r = (a - b).abs() / b.abs().max(1e-3 * e.nll.abs());
                worst = worst.max(r);
                assert!(r < 1e-8, "sparse {a} vs exact {b}");
            }
        }
        // Measured 1.5e-12; the tolerance is the 1e-8.
        assert!(worst < 1e-8, "{worst:e}");
    }

    #[test]
    fn every_gradient_block_matches_central_differences() {
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let mut worst = 0.0f64;
        for (n, m, q, d) in [(30, 6, 2, 3), (45, 9, 3, 2)] {
            let x = random(n, q, &mut rng);
            let z = random(m, q, &mut rng);
            let y = random(n, d, &mut rng);
            let k = kernel(q, &mut rng);
            let (xr, zr) = (row_major(x.as_ref()), row_major(z.as_ref()));
            let f = |xr: &[f64], zr: &[f64], k: &KernelParams| {
                eval_sparse_space(xr, zr, q, y.as_ref(), k, RELATIVE_JITTER, false, None, None)
                    .expect("pd")
                    .nll
            };
            let (mut dx, mut dz) = (vec![0.0; n * q], vec![0.0; m * q]);
            let e = eval_sparse_space(
                &xr,
                &zr,
                q,
                y.as_ref(),
                &k,
                RELATIVE_JITTER,
                true,
                Some(&mut dx),
                Some(&mut dz),
            )
            .expect("pd");
            assert!((e.nll - f(&xr, &zr, &k)).abs() < 1e-12 * e.nll.abs());
            let h = 1e-6;
            let mut check = |an: f64, plus: f64, minus: f64, what: &str| {
                let fd = (plus - minus) / (2.0 * h);
                let err = (an - fd).abs() / (1.0 + fd.abs());
                worst = worst.max(err);
                assert!(err < 1e-6, "{what}: analytic {an} vs fd {fd}");
            };
            let bump = |k: &KernelParams, which: usize, by: f64| {
                let mut k = k.clone();
                match which {
                    0 => k.variance += by,
                    1 => k.noise += by,
                    t => k.lengthscale[t - 2] += by,
                }
                k
            };
            check(
                e.d_variance,
                f(&xr, &zr, &bump(&k, 0, h)),
                f(&xr, &zr, &bump(&k, 0, -h)),
                "variance",
            );
            check(
                e.d_noise,
                f(&xr, &zr, &bump(&k, 1, h)),
                f(&xr, &zr, &bump(&k, 1, -h)),
                "noise",
            );
            for t in 0..q {
                check(
                    e.d_lengthscale[t],
                    f(&xr, &zr, &bump(&k, 2 + t, h)),
                    f(&xr, &zr, &bump(&k, 2 + t, -h)),
                    "lengthscale",
                );
            }
            for i in 0..n * q {
                let (mut p, mut mi) = (xr.clone(), xr.clone());
                p[i] += h;
                mi[i] -= h;
                check(dx[i], f(&p, &zr, &k), f(&mi, &zr, &k), "x");
            }
            for i in 0..m * q {
                let (mut p, mut mi) = (zr.clone(), zr.clone());
                p[i] += h;
                mi[i] -= h;
                check(dz[i], f(&xr, &p, &k), f(&xr, &mi, &k), "z");
            }
            // Without the latent outputs the kernel gradient is the same.
            let e2 = eval_sparse_space(
                &xr,
                &zr,
                q,
                y.as_ref(),
                &k,
                RELATIVE_JITTER,
                true,
                None,
                None,
            )
            .expect("pd");
            assert!(rel(e2.d_variance, e.d_variance) < 1e-12);
        }
        // Measured 4.2e-8 (h = 1e-6); tolerance 1e-6.
        assert!(worst < 1e-6, "{worst:e}");
    }

    #[test]
    fn the_bound_lies_below_the_exact_likelihood() {
        // Titsias' bound: −L_sparse ≤ log p(Y), with equality only when Q_nn = K_nn.
        let mut rng = ChaCha8Rng::seed_from_u64(9);
        let (n, q, d) = (40, 2, 3);
        let x = random(n, q, &mut rng);
        let y = random(n, d, &mut rng);
        let k = kernel(q, &mut rng);
        let xr = row_major(x.as_ref());
        let mut w = SpaceWork::new(n, d);
        let exact = eval_space(&xr, q, y.as_ref(), &k, &mut w, 1, Wanted::Objective)
            .expect("pd")
            .nll;
        let zr: Vec<f64> = xr[..10 * q].to_vec();
        let s = eval_sparse_space(
            &xr,
            &zr,
            q,
            y.as_ref(),
            &k,
            RELATIVE_JITTER,
            false,
            None,
            None,
        )
        .expect("pd");
        assert!(s.nll > exact, "{} ≤ {exact}", s.nll);
    }

    #[test]
    fn blocks_on_threads_give_the_same_bits_and_a_correct_gradient() {
        // N over two block boundaries (the tests above fit in one block), evaluated on the
        // calling thread (blocks in turn) and on the pool (blocks in parallel).
        let mut rng = ChaCha8Rng::seed_from_u64(17);
        let (n, m, q, d) = (2 * BLOCK + 77, 15, 2, 3);
        let x = random(n, q, &mut rng);
        let z = random(m, q, &mut rng);
        let y = random(n, d, &mut rng);
        let k = kernel(q, &mut rng);
        let (xr, zr) = (row_major(x.as_ref()), row_major(z.as_ref()));
        let run = || {
            let (mut dx, mut dz) = (vec![0.0; n * q], vec![0.0; m * q]);
            let e = eval_sparse_space(
                &xr,
                &zr,
                q,
                y.as_ref(),
                &k,
                RELATIVE_JITTER,
                true,
                Some(&mut dx),
                Some(&mut dz),
            )
            .expect("pd");
            (e.nll, e.d_variance, e.d_noise, e.d_lengthscale, dx, dz)
        };
        let seq = run();
        let par = crate::pool::in_pool(run);
        assert_eq!(seq, par);
        let f = |xr: &[f64], zr: &[f64], k: &KernelParams| {
            eval_sparse_space(xr, zr, q, y.as_ref(), k, RELATIVE_JITTER, false, None, None)
                .expect("pd")
                .nll
        };
        assert_eq!(f(&xr, &zr, &k), seq.0);
        let h = 1e-5;
        let close = |an: f64, fd: f64| (an - fd).abs() / (1.0 + fd.abs()) < 1e-6;
        // Points in the first, second and last block, and every coordinate of two of Z's.
        for i in [3 * q, (BLOCK + 5) * q + 1, (n - 1) * q] {
            let (mut p, mut mi) = (xr.clone(), xr.clone());
            p[i] += h;
            mi[i] -= h;
            let fd = (f(&p, &zr, &k) - f(&mi, &zr, &k)) / (2.0 * h);
            assert!(close(seq.4[i], fd), "x[{i}]: {} vs {fd}", seq.4[i]);
        }
        for i in [0, 1, 2 * q, 2 * q + 1] {
            let (mut p, mut mi) = (zr.clone(), zr.clone());
            p[i] += h;
            mi[i] -= h;
            let fd = (f(&xr, &p, &k) - f(&xr, &mi, &k)) / (2.0 * h);
            assert!(close(seq.5[i], fd), "z[{i}]: {} vs {fd}", seq.5[i]);
        }
        for t in 0..q {
            let (mut p, mut mi) = (k.clone(), k.clone());
            p.lengthscale[t] += h;
            mi.lengthscale[t] -= h;
            let fd = (f(&xr, &zr, &p) - f(&xr, &zr, &mi)) / (2.0 * h);
            assert!(close(seq.3[t], fd), "lengthscale {t}: {} vs {fd}", seq.3[t]);
        }
    }
}
