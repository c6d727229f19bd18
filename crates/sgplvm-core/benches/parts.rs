//! Criterion benches of a latent space per arm (`PartsGplvm`, issue 49): one frame and a batch
//! of 1,000 predicted through both arms' models, beside the single shared latent space on the
//! same frames (human 18-D = 9 + 9, robot 14-D = 7 + 7, Q = 5 per model, input back
//! constraints), exact at N = 300 and sparse at N = 3,000 (M = 100). Goal: one frame ≤ 50 µs.
//!
//! Run: `cargo bench -p sgplvm-core --bench parts`

use criterion::{criterion_group, criterion_main, Criterion};
use sgplvm_core::{Mat, ModelConfig, PartSpec, PartsConfig, PartsGplvm, SharedGplvm, TrainOptions};
use std::hint::black_box;

mod data;

/// The left arm (the first half of each space's columns) and the right arm.
fn arms() -> Vec<PartSpec> {
    let half = |d: usize, k: usize| -> Vec<usize> { (k * d / 2..(k + 1) * d / 2).collect() };
    ["left_arm", "right_arm"]
        .iter()
        .enumerate()
        .map(|(k, name)| PartSpec::new(*name, [("human", half(18, k)), ("robot", half(14, k))]))
        .collect()
}

/// Both models on `n` frames, `inducing` inputs (None: exact), a few iterations (prediction
/// costs the same at any parameters).
fn models(n: usize, inducing: Option<usize>) -> (SharedGplvm, PartsGplvm) {
    let (h, r) = data::smooth(n, 12.0);
    let spaces = [("human", h.as_ref()), ("robot", r.as_ref())];
    let config = ModelConfig::default().with_inducing(inducing);
    let options = TrainOptions::default().with_max_iters(3);
    let single = SharedGplvm::fit(&config, &spaces, "human", &options, None).expect("fits");
    let parts_config = PartsConfig::new(config, arms()).with_parent_latent_dim(None);
    let parts =
        PartsGplvm::fit(&parts_config, &spaces, "human", &options, None, None).expect("fits");
    (single, parts)
}

fn bench_parts(c: &mut Criterion) {
    let mut g = c.benchmark_group("parts_prediction");
    for (n, inducing) in [(300usize, None), (3000, Some(100))] {
        let what = match inducing {
            None => format!("exact N={n}"),
            Some(m) => format!("sparse N={n} M={m}"),
        };
        let (single, parts) = models(n, inducing);
        let (h, _): (Mat<f64>, _) = data::smooth(1000, 12.0);
        let frame: Vec<f64> = (0..18).map(|j| h[(17, j)]).collect();
        let mut out = vec![0.0; 14];
        g.throughput(criterion::Throughput::Elements(1));
        g.bench_function(format!("frame, per arm, {what}"), |b| {
            b.iter(|| {
                parts
                    .predict_frame(black_box(&frame), "robot", &mut out)
                    .expect("predicts");
                black_box(out[0])
            })
        });
        g.bench_function(format!("frame, single, {what}"), |b| {
            b.iter(|| {
                single
                    .predict_frame(black_box(&frame), "robot", &mut out)
                    .expect("predicts");
                black_box(out[0])
            })
        });
        g.throughput(criterion::Throughput::Elements(1000));
        g.bench_function(format!("1000 frames, per arm, {what}"), |b| {
            b.iter(|| black_box(parts.predict(h.as_ref(), "robot", false).expect("predicts")))
        });
        g.bench_function(format!("1000 frames, single, {what}"), |b| {
            b.iter(|| {
                black_box(
                    single
                        .predict(h.as_ref(), "robot", false)
                        .expect("predicts"),
                )
            })
        });
    }
    g.finish();
}

criterion_group!(benches, bench_parts);
criterion_main!(benches);
