//! Shared fixtures of the core's unit tests: synthetic demonstrations, quick training options,
//! a model fitted per back constraint and flat views of [`Params`] for finite differences.
//! Also a prelude of what the test modules use (`use crate::test_support::*`).

pub(crate) use faer::{Mat, MatRef};
pub(crate) use rand::{Rng, SeedableRng};
pub(crate) use rand_chacha::ChaCha8Rng;

pub(crate) use crate::config::{BackConstraint, ModelConfig, ScaleMode};
pub(crate) use crate::error::Error;
pub(crate) use crate::model::{Latent, SharedGplvm};
pub(crate) use crate::params::{LatentParams, Params};
pub(crate) use crate::predict::Prediction;
pub(crate) use crate::regression::GpRegression;
pub(crate) use crate::train::{IterationRecord, StopReason, TrainOptions};

/// Synthetic demonstration: a 2-D phase drives a human (6 columns) and robots (4 columns,
/// each robot a slightly different smooth function of the same phase).
pub(crate) fn demo(n: usize, seed: u64) -> (Mat<f64>, Mat<f64>, Mat<f64>, Mat<f64>) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let t: Vec<(f64, f64)> = (0..n)
        .map(|i| (i as f64 / n as f64 * 6.0, rng.random_range(-1.0..1.0)))
        .collect();
    let mut noise = |s: f64| s * rng.random_range(-1.0..1.0);
    let h = Mat::from_fn(n, 6, |i, j| {
        let (a, b) = t[i];
        (a * (1.0 + 0.2 * j as f64)).sin() + 0.3 * b * j as f64 + 2.0 + noise(0.02)
    });
    let robot = |scale: f64, shift: f64| {
        Mat::from_fn(n, 4, |i, j| {
            let (a, b) = t[i];
            scale * (a * (1.0 + 0.2 * j as f64) + shift).sin() + 0.2 * b - 1.0
                + 0.01 * ((i * 7 + j * 3) % 5) as f64
        })
    };
    (h, robot(1.0, 0.0), robot(0.8, 0.1), robot(1.2, -0.1))
}

pub(crate) fn quick(max_iters: usize) -> TrainOptions {
    TrainOptions {
        max_iters,
        map_max_iters: 50,
        ..TrainOptions::default()
    }
}

pub(crate) fn fit(bc: BackConstraint, n: usize, iters: usize, seed: u64) -> SharedGplvm {
    fit_with(bc, n, seed, &quick(iters))
}

/// [`fit`] with the caller's training options.
pub(crate) fn fit_with(
    bc: BackConstraint,
    n: usize,
    seed: u64,
    options: &TrainOptions,
) -> SharedGplvm {
    let (h, r1, _, _) = demo(n, 7);
    let config = ModelConfig::default()
        .with_latent_dim(2)
        .with_back_constraint(bc)
        .with_seed(seed);
    SharedGplvm::fit(
        &config,
        &[("human", h.as_ref()), ("walkman", r1.as_ref())],
        "human",
        options,
        None,
    )
    .expect("fit")
}

/// Every scalar of `p`: latent entries (column-major), then (bandwidth,) then per space
/// variance, lengthscales, noise.
pub(crate) fn flatten(p: &Params) -> Vec<f64> {
    let mut v = Vec::new();
    let lat = match &p.latent {
        LatentParams::Free { x } => x,
        LatentParams::BackConstrained { weights, .. } => weights,
    };
    for j in 0..lat.ncols() {
        for i in 0..lat.nrows() {
            v.push(lat[(i, j)]);
        }
    }
    if let LatentParams::BackConstrained { bandwidth, .. } = &p.latent {
        v.push(*bandwidth);
    }
    for (_, k) in &p.spaces {
        v.push(k.variance);
        v.extend(&k.lengthscale);
        v.push(k.noise);
    }
    v
}

/// Inverse of [`flatten`] with the structure of `like`.
pub(crate) fn unflatten(like: &Params, v: &[f64]) -> Params {
    let mut p = like.clone();
    let mut it = v.iter().copied();
    let mut next = || it.next().expect("length");
    let lat = match &mut p.latent {
        LatentParams::Free { x } => x,
        LatentParams::BackConstrained { weights, .. } => weights,
    };
    for j in 0..lat.ncols() {
        for i in 0..lat.nrows() {
            lat[(i, j)] = next();
        }
    }
    if let LatentParams::BackConstrained { bandwidth, .. } = &mut p.latent {
        *bandwidth = next();
    }
    for (_, k) in &mut p.spaces {
        k.variance = next();
        for l in &mut k.lengthscale {
            *l = next();
        }
        k.noise = next();
    }
    p
}

pub(crate) fn bump(p: &Params, which: usize, h: f64) -> Params {
    let mut v = flatten(p);
    v[which] += h;
    unflatten(p, &v)
}

/// Objective at parameters `p` without refitting anything (crate-internal).
pub(crate) fn objective_at(model: &SharedGplvm, p: &Params) -> f64 {
    let mut m = model.clone();
    match (&mut m.latent, &p.latent) {
        (Latent::Free { x }, LatentParams::Free { x: nx }) => *x = nx.clone(),
        (
            Latent::Back {
                weights, bandwidth, ..
            },
            LatentParams::BackConstrained {
                weights: w,
                bandwidth: b,
            },
        ) => {
            *weights = w.clone();
            *bandwidth = *b;
        }
        _ => panic!("kind"),
    }
    for (s, (_, k)) in m.spaces.iter_mut().zip(&p.spaces) {
        s.kernel = k.clone();
    }
    m.update_latent_points();
    m.objective()
}

/// Largest |(L·Lᵀ)_ij − (K_ij + added·δ_ij)| over the lower triangle, relative to the largest
/// |K_ij + added·δ_ij|: how far the lower-triangular factor `l` is from one of K + added·I
/// (only the lower triangles of `kf` and `l` are read).
pub(crate) fn reconstruction_error(kf: MatRef<'_, f64>, l: MatRef<'_, f64>, added: f64) -> f64 {
    let n = kf.nrows();
    let mut worst = 0.0f64;
    let mut top = 0.0f64;
    for i in 0..n {
        for j in 0..=i {
            let llt: f64 = (0..=j).map(|t| l[(i, t)] * l[(j, t)]).sum();
            let want = kf[(i, j)] + if i == j { added } else { 0.0 };
            worst = worst.max((llt - want).abs());
            top = top.max(want.abs());
        }
    }
    worst / top
}

/// `m` times `f`.
pub(crate) fn times(m: &Mat<f64>, f: f64) -> Mat<f64> {
    Mat::from_fn(m.nrows(), m.ncols(), |i, j| m[(i, j)] * f)
}

/// `m` divided by the power of two nearest its centred root mean square (a scale in
/// [1/√2, √2]), so that `m · 2^k` is standardised by exactly `2^k`.
pub(crate) fn unit_scale(m: &Mat<f64>) -> Mat<f64> {
    let (n, d) = (m.nrows(), m.ncols());
    let mut ss = 0.0;
    for j in 0..d {
        let mu = (0..n).map(|i| m[(i, j)]).sum::<f64>() / n as f64;
        ss += (0..n).map(|i| (m[(i, j)] - mu).powi(2)).sum::<f64>();
    }
    let rms = (ss / (n * d) as f64).sqrt();
    times(m, 2f64.powi(-(rms.log2().round() as i32)))
}

/// The bench's human and robot data for the ignored timing tests, from the file `BC_DATA`
/// names (little-endian f64: n, d_human, d_robot, then the human rows and the robot rows, as
/// `benches/bench_vs_gpy.py`'s smooth_data writes them); `None` when `BC_DATA` is not set.
pub(crate) fn bench_data_from_env() -> Option<(Mat<f64>, Mat<f64>)> {
    let path = std::env::var("BC_DATA").ok()?;
    let bytes = std::fs::read(path).expect("BC_DATA reads");
    let v: Vec<f64> = bytes
        .chunks_exact(8)
        .map(|c| f64::from_le_bytes(c.try_into().expect("8 bytes")))
        .collect();
    let (n, dh, dr) = (v[0] as usize, v[1] as usize, v[2] as usize);
    let h = Mat::from_fn(n, dh, |i, j| v[3 + i * dh + j]);
    let r = Mat::from_fn(n, dr, |i, j| v[3 + n * dh + i * dr + j]);
    Some((h, r))
}

/// The kernel `kern` between two 1-D latent points.
pub(crate) fn kernel_1d(kern: &crate::kernel::KernelParams, a: f64, b: f64) -> f64 {
    let l2 = kern.lengthscale[0] * kern.lengthscale[0];
    kern.variance * (-0.5 * (a - b) * (a - b) / l2).exp()
}

/// `(K + σ² I)⁻¹ b` for a GP with `kern` on the 1-D points `xs` (with the jitter the model's
/// factorisation adds), by plain Gaussian elimination: a reference independent of faer.
pub(crate) fn gp_solve_1d(kern: &crate::kernel::KernelParams, xs: &[f64], b: &[f64]) -> Vec<f64> {
    let m = xs.len();
    let mut aug: Vec<Vec<f64>> = (0..m)
        .map(|r| {
            (0..m)
                .map(|c| {
                    let jitter = if r == c {
                        kern.noise + 1e-8 * kern.variance
                    } else {
                        0.0
                    };
                    kernel_1d(kern, xs[r], xs[c]) + jitter
                })
                .chain([b[r]])
                .collect()
        })
        .collect();
    for c in 0..m {
        for r in c + 1..m {
            let f = aug[r][c] / aug[c][c];
            for j in c..=m {
                aug[r][j] -= f * aug[c][j];
            }
        }
    }
    let mut sol = vec![0.0; m];
    for r in (0..m).rev() {
        let s: f64 = (r + 1..m).map(|j| aug[r][j] * sol[j]).sum();
        sol[r] = (aug[r][m] - s) / aug[r][r];
    }
    sol
}
