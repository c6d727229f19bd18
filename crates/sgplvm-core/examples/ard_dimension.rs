//! The latent dimension from the data (issue 34): data drawn from a known latent dimension Q*,
//! two spaces of 18 and 14 columns through random smooth maps plus noise, a Bayesian shared
//! GP-LVM trained with Q = 8; the number of latent dimensions whose ARD weight (α²/ℓ²) exceeds
//! 5 % of the largest, per seed.
//!
//! `cargo run --release -p sgplvm-core --example ard_dimension -- [SEEDS] [N] [M] [ITERS] [BC]
//! [NOISE] [Q*...]` (defaults 10 seeds, N = 200, M = 30, 1000 iterations, back constraint
//! `input`, initial noise 0.1 of each space's variance, Q* = 2, 3, 4).

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use sgplvm_core::{BackConstraint, Mat, ModelConfig, SharedGplvm, TrainOptions};

/// The share of a space's largest ARD weight above which a dimension counts as used.
const USED: f64 = 0.05;

/// `n` frames of two spaces (18 and 14 columns) from `q_true` latent dimensions.
fn data(q_true: usize, n: usize, seed: u64) -> (Mat<f64>, Mat<f64>) {
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

/// Dimensions whose weight exceeds [`USED`] of the largest, in either space.
fn used_dimensions(model: &SharedGplvm) -> (usize, Vec<Vec<f64>>) {
    let weights: Vec<Vec<f64>> = ["a", "b"]
        .iter()
        .map(|s| model.ard_weights(s).expect("space"))
        .collect();
    let q = weights[0].len();
    let used = (0..q)
        .filter(|&t| {
            weights.iter().any(|w| {
                let max = w.iter().cloned().fold(0.0, f64::max);
                w[t] > USED * max
            })
        })
        .count();
    (used, weights)
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let arg = |i: usize, default: usize| {
        args.get(i)
            .map(|a| a.parse().expect("a whole number"))
            .unwrap_or(default)
    };
    let (seeds, n, m, iters) = (arg(0, 10), arg(1, 200), arg(2, 30), arg(3, 1000));
    let bc: BackConstraint = args
        .get(4)
        .map(|s| s.parse().expect("none or input"))
        .unwrap_or(BackConstraint::Input);
    let noise: f64 = args.get(5).map_or(0.1, |s| s.parse().expect("a number"));
    let dims: Vec<usize> = match args.len() > 6 {
        true => args[6..].iter().map(|s| s.parse().expect("Q*")).collect(),
        false => vec![2, 3, 4],
    };
    println!("Q*  seed  used  iterations  ARD weights / largest (space a | space b)");
    for q_true in dims {
        let mut right = 0;
        for seed in 0..seeds as u64 {
            let (a, b) = data(q_true, n, 1000 * q_true as u64 + seed);
            let mut config = ModelConfig::default()
                .with_latent_dim(8)
                .with_back_constraint(bc)
                .with_inducing(Some(m))
                .with_bayesian(true)
                .with_seed(seed);
            config.init_noise_fraction = noise;
            // To convergence: no relative-decrease stop (the bound creeps on flat stretches
            // while a dimension is being switched off).
            let options = TrainOptions {
                max_iters: iters,
                rel_tol: 0.0,
                grad_tol: 1e-8,
                ..TrainOptions::default()
            };
            let model = SharedGplvm::fit(
                &config,
                &[("a", a.as_ref()), ("b", b.as_ref())],
                "a",
                &options,
                None,
            )
            .expect("fit");
            let (used, weights) = used_dimensions(&model);
            right += usize::from(used == q_true);
            let shown: Vec<String> = weights
                .iter()
                .map(|w| {
                    let max = w.iter().cloned().fold(0.0, f64::max);
                    w.iter()
                        .map(|v| format!("{:.2}", v / max))
                        .collect::<Vec<_>>()
                        .join(" ")
                })
                .collect();
            println!(
                "{q_true:>2}  {seed:>4}  {used:>4}  {:>10}  {}  ({})",
                model.history().len(),
                shown.join(" | "),
                model.stop_reason().map_or("-".into(), |r| r.to_string())
            );
        }
        println!("Q* = {q_true}: {right} of {seeds} seeds found {q_true} dimensions");
    }
}
