//! Wall time to convergence of a full fit versus a transfer to a new robot (same data sizes).
//!
//! Run: `cargo run --release -p sgplvm-core --example transfer_speed -- 300`
use sgplvm_core::{Mat, ModelConfig, SharedGplvm, TrainOptions};
use std::time::Instant;

/// Deterministic pseudo-random noise in [-0.02, 0.02] (a demonstrator is never exact).
fn noise(i: usize, j: usize, salt: u64) -> f64 {
    let mut z = (i as u64) << 32 ^ (j as u64) << 8 ^ salt;
    z = z.wrapping_mul(0x9E37_79B9_7F4A_7C15);
    z ^= z >> 29;
    z = z.wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z ^= z >> 32;
    0.04 * ((z >> 11) as f64 / (1u64 << 53) as f64 - 0.5)
}

fn robot(n: usize, d: usize, gain: f64, shift: f64) -> Mat<f64> {
    Mat::from_fn(n, d, |i, j| {
        let t = i as f64 / n as f64 * 12.0;
        gain * (t * (1.0 + 0.07 * j as f64) + shift).sin()
            + 0.2 * (0.41 * t + j as f64).cos()
            + noise(i, j, 3)
    })
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let n: usize = std::env::args()
        .nth(1)
        .and_then(|a| a.parse().ok())
        .unwrap_or(300);
    let h = Mat::from_fn(n, 18, |i, j| {
        let t = i as f64 / n as f64 * 12.0;
        (t * (1.0 + 0.05 * j as f64)).sin() + 0.3 * (0.37 * t + j as f64).cos() + noise(i, j, 1)
    });
    let (r1, r2) = (robot(n, 14, 0.8, 0.1), robot(n, 14, 0.6, -0.1));
    let options = TrainOptions::default().with_max_iters(500);
    let t = Instant::now();
    let full = SharedGplvm::fit(
        &ModelConfig::default(),
        &[("human", h.as_ref()), ("walkman", r1.as_ref())],
        "human",
        &options,
        None,
    )?;
    let full_s = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let tr = full.transfer("coman", r2.as_ref(), &options, None)?;
    let tr_s = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let full2 = SharedGplvm::fit(
        &ModelConfig::default(),
        &[("human", h.as_ref()), ("coman", r2.as_ref())],
        "human",
        &options,
        None,
    )?;
    let full2_s = t.elapsed().as_secs_f64();
    let last = |m: &SharedGplvm| {
        m.history()
            .last()
            .map(|r| (r.iteration, r.objective))
            .unwrap_or((0, f64::NAN))
    };
    println!("N={n}");
    println!(
        "full fit (walkman):  {full_s:8.3} s, {:?} iterations/objective, stop {:?}",
        last(&full),
        full.stop_reason()
    );
    println!(
        "full fit (coman):    {full2_s:8.3} s, {:?}, stop {:?}",
        last(&full2),
        full2.stop_reason()
    );
    println!(
        "transfer (coman):    {tr_s:8.3} s, {:?}, stop {:?}",
        last(&tr),
        tr.stop_reason()
    );
    println!(
        "speed-up transfer vs full coman fit: {:.1}x",
        full2_s / tr_s
    );
    Ok(())
}
