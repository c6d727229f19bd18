//! Criterion benches of the sparse model (issue 14): one objective + gradient evaluation
//! (human 18-D + robot 14-D, Q = 5, input back constraints with M centres, Z trained) at
//! N = 20,000 and M = 100, one-frame and batch prediction at M = 100 (and one frame of the
//! Bayesian model at M = 50, issue 34's ≤ 10 µs), and the scaling of one
//! evaluation over N × M (`SGPLVM_SPARSE_SCALING=1`: N ∈ {1k, 5k, 20k, 100k}, M ∈ {50, 100,
//! 200}; off by default, it takes minutes).
//!
//! Run: `cargo bench -p sgplvm-core --bench sparse`

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use sgplvm_core::{Mat, ModelConfig, SharedGplvm, TrainOptions};
use std::hint::black_box;

mod data;

/// The benches' demonstration over a phase of 120 radians (long recordings).
fn data(n: usize) -> (Mat<f64>, Mat<f64>) {
    data::smooth(n, 120.0)
}

/// The sparse model at its starting point (no training).
fn model(n: usize, m: usize) -> SharedGplvm {
    model_of(n, ModelConfig::default().with_inducing(Some(m)))
}

/// The model `config` describes on `n` frames, at its starting point (no training: the cost of a
/// prediction does not depend on the parameters' values).
fn model_of(n: usize, config: ModelConfig) -> SharedGplvm {
    let (h, r) = data(n);
    let options = TrainOptions {
        max_iters: 0,
        ..TrainOptions::default()
    };
    SharedGplvm::fit(
        &config,
        &[("human", h.as_ref()), ("robot", r.as_ref())],
        "human",
        &options,
        None,
    )
    .expect("model builds")
}

fn bench_eval(c: &mut Criterion) {
    let mut g = c.benchmark_group("sparse_evaluation");
    g.sample_size(10);
    let m = model(20_000, 100);
    let mut ev = m.sparse_evaluator().expect("evaluator");
    g.bench_function("n20000_m100", |b| {
        b.iter(|| black_box(ev.evaluate().expect("evaluates")))
    });
    g.finish();
    if std::env::var_os("SGPLVM_SPARSE_SCALING").is_some() {
        let mut g = c.benchmark_group("sparse_scaling");
        g.sample_size(10);
        for n in [1_000usize, 5_000, 20_000, 100_000] {
            for mm in [50usize, 100, 200] {
                let m = model(n, mm);
                let mut ev = m.sparse_evaluator().expect("evaluator");
                g.bench_with_input(BenchmarkId::new(format!("m{mm}"), n), &n, |b, _| {
                    b.iter(|| black_box(ev.evaluate().expect("evaluates")))
                });
            }
        }
        g.finish();
    }
}

fn bench_predict(c: &mut Criterion) {
    let mut g = c.benchmark_group("sparse_prediction");
    let m = model(5_000, 100);
    let (h, _) = data(10_000);
    let frame: Vec<f64> = (0..18).map(|j| h[(123, j)]).collect();
    let mut out = vec![0.0; 14];
    g.bench_function("frame_m100", |b| {
        b.iter(|| {
            m.predict_frame(black_box(&frame), "robot", &mut out)
                .expect("predicts");
            black_box(out[0])
        })
    });
    // The Bayesian model (issue 34) as `train --bayesian` builds it: M = 50, input back
    // constraints, Q = 5; its goal is ≤ 10 µs per frame.
    let bayesian = model_of(
        1_000,
        ModelConfig::default()
            .with_inducing(Some(50))
            .with_bayesian(true),
    );
    g.bench_function("frame_bayesian_m50", |b| {
        b.iter(|| {
            bayesian
                .predict_frame(black_box(&frame), "robot", &mut out)
                .expect("predicts");
            black_box(out[0])
        })
    });
    g.sample_size(10);
    g.bench_function("batch10000_m100", |b| {
        b.iter(|| black_box(m.predict(h.as_ref(), "robot", false).expect("predicts")))
    });
    g.finish();
}

criterion_group!(benches, bench_eval, bench_predict);
criterion_main!(benches);
