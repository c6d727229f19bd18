//! Anatomies of the shipped robots, of published URDFs (data/urdf/published: Unitree G1,
//! Rethink Baxter, iCub) and of small hand-written ones; and the errors of unusable
//! descriptions.

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

/// A torso with two 4-joint arms named `arm_a_*` and `arm_b_*` (no side in any name), the
/// `a` arm at `y_a`, and a head.
fn unnamed_arms(y_a: f64) -> String {
    let arm = |tag: &str, y: f64| {
        let mut s = format!(
            r#"<link name="{tag}_0"/><joint name="j_{tag}_0" type="revolute"><parent link="torso"/><child link="{tag}_0"/><origin xyz="0 {y} 0.4"/><axis xyz="0 1 0"/><limit lower="-3" upper="3" velocity="2" effort="1"/></joint>"#
        );
        for (k, axis) in ["1 0 0", "0 0 1", "0 1 0"].iter().enumerate() {
            s += &format!(
                r#"<link name="{tag}_{n}"/><joint name="j_{tag}_{n}" type="revolute"><parent link="{tag}_{k}"/><child link="{tag}_{n}"/><origin xyz="0 0 {z}"/><axis xyz="{axis}"/><limit lower="-2" upper="2" velocity="2" effort="1"/></joint>"#,
                n = k + 1,
                z = if k == 0 { 0.0 } else { -0.25 }
            );
        }
        s
    };
    format!(
        r#"<robot name="twin"><link name="torso"/>{}{}<link name="head_link"/><joint name="neck" type="revolute"><parent link="torso"/><child link="head_link"/><origin xyz="0 0 0.6"/><axis xyz="0 0 1"/><limit lower="-1" upper="1" velocity="1" effort="1"/></joint></robot>"#,
        arm("arm_a", y_a),
        arm("arm_b", -y_a)
    )
}

#[test]
fn arms_without_side_names_are_found_by_structure_left_along_the_root_s_y() {
    for y in [0.2, -0.2] {
        let robot = Robot::from_urdf_str(&unnamed_arms(y), "twin.urdf").unwrap();
        let a = Anatomy::of(robot).unwrap();
        assert_eq!(a.found(), &Found::Structure);
        let left_first = &a.arm(Side::Left).unwrap().chain.joint_names()[0];
        assert_eq!(left_first, if y > 0.0 { "j_arm_a_0" } else { "j_arm_b_0" });
        assert_eq!(a.held_joints().len(), 1);
        assert!(a.notes().iter().any(|n| n.contains("--arm")));
    }
    // A body with no arm at all is an error naming the file and saying how to name arms.
    let e = Anatomy::of(
        Robot::from_urdf_str(
            r#"<robot name="stick"><link name="a"/><link name="b"/><joint name="j" type="revolute"><parent link="a"/><child link="b"/><axis xyz="0 0 1"/><limit lower="-1" upper="1" velocity="1" effort="1"/></joint></robot>"#,
            "stick.urdf",
        )
        .unwrap(),
    )
    .unwrap_err()
    .to_string();
    assert!(
        e.starts_with("stick.urdf: cannot tell the robot's arms"),
        "{e}"
    );
    assert!(
        e.contains("--arm left=FROM_LINK:TO_LINK") && e.contains("stick.anatomy.json"),
        "{e}"
    );
}

/// A dual-arm robot as a maker of mobile manipulators writes one: a prismatic torso lift,
/// arms `arm_{side}_1_joint` … `arm_{side}_7_joint` whose axes are all local z turned by large
/// `rpy`, a force-torque sensor and a palm fixed on the last link, and on the palm a
/// five-finger hand's three actuated joints (`hand_{side}_thumb_joint`, `…_index_joint`,
/// `…_mrl_joint`: middle, ring and little; "hand" in every name, a finger word in two).
fn dual_arm_with_five_finger_hands() -> String {
    let rev = |name: &str, parent: &str, child: &str, xyz: &str, rpy: &str| {
        format!(
            r#"<link name="{child}"/><joint name="{name}" type="revolute"><parent link="{parent}"/><child link="{child}"/><origin xyz="{xyz}" rpy="{rpy}"/><axis xyz="0 0 1"/><limit lower="-2.5" upper="2.5" velocity="2" effort="10"/></joint>"#
        )
    };
    let fixed = |name: &str, parent: &str, child: &str, xyz: &str| {
        format!(
            r#"<link name="{child}"/><joint name="{name}" type="fixed"><parent link="{parent}"/><child link="{child}"/><origin xyz="{xyz}"/></joint>"#
        )
    };
    let mut s = String::from(
        r#"<robot name="dual"><link name="base_link"/><link name="torso_lift_link"/><joint name="torso_lift_joint" type="prismatic"><parent link="base_link"/><child link="torso_lift_link"/><origin xyz="0 0 0.8"/><axis xyz="0 0 1"/><limit lower="0" upper="0.35" velocity="0.07" effort="2000"/></joint>"#,
    );
    for (side, y, sign) in [("left", 0.15, 1.0), ("right", -0.15, -1.0)] {
        let rpys = [
            format!("{}1.5708 0 0", if sign > 0.0 { "-" } else { "" }),
            "0 -1.5708 0".to_string(),
            "1.5708 0 0".into(),
            "-1.5708 0 0".into(),
            "1.5708 0 0".into(),
            "-1.5708 0 0".into(),
            "1.5708 0 1.5708".into(),
        ];
        let xyzs = [
            "0 0 0",
            "0 0 0",
            "0.0 0 0.25",
            "0 0 0",
            "0 0 0.25",
            "0 0 0",
            "0 0 0",
        ];
        let mut parent = "torso_lift_link".to_string();
        for k in 0..7 {
            let child = format!("arm_{side}_{}_link", k + 1);
            let xyz = if k == 0 {
                format!("0 {y} 0.3")
            } else {
                xyzs[k].to_string()
            };
            s += &rev(
                &format!("arm_{side}_{}_joint", k + 1),
                &parent,
                &child,
                &xyz,
                &rpys[k],
            );
            parent = child;
        }
        s += &fixed(
            &format!("wrist_{side}_ft_joint"),
            &parent,
            &format!("wrist_{side}_ft_link"),
            "0 0 0.05",
        );
        s += &fixed(
            &format!("hand_{side}_palm_joint"),
            &format!("wrist_{side}_ft_link"),
            &format!("hand_{side}_palm_link"),
            "0 0 0.05",
        );
        for finger in ["thumb", "index", "mrl"] {
            s += &rev(
                &format!("hand_{side}_{finger}_joint"),
                &format!("hand_{side}_palm_link"),
                &format!("hand_{side}_{finger}_link"),
                "0 0 0.05",
                "0 0 0",
            );
        }
    }
    s + "</robot>"
}

#[test]
fn a_finger_on_the_arm_s_tip_link_is_no_arm_joint() {
    let robot = Robot::from_urdf_str(&dual_arm_with_five_finger_hands(), "dual.urdf").unwrap();
    let a = Anatomy::of(robot).unwrap();
    assert_eq!(a.found(), &Found::Names);
    for side in [Side::Left, Side::Right] {
        let s = side.as_str();
        let arm = a.arm(side).unwrap();
        let names = arm.chain.joint_names();
        let expected: Vec<String> = (1..=7).map(|k| format!("arm_{s}_{k}_joint")).collect();
        assert_eq!(names, expected.as_slice(), "{s}");
        assert_eq!(arm.chain.tip(), format!("hand_{s}_palm_link"), "{s}");
    }
    // The fingers and the torso lift are held.
    let held_joints = a.held_joints();
    let held: Vec<&str> = held_joints.iter().map(|(n, _)| n.as_str()).collect();
    assert!(
        held.contains(&"hand_left_mrl_joint") && held.contains(&"torso_lift_joint"),
        "{held:?}"
    );
    assert_eq!(held.len(), 7, "{held:?}");
}

#[test]
fn a_single_arm_is_found_by_structure_driven_by_the_side_its_names_say_else_the_right() {
    // KUKA's iiwa as published (7 joints, no side in any name): one arm from its base.
    let kuka = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/kuka_iiwa.urdf");
    let a = Anatomy::load(&kuka, &AnatomySpec::default()).unwrap();
    assert_eq!(a.found(), &Found::Structure);
    assert_eq!(a.sides(), vec![Side::Right]);
    let arm = a.arm(Side::Right).unwrap();
    assert_eq!(arm.chain.dof(), 7);
    assert_eq!(a.torso_link(), arm.chain.base());
    // The body frame is the root link's own axes.
    let [fwd, left, up] = a.body_axes_in_root();
    assert!((fwd - Vector3::x()).norm() < 1e-9 && (left - Vector3::y()).norm() < 1e-9);
    assert!((up - Vector3::z()).norm() < 1e-9);
    // Its neutral posture is within the limits and the hand is found.
    for (q, (lo, hi)) in arm.neutral.iter().zip(arm.chain.limits()) {
        assert!(*q >= lo - 1e-9 && *q <= hi + 1e-9);
    }
    assert!(
        a.notes().iter().any(|n| n.contains("person's right arm")),
        "{:?}",
        a.notes()
    );
    // The description file round trips a single arm.
    let file = a.to_file();
    assert_eq!(file.arms.len(), 1);
    assert!(file.arms.contains_key("right"));

    // One chain whose names say left: the person's left arm drives it.
    let twin = unnamed_arms(0.2).replace("arm_b", "left_arm");
    let one = twin
        .split("<link name=\"arm_a_0\"/>")
        .next()
        .unwrap()
        .to_string()
        + &twin[twin.find("<link name=\"left_arm_0\"/>").unwrap()..];
    let a = Anatomy::of(Robot::from_urdf_str(&one, "one.urdf").unwrap()).unwrap();
    assert_eq!(a.sides(), vec![Side::Left]);
    assert_eq!(a.arm_joint_names()[0], "j_left_arm_0");
}

#[test]
fn an_arm_folded_at_zero_finds_its_elbow_and_shoulder_from_the_middle_of_its_ranges() {
    // As Kinova's Jaco 2: at zero the upper arm points down and the forearm folds back up
    // onto it (the hand beside the shoulder); the ranges are centred on the arm standing
    // straight up. Until 2026-12-05 the folded zero pose put the elbow at a wrist joint and the
    // shoulder 0.3 m off.
    let rev = |name: &str, parent: &str, xyz: &str, axis: &str, range: (f64, f64)| {
        format!(
            r#"<link name="{name}_link"/><joint name="{name}" type="revolute"><parent link="{parent}"/><child link="{name}_link"/><origin xyz="{xyz}"/><axis xyz="{axis}"/><limit lower="{}" upper="{}" velocity="1" effort="1"/></joint>"#,
            range.0, range.1
        )
    };
    let wide = (-6.0, 6.0);
    let urdf = format!(
        r#"<robot name="folded"><link name="base"/>{}{}{}{}{}{}<link name="hand"/><joint name="tool" type="fixed"><parent link="wrist_3_link"/><child link="hand"/><origin xyz="0 0 0.1"/></joint></robot>"#,
        rev("base_yaw", "base", "0 0 0.3", "0 0 1", wide),
        rev("shoulder", "base_yaw_link", "0 0 0", "0 1 0", (0.82, 5.46)),
        rev("elbow", "shoulder_link", "0 0 -0.4", "0 1 0", (0.33, 5.95)),
        rev("wrist_1", "elbow_link", "0 0 0.4", "0 0 1", wide),
        rev("wrist_2", "wrist_1_link", "0 0 0", "0 1 0", (0.52, 5.76)),
        rev("wrist_3", "wrist_2_link", "0 0 0", "0 0 1", wide),
    );
    let a = Anatomy::of(Robot::from_urdf_str(&urdf, "folded.urdf").unwrap()).unwrap();
    let arm = &a.arms()[0];
    assert_eq!(arm.chain.joint_names()[arm.elbow], "elbow");
    assert!(
        (a.torso_in_root() * nalgebra::Point3::from(arm.shoulder))
            .coords
            .metric_distance(&Vector3::new(0.0, 0.0, 0.3))
            < 1e-6,
        "{:?}",
        arm.shoulder
    );
    // Straightened: 0.8 m of arm, the hand 0.1 m on a wrist that bends at least 30°.
    assert!(arm.reach > 0.88 && arm.reach < 0.9, "{}", arm.reach);
}

#[test]
fn a_model_drawn_y_up_takes_up_from_its_root_towards_the_shoulders() {
    // As biomechanics draws people (the ISB human of example-robot-data): x forward, y up, z
    // to the right. The root's z runs along the shoulders, so up is from the root (the
    // pelvis, 0.3 m below the torso) towards the shoulders.
    let twin = unnamed_arms(0.2)
        .replace("arm_a", "left_arm")
        .replace("arm_b", "right_arm")
        .replace(
            r#"<robot name="twin"><link name="torso"/>"#,
            r#"<robot name="twin"><link name="pelvis"/><link name="torso"/><joint name="spine" type="fixed"><parent link="pelvis"/><child link="torso"/><origin xyz="0 0.3 0" rpy="-1.5707963267948966 0 0"/></joint>"#,
        );
    let a = Anatomy::of(Robot::from_urdf_str(&twin, "yup.urdf").unwrap()).unwrap();
    let [fwd, left, up] = a.body_axes_in_root();
    assert!((up - Vector3::y()).norm() < 1e-9, "{up:?}");
    assert!((left + Vector3::z()).norm() < 1e-9, "{left:?}");
    assert!((fwd - Vector3::x()).norm() < 1e-9, "{fwd:?}");
    assert!(
        a.notes().iter().any(|n| n.contains("up +y")),
        "{:?}",
        a.notes()
    );
}
