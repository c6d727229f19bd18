//! Times repeated objective+gradient evaluations (for profiling with `perf record`).
//!
//! Run: `cargo run --release -p sgplvm-core --example eval_profile -- 300 50` (input back
//! constraints; `FREE=1` for free latent points; `RAYON_NUM_THREADS=1` for one core).
use sgplvm_core::{BackConstraint, Mat, ModelConfig, SharedGplvm, TrainOptions};
use std::time::Instant;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<usize> = std::env::args()
        .skip(1)
        .filter_map(|a| a.parse().ok())
        .collect();
    let n = args.first().copied().unwrap_or(300);
    let reps = args.get(1).copied().unwrap_or(50);
    let h = Mat::from_fn(n, 18, |i, j| {
        ((i as f64) * 12.0 / n as f64 * (1.0 + 0.05 * j as f64)).sin()
    });
    let r = Mat::from_fn(n, 14, |i, j| {
        ((i as f64) * 12.0 / n as f64 * (1.0 + 0.07 * j as f64) + 0.1).sin()
    });
    let back_constraint = if std::env::var_os("FREE").is_some() {
        BackConstraint::None
    } else {
        BackConstraint::Input
    };
    let options = TrainOptions {
        max_iters: 0,
        map_max_iters: 0,
        ..TrainOptions::default()
    };
    let m = SharedGplvm::fit(
        &ModelConfig::default().with_back_constraint(back_constraint),
        &[("human", h.as_ref()), ("robot", r.as_ref())],
        "human",
        &options,
        None,
    )?;
    let mut e = m.evaluator()?;
    let t = Instant::now();
    let mut f = 0.0;
    for _ in 0..reps {
        f = e.evaluate()?;
    }
    println!(
        "N={n}: {:.3} ms per evaluation (objective {f:.6})",
        t.elapsed().as_secs_f64() * 1e3 / reps as f64
    );
    let t = Instant::now();
    for _ in 0..reps {
        f = m.evaluate()?.0;
    }
    println!(
        "N={n}: {:.3} ms per SharedGplvm::evaluate (objective {f:.6})",
        t.elapsed().as_secs_f64() * 1e3 / reps as f64
    );
    let frame: Vec<f64> = (0..18).map(|j| h[(n / 3, j)]).collect();
    let mut out = vec![0.0; 14];
    let t = Instant::now();
    for _ in 0..reps * 100 {
        m.predict_frame(&frame, "robot", &mut out)?;
    }
    println!(
        "N={n}: {:.2} us per predict_frame",
        t.elapsed().as_secs_f64() * 1e6 / (reps * 100) as f64
    );
    Ok(())
}
