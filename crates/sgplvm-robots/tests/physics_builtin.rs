//! Physics replay of the five shipped body models: a gentle motion around the neutral pose
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

#[test]
fn the_shipped_demonstrations_replay_within_limits() {
    // Seconds 8-10 of data/demos/bimanual.mcap (the generator's bimanual key poses): every
    // body follows its recorded commands closely and inside its joint limits.
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../data/demos/bimanual.mcap"
    );
    let data = sgplvm_robots::dataset::load_demonstrations(path).unwrap();
    let t0 = data.times_ns[0];
    let seconds = |i: usize| (data.times_ns[i] - t0) as f64 * 1e-9;
    let frames: Vec<usize> = (0..data.len())
        .filter(|&i| (8.0..=10.0).contains(&seconds(i)))
        .collect();
    assert!(frames.len() > 70, "{} frames", frames.len());
    let times: Vec<f64> = frames.iter().map(|&i| seconds(i)).collect();
    let mut bodies: Vec<&sgplvm_robots::dataset::BodyData> = data.robots.iter().collect();
    bodies.push(&data.human);
    let options = ReplayOptions::default();
    for body in bodies {
        let trajectory = body.to_trajectory(&frames, times.clone()).unwrap();
        let xml = Robot::builtin_urdf(&body.name).unwrap();
        let report = replay(xml, &body.name, &trajectory, &options).unwrap();
        for joint in &report.joints {
            assert!(joint.rms_error < 0.03, "{}: {joint:?}", body.name);
        }
        assert!(
            report.limit_violations.iter().all(|v| !v.commanded),
            "{}: commands beyond limits {:?}",
            body.name,
            report.limit_violations
        );
        // Collisions (the generator's poses may bring the hands together) come as merged
        // events: two events of one pair are further apart than the merge gap.
        for (k, a) in report.collisions.iter().enumerate() {
            assert!(a.end_time >= a.time);
            for b in &report.collisions[k + 1..] {
                if (a.link_a.as_str(), a.link_b.as_str()) == (b.link_a.as_str(), b.link_b.as_str())
                {
                    assert!(
                        b.time - a.end_time > options.merge_gap_seconds,
                        "{a:?} {b:?}"
                    );
                }
            }
        }
        println!("{}: collisions {:?}", body.name, report.collisions);
    }
}

#[test]
fn the_shipped_fleet_replays_on_the_six_joint_ur5e() {
    // Seconds 0-40 of data/demos/fleet.mcap (neutral to forward, forward_high, lateral and
    // overhead, three times each): the ur5e follows its IK commands closely, inside its
    // joint limits and its 180°/s, touching nothing.
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../data/demos/fleet.mcap");
    let data = sgplvm_robots::dataset::load_demonstrations(path).unwrap();
    let t0 = data.times_ns[0];
    let seconds = |i: usize| (data.times_ns[i] - t0) as f64 * 1e-9;
    let frames: Vec<usize> = (0..data.len()).filter(|&i| seconds(i) <= 40.0).collect();
    let times: Vec<f64> = frames.iter().map(|&i| seconds(i)).collect();
    let body = data.robot("ur5e").expect("the fleet has the ur5e");
    let trajectory = body.to_trajectory(&frames, times).unwrap();
    let xml = Robot::builtin_urdf("ur5e").unwrap();
    let report = replay(xml, "ur5e", &trajectory, &ReplayOptions::default()).unwrap();
    assert_eq!(report.joints.len(), 12);
    for joint in &report.joints {
        assert!(joint.rms_error < 0.01, "{joint:?}");
    }
    assert!(
        report.limit_violations.is_empty(),
        "{:?}",
        report.limit_violations
    );
    assert!(
        report.velocity_violations.is_empty(),
        "{:?}",
        report.velocity_violations
    );
    assert!(report.collisions.is_empty(), "{:?}", report.collisions);
}
