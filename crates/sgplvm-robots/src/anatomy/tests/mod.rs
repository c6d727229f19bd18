//! Anatomies of the shipped robots, of published URDFs (data/urdf/published: Unitree G1,
//! Rethink Baxter, iCub) and of small hand-written ones; the errors of unusable descriptions;
//! arms found by structure in [`structure`].

use nalgebra::Vector3;

use super::*;

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../data/urdf/published")
        .join(name)
}

fn load(name: &str, spec: &AnatomySpec) -> Anatomy {
    Anatomy::load(&fixture(name), spec).unwrap_or_else(|e| panic!("{name}: {e}"))
}

fn error(name: &str, spec: &AnatomySpec) -> String {
    match Anatomy::load(&fixture(name), spec) {
        Ok(_) => panic!("{name}: expected an error"),
        Err(e) => e.to_string(),
    }
}

/// The hand of `arm` at its neutral posture, relative to its shoulder in reach units, in the
/// body frame.
fn neutral_hand(a: &Anatomy, side: Side) -> Vector3<f64> {
    let arm = a.arm(side).unwrap();
    let q = a.hold_configuration();
    let robot = a.robot();
    let torso = robot.forward_kinematics(q, a.torso_link()).unwrap();
    let hand = torso.inverse() * robot.forward_kinematics(q, arm.chain.tip()).unwrap();
    a.body_in_torso().inverse() * (hand.translation.vector - arm.shoulder) / arm.reach
}

#[test]
fn builtins_follow_the_convention_with_nothing_held() {
    for name in ["walkman", "coman", "centauro", "ur5e", "human"] {
        let a = Anatomy::builtin(name).unwrap();
        let robot = a.robot();
        assert_eq!(a.found(), &Found::Convention, "{name}");
        assert!(a.held_joints().is_empty(), "{name}");
        assert_eq!(a.arm_joint_names(), robot.joint_names(), "{name}");
        assert_eq!(a.command_joint_names(), robot.joint_names(), "{name}");
        // Their root frames are x forward, y left, z up.
        let [f, l, u] = a.body_axes_in_root();
        assert!((f - Vector3::x()).norm() < 1e-9 && (l - Vector3::y()).norm() < 1e-9);
        assert!((u - Vector3::z()).norm() < 1e-9, "{name}");
        // The shoulder point is the convention's shoulder link.
        for side in [Side::Left, Side::Right] {
            let link = format!("{}_shoulder", side.as_str());
            let at = robot
                .forward_kinematics(a.hold_configuration(), &link)
                .unwrap();
            assert!((a.arm(side).unwrap().shoulder - at.translation.vector).norm() < 1e-12);
            // Where the first axes meet the shoulder is fixed on the torso; the person's rides
            // on the collarbone's two joints, WALK-MAN's (whose first axis misses the others)
            // on its first.
            let after = match name {
                "human" => 2,
                "walkman" => 1,
                _ => 0,
            };
            assert_eq!(a.arm(side).unwrap().shoulder_after, after, "{name}");
        }
    }
    // Arms straight at zero: the reach is the zero pose's (to within the elbows' offsets).
    for name in ["coman", "centauro"] {
        let a = Anatomy::builtin(name).unwrap();
        let arm = a.arm(Side::Left).unwrap();
        assert!(
            arm.reach >= arm.zero_pose_reach - 1e-9 && arm.reach < arm.zero_pose_reach * 1.005,
            "{name}: {} vs {}",
            arm.reach,
            arm.zero_pose_reach
        );
    }
    // The human's reach is its arm's length, 0.414 of its height of 1.75 m.
    let human = Anatomy::builtin("human").unwrap();
    assert!((human.arm(Side::Left).unwrap().reach - 0.414 * 1.75).abs() < 1e-6);
}

#[test]
fn landmarks_sit_on_the_links_where_the_arms_joints_are() {
    use crate::kinematics::frames::{Ancestry, RobotFrames};
    for name in ["coman", "human"] {
        let a = Anatomy::builtin(name).unwrap();
        let robot = a.robot();
        let ancestry = Ancestry::of(robot);
        let q: Vec<f64> = (0..robot.dof()).map(|i| 0.2 * (i as f64).sin()).collect();
        let frames = RobotFrames::new(robot, &ancestry, &q);
        for arm in a.arms() {
            let qa = arm.chain.extract(&q).unwrap();
            let marks = arm.landmarks(robot);
            let in_root = |p: Vector3<f64>| {
                (robot.forward_kinematics(&q, arm.chain.base()).unwrap()
                    * nalgebra::Point3::from(p))
                .coords
            };
            // The elbow's centre: on the elbow's axis, midway along it between the shoulder
            // and wrist centres.
            let origin = in_root(arm.chain.joint_origins(&qa)[arm.elbow]);
            let base = robot.forward_kinematics(&q, arm.chain.base()).unwrap();
            let axis = base.rotation * arm.chain.joint_axes(&qa)[arm.elbow];
            let elbow = marks.elbow.at(&frames);
            let off = elbow - origin;
            assert!(
                (off - axis * off.dot(&axis)).norm() < 1e-12,
                "{name}: off the axis"
            );
            let wrist = marks.wrist.at(&frames);
            let shoulder_at = marks.shoulder.at(&frames);
            let mid = 0.5 * ((shoulder_at - elbow).dot(&axis) + (wrist - elbow).dot(&axis));
            assert!(mid.abs() < 1e-12, "{name}: {mid}");
            let shoulder = in_root(arm.shoulder_at(&qa));
            assert!(
                (marks.shoulder.at(&frames) - shoulder).norm() < 1e-12,
                "{name}"
            );
            let hand = in_root(arm.chain.forward(&qa).translation.vector);
            assert!((marks.hand.at(&frames) - hand).norm() < 1e-12, "{name}");
            // The wrist centre is on the forearm, between the elbow and the hand.
            let w = marks.wrist.at(&frames);
            assert!((w - elbow).norm() > 0.5 * (hand - elbow).norm(), "{name}");
            assert!((w - hand).norm() < 0.5 * (hand - elbow).norm(), "{name}");
        }
    }
}

#[test]
fn unitree_g1_arms_by_name_waist_and_legs_held_reach_from_the_straightened_arm() {
    let a = load("g1_29dof.urdf", &AnatomySpec::default());
    assert_eq!(a.found(), &Found::Names);
    assert_eq!(a.torso_link(), "torso_link");
    let left = a.arm(Side::Left).unwrap();
    assert_eq!(left.chain.base(), "torso_link");
    assert_eq!(left.chain.tip(), "left_rubber_hand");
    assert_eq!(
        left.chain.joint_names(),
        [
            "left_shoulder_pitch_joint",
            "left_shoulder_roll_joint",
            "left_shoulder_yaw_joint",
            "left_elbow_joint",
            "left_wrist_roll_joint",
            "left_wrist_pitch_joint",
            "left_wrist_yaw_joint"
        ]
    );
    assert_eq!(left.chain.joint_names()[left.elbow], "left_elbow_joint");
    let held: Vec<String> = a.held_joints().into_iter().map(|(n, _)| n).collect();
    assert_eq!(held.len(), 15);
    for w in ["waist_yaw_joint", "waist_roll_joint", "waist_pitch_joint"] {
        assert!(held.contains(&w.to_string()), "{w}");
    }
    assert!(held
        .iter()
        .all(|n| !n.contains("shoulder") && !n.contains("wrist")));
    // The zero pose bends the elbow 90°: the reach comes from the straightened arm, which is
    // longer, and a note says so.
    assert!(left.zero_pose_reach < 0.8 * left.reach, "{left:?}");
    assert!((0.40..0.45).contains(&left.reach), "{}", left.reach);
    assert!(a.notes().iter().any(|n| n.contains("zero pose")));
    // Hand by hand, shoulder point by shoulder point, the arms mirror each other.
    let right = a.arm(Side::Right).unwrap();
    assert!((left.reach - right.reach).abs() < 1e-3);
    assert!((left.shoulder.y + right.shoulder.y).abs() < 2e-3);
    assert!(left.shoulder.y > 0.05);
    // The neutral posture hangs the arms slightly forward, as the generator's neutral pose.
    for side in [Side::Left, Side::Right] {
        let rel = neutral_hand(&a, side);
        let want = match side {
            Side::Left => Vector3::new(0.15, 0.05, -0.85),
            Side::Right => Vector3::new(0.15, -0.05, -0.85),
        };
        assert!(
            (rel - want).norm() * a.arm(side).unwrap().reach < 0.005,
            "{side:?}: {rel}"
        );
    }
}

#[test]
fn baxter_arms_on_45_degree_mounts_in_the_torso_s_frame() {
    let a = load("baxter.urdf", &AnatomySpec::default());
    let left = a.arm(Side::Left).unwrap();
    assert_eq!(left.chain.base(), "left_arm_mount");
    assert_eq!(left.chain.tip(), "left_hand_link");
    assert_eq!(left.chain.dof(), 7);
    assert_eq!(left.chain.joint_names()[left.elbow], "left_e1");
    // The mounts turn the arms 45° outward; the body frame is the robot's, not the mounts'.
    let [f, l, u] = a.body_axes_in_root();
    assert!((f - Vector3::x()).norm() < 1e-6 && (l - Vector3::y()).norm() < 1e-6);
    assert!((u - Vector3::z()).norm() < 1e-6);
    // The grippers' fingers (one a mimic joint) and the head are held.
    let held: Vec<String> = a.held_joints().into_iter().map(|(n, _)| n).collect();
    assert!(held.contains(&"l_gripper_r_finger_joint".to_string()));
    assert!(held.contains(&"head_pan".to_string()));
    assert_eq!(held.len(), 5);
}

#[test]
fn icub_root_with_x_backward_and_y_right_gives_a_forward_facing_body_frame() {
    let a = load("icub.urdf", &AnatomySpec::default());
    assert_eq!(a.torso_link(), "chest");
    assert_eq!(
        a.arm(Side::Left).unwrap().chain.joint_names()[0],
        "l_shoulder_pitch"
    );
    let [f, l, u] = a.body_axes_in_root();
    assert!((f + Vector3::x()).norm() < 1e-3, "forward {f}");
    assert!((l + Vector3::y()).norm() < 1e-3, "left {l}");
    assert!((u - Vector3::z()).norm() < 1e-3, "up {u}");
    assert!(a.notes().iter().any(|n| n.contains("forward is -x")));
    // The left shoulder is on the robot's left: −y of its root.
    let root_left = a.torso_in_root() * nalgebra::Point3::from(a.arm(Side::Left).unwrap().shoulder);
    assert!(root_left.y < -0.05);
    // The torso's three joints are held.
    let held: Vec<String> = a.held_joints().into_iter().map(|(n, _)| n).collect();
    for t in ["torso_pitch", "torso_roll", "torso_yaw"] {
        assert!(held.contains(&t.to_string()));
    }
}

#[test]
fn named_arms_holds_and_the_errors_of_unusable_descriptions() {
    let mut spec = AnatomySpec::default();
    spec.set_arm("left=torso_link:left_wrist_yaw_link").unwrap();
    spec.set_arm("right=torso_link:right_wrist_yaw_link")
        .unwrap();
    spec.set_hold("waist_pitch_joint=0.2").unwrap();
    let a = load("g1_29dof.urdf", &spec);
    assert_eq!(a.found(), &Found::Named);
    assert_eq!(
        a.arm(Side::Left).unwrap().chain.tip(),
        "left_wrist_yaw_link"
    );
    let waist = a.robot().joint_index("waist_pitch_joint").unwrap();
    assert_eq!(a.hold_configuration()[waist], 0.2);

    // Arms from the pelvis share the waist.
    let mut shared = AnatomySpec::default();
    shared.set_arm("left=pelvis:left_rubber_hand").unwrap();
    shared.set_arm("right=pelvis:right_rubber_hand").unwrap();
    let e = error("g1_29dof.urdf", &shared);
    assert!(
        e.contains("g1_29dof.urdf") && e.contains("waist_yaw_joint"),
        "{e}"
    );
    assert!(e.contains("--arm left=torso_link:left_rubber_hand"), "{e}");

    let mut missing = spec.clone();
    missing.set_arm("left=torso_link:left_palm").unwrap();
    let e = error("g1_29dof.urdf", &missing);
    assert!(
        e.contains("--arm left") && e.contains("\"left_palm\""),
        "{e}"
    );

    let mut upside = spec.clone();
    upside.set_arm("left=left_rubber_hand:torso_link").unwrap();
    let e = error("g1_29dof.urdf", &upside);
    assert!(e.contains("is not below"), "{e}");

    // One arm named alone: a single arm, the other side's joints held with the rest.
    let mut one = AnatomySpec::default();
    one.set_arm("left=torso_link:left_rubber_hand").unwrap();
    let a = load("g1_29dof.urdf", &one);
    assert_eq!(a.sides(), vec![Side::Left]);
    assert!(a.arm(Side::Right).is_none());
    assert_eq!(a.torso_link(), "torso_link");
    assert_eq!(a.arm_joint_names().len(), 7);
    assert!(a
        .held_joints()
        .iter()
        .any(|(n, _)| n == "right_elbow_joint"));
    assert!(
        a.notes().iter().any(|n| n.contains("single-arm")),
        "{:?}",
        a.notes()
    );
    // The body frame of one arm is the root's (x forward, z up): the G1's, as with two arms.
    let two = load("g1_29dof.urdf", &AnatomySpec::default());
    let (one_axes, two_axes) = (a.body_axes_in_root(), two.body_axes_in_root());
    for k in 0..3 {
        assert!((one_axes[k] - two_axes[k]).norm() < 1e-6, "{k}");
    }
    assert!(a.report().shoulder_width_m.is_none());
    assert!(a.summary().contains("one arm"), "{}", a.summary());

    for (hold, says) in [
        ("waist_pitch_joint=2", "outside the joint's limits"),
        ("left_elbow_joint=0.1", "is an arm joint"),
        ("waist_twist=0", "no movable joint of that name"),
    ] {
        let mut bad = AnatomySpec::default();
        bad.set_hold(hold).unwrap();
        let e = error("g1_29dof.urdf", &bad);
        assert!(e.contains(says) && e.contains("--hold"), "{hold}: {e}");
    }
    assert!(AnatomySpec::default().set_hold("waist=nan").is_err());
    assert!(AnatomySpec::default().set_arm("up=a:b").is_err());
    assert!(AnatomySpec::default().set_arm("left=a").is_err());

    let bad = AnatomySpec {
        command_joints: CommandJoints::parse("left_elbow_joint,knee"),
        ..AnatomySpec::default()
    };
    assert!(error("g1_29dof.urdf", &bad).contains("command joint knee"));
    let all = AnatomySpec {
        command_joints: CommandJoints::parse("all"),
        ..AnatomySpec::default()
    };
    assert_eq!(load("g1_29dof.urdf", &all).command_joint_names().len(), 29);
}

#[test]
fn body_axes_given_override_and_contradictions_are_refused() {
    // iCub's chest: forward is its -x... as found; giving the same is accepted.
    let found = load("icub.urdf", &AnatomySpec::default());
    let fwd = found.body_in_torso() * Vector3::x();
    let given = AnatomySpec {
        forward: Some(fwd),
        ..AnatomySpec::default()
    };
    let a = load("icub.urdf", &given);
    assert!((a.body_in_torso() * Vector3::x() - fwd).norm() < 1e-9);
    // A forward along the shoulders is no forward.
    let along = AnatomySpec {
        forward: Some(found.body_in_torso() * Vector3::y()),
        ..AnatomySpec::default()
    };
    assert!(error("icub.urdf", &along).contains("along the shoulders"));
    let against = AnatomySpec {
        forward: Some(-fwd),
        up: Some(found.body_in_torso() * Vector3::z()),
        ..AnatomySpec::default()
    };
    assert!(error("icub.urdf", &against).contains("do not fit"));
}

#[test]
fn a_description_file_round_trips_and_bad_files_are_refused() {
    let dir = std::env::temp_dir().join(format!("sgplvm-anatomy-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let urdf = dir.join("g1.urdf");
    std::fs::copy(fixture("g1_29dof.urdf"), &urdf).unwrap();
    let mut spec = AnatomySpec::default();
    spec.set_hold("waist_yaw_joint=-0.1").unwrap();
    let a = Anatomy::load(&urdf, &spec).unwrap();
    let written = a.to_file().to_json();
    std::fs::write(description_path(&urdf), &written).unwrap();
    // Read back beside the URDF with nothing said on the command line: the same anatomy.
    let b = Anatomy::load(&urdf, &AnatomySpec::default()).unwrap();
    assert!(matches!(b.found(), Found::File(_)));
    assert_eq!(b.hold_configuration(), a.hold_configuration());
    assert_eq!(b.command_joint_names(), a.command_joint_names());
    assert!((b.body_in_torso().angle_to(&a.body_in_torso())) < 1e-8);
    // The command line wins over the file.
    let mut over = AnatomySpec::default();
    over.set_hold("waist_yaw_joint=0.1").unwrap();
    let c = Anatomy::load(&urdf, &over).unwrap();
    let i = c.robot().joint_index("waist_yaw_joint").unwrap();
    assert_eq!(c.hold_configuration()[i], 0.1);

    let path = description_path(&urdf);
    for (text, says) in [
        ("{\"sgplvm_anatomy\": 2}", "expected 1"),
        ("{\"arms\": {}}", "missing"),
        (
            "{\"sgplvm_anatomy\": 1, \"arm\": {}}",
            "unknown field `arm`",
        ),
        (
            "{\"sgplvm_anatomy\": 1, \"arms\": {\"middle\": \"a:b\", \"left\": \"a:b\"}}",
            "arms.middle",
        ),
        ("not json", "not JSON"),
    ] {
        std::fs::write(&path, text).unwrap();
        let e = Anatomy::load(&urdf, &AnatomySpec::default())
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("g1.anatomy.json") && e.contains(says),
            "{text}: {e}"
        );
    }
    // A file naming a link the URDF does not have names the file and the link.
    std::fs::write(
        &path,
        "{\"sgplvm_anatomy\": 1, \"arms\": {\"left\": \"torso_link:lhand\", \"right\": \"torso_link:right_rubber_hand\"}}",
    )
    .unwrap();
    let e = Anatomy::load(&urdf, &AnatomySpec::default())
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("g1.anatomy.json: arms.left") && e.contains("\"lhand\""),
        "{e}"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

mod structure;
