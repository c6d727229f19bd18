//! Kinematics speed: forward kinematics of a 7-joint arm (target < 1 µs per configuration) and
//! position inverse kinematics to a reachable target (target < 100 µs).
//!
//! Run: `cargo bench --release -p sgplvm-robots --bench kinematics`.

use criterion::{criterion_group, criterion_main, Criterion};
use sgplvm_robots::{IkOptions, IkTarget, Robot};
use std::hint::black_box;

fn bench(c: &mut Criterion) {
    let robot = Robot::builtin("coman").expect("the built-in COMAN model loads");
    let arm = robot
        .chain("DWYTorso", "left_hand")
        .expect("COMAN has a left arm chain");
    let q = [-0.5, 0.3, 0.2, -1.0, 0.1, 0.2, 0.1];
    c.bench_function("fk_7dof_coman_left_arm", |b| {
        b.iter(|| arm.forward(black_box(&q)))
    });
    let qs: Vec<f64> = (0..1000)
        .flat_map(|k| q.iter().map(move |v| v * (1.0 - k as f64 * 1e-4)))
        .collect();
    c.bench_function("fk_batch_1000_7dof", |b| {
        b.iter(|| arm.forward_batch(black_box(&qs)))
    });
    c.bench_function("jacobian_7dof", |b| b.iter(|| arm.jacobian(black_box(&q))));
    let target = IkTarget::Position(arm.forward(&q).translation.vector);
    let q0 = robot.neutral_configuration();
    let q0 = &q0[..7];
    let opts = IkOptions::default();
    c.bench_function("ik_position_7dof_from_neutral", |b| {
        b.iter(|| arm.inverse_kinematics(black_box(&target), black_box(q0), &opts))
    });
    let near: Vec<f64> = q.iter().map(|v| v + 0.1).collect();
    c.bench_function("ik_position_7dof_from_nearby", |b| {
        b.iter(|| arm.inverse_kinematics(black_box(&target), black_box(&near), &opts))
    });
    let walkman = Robot::builtin("walkman").expect("the built-in WALK-MAN model loads");
    let warm = walkman
        .chain("DWYTorso", "left_hand")
        .expect("WALK-MAN has a left arm chain");
    let wq = [0.3, 0.6, 0.2, -1.0, 0.3, 0.2, 0.1];
    let wt = IkTarget::Position(warm.forward(&wq).translation.vector);
    let w0 = walkman.neutral_configuration();
    c.bench_function("ik_position_7dof_walkman_from_neutral", |b| {
        b.iter(|| warm.inverse_kinematics(black_box(&wt), black_box(&w0[..7]), &opts))
    });
    let human = Robot::builtin("human").expect("the built-in human model loads");
    let [harm, _] = human.arms().expect("the human has arms");
    let hq = [0.1, 0.1, 0.8, 0.3, 0.2, 1.2, 0.3, 0.2, 0.1];
    let ht = IkTarget::Position(harm.chain.forward(&hq).translation.vector);
    let posture = IkOptions {
        posture_gain: 0.5,
        ..IkOptions::default()
    };
    c.bench_function("ik_position_9dof_human_with_posture_task", |b| {
        b.iter(|| {
            harm.chain
                .inverse_kinematics(black_box(&ht), black_box(&[0.0; 9]), &posture)
        })
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
