//! The live safety step (issue 43's target: ≤ 100 µs per robot at the 99th percentile): the
//! nearest safe command for COMAN's 14 joints, 25 ms after the last, where nothing is near
//! (the unconstrained step) and where both hands meet in front of the chest (the
//! self-collision limit binds and the QP solver runs).
//!
//! Run: `cargo bench -p sgplvm-robots --bench safety`.

use criterion::{criterion_group, criterion_main, Criterion};
use sgplvm_robots::safety::{SafetyOptions, SafetyStep};
use sgplvm_robots::{Anatomy, IkOptions, IkTarget};
use std::hint::black_box;

fn bench(c: &mut Criterion) {
    let anatomy = Anatomy::builtin("coman").expect("COMAN");
    let robot = anatomy.robot();
    let names = robot.joint_names();
    let zero = robot.neutral_configuration();
    // Both hands at one point in front of the chest.
    let mut crossed = zero.clone();
    for hand in ["left_hand", "right_hand"] {
        let chain = robot.chain("DWYTorso", hand).expect("arm");
        let target = IkTarget::Position(nalgebra::Vector3::new(0.22, 0.0, 0.0));
        let sol = chain.inverse_kinematics(
            &target,
            &chain.extract(&zero).expect("q"),
            &IkOptions::default(),
        );
        for (k, &i) in chain.robot_indices().iter().enumerate() {
            crossed[i] = sol.q[k];
        }
    }
    let step = SafetyStep::new(&anatomy, &names, SafetyOptions::default()).expect("safety");
    let mut out = vec![0.0; names.len()];
    let moved: Vec<f64> = zero.iter().map(|v| v + 0.05).collect();
    c.bench_function("safety_step_coman_free", |b| {
        let mut s = step.clone();
        b.iter(|| s.step_from(black_box(&moved), Some((&zero, 0.0)), 0.025, &mut out))
    });
    // The last command just short of the crossing, the next one asking for it.
    let near: Vec<f64> = zero
        .iter()
        .zip(&crossed)
        .map(|(a, b)| a + 0.85 * (b - a))
        .collect();
    c.bench_function("safety_step_coman_hands_meeting", |b| {
        let mut s = step.clone();
        b.iter(|| s.step_from(black_box(&crossed), Some((&near, 0.0)), 0.025, &mut out))
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
