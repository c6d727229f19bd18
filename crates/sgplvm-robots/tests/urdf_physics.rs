//! The shipped models load in rapier (through the crate's physics replay, rapier3d-urdf), their
//! inertias are physically plausible, and no two links touch at the neutral pose or while the
//! arms move to a pose in front of the body.

use sgplvm_robots::physics::{replay, ReplayOptions, Trajectory};
use sgplvm_robots::Robot;

#[test]
fn inertias_are_positive_definite_and_satisfy_the_triangle_inequality() {
    for name in Robot::builtin_names() {
        let robot = Robot::builtin(name).unwrap();
        let mut total = 0.0;
        for link in &robot.urdf().links {
            let m = link.inertial.mass.value;
            let i = &link.inertial.inertia;
            if m == 0.0 {
                // Massless frames only: the shoulder and hand markers.
                assert!(
                    link.collision.is_empty(),
                    "{name}: {} has shapes but no mass",
                    link.name
                );
                assert!(
                    link.name.ends_with("_shoulder") || link.name.ends_with("_hand"),
                    "{}",
                    link.name
                );
                continue;
            }
            total += m;
            assert!(
                m > 0.0 && i.ixx > 0.0 && i.iyy > 0.0 && i.izz > 0.0,
                "{name}: {}",
                link.name
            );
            assert!(i.ixx + i.iyy >= i.izz && i.iyy + i.izz >= i.ixx && i.ixx + i.izz >= i.iyy);
        }
        // Upper bodies of 5–60 kg.
        assert!((5.0..60.0).contains(&total), "{name}: {total} kg");
    }
}

#[test]
fn builtins_hold_the_neutral_pose_and_reach_forward_without_self_collision() {
    for name in Robot::builtin_names() {
        let robot = Robot::builtin(name).unwrap();
        let neutral = robot.neutral_configuration();
        // Second key frame: both hands 25 cm in front of and 10 cm below the shoulders.
        let mut forward = neutral.clone();
        for arm in robot.arms().unwrap() {
            let s = robot
                .forward_kinematics(&neutral, &arm.shoulder_link)
                .unwrap()
                .translation
                .vector;
            let target = s + nalgebra::Vector3::new(0.25, 0.0, -0.10);
            let q0 = arm.chain.extract(&neutral).unwrap();
            let sol = arm.chain.inverse_kinematics(
                &sgplvm_robots::IkTarget::Position(target),
                &q0,
                &sgplvm_robots::IkOptions {
                    posture_gain: 0.5,
                    ..Default::default()
                },
            );
            assert!(sol.converged, "{name}: {sol:?}");
            for (&i, v) in arm.chain.robot_indices().iter().zip(&sol.q) {
                forward[i] = *v;
            }
        }
        let times = vec![0.0, 0.5, 1.5, 2.0];
        let mut positions = neutral.clone();
        positions.extend(&neutral);
        positions.extend(&forward);
        positions.extend(&forward);
        let traj = Trajectory::new(robot.joint_names(), times, positions).unwrap();
        let report = replay(
            Robot::builtin_urdf(name).unwrap(),
            name,
            &traj,
            &ReplayOptions::default(),
        )
        .unwrap_or_else(|e| panic!("{name}: {e}"));
        assert!(
            report.collisions.is_empty(),
            "{name}: {:?}",
            report.collisions
        );
        assert!(report.warnings.is_empty(), "{name}: {:?}", report.warnings);
        let worst = report
            .joints
            .iter()
            .map(|j| j.max_error)
            .fold(0.0, f64::max);
        assert!(worst < 0.1, "{name}: tracking error {worst} rad");
    }
}
