//! Physics replay of the four shipped body models: a gentle motion around the neutral pose
//! stays inside the limits, tracks within a few milliradians and touches nothing.

use sgplvm_robots::physics::{replay, replay_urdf, ReplayOptions, Trajectory};
use sgplvm_robots::Robot;

/// `seconds` of 40 Hz motion: every joint swings ±0.15 rad (at its own frequency) around the
/// neutral configuration, kept 0.05 rad inside its limits.
fn gentle(robot: &Robot, seconds: f64) -> Trajectory {
    let q0 = robot.neutral_configuration();
    let limits = robot.joint_limits();
    let frames = (seconds * 40.0).round() as usize + 1;
    let times: Vec<f64> = (0..frames).map(|i| i as f64 / 40.0).collect();
    let mut positions = Vec::with_capacity(frames * q0.len());
    for &t in &times {
        for (j, (&q, &(lo, hi))) in q0.iter().zip(&limits).enumerate() {
            let f = 0.2 + 0.05 * j as f64;
            // Starts at rest: (1 - cos) ramps the swing in.
            let swing = 0.15 * (1.0 - (2.0 * std::f64::consts::PI * f * t).cos()) * 0.5;
            // Toward the roomier side of the joint range (away from the torso for arms
            // hanging at their sides).
            let sign = if q - lo >= hi - q { -1.0 } else { 1.0 };
            let (lo, hi) = (lo + 0.05, hi - 0.05);
            positions.push((q + sign * swing).clamp(lo.min(hi), hi.max(lo)));
        }
    }
    Trajectory::new(robot.joint_names(), times, positions).expect("valid trajectory")
}

#[test]
fn every_builtin_robot_tracks_a_gentle_motion_without_events() {
    for &name in Robot::builtin_names() {
        let robot = Robot::builtin(name).unwrap();
        let xml = Robot::builtin_urdf(name).unwrap();
        let trajectory = gentle(&robot, 2.0);
        let report = replay(xml, name, &trajectory, &ReplayOptions::default())
            .unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(report.joints.len(), robot.dof(), "{name}");
        assert_eq!(report.physics_steps, 2000);
        for joint in &report.joints {
            assert!(joint.rms_error < 0.01, "{name}: {joint:?}");
            assert!(joint.max_error < 0.03, "{name}: {joint:?}");
        }
        assert!(
            report.limit_violations.is_empty(),
            "{name}: {:?}",
            report.limit_violations
        );
        assert!(
            report.collisions.is_empty(),
            "{name}: {:?}",
            report.collisions
        );
        // The parsed description of the robots module drives the same simulation.
        let again = replay_urdf(robot.urdf(), name, &trajectory, &ReplayOptions::default())
            .unwrap_or_else(|e| panic!("{name}: {e}"));
        for (a, b) in report.joints.iter().zip(&again.joints) {
            assert!(
                (a.rms_error - b.rms_error).abs() < 1e-9,
                "{name}: {a:?} {b:?}"
            );
        }
    }
}

#[test]
fn coman_adducting_its_arms_hits_its_torso() {
    // COMAN's arms hang 2-3 cm beside its torso: adducting the shoulders (LShLat < 0,
    // RShLat > 0) by 0.25 rad swings the elbow links into the torso box.
    let robot = Robot::builtin("coman").unwrap();
    let names = robot.joint_names();
    let times: Vec<f64> = (0..=80).map(|i| i as f64 / 40.0).collect();
    let mut positions = Vec::new();
    for &t in &times {
        let s = 0.25 * (std::f64::consts::PI * t / 2.0).sin();
        for name in &names {
            positions.push(match name.as_str() {
                "LShLat" => -s,
                "RShLat" => s,
                _ => 0.0,
            });
        }
    }
    let trajectory = Trajectory::new(names, times, positions).unwrap();
    let xml = Robot::builtin_urdf("coman").unwrap();
    let report = replay(xml, "coman", &trajectory, &ReplayOptions::default()).unwrap();
    let pairs: Vec<(&str, &str)> = report
        .collisions
        .iter()
        .map(|c| (c.link_a.as_str(), c.link_b.as_str()))
        .collect();
    assert!(pairs.contains(&("DWYTorso", "LElb")), "{pairs:?}");
    assert!(pairs.contains(&("DWYTorso", "RElb")), "{pairs:?}");
    assert!(
        report.limit_violations.is_empty(),
        "{:?}",
        report.limit_violations
    );
}
