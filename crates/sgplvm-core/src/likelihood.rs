//! The exact negative log marginal likelihood of one observation space and its analytic
//! gradient, from one Cholesky factor `K = L Lᵀ`.
//!
//! For latent points X (N×Q), centred data Y (N×D) and `K = k(X, X) + σ² I`:
//! `L = D/2 log|K| + ½ tr(K⁻¹ Y Yᵀ) + N D/2 log 2π`. Through `G = ∂L/∂K = ½ (D K⁻¹ − A Aᵀ)`,
//! `A = K⁻¹ Y`, it gives ∂L/∂α², ∂L/∂ℓ_q, ∂L/∂σ² = tr G and ∂L/∂X. Only lower triangles are
//! formed. A factorisation that fails gets growing jitter on the diagonal (never a panic).

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt;
use faer::linalg::matmul::triangular::BlockStructure;
use faer::reborrow::ReborrowMut;
use faer::{Accum, Mat, MatMut, MatRef, Par};

use crate::error::Error;
use crate::factor::{self, IN_PIECES_FROM};
use crate::kernel::{rbf_lower, KernelParams};
use crate::pool::{both, par_alone_for, par_for, par_space};
use crate::simd::{clear_upper_simd_state, vectorized};

const LN_2PI: f64 = 1.837_877_066_409_345_5;

/// Failure of a Cholesky factorisation even after the largest jitter.
#[derive(Clone, Copy, Debug)]
pub(crate) struct NotPd {
    /// Largest jitter tried.
    pub jitter: f64,
}

impl NotPd {
    /// The model's error for this failure, naming the space whose matrix it was.
    pub(crate) fn in_space(self, space: &str) -> Error {
        Error::NotPositiveDefinite {
            space: space.into(),
            jitter: self.jitter,
        }
    }
}

/// Copies the lower triangle of `kf` into `l`, adds `noise` on the diagonal and factorises it in
/// place. On failure jitter starting at `1e-10 × mean diagonal` is added, growing ×10 up to
/// `1e-2 × mean diagonal`. Returns the jitter used (0 when none was needed).
pub(crate) fn cholesky_with_jitter(
    kf: MatRef<'_, f64>,
    noise: f64,
    mut l: MatMut<'_, f64>,
    par: Par,
) -> Result<f64, NotPd> {
    let n = kf.nrows();
    let mean_diag = if n == 0 {
        1.0
    } else {
        (0..n).map(|i| kf[(i, i)]).sum::<f64>() / n as f64 + noise
    };
    let mut jitter = 0.0;
    let mut next = 1e-10 * mean_diag;
    loop {
        for j in 0..n {
            for i in j..n {
                l[(i, j)] = kf[(i, j)];
            }
            l[(j, j)] += noise + jitter;
        }
        let ok = mean_diag.is_finite()
            && factor::cholesky(l.rb_mut(), par).is_ok()
            && (0..n).all(|i| l[(i, i)].is_finite() && l[(i, i)] > 0.0);
        if ok {
            return Ok(jitter);
        }
        if next.is_nan() || next > 1e-2 * mean_diag || !next.is_finite() {
            return Err(NotPd { jitter });
        }
        jitter = next;
        next *= 10.0;
    }
}

/// Reusable buffers for evaluating one space (avoids O(N²) allocations per evaluation).
pub(crate) struct SpaceWork {
    kf: Mat<f64>,
    l: Mat<f64>,
    g: Mat<f64>,
    a: Mat<f64>,
    mem: MemBuffer,
}

impl SpaceWork {
    /// Buffers for `n` points and `d` output columns.
    pub(crate) fn new(n: usize, d: usize) -> Self {
        let par = par_for(n);
        let req = llt::inverse::inverse_scratch::<f64>(n, par);
        Self {
            kf: Mat::zeros(n, n),
            l: Mat::zeros(n, n),
            g: Mat::zeros(n, n),
            a: Mat::zeros(n, d),
            mem: MemBuffer::new(req),
        }
    }

    /// True when these buffers serve `n` points and `d` output columns.
    pub(crate) fn fits(&self, n: usize, d: usize) -> bool {
        self.kf.nrows() == n && self.a.nrows() == n && self.a.ncols() == d
    }

    /// The Cholesky factor of the last evaluation (lower triangle).
    pub(crate) fn factor(&self) -> MatRef<'_, f64> {
        self.l.as_ref()
    }

    /// `K⁻¹ Y` of the last evaluation.
    pub(crate) fn alpha(&self) -> MatRef<'_, f64> {
        self.a.as_ref()
    }
}

/// Result of evaluating one space.
#[derive(Clone, Debug)]
pub(crate) struct SpaceEval {
    /// Negative log marginal likelihood of the space.
    pub nll: f64,
    /// Jitter that had to be added to the diagonal.
    pub jitter: f64,
    /// ∂L/∂variance.
    pub d_variance: f64,
    /// ∂L/∂lengthscale_q.
    pub d_lengthscale: Vec<f64>,
    /// ∂L/∂noise.
    pub d_noise: f64,
}

/// What [`eval_space`] computes besides the objective.
pub(crate) enum Wanted<'a> {
    /// The objective alone: only `nll` and `jitter` are meaningful (the factor and `K⁻¹Y` are
    /// left in the buffers for prediction).
    Objective,
    /// The kernel's derivatives too.
    KernelGradient,
    /// The kernel's derivatives, and ∂L/∂X *added* to the slice (row-major N×Q).
    AllGradients(&'a mut [f64]),
}

/// Evaluates one space. `xr` is the latent matrix row-major (N×Q), `y` the (centred) data,
/// `wanted` what to compute. `alongside` is how many evaluations (this one included) run side
/// by side on the pool: they share its threads.
pub(crate) fn eval_space(
    xr: &[f64],
    q: usize,
    y: MatRef<'_, f64>,
    kern: &KernelParams,
    work: &mut SpaceWork,
    alongside: usize,
    wanted: Wanted<'_>,
) -> Result<SpaceEval, NotPd> {
    let n = y.nrows();
    let d = y.ncols();
    let (par, par_alone) = (par_space(n, alongside), par_alone_for(n, alongside));
    // This thread may have run faer's kernels for another evaluation's parallel inverse.
    clear_upper_simd_state();
    rbf_lower(xr, q, kern, &mut work.kf, par_alone);
    let jitter = cholesky_with_jitter(work.kf.as_ref(), kern.noise, work.l.as_mut(), par)?;
    let l = work.l.as_ref();
    clear_upper_simd_state();
    let logdet: f64 = 2.0 * (0..n).map(|i| l[(i, i)].ln()).sum::<f64>();
    work.a.copy_from(y);
    factor::solve(l, work.a.as_mut(), par);
    clear_upper_simd_state();
    let mut fit = 0.0;
    for j in 0..d {
        for i in 0..n {
            fit += y[(i, j)] * work.a[(i, j)];
        }
    }
    let nll = 0.5 * d as f64 * logdet + 0.5 * fit + 0.5 * (n * d) as f64 * LN_2PI;
    let mut out = SpaceEval {
        nll,
        jitter,
        d_variance: 0.0,
        d_lengthscale: vec![0.0; q],
        d_noise: 0.0,
    };
    let dx = match wanted {
        Wanted::Objective => return Ok(out),
        Wanted::KernelGradient => None,
        Wanted::AllGradients(dx) => Some(dx),
    };
    out.d_noise = weigh_by_kernel(work, d, par, par_alone);
    let (sum_m, d_lengthscale) = pair_sums(&work.g, xr, q, kern, dx, par);
    out.d_lengthscale = d_lengthscale;
    out.d_variance = sum_m / kern.variance;
    Ok(out)
}

/// Turns `work.g` into M = ∂L/∂K ∘ K_f (lower triangle) and returns tr ∂L/∂K = ∂L/∂σ².
///
/// First g = K⁻¹ − (1/D) A Aᵀ, so that ∂L/∂K = D/2 · g; then M = D/2 · g ∘ K_f in place:
/// every kernel derivative is a weighted sum of M's entries, ∂K_ij/∂θ = K_f,ij · (…). The
/// inverse runs with `par_inverse` (see [`par_alone_for`]).
fn weigh_by_kernel(work: &mut SpaceWork, d: usize, par: Par, par_inverse: Par) -> f64 {
    let n = work.kf.nrows();
    llt::inverse::inverse(
        work.g.as_mut(),
        work.l.as_ref(),
        par_inverse,
        MemStack::new(&mut work.mem),
    );
    if d > 0 {
        faer::linalg::matmul::triangular::matmul(
            work.g.as_mut(),
            BlockStructure::TriangularLower,
            Accum::Add,
            work.a.as_ref(),
            BlockStructure::Rectangular,
            work.a.transpose(),
            BlockStructure::Rectangular,
            -1.0 / d as f64,
            par,
        );
    }
    let half_d = 0.5 * d as f64;
    let trace_g: f64 = (0..n).map(|j| half_d * work.g[(j, j)]).sum();
    let (g, kf) = (&mut work.g, &work.kf);
    vectorized(
        #[inline(always)]
        || {
            for j in 0..n {
                let gc = &mut g.col_as_slice_mut(j)[j..];
                for (m, &k) in gc.iter_mut().zip(&kf.col_as_slice(j)[j..]) {
                    *m *= half_d * k;
                }
            }
        },
    );
    trace_g
}

/// From M (lower triangle of `m`): Σ_ij M_ij (for ∂L/∂α²), ∂L/∂ℓ_t for every lengthscale, and
/// ∂L/∂X added to `dx` (row-major N×Q) when given.
///
/// With the latent points centred (the kernel is translation invariant) and a column of ones,
/// one product gives P = M X and the row sums r = M 1. Then Σ_j M_ij (x_i − x_j) = r_i x_i − P_i
/// and Σ_{i<j} M_ij (x_i − x_j)² = Σ_i x_i (r_i x_i − P_i).
fn pair_sums(
    m: &Mat<f64>,
    xr: &[f64],
    q: usize,
    kern: &KernelParams,
    mut dx: Option<&mut [f64]>,
    par: Par,
) -> (f64, Vec<f64>) {
    let n = m.nrows();
    let mut xc = Mat::from_fn(n, q + 1, |i, t| if t < q { xr[i * q + t] } else { 1.0 });
    for t in 0..q {
        let mean = xc.col_as_slice(t).iter().sum::<f64>() / n as f64;
        xc.col_as_slice_mut(t).iter_mut().for_each(|v| *v -= mean);
    }
    // M is symmetric and only its lower triangle is stored: P = tril(M) X + stril(M)ᵀ X.
    let g = m.as_ref();
    let product = |out: MatMut<'_, f64>, lhs: MatRef<'_, f64>, structure, accum| {
        faer::linalg::matmul::triangular::matmul(
            out,
            BlockStructure::Rectangular,
            accum,
            lhs,
            structure,
            xc.as_ref(),
            BlockStructure::Rectangular,
            1.0,
            Par::Seq,
        )
    };
    let mut p = Mat::zeros(n, q + 1);
    let lower = (g, BlockStructure::TriangularLower);
    let upper = (g.transpose(), BlockStructure::StrictTriangularUpper);
    if n >= IN_PIECES_FROM {
        // The two products apart, side by side on a two-thread `par`, then summed (on any
        // number of threads: the same bits). Each is too small to split: on two threads
        // faer's product took 67 against 59 µs on one at N = 300.
        let mut p2 = Mat::zeros(n, q + 1);
        both(
            par,
            || product(p.as_mut(), lower.0, lower.1, Accum::Replace),
            || product(p2.as_mut(), upper.0, upper.1, Accum::Replace),
        );
        p += &p2;
    } else {
        product(p.as_mut(), lower.0, lower.1, Accum::Replace);
        product(p.as_mut(), upper.0, upper.1, Accum::Add);
    }
    clear_upper_simd_state();
    let r = p.col_as_slice(q);
    let sum_m: f64 = r.iter().sum();
    let mut d_lengthscale = vec![0.0; q];
    for (t, &lt) in kern.lengthscale.iter().enumerate().take(q) {
        let (x, pt) = (xc.col_as_slice(t), p.col_as_slice(t));
        let c = -2.0 / (lt * lt);
        let mut dl = 0.0;
        for i in 0..n {
            let acc = r[i] * x[i] - pt[i];
            dl += x[i] * acc;
            if let Some(dx) = dx.as_deref_mut() {
                dx[i * q + t] += c * acc;
            }
        }
        d_lengthscale[t] = 2.0 * dl / (lt * lt * lt);
    }
    (sum_m, d_lengthscale)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kernel::row_major;
    use crate::pool::{ALONE_PARALLEL_FROM, PARALLEL_FROM};
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn random(n: usize, c: usize, rng: &mut ChaCha8Rng) -> Mat<f64> {
        Mat::from_fn(n, c, |_, _| rng.random_range(-1.0..1.0))
    }

    /// One evaluation with every gradient at `x` (row-major): the result and ∂L/∂X.
    fn eval_all(
        x: &[f64],
        y: &Mat<f64>,
        k: &KernelParams,
        w: &mut SpaceWork,
        alongside: usize,
    ) -> (SpaceEval, Vec<f64>) {
        let q = k.lengthscale.len();
        let mut dx = vec![0.0; y.nrows() * q];
        let wanted = Wanted::AllGradients(&mut dx);
        let e = eval_space(x, q, y.as_ref(), k, w, alongside, wanted).expect("pd");
        (e, dx)
    }

    fn nll(x: &Mat<f64>, y: &Mat<f64>, k: &KernelParams) -> f64 {
        let mut w = SpaceWork::new(x.nrows(), y.ncols());
        eval_space(
            &row_major(x.as_ref()),
            x.ncols(),
            y.as_ref(),
            k,
            &mut w,
            1,
            Wanted::Objective,
        )
        .expect("pd")
        .nll
    }

    /// Direct O(N³) evaluation with faer's dense solvers as an independent reference.
    fn reference_nll(x: &Mat<f64>, y: &Mat<f64>, k: &KernelParams) -> f64 {
        use faer::linalg::solvers::DenseSolveCore;
        let n = x.nrows();
        let kk = Mat::from_fn(n, n, |i, j| {
            let mut r2 = 0.0;
            for t in 0..x.ncols() {
                r2 += (x[(i, t)] - x[(j, t)]).powi(2) / k.lengthscale[t].powi(2);
            }
            k.variance * (-0.5 * r2).exp() + if i == j { k.noise } else { 0.0 }
        });
        let llt = kk.llt(faer::Side::Lower).expect("pd");
        let inv = llt.inverse();
        let logdet: f64 = (0..n).map(|i| 2.0 * llt.L()[(i, i)].ln()).sum();
        let tr = (y.transpose() * &inv * y).diagonal().column_vector().sum();
        let d = y.ncols() as f64;
        0.5 * d * logdet + 0.5 * tr + 0.5 * n as f64 * d * LN_2PI
    }

    #[test]
    fn nll_matches_dense_reference() {
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let x = random(25, 3, &mut rng);
        let y = random(25, 4, &mut rng);
        let k = KernelParams {
            variance: 1.3,
            lengthscale: vec![0.7, 1.1, 2.0],
            noise: 0.05,
        };
        let a = nll(&x, &y, &k);
        let b = reference_nll(&x, &y, &k);
        assert!((a - b).abs() < 1e-10 * b.abs(), "{a} vs {b}");
    }

    /// A space evaluated alone on a pool with threads to spare runs every step on two threads
    /// (kernel matrix, factor, solve, inverse, products); two spaces side by side on two
    /// threads run one each. The objective and every gradient must be those of one thread, bit
    /// for bit, so that a model does not depend on the cores it was trained on.
    #[test]
    fn parallel_evaluation_gives_the_sequential_result_bit_for_bit() {
        let two = rayon::ThreadPoolBuilder::new()
            .num_threads(2)
            .build()
            .expect("pool");
        for n in [
            ALONE_PARALLEL_FROM + 44,
            ALONE_PARALLEL_FROM + 201,
            PARALLEL_FROM + 20,
        ] {
            // Four outputs: the smallest halves the two-thread solve makes (two columns each).
            let (q, d) = (3, if n > PARALLEL_FROM { 18 } else { 4 });
            let mut rng = ChaCha8Rng::seed_from_u64(8);
            let x = random(n, q, &mut rng);
            let y = random(n, d, &mut rng);
            let k = KernelParams {
                variance: 1.3,
                lengthscale: vec![0.9, 1.4, 2.0],
                noise: 0.05,
            };
            let xr = row_major(x.as_ref());
            let eval = |alongside: usize| {
                let mut w = SpaceWork::new(n, d);
                let (e, dx) = eval_all(&xr, &y, &k, &mut w, alongside);
                let mut bits: Vec<u64> = [e.nll, e.d_variance, e.d_noise, e.jitter]
                    .iter()
                    .chain(&e.d_lengthscale)
                    .chain(&dx)
                    .map(|v| v.to_bits())
                    .collect();
                let a = w.alpha();
                bits.extend((0..d).flat_map(|j| (0..n).map(move |i| a[(i, j)].to_bits())));
                bits
            };
            let (parallel, shared) = two.install(|| {
                for par in [par_alone_for, par_space] {
                    assert!(matches!(par(n, 1), Par::Rayon(_)));
                    assert!(matches!(par(n, 2), Par::Seq));
                }
                (eval(1), eval(2))
            });
            let sequential = eval(1);
            assert!(
                parallel == sequential,
                "N = {n}: two threads changed the result"
            );
            assert!(shared == sequential, "N = {n}");
        }
    }

    #[test]
    fn gradients_match_central_differences() {
        let mut rng = ChaCha8Rng::seed_from_u64(2);
        for trial in 0..3 {
            let (n, q, d) = (20 + trial * 7, 2 + trial, 3);
            let x = random(n, q, &mut rng);
            let y = random(n, d, &mut rng);
            let k = KernelParams {
                variance: rng.random_range(0.5..2.0),
                lengthscale: (0..q).map(|_| rng.random_range(0.5..2.0)).collect(),
                noise: rng.random_range(0.05..0.3),
            };
            let xr = row_major(x.as_ref());
            let mut w = SpaceWork::new(n, d);
            let (e, dx) = eval_all(&xr, &y, &k, &mut w, 1);
            let h = 1e-6;
            let check = |analytic: f64, plus: f64, minus: f64, what: &str| {
                let fd = (plus - minus) / (2.0 * h);
                assert!(
                    (analytic - fd).abs() <= 1e-5 * (1.0 + fd.abs()),
                    "{what}: analytic {analytic} fd {fd}"
                );
            };
            let mut kp = k.clone();
            kp.variance += h;
            let mut km = k.clone();
            km.variance -= h;
            check(e.d_variance, nll(&x, &y, &kp), nll(&x, &y, &km), "variance");
            let mut kp = k.clone();
            kp.noise += h;
            let mut km = k.clone();
            km.noise -= h;
            check(e.d_noise, nll(&x, &y, &kp), nll(&x, &y, &km), "noise");
            for t in 0..q {
                let mut kp = k.clone();
                kp.lengthscale[t] += h;
                let mut km = k.clone();
                km.lengthscale[t] -= h;
                check(
                    e.d_lengthscale[t],
                    nll(&x, &y, &kp),
                    nll(&x, &y, &km),
                    "lengthscale",
                );
            }
            for (i, t) in [(0, 0), (n - 1, q - 1), (n / 2, 1)] {
                let mut xp = x.clone();
                xp[(i, t)] += h;
                let mut xm = x.clone();
                xm[(i, t)] -= h;
                check(dx[i * q + t], nll(&xp, &y, &k), nll(&xm, &y, &k), "x");
            }
            // The kernel-only path gives the same kernel gradient.
            let e2 =
                eval_space(&xr, q, y.as_ref(), &k, &mut w, 1, Wanted::KernelGradient).expect("pd");
            assert!((e2.d_variance - e.d_variance).abs() < 1e-9 * e.d_variance.abs().max(1.0));
            assert!(
                (e2.d_lengthscale[0] - e.d_lengthscale[0]).abs()
                    < 1e-9 * e.d_lengthscale[0].abs().max(1.0)
            );
        }
    }

    #[test]
    fn the_factor_is_of_k_plus_noise_plus_the_reported_jitter() {
        // 6 points, each twice, no noise: K is singular.
        let x = Mat::from_fn(12, 2, |i, t| {
            ((i / 2) as f64 * (0.7 + 0.4 * t as f64)).sin()
        });
        let k = KernelParams {
            variance: 1.7,
            lengthscale: vec![0.8, 1.3],
            noise: 0.0,
        };
        let mut kf = Mat::zeros(12, 12);
        rbf_lower(&row_major(x.as_ref()), 2, &k, &mut kf, Par::Seq);
        let mut l = Mat::zeros(12, 12);
        let j = cholesky_with_jitter(kf.as_ref(), k.noise, l.as_mut(), Par::Seq).expect("jitter");
        // On the ladder 1e-10 … 1e-2 × mean diagonal, by factors of 10.
        let rung = (j / 1.7).log10();
        assert!(
            (-10.0..=-2.0).contains(&rung) && (rung - rung.round()).abs() < 1e-9,
            "jitter {j:e} not on the ladder"
        );
        // Measured 1.3e-16 (tolerance 2e-15): the factor is of K + (noise + jitter) I, not of
        // K + noise I or K + (noise + the next rung) I, which differ by 1e-10 … 9e-10 (relative).
        let err = crate::test_support::reconstruction_error(kf.as_ref(), l.as_ref(), k.noise + j);
        assert!(err < 2e-15, "L·Lᵀ off by {err:e}");
        assert!(
            crate::test_support::reconstruction_error(kf.as_ref(), l.as_ref(), k.noise + 10.0 * j)
                > 1e3 * err
        );
        // A well-conditioned matrix gets no jitter at all and exactly K + noise I.
        let k = KernelParams { noise: 0.1, ..k };
        let j = cholesky_with_jitter(kf.as_ref(), 0.1, l.as_mut(), Par::Seq).expect("pd");
        assert_eq!(j, 0.0);
        let err = crate::test_support::reconstruction_error(kf.as_ref(), l.as_ref(), k.noise);
        assert!(err < 2e-15, "L·Lᵀ off by {err:e}");
    }

    /// Per-step times of one space's evaluation (profiling aid, no assertion):
    /// `cargo test --release -p sgplvm-core --lib step_times -- --ignored --nocapture`
    /// (`STEP_N=1000` for another size). The fastest of 20 runs of each step, on the buffers
    /// the evaluation uses (Q = 5, D = 18).
    #[test]
    #[ignore = "profiling aid: prints times"]
    fn step_times() {
        use std::time::Instant;
        let n: usize = std::env::var("STEP_N")
            .ok()
            .and_then(|v| v.parse().ok())
            .unwrap_or(300);
        let (q, d, reps) = (5, 18, 20);
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let x = Mat::from_fn(n, q, |i, t| {
            (i as f64 * 0.01 * (t + 1) as f64).sin() + 0.01 * rng.random_range(-1.0..1.0)
        });
        let y = random(n, d, &mut rng);
        let k = KernelParams {
            variance: 1.0,
            lengthscale: vec![1.0; q],
            noise: 0.01,
        };
        let xr = row_major(x.as_ref());
        let mut w = SpaceWork::new(n, d);
        let mut dx = vec![0.0; n * q];
        let mut time = |what: &str, f: &mut dyn FnMut(&mut SpaceWork)| {
            f(&mut w);
            let mut best = f64::INFINITY;
            for _ in 0..reps {
                let t = Instant::now();
                f(&mut w);
                best = best.min(t.elapsed().as_secs_f64());
            }
            println!("{what:<28} {:>9.1} us (fastest of {reps})", best * 1e6);
        };
        time("whole eval_space", &mut |w| {
            eval_space(&xr, q, y.as_ref(), &k, w, 1, Wanted::AllGradients(&mut dx)).expect("pd");
        });
        time("rbf_lower", &mut |w| {
            rbf_lower(&xr, q, &k, &mut w.kf, Par::Seq)
        });
        let mut tri = vec![-0.3; n * (n + 1) / 2];
        time("exp_neg_slice, N(N+1)/2", &mut |_| {
            tri.iter_mut().for_each(|v| *v = -0.3);
            crate::simd::exp_neg_slice(&mut tri);
        });
        time("squared distances only", &mut |w| {
            crate::kernel::map_sqdist_lower(&xr, q, &k.lengthscale, &mut w.g, |v| v)
        });
        time("cholesky_with_jitter", &mut |w| {
            cholesky_with_jitter(w.kf.as_ref(), k.noise, w.l.as_mut(), Par::Seq).expect("pd");
        });
        time("solve (A = K^-1 Y)", &mut |w| {
            w.a.copy_from(&y);
            factor::solve(w.l.as_ref(), w.a.as_mut(), Par::Seq);
        });
        time("inverse from factor", &mut |w| {
            llt::inverse::inverse(
                w.g.as_mut(),
                w.l.as_ref(),
                Par::Seq,
                MemStack::new(&mut w.mem),
            );
        });
        // A space evaluated alone on a pool of two threads (a transfer): the inverse, and
        // the whole evaluation, as `eval_space` spreads them.
        let two = rayon::ThreadPoolBuilder::new()
            .num_threads(2)
            .build()
            .expect("pool");
        two.install(|| {
            time("inverse, 2 threads", &mut |w| {
                llt::inverse::inverse(
                    w.g.as_mut(),
                    w.l.as_ref(),
                    par_alone_for(n, 1),
                    MemStack::new(&mut w.mem),
                );
            });
            time("rbf_lower, 2 threads", &mut |w| {
                rbf_lower(&xr, q, &k, &mut w.kf, par_alone_for(n, 1))
            });
            let par = par_space(n, 1);
            time("cholesky_with_jitter, 2 thr.", &mut |w| {
                cholesky_with_jitter(w.kf.as_ref(), k.noise, w.l.as_mut(), par).expect("pd");
            });
            time("solve, 2 threads", &mut |w| {
                w.a.copy_from(&y);
                factor::solve(w.l.as_ref(), w.a.as_mut(), par);
            });
            time("weigh_by_kernel, 2 threads", &mut |w| {
                weigh_by_kernel(w, d, par, par);
            });
            time("pair_sums, 2 threads", &mut |w| {
                pair_sums(&w.g, &xr, q, &k, Some(&mut dx), par);
            });
            time("whole eval_space, 2 threads", &mut |w| {
                eval_all(&xr, &y, &k, w, 1);
            });
        });
        time("  of which L^-1", &mut |w| {
            faer::linalg::triangular_inverse::invert_lower_triangular(
                w.g.as_mut(),
                w.l.as_ref(),
                Par::Seq,
            );
        });
        let mut prod = Mat::<f64>::zeros(n, n);
        time("  of which L^-T L^-1", &mut |w| {
            faer::linalg::matmul::triangular::matmul(
                prod.as_mut(),
                BlockStructure::TriangularLower,
                Accum::Replace,
                w.g.transpose(),
                BlockStructure::TriangularUpper,
                w.g.as_ref(),
                BlockStructure::TriangularLower,
                1.0,
                Par::Seq,
            );
        });
        time("weigh_by_kernel (inv+AAt+o)", &mut |w| {
            weigh_by_kernel(w, d, Par::Seq, Par::Seq);
        });
        time("pair_sums", &mut |w| {
            pair_sums(&w.g, &xr, q, &k, Some(&mut dx), Par::Seq);
        });
    }

    #[test]
    fn jitter_rescues_singular_matrix() {
        // Duplicate points and zero noise: K is singular, jitter must make it factorisable.
        let x = Mat::from_fn(6, 1, |i, _| (i / 2) as f64);
        let k = KernelParams {
            variance: 1.0,
            lengthscale: vec![1.0],
            noise: 0.0,
        };
        let mut kf = Mat::zeros(6, 6);
        rbf_lower(&row_major(x.as_ref()), 1, &k, &mut kf, Par::Seq);
        let mut l = Mat::zeros(6, 6);
        let j = cholesky_with_jitter(kf.as_ref(), 0.0, l.as_mut(), Par::Seq).expect("jitter");
        assert!(j > 0.0 && j <= 1e-2, "jitter {j}");
        // A NaN matrix fails cleanly.
        let k = KernelParams {
            variance: f64::NAN,
            lengthscale: vec![1.0],
            noise: 0.1,
        };
        rbf_lower(&row_major(x.as_ref()), 1, &k, &mut kf, Par::Seq);
        assert!(cholesky_with_jitter(kf.as_ref(), 0.1, l.as_mut(), Par::Seq).is_err());
    }
}
