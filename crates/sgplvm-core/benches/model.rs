//! Criterion benches of the core: one objective+gradient evaluation (human 18-D + robot 14-D,
//! Q = 5) at N = 300 and 1000, the Cholesky + inverse floor of the same matrices, one-frame
//! prediction and batch prediction, and `set_params` + `evaluate` against `evaluate` alone.
//!
//! Run: `cargo bench -p sgplvm-core --bench model`

use criterion::{criterion_group, criterion_main, Criterion};
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt;
use faer::Par;
use sgplvm_core::{BackConstraint, Mat, ModelConfig, SharedGplvm, TrainOptions};
use std::hint::black_box;

mod data;

/// The benches' demonstration over a phase of 12 radians.
fn data(n: usize) -> (Mat<f64>, Mat<f64>) {
    data::smooth(n, 12.0)
}

fn model(n: usize, bc: BackConstraint) -> SharedGplvm {
    let (h, r) = data(n);
    let config = ModelConfig::default().with_back_constraint(bc);
    let options = TrainOptions {
        max_iters: 0,
        map_max_iters: 0,
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
    let mut g = c.benchmark_group("evaluation");
    g.sample_size(20);
    for n in [300usize, 1000] {
        for bc in [BackConstraint::Input, BackConstraint::None] {
            let m = model(n, bc);
            let mut e = m.evaluator().expect("evaluator");
            g.bench_function(format!("objective+gradient N={n} {bc:?}"), |b| {
                b.iter(|| black_box(e.evaluate().expect("evaluates")))
            });
        }
        // Floor: Cholesky + inverse of two N×N SPD matrices (one per space), with the same
        // parallelism as the evaluation: the two spaces on rayon's pool (one thread each with
        // RAYON_NUM_THREADS=1 making it sequential), faer's own threads from N = 700.
        let m = model(n, BackConstraint::None);
        let x = m.latent_points().to_owned();
        let k = Mat::from_fn(n, n, |i, j| {
            let r2: f64 = (0..x.ncols())
                .map(|t| (x[(i, t)] - x[(j, t)]).powi(2))
                .sum();
            (-0.5 * r2).exp() + if i == j { 0.1 } else { 0.0 }
        });
        let par = if n >= 700 { Par::rayon(0) } else { Par::Seq };
        let buffers = || {
            let mem = MemBuffer::new(
                llt::factor::cholesky_in_place_scratch::<f64>(n, par, Default::default())
                    .or(llt::inverse::inverse_scratch::<f64>(n, par)),
            );
            (k.clone(), Mat::<f64>::zeros(n, n), mem)
        };
        let floor = |(l, inv, mem): &mut (Mat<f64>, Mat<f64>, MemBuffer)| {
            l.copy_from(&k);
            llt::factor::cholesky_in_place(
                l.as_mut(),
                Default::default(),
                par,
                MemStack::new(mem),
                Default::default(),
            )
            .expect("spd");
            llt::inverse::inverse(inv.as_mut(), l.as_ref(), par, MemStack::new(mem));
        };
        let (mut first, mut second) = (buffers(), buffers());
        g.bench_function(format!("2x(cholesky+inverse) N={n}"), |b| {
            b.iter(|| {
                rayon::join(|| floor(&mut first), || floor(&mut second));
                black_box(first.1[(0, 0)] + second.1[(0, 0)])
            })
        });
    }
    g.finish();
}

/// A user's own optimiser driving the model: `set_params` then `evaluate` (objective and
/// gradient in natural units), against `evaluate` alone (issue 18: within 1.3×).
fn bench_set_params(c: &mut Criterion) {
    let mut g = c.benchmark_group("set_params");
    g.sample_size(20);
    for bc in [BackConstraint::None, BackConstraint::Input] {
        let mut m = model(300, bc);
        let p = m.params();
        g.bench_function(format!("evaluate N=300 {bc:?}"), |b| {
            b.iter(|| black_box(m.evaluate().expect("evaluates")))
        });
        g.bench_function(format!("set_params+evaluate N=300 {bc:?}"), |b| {
            b.iter(|| {
                m.set_params(&p).expect("valid");
                black_box(m.evaluate().expect("evaluates"))
            })
        });
    }
    g.finish();
}

fn bench_predict(c: &mut Criterion) {
    let mut g = c.benchmark_group("prediction");
    let n = 300;
    for bc in [BackConstraint::Input, BackConstraint::None] {
        let m = model(n, bc);
        let (h, _) = data(1000);
        let frame: Vec<f64> = (0..18).map(|j| h[(17, j)]).collect();
        let mut out = vec![0.0; 14];
        g.bench_function(format!("predict_frame N={n} {bc:?}"), |b| {
            b.iter(|| {
                m.predict_frame(black_box(&frame), "robot", &mut out)
                    .expect("predicts");
                black_box(out[0])
            })
        });
        g.throughput(criterion::Throughput::Elements(1000));
        g.bench_function(format!("predict 1000 frames N={n} {bc:?}"), |b| {
            b.iter(|| black_box(m.predict(h.as_ref(), "robot", false).expect("predicts")))
        });
        g.bench_function(format!("predict+variance 1000 frames N={n} {bc:?}"), |b| {
            b.iter(|| black_box(m.predict(h.as_ref(), "robot", true).expect("predicts")))
        });
        g.throughput(criterion::Throughput::Elements(1));
    }
    g.finish();
}

criterion_group!(benches, bench_eval, bench_set_params, bench_predict);
criterion_main!(benches);
