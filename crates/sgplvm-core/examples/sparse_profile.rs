//! Times repeated objective+gradient evaluations of the sparse model (issue 14's benchmark
//! problem: human 18-D + robot 14-D, Q = 5, input back constraints with M centres, Z trained)
//! and prints the fastest and the CPU time per evaluation (then of prediction, in batch and
//! frame by frame), for profiling with `perf record` on
//! a shared machine.
//!
//! Run: `cargo run --release -p sgplvm-core --example sparse_profile -- 20000 100 20`
//! (N, M, repetitions; `RAYON_NUM_THREADS=1` for one core).
use sgplvm_core::{ModelConfig, SharedGplvm, TrainOptions};
use std::time::Instant;

#[path = "../benches/data/mod.rs"]
mod data;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<usize> = std::env::args()
        .skip(1)
        .filter_map(|a| a.parse().ok())
        .collect();
    let n = args.first().copied().unwrap_or(20_000);
    let m = args.get(1).copied().unwrap_or(100);
    let reps = args.get(2).copied().unwrap_or(20);
    // The data of `benches/sparse.rs`.
    let (h, r) = data::smooth(n, 120.0);
    let options = TrainOptions {
        max_iters: 0,
        ..TrainOptions::default()
    };
    let model = SharedGplvm::fit(
        &ModelConfig::default().with_inducing(Some(m)),
        &[("human", h.as_ref()), ("robot", r.as_ref())],
        "human",
        &options,
        None,
    )?;
    let mut ev = model.sparse_evaluator()?;
    let mut best = f64::INFINITY;
    let mut f = 0.0;
    let cpu0 = cpu_seconds();
    for _ in 0..reps {
        let t = Instant::now();
        f = ev.evaluate()?;
        best = best.min(t.elapsed().as_secs_f64());
    }
    let cpu = cpu_seconds().zip(cpu0).map(|(b, a)| (b - a) / reps as f64);
    let g = ev.gradient();
    let norm = g.iter().map(|v| v * v).sum::<f64>().sqrt();
    println!(
        "N = {n}, M = {m}: objective {f:.10e}, |gradient| {norm:.10e}, fastest of {reps}: {:.2} ms",
        best * 1e3
    );
    if let Some(cpu) = cpu {
        println!("CPU time (all threads) per evaluation: {:.1} ms", cpu * 1e3);
    }
    // Prediction (the bench's: M inducing inputs, frames of the same demonstration): a batch
    // of 10,000 frames and one frame at a time.
    let frames = 10_000.min(n);
    let batch = h.as_ref().subrows(0, frames);
    let (mut best, reps) = (f64::INFINITY, 20);
    let cpu0 = cpu_seconds();
    for _ in 0..reps {
        let t = Instant::now();
        std::hint::black_box(model.predict(batch, "robot", false)?);
        best = best.min(t.elapsed().as_secs_f64());
    }
    let cpu = cpu_seconds().zip(cpu0).map(|(b, a)| (b - a) / reps as f64);
    println!(
        "batch of {frames} frames: fastest {:.2} ms ({:.0} frames/s), CPU time {:.2} ms",
        best * 1e3,
        frames as f64 / best,
        cpu.unwrap_or(f64::NAN) * 1e3
    );
    let mut out = vec![0.0; 14];
    let mut row = vec![0.0; 18];
    let (mut best, per) = (f64::INFINITY, 1000);
    let cpu0 = cpu_seconds();
    for r in 0..reps {
        let t = Instant::now();
        for i in 0..per {
            for (j, v) in row.iter_mut().enumerate() {
                *v = h[((r * per + i) % n, j)];
            }
            model.predict_frame(&row, "robot", &mut out)?;
            std::hint::black_box(out[0]);
        }
        best = best.min(t.elapsed().as_secs_f64() / per as f64);
    }
    let cpu = cpu_seconds()
        .zip(cpu0)
        .map(|(b, a)| (b - a) / (reps * per) as f64);
    println!(
        "one frame: fastest {:.2} µs, CPU time {:.2} µs",
        best * 1e6,
        cpu.unwrap_or(f64::NAN) * 1e6
    );
    Ok(())
}

/// User + system CPU seconds of this process (all threads) from `/proc/self/stat` (Linux;
/// 100 ticks per second assumed): on a loaded machine, the work done whatever the wall time.
fn cpu_seconds() -> Option<f64> {
    let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
    let fields: Vec<&str> = stat.rsplit_once(')')?.1.split_whitespace().collect();
    let ticks = fields.get(11)?.parse::<f64>().ok()? + fields.get(12)?.parse::<f64>().ok()?;
    Some(ticks / 100.0)
}
