//! The latent-dimension problem of issue 34, shared by the test `tests/latent_dimension.rs`
//! and the table's example `examples/ard_dimension.rs`: data drawn from a known latent
//! dimension Q* (X* ~ N(0, I), two spaces of 18 and 14 columns through random smooth maps,
//! sin(X* A + b), plus N(0, 0.05²) noise), a Bayesian shared GP-LVM trained on it with Q = 8,
//! and the number of latent dimensions its ARD weights (α²/ℓ²) say it uses.

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use sgplvm_core::{BackConstraint, Mat, ModelConfig, SharedGplvm, TrainOptions};

/// The share of a space's largest ARD weight above which a dimension counts as used.
pub const USED: f64 = 0.05;

/// The latent dimension the model is given (an upper bound on Q*).
pub const LATENT_DIM: usize = 8;

/// How one recovery is trained.
#[derive(Debug, Clone, Copy)]
pub struct Setting {
    /// Frames N.
    pub frames: usize,
    /// Inducing inputs M per space.
    pub inducing: usize,
    /// Iteration budget.
    pub iterations: usize,
    /// Back constraint of q(X)'s means.
    pub back_constraint: BackConstraint,
    /// Initial noise variance as a fraction of each space's variance.
    pub initial_noise: f64,
}

/// `n` frames of two spaces (18 and 14 columns) from `q_true` latent dimensions.
pub fn data(q_true: usize, n: usize, seed: u64) -> (Mat<f64>, Mat<f64>) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut normal = || -> f64 { StandardNormal.sample(&mut rng) };
    let x = Mat::from_fn(n, q_true, |_, _| normal());
    let mut space = |d: usize| {
        let a = Mat::from_fn(q_true, d, |_, _| normal());
        let b: Vec<f64> = (0..d).map(|_| normal()).collect();
        let noise = Mat::from_fn(n, d, |_, _| 0.05 * normal());
        Mat::from_fn(n, d, |i, j| {
            let t: f64 = (0..q_true).map(|k| x[(i, k)] * a[(k, j)]).sum::<f64>() + b[j];
            t.sin() + noise[(i, j)]
        })
    };
    let h = space(18);
    let r = space(14);
    (h, r)
}

/// Trains the model on the data of `q_true` dimensions drawn with `seed` (data seed
/// `1000 Q* + seed`, model seed `seed`).
pub fn fit(q_true: usize, seed: u64, setting: &Setting) -> SharedGplvm {
    let (a, b) = data(q_true, setting.frames, 1000 * q_true as u64 + seed);
    let mut config = ModelConfig::default()
        .with_latent_dim(LATENT_DIM)
        .with_back_constraint(setting.back_constraint)
        .with_inducing(Some(setting.inducing))
        .with_bayesian(true)
        .with_seed(seed);
    config.init_noise_fraction = setting.initial_noise;
    // To convergence: no relative-decrease stop (the bound creeps on flat stretches while a
    // dimension is being switched off).
    let options = TrainOptions {
        max_iters: setting.iterations,
        rel_tol: 0.0,
        grad_tol: 1e-8,
        ..TrainOptions::default()
    };
    SharedGplvm::fit(
        &config,
        &[("a", a.as_ref()), ("b", b.as_ref())],
        "a",
        &options,
        None,
    )
    .expect("the Bayesian model trains on the synthetic data")
}

/// The dimensions whose weight exceeds [`USED`] of its space's largest in either space, and
/// the weights of both spaces.
pub fn used_dimensions(model: &SharedGplvm) -> (usize, Vec<Vec<f64>>) {
    let weights: Vec<Vec<f64>> = ["a", "b"]
        .iter()
        .map(|s| model.ard_weights(s).expect("space"))
        .collect();
    let used = (0..LATENT_DIM)
        .filter(|&t| {
            weights.iter().any(|w| {
                let max = w.iter().cloned().fold(0.0, f64::max);
                w[t] > USED * max
            })
        })
        .count();
    (used, weights)
}
