//! Times one evaluation of the Bayesian bound and gradient (two spaces of 18 and 14 columns,
//! Q = 8, M = 50) for profiling: `cargo run --release -p sgplvm-core --example bayesian_eval -- N REPEATS`.

use sgplvm_core::{bayesian_bound, Jitter, KernelParams, Mat, MatRef};

fn main() {
    let args: Vec<usize> = std::env::args()
        .skip(1)
        .map(|a| a.parse().expect("number"))
        .collect();
    let (n, repeats) = (
        args.first().copied().unwrap_or(3000),
        args.get(1).copied().unwrap_or(10),
    );
    let (q, m) = (8, 50);
    let mut seed = 1u64;
    let mut r = move || {
        seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((seed >> 11) as f64) / ((1u64 << 53) as f64)
    };
    let mean = Mat::from_fn(n, q, |_, _| 2.0 * r() - 1.0);
    let var = Mat::from_fn(n, q, |_, _| 0.05 + 0.5 * r());
    let z = Mat::from_fn(m, q, |_, _| 2.0 * r() - 1.0);
    let ys: Vec<Mat<f64>> = [18, 14]
        .iter()
        .map(|&d| Mat::from_fn(n, d, |i, j| (mean[(i, j % q)] * (1.0 + j as f64)).sin()))
        .collect();
    let kernels: Vec<KernelParams> = (0..2)
        .map(|_| KernelParams {
            variance: 1.0,
            lengthscale: (0..q).map(|t| 1.0 + 0.1 * t as f64).collect(),
            noise: 0.1,
        })
        .collect();
    let views: Vec<MatRef<'_, f64>> = ys.iter().map(|y| y.as_ref()).collect();
    let start = std::time::Instant::now();
    let mut v = 0.0;
    for _ in 0..repeats {
        v += bayesian_bound(
            mean.as_ref(),
            var.as_ref(),
            z.as_ref(),
            &views,
            &kernels,
            Jitter::Absolute(1e-8),
        )
        .expect("bound")
        .value;
    }
    println!(
        "N = {n}: {:.4} s per evaluation ({v:.3})",
        start.elapsed().as_secs_f64() / repeats as f64
    );
}
