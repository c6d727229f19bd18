//! The teleoperation path end to end on the shipped demonstrations: one human frame as a CSV
//! line in, the robot's joint commands out (parse, reorder, human → latent → robot, format),
//! and the model's per-frame prediction alone. Run with `cargo bench --bench teleop`.

use criterion::{criterion_group, criterion_main, Criterion};
use sgplvm::csv::{format_line, CsvHeader};
use sgplvm::pipeline;
use sgplvm::{ModelConfig, TrainOptions};

fn teleop(c: &mut Criterion) {
    let demos = pipeline::load(None).expect("shipped demonstrations");
    let options = TrainOptions::default().with_max_iters(100);
    let full = demos
        .train(
            &["walkman".to_string()],
            &ModelConfig::default(),
            &options,
            None,
            None,
        )
        .expect("training");
    let model = demos
        .transfer(&full, "coman", &options, None, None)
        .expect("transfer");
    let ds = &demos.dataset;
    let header = CsvHeader::parse(&ds.human.joint_names.join(","));
    let frame = ds.test[0];
    let line = format_line(
        None,
        &ds.human
            .positions
            .row(frame)
            .iter()
            .copied()
            .collect::<Vec<_>>(),
    );
    let mut joints = vec![0.0; 14];

    c.bench_function(
        "predict_frame (N = training frames, 18 → 5 → 14)",
        |b| {
            let human: Vec<f64> = ds.human.positions.row(frame).iter().copied().collect();
            b.iter(|| {
                model
                    .predict_frame(&human, "coman", &mut joints)
                    .expect("the model predicts for coman")
            })
        },
    );
    c.bench_function("CSV line in → CSV line out", |b| {
        b.iter(|| {
            let (_, human) = header
                .parse_line(&line, 2, "bench")
                .expect("a line formatted from a frame parses");
            model
                .predict_frame(&human, "coman", &mut joints)
                .expect("the model predicts for coman");
            format_line(None, &joints)
        })
    });
}

criterion_group!(benches, teleop);
criterion_main!(benches);
