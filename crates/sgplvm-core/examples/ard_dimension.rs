//! The latent dimension from the data (issue 34), the full table: data drawn from a known
//! latent dimension Q*, two spaces of 18 and 14 columns through random smooth maps plus noise,
//! a Bayesian shared GP-LVM trained with Q = 8; per seed, the number of latent dimensions whose
//! ARD weight (α²/ℓ²) exceeds 5 % of its space's largest (`tests/support/latent_dimension.rs`;
//! the seeded test `tests/latent_dimension.rs` runs a small part of it).
//!
//! `cargo run --release -p sgplvm-core --example ard_dimension -- [SEEDS] [N] [M] [ITERS] [BC]
//! [NOISE] [Q*...]` (defaults 10 seeds, N = 400, M = 50, 3000 iterations, back constraint
//! `none`, initial noise 0.1 of each space's variance, Q* = 2, 3, 4).

#[path = "../tests/support/latent_dimension.rs"]
mod latent_dimension;

use latent_dimension::{fit, used_dimensions, Setting};
use sgplvm_core::BackConstraint;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let arg = |i: usize, default: usize| {
        args.get(i)
            .map(|a| a.parse().expect("a whole number"))
            .unwrap_or(default)
    };
    let seeds = arg(0, 10);
    let setting = Setting {
        frames: arg(1, 400),
        inducing: arg(2, 50),
        iterations: arg(3, 3000),
        back_constraint: args
            .get(4)
            .map(|s| s.parse().expect("none or input"))
            .unwrap_or(BackConstraint::None),
        initial_noise: args.get(5).map_or(0.1, |s| s.parse().expect("a number")),
    };
    let dims: Vec<usize> = match args.len() > 6 {
        true => args[6..].iter().map(|s| s.parse().expect("Q*")).collect(),
        false => vec![2, 3, 4],
    };
    println!("{setting:?}");
    println!("Q*  seed  used  iterations  ARD weights / largest (space a | space b)  stop");
    for q_true in dims {
        let mut right = 0;
        for seed in 0..seeds as u64 {
            let model = fit(q_true, seed, &setting);
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
                model.history().len() - 1,
                shown.join(" | "),
                model
                    .stop_reason()
                    .map_or("-".into(), |r| r.name().to_string())
            );
        }
        println!("Q* = {q_true}: {right} of {seeds} seeds found {q_true} dimensions");
    }
}
