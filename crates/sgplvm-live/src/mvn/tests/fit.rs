//! MVN frames through the capture importer's arm poses and fit: built by forward kinematics,
//! and the human model's own angles round-tripped.

use nalgebra::Rotation3;

use super::*;

/// Left-arm rest offsets, each in its parent segment's frame (T8 → clavicle → upper arm →
/// forearm → hand), metres; the right arm mirrors y.
const REST: [[f64; 3]; 4] = [
    [0.0, 0.02, 0.18],
    [0.0, 0.16, 0.0],
    [0.0, 0.29, 0.0],
    [0.0, 0.26, 0.0],
];

/// An MVN frame of T8 and both arms built by forward kinematics: the body turned and leaning,
/// each upper arm hanging down, each elbow bent 90° forward.
fn arms_frame() -> MvnPose {
    let deg = |a: f64| a.to_radians();
    let t8 = WorldPose {
        position: Vector3::new(0.3, -0.2, 1.3),
        rotation: Rotation3::from_euler_angles(0.0, deg(10.0), deg(30.0)),
    };
    let mut named = vec![("T8", t8)];
    for (sign, names) in [
        (
            1.0,
            ["LeftShoulder", "LeftUpperArm", "LeftForeArm", "LeftHand"],
        ),
        (
            -1.0,
            [
                "RightShoulder",
                "RightUpperArm",
                "RightForeArm",
                "RightHand",
            ],
        ),
    ] {
        // The arm down (its +y or −y to −z), then the forearm forward (to +x).
        let turns = [
            Rotation3::identity(),
            Rotation3::from_euler_angles(sign * deg(-90.0), 0.0, 0.0),
            Rotation3::from_euler_angles(0.0, 0.0, sign * deg(-90.0)),
            Rotation3::identity(),
        ];
        let mut parent = t8;
        for ((name, offset), turn) in names.iter().zip(REST).zip(turns) {
            let offset = Vector3::new(offset[0], sign * offset[1], offset[2]);
            let pose = WorldPose {
                position: parent.position + parent.rotation * offset,
                rotation: parent.rotation * turn,
            };
            named.push((name, pose));
            parent = pose;
        }
    }
    MvnPose::from_world_poses(5, 40, 0, named).unwrap()
}

#[test]
fn mvn_frame_gives_the_importers_arm_poses() {
    let frame = arms_frame();
    // Through the wire and back: what the node will see.
    let frame = decode(&encode(&frame, PoseType::Quaternion).unwrap()).unwrap();
    let left = frame.arm_pose(sgplvm_robots::Side::Left).unwrap();
    let close = |a: Vector3<f64>, b: [f64; 3]| (a - Vector3::from(b)).norm() < 1e-5;
    assert!(close(left.clavicle, [0.0, 0.02, 0.18]), "{left:?}");
    assert!(close(left.shoulder, [0.0, 0.18, 0.18]), "{left:?}");
    assert!(close(left.elbow, [0.0, 0.18, -0.11]), "{left:?}");
    assert!(close(left.wrist, [0.26, 0.18, -0.11]), "{left:?}");
    // The hand continues the forearm: one forearm (0.26) further forward.
    assert!(close(left.hand_tip, [0.52, 0.18, -0.11]), "{left:?}");
    let right = frame.arm_pose(sgplvm_robots::Side::Right).unwrap();
    assert!(close(right.wrist, [0.26, -0.18, -0.11]), "{right:?}");
    let rest = frame.rest_arm_pose(sgplvm_robots::Side::Left).unwrap();
    assert!(close(rest.shoulder, [0.0, 0.18, 0.18]), "{rest:?}");
    assert!(close(rest.elbow, [0.0, 0.47, 0.18]), "{rest:?}");
    assert!(close(rest.wrist, [0.0, 0.73, 0.18]), "{rest:?}");
    assert!(close(rest.hand_tip, [0.0, 0.99, 0.18]), "{rest:?}");
    assert_eq!(rest.hand_turn, Rotation3::identity());
    // A segment missing is named.
    let mut no_hand = frame.clone();
    no_hand.segments.retain(|s| s.id != 11);
    let e = no_hand.arm_pose(sgplvm_robots::Side::Right).unwrap_err();
    assert!(
        e.to_string()
            .contains("segment RightHand: not in this frame"),
        "{e}"
    );
    assert!(MvnPose::from_world_poses(0, 0, 0, [("Spine", frame.named("T8").unwrap())]).is_err());
}

#[test]
fn mvn_frame_through_the_importers_arm_fit() {
    use sgplvm_capture::calibration::UntoldTwist;
    use sgplvm_capture::{Calibration, HumanArms, PoseFitter, Twist};
    use sgplvm_robots::Side;
    // The importer's own per-frame fit, on an MVN frame.
    let model = HumanArms::new(&sgplvm_robots::Robot::builtin("human").unwrap()).unwrap();
    let frame = arms_frame();
    let rest = [Side::Left, Side::Right].map(|side| frame.rest_arm_pose(side).unwrap());
    let untold = UntoldTwist {
        hinge: None,
        otherwise: Twist::NullPose,
    };
    let calibration = Calibration::from_rest(
        &model,
        [&rest[0], &rest[1]],
        [true, true],
        untold,
        "test",
        "MVN",
        Some(1.0),
    );
    let mut fitter = PoseFitter::new(model, &calibration);
    let poses = [Side::Left, Side::Right].map(|side| frame.arm_pose(side).unwrap());
    for (fit, side) in fitter
        .fit([&poses[0], &poses[1]])
        .iter()
        .zip([Side::Left, Side::Right])
    {
        assert!(
            (fit.angles[5].to_degrees() - 90.0).abs() < 1.0,
            "{side:?}: {fit:?}"
        );
        assert!(
            fit.elbow_m < 0.01 && fit.wrist_m < 0.01,
            "{side:?}: {fit:?}"
        );
    }
}

#[test]
fn the_human_model_s_angles_come_back_through_mvn_and_the_importer_s_fit() {
    use super::human::{HumanSegments, MvnFit};
    let human = HumanSegments::new().unwrap();
    let mut fit = MvnFit::default();
    // The null pose first (the stream's calibration), then poses across the joints' ranges.
    let mut t_pose = vec![0.0; 18];
    t_pose[3] = std::f64::consts::FRAC_PI_2;
    t_pose[12] = std::f64::consts::FRAC_PI_2;
    let poses = std::iter::once(t_pose).chain(super::super::human::poses_across_ranges(59));
    let mut worst = 0.0_f64;
    for (k, q) in poses.enumerate() {
        let frame = human.frame(&q, k as u32, 0).unwrap();
        let bytes = encode(&frame, PoseType::Quaternion).unwrap();
        let back = decode(&bytes).unwrap();
        let (angles, fits) = fit
            .angles(&back)
            .unwrap()
            .expect("MVN's null pose calibrates at once");
        for f in &fits {
            assert!(f.elbow_m < 1e-3 && f.wrist_m < 1e-3, "{k}: {f:?}");
        }
        for j in 0..18 {
            worst = worst.max((angles[j] - q[j]).abs());
        }
    }
    // Single precision travels (the quaternions and positions are f32).
    assert!(worst < 1e-3, "worst angle difference {worst} rad");
}
