//! Physics replay speed: 60 s of 40 Hz motion (2,400 frames, 60,000 physics steps at 1 kHz)
//! on the shipped robots. Before the criterion groups it prints, per robot, the wall time of
//! one replay and its ratio to real time (wall seconds per simulated second).
//!
//! Run: `cargo bench -p sgplvm-robots --bench physics`

use criterion::{criterion_group, criterion_main, Criterion};
use sgplvm_robots::physics::{replay, ReplayOptions, Trajectory};
use sgplvm_robots::Robot;
use std::hint::black_box;

/// `seconds` of 40 Hz motion: every joint swings up to 0.3 rad from neutral toward the
/// roomier side of its range, each at its own frequency.
fn motion(robot: &Robot, seconds: f64) -> Trajectory {
    let q0 = robot.neutral_configuration();
    let limits = robot.joint_limits();
    let frames = (seconds * 40.0).round() as usize + 1;
    let times: Vec<f64> = (0..frames).map(|i| i as f64 / 40.0).collect();
    let mut positions = Vec::with_capacity(frames * q0.len());
    for &t in &times {
        for (j, (&q, &(lo, hi))) in q0.iter().zip(&limits).enumerate() {
            let f = 0.2 + 0.03 * j as f64;
            let swing = 0.3 * (1.0 - (2.0 * std::f64::consts::PI * f * t).cos()) * 0.5;
            let sign = if q - lo >= hi - q { -1.0 } else { 1.0 };
            positions.push((q + sign * swing).clamp(lo.min(hi), hi.max(lo)));
        }
    }
    Trajectory::new(robot.joint_names(), times, positions).expect("valid trajectory")
}

fn bench(c: &mut Criterion) {
    let options = ReplayOptions::default();
    for &name in Robot::builtin_names() {
        let robot = Robot::builtin(name).expect("built-in robot");
        let xml = Robot::builtin_urdf(name).expect("built-in URDF");
        let trajectory = motion(&robot, 60.0);
        let report = replay(xml, name, &trajectory, &options).expect("replay");
        println!(
            "{name}: 60 s replay ({} steps, {} joints) in {:.2} s wall = {:.3} × real time; worst max error {:.4} rad, {} collisions, {} limit violations",
            report.physics_steps,
            report.joints.len(),
            report.wall_seconds,
            report.wall_seconds / report.duration,
            report.joints.iter().map(|j| j.max_error).fold(0.0, f64::max),
            report.collisions.len(),
            report.limit_violations.len(),
        );
    }
    let mut group = c.benchmark_group("replay_60s");
    group.sample_size(10);
    for name in ["coman", "human"] {
        let robot = Robot::builtin(name).expect("built-in robot");
        let xml = Robot::builtin_urdf(name).expect("built-in URDF");
        let trajectory = motion(&robot, 60.0);
        group.bench_function(name, |b| {
            b.iter(|| {
                replay(black_box(xml), name, black_box(&trajectory), &options).expect("replay")
            })
        });
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
