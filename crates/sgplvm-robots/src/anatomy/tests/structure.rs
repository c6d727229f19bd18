//! Arms found by structure where names do not tell: no side in any name, a five-finger hand on
//! the arm's tip, a single arm, an arm folded at zero, a model drawn y up.

use super::*;

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

#[test]
fn arms_whose_joints_are_fixed_are_said_to_be_locked_not_unnamed() {
    // A walking robot's training description (AgiBot's X1, Booster's T1_locomotion): the arm
    // joints say their side and part, but are fixed; only the legs move.
    let mut urdf = String::from(r#"<robot name="walker"><link name="base"/>"#);
    for side in ["left", "right"] {
        let mut parent = "base".to_string();
        for part in [
            "shoulder_pitch",
            "shoulder_roll",
            "elbow_pitch",
            "wrist_roll",
        ] {
            let child = format!("{side}_{part}_link");
            urdf += &format!(
                r#"<link name="{child}"/><joint name="{side}_{part}_joint" type="fixed"><parent link="{parent}"/><child link="{child}"/><origin xyz="0 0 -0.1"/></joint>"#
            );
            parent = child;
        }
        let mut parent = "base".to_string();
        for part in ["hip_pitch", "hip_roll", "knee", "ankle_pitch"] {
            let child = format!("{side}_{part}_link");
            urdf += &format!(
                r#"<link name="{child}"/><joint name="{side}_{part}_joint" type="revolute"><parent link="{parent}"/><child link="{child}"/><origin xyz="0 0 -0.2"/><axis xyz="0 1 0"/><limit lower="-1" upper="1" velocity="1" effort="1"/></joint>"#
            );
            parent = child;
        }
    }
    urdf += "</robot>";
    let robot = Robot::from_urdf_str(&urdf, "walker.urdf").unwrap();
    let e = Anatomy::of(robot).unwrap_err().to_string();
    assert!(
        e.contains("8 joints named as arm joints are fixed in this file")
            && e.contains(r#""left_shoulder_pitch_joint""#)
            && !e.contains("no joint name says left or right"),
        "{e}"
    );
}

#[test]
fn a_robot_of_legs_alone_is_said_to_have_no_arm() {
    // As EngineAI's SA01: two 6-joint legs named `leg_l1_joint` …, nothing else moves.
    let mut urdf = String::from(r#"<robot name="legs"><link name="base"/>"#);
    for side in ["l", "r"] {
        let mut parent = "base".to_string();
        for k in 1..=6 {
            let name = format!("leg_{side}{k}");
            urdf += &revolute(&name, &parent, "0 0 -0.1", "0 1 0", (-1.0, 1.0));
            parent = format!("{name}_link");
        }
    }
    urdf += "</robot>";
    let e = Anatomy::of(Robot::from_urdf_str(&urdf, "legs.urdf").unwrap())
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("its 12 revolute joints are named as legs, a head or grippers")
            && e.contains("no arm"),
        "{e}"
    );
}

#[test]
fn arms_broken_by_gear_trains_are_said_to_branch_not_to_be_locked() {
    // As ToddlerBot's main description: beside each driven arm joint a drive pinion turns on a
    // leaf of its own, and fixed connectors join the gears; the arms turn, but the tree
    // branches between their joints.
    let mut urdf = String::from(r#"<robot name="toddler"><link name="torso"/>"#);
    let joint = |name: &str, kind: &str, parent: &str, child: &str| {
        let limit = if kind == "revolute" {
            r#"<axis xyz="0 1 0"/><limit lower="-1" upper="1" velocity="1" effort="1"/>"#
        } else {
            ""
        };
        format!(
            r#"<link name="{child}"/><joint name="{name}" type="{kind}"><parent link="{parent}"/><child link="{child}"/><origin xyz="0 0 -0.05"/>{limit}</joint>"#
        )
    };
    for side in ["left", "right"] {
        let l = |n: &str| format!("{side}_{n}");
        #[rustfmt::skip]
        let parts = [
            (l("sho_pitch"), "revolute", "torso".to_string(), l("sho_pitch_link")),
            (l("sho_roll"), "revolute", l("sho_pitch_link"), l("gears")),
            (l("sho_yaw_drive"), "revolute", l("gears"), l("pinion")),
            (l("sho_yaw_driven"), "revolute", l("gears"), l("driven")),
            (l("sho_yaw_fixed"), "fixed", l("driven"), l("sho_yaw_link")),
            (l("elbow_roll"), "revolute", l("sho_yaw_link"), l("gears_2")),
            (l("elbow_yaw_drive"), "revolute", l("gears_2"), l("pinion_2")),
            (l("elbow_yaw_driven"), "revolute", l("gears_2"), l("driven_2")),
            (l("elbow_yaw_fixed"), "fixed", l("driven_2"), l("elb_yaw_link")),
            (l("wrist_roll"), "revolute", l("elb_yaw_link"), l("hand")),
        ];
        for (name, kind, parent, child) in parts {
            urdf += &joint(&name, kind, &parent, &child);
        }
    }
    urdf += "</robot>";
    let robot = Robot::from_urdf_str(&urdf, "toddler.urdf").unwrap();
    let e = Anatomy::of(robot).unwrap_err().to_string();
    assert!(
        e.contains("its 16 revolute arm joints do not make a serial chain")
            && !e.contains("cannot move")
            && e.contains("--arm left=FROM_LINK:TO_LINK"),
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
fn a_jaw_named_under_the_arm_s_namespace_is_no_arm_joint() {
    // Boston Dynamics' Spot arm names every joint `arm_…` (`arm_sh0` … `arm_wr1`) and its
    // gripper's jaw `arm_f1x`, moving `arm_link_fngr`: serial on the wrist, it was taken as the
    // arm's seventh joint and commanded. Here on the iiwa's tip.
    let kuka = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/kuka_iiwa.urdf"),
    )
    .unwrap();
    let jaw = r#"<link name="arm_link_fngr"/><joint name="arm_f1x" type="revolute"><parent link="lbr_iiwa_link_7"/><child link="arm_link_fngr"/><origin xyz="0 0 0.1"/><axis xyz="0 1 0"/><limit lower="-1.57" upper="0" velocity="1" effort="1"/></joint></robot>"#;
    let with_jaw = kuka.replace("</robot>", jaw);
    let a = Anatomy::of(Robot::from_urdf_str(&with_jaw, "jaw.urdf").unwrap()).unwrap();
    let arm = a.arm(Side::Right).unwrap();
    assert_eq!(arm.chain.dof(), 7, "{:?}", arm.chain.joint_names());
    assert_eq!(arm.chain.joint_names()[6], "lbr_iiwa_joint_7");
    assert!(a.held_joints().iter().any(|(j, _)| j == "arm_f1x"));
}

/// A revolute joint `name` on `parent` at `xyz` turning about `axis` within `range`, and its
/// link `{name}_link`.
fn revolute(name: &str, parent: &str, xyz: &str, axis: &str, range: (f64, f64)) -> String {
    format!(
        r#"<link name="{name}_link"/><joint name="{name}" type="revolute"><parent link="{parent}"/><child link="{name}_link"/><origin xyz="{xyz}"/><axis xyz="{axis}"/><limit lower="{}" upper="{}" velocity="1" effort="1"/></joint>"#,
        range.0, range.1
    )
}

#[test]
fn an_arm_folded_at_zero_finds_its_elbow_and_shoulder_from_the_middle_of_its_ranges() {
    // As Kinova's Jaco 2: at zero the upper arm points down and the forearm folds back up
    // onto it (the hand beside the shoulder); the ranges are centred on the arm standing
    // straight up. Until 2026-12-05 the folded zero pose put the elbow at a wrist joint and the
    // shoulder 0.3 m off.
    let wide = (-6.0, 6.0);
    let urdf = format!(
        r#"<robot name="folded"><link name="base"/>{}{}{}{}{}{}<link name="hand"/><joint name="tool" type="fixed"><parent link="wrist_3_link"/><child link="hand"/><origin xyz="0 0 0.1"/></joint></robot>"#,
        revolute("base_yaw", "base", "0 0 0.3", "0 0 1", wide),
        revolute("shoulder", "base_yaw_link", "0 0 0", "0 1 0", (0.82, 5.46)),
        revolute("elbow", "shoulder_link", "0 0 -0.4", "0 1 0", (0.33, 5.95)),
        revolute("wrist_1", "elbow_link", "0 0 0.4", "0 0 1", wide),
        revolute("wrist_2", "wrist_1_link", "0 0 0", "0 1 0", (0.52, 5.76)),
        revolute("wrist_3", "wrist_2_link", "0 0 0", "0 0 1", wide),
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
fn a_gripper_as_long_as_the_forearm_does_not_make_the_wrist_s_pitch_the_elbow() {
    // As Trossen's WXAI (the Stationary AI's arms): folded at zero, the elbow bends at most
    // 135°, and the gripper reaches 0.25 m past the wrist's pitch, as far as the forearm.
    // Bending the wrist's pitch shortens the straightened arm to the gripper's tip as much as
    // the elbow does; to the wrist (where the wrist's yaw and roll meet) it barely does. Until
    // 2026-12-07 the wrist's pitch was taken for the elbow.
    let (half, pi) = (std::f64::consts::FRAC_PI_2, std::f64::consts::PI);
    #[rustfmt::skip]
    let joints = [
        ("base_yaw", "base", "0 0 0.057", "0 0 1", (-3.0, 3.0)),
        ("shoulder", "base_yaw_link", "0.02 0 0.046", "0 1 0", (0.0, pi)),
        ("elbow", "shoulder_link", "-0.264 0 0", "0 -1 0", (0.0, 2.356)),
        ("wrist_pitch", "elbow_link", "0.245 0 0.06", "0 -1 0", (-half, half)),
        ("wrist_yaw", "wrist_pitch_link", "0.068 0 0.0455", "0 0 -1", (-half, half)),
        ("wrist_roll", "wrist_yaw_link", "0.029 0 -0.0455", "1 0 0", (-pi, pi)),
    ]
    .map(|(name, parent, xyz, axis, range)| revolute(name, parent, xyz, axis, range))
    .concat();
    let urdf = format!(
        r#"<robot name="wxai"><link name="base"/>{joints}<link name="gripper"/><joint name="tool" type="fixed"><parent link="wrist_roll_link"/><child link="gripper"/><origin xyz="0.156 0 0"/></joint></robot>"#
    );
    let a = Anatomy::of(Robot::from_urdf_str(&urdf, "wxai.urdf").unwrap()).unwrap();
    let arm = &a.arms()[0];
    assert_eq!(arm.chain.joint_names()[arm.elbow], "elbow");
}

#[test]
fn a_hand_as_long_as_the_forearm_does_not_move_the_shoulder_to_the_elbow() {
    // As Leju's Kuavo 4: three shoulder axes at one point, the elbow 0.28 m below (2 cm
    // aside), the forearm's turn, the wrist's roll and pitch, and the hand's end 0.17 m past
    // the wrist. The joint most in the middle of shoulder and hand was the forearm's turn, the
    // elbow's axis and the upper arm's turn (2 cm apart) were taken for the shoulder, and the
    // wrist's roll for the elbow (until 2026-12-07).
    #[rustfmt::skip]
    let joints = [
        ("shoulder_pitch", "base", "0 0 0.42", "0 1 0"),
        ("shoulder_roll", "shoulder_pitch_link", "0 0 0", "1 0 0"),
        ("shoulder_yaw", "shoulder_roll_link", "0 0 0", "0 0 1"),
        ("elbow", "shoulder_yaw_link", "0.02 0 -0.2837", "0 1 0"),
        ("forearm_yaw", "elbow_link", "-0.02 0 -0.127", "0 0 1"),
        ("wrist_roll", "forearm_yaw_link", "0 0 -0.1065", "1 0 0"),
        ("wrist_pitch", "wrist_roll_link", "0 0 -0.021", "0 1 0"),
    ]
    .map(|(name, parent, xyz, axis)| revolute(name, parent, xyz, axis, (-2.6, 2.0)))
    .concat();
    let urdf = format!(
        r#"<robot name="kuavo"><link name="base"/>{joints}<link name="hand"/><joint name="tool" type="fixed"><parent link="wrist_pitch_link"/><child link="hand"/><origin xyz="0 -0.03 -0.17"/></joint></robot>"#
    );
    let a = Anatomy::of(Robot::from_urdf_str(&urdf, "kuavo.urdf").unwrap()).unwrap();
    let arm = &a.arms()[0];
    assert_eq!(arm.chain.joint_names()[arm.elbow], "elbow");
    let shoulder = (a.torso_in_root() * nalgebra::Point3::from(arm.shoulder)).coords;
    assert!(
        shoulder.metric_distance(&Vector3::new(0.0, 0.0, 0.42)) < 1e-6,
        "{shoulder:?}"
    );
}

#[test]
fn an_arm_whose_last_joint_is_its_elbow_finds_it() {
    // As PAL's ARI: the shoulder's pitch, a roll 0.11 m down its bracket, the upper arm's
    // turn 0.10 m further, the elbow another 0.10 m down, and no wrist: the hand 0.35 m past the
    // elbow. The elbow guess never weighed the last joint: it took the roll for the elbow, put
    // the shoulder on the pitch alone and rolled the person's arm 90° to "mount" an arm that
    // hangs (until 2026-12-07).
    #[rustfmt::skip]
    let joints = [
        ("arm_1", "base", "0 0 1.1", "0 1 0"),
        ("arm_2", "arm_1_link", "0 0 -0.11", "1 0 0"),
        ("arm_3", "arm_2_link", "0 0 -0.10", "0 0 1"),
        ("arm_4", "arm_3_link", "0 0 -0.10", "0 1 0"),
    ]
    .map(|(name, parent, xyz, axis)| revolute(name, parent, xyz, axis, (-2.0, 2.0)))
    .concat();
    let urdf = format!(
        r#"<robot name="ari"><link name="base"/>{joints}<link name="hand"/><joint name="tool" type="fixed"><parent link="arm_4_link"/><child link="hand"/><origin xyz="0 0 -0.35"/></joint></robot>"#
    );
    let a = Anatomy::of(Robot::from_urdf_str(&urdf, "ari.urdf").unwrap()).unwrap();
    let arm = &a.arms()[0];
    assert_eq!(arm.chain.joint_names()[arm.elbow], "arm_4");
    // Straightened from the roll and turn (their axes meet; the pitch sits 0.11 m above).
    assert!((arm.reach - 0.55).abs() < 1e-6, "{}", arm.reach);
}

#[test]
fn a_roll_last_is_no_elbow_however_long_the_tool_beyond_it() {
    // The last joint as the elbow (ARI, above) only where it bends what lies beyond it: a
    // seven-joint arm's wrist roll with a tool longer than the forearm (the review found the
    // arm refused, its shoulder put at the wrist) and Toyota's HSR's four joints (flex, roll,
    // wrist flex, wrist roll: the wrist flex is its elbow) keep their elbows.
    for tool in [0.1, 0.3] {
        #[rustfmt::skip]
        let joints = [
            ("shoulder_pitch", "base", "0 0 1.0", "0 1 0"),
            ("shoulder_roll", "shoulder_pitch_link", "0 0 0", "1 0 0"),
            ("shoulder_yaw", "shoulder_roll_link", "0 0 0", "0 0 1"),
            ("elbow", "shoulder_yaw_link", "0 0 -0.25", "0 1 0"),
            ("forearm_yaw", "elbow_link", "0 0 -0.2", "0 0 1"),
            ("wrist_pitch", "forearm_yaw_link", "0 0 0", "0 1 0"),
            ("wrist_roll", "wrist_pitch_link", "0 0 0", "0 0 1"),
        ]
        .map(|(name, parent, xyz, axis)| revolute(name, parent, xyz, axis, (-2.0, 2.0)))
        .concat();
        let urdf = format!(
            r#"<robot name="seven"><link name="base"/>{joints}<link name="tool"/><joint name="tip" type="fixed"><parent link="wrist_roll_link"/><child link="tool"/><origin xyz="0 0 -{tool}"/></joint></robot>"#
        );
        let a = Anatomy::of(Robot::from_urdf_str(&urdf, "seven.urdf").unwrap()).unwrap();
        let arm = &a.arms()[0];
        assert_eq!(arm.chain.joint_names()[arm.elbow], "elbow", "tool {tool} m");
    }
    #[rustfmt::skip]
    let joints = [
        ("arm_flex", "base", "0 0 0.8", "0 1 0"),
        ("arm_roll", "arm_flex_link", "0 0 -0.1", "0 0 1"),
        ("wrist_flex", "arm_roll_link", "0 0 -0.25", "0 1 0"),
        ("wrist_roll", "wrist_flex_link", "0 0 0", "0 0 1"),
    ]
    .map(|(name, parent, xyz, axis)| revolute(name, parent, xyz, axis, (-2.0, 2.0)))
    .concat();
    let urdf = format!(
        r#"<robot name="hsr"><link name="base"/>{joints}<link name="palm"/><joint name="tip" type="fixed"><parent link="wrist_roll_link"/><child link="palm"/><origin xyz="0 0 -0.14"/></joint></robot>"#
    );
    let a = Anatomy::of(Robot::from_urdf_str(&urdf, "hsr.urdf").unwrap()).unwrap();
    let arm = &a.arms()[0];
    assert_eq!(arm.chain.joint_names()[arm.elbow], "wrist_flex");
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

#[test]
fn an_arm_that_cannot_hang_is_mounted_rolled_out_and_the_humanoids_are_not() {
    use crate::anatomy::{Mount, MountReason, HANG_MISS_DEG, TABLE_ROLL_DEG};
    // KUKA's iiwa stands on its base: its second joint tilts the upper arm at most 120° from
    // straight up, never down along a person's hanging arm.
    let kuka = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/kuka_iiwa.urdf");
    let a = Anatomy::load(&kuka, &AnatomySpec::default()).unwrap();
    let mount = a.mount();
    assert_eq!(mount.roll_deg, TABLE_ROLL_DEG);
    match mount.reason {
        MountReason::CannotHang { missed } => {
            assert!(missed > HANG_MISS_DEG && missed < 90.0, "{missed}")
        }
        other => panic!("{other:?}"),
    }
    // Its neutral posture is the person's neutral rolled out: the hand out to the right at
    // about shoulder height, not down through its base (the body frame is the root's here).
    let arm = a.arm(Side::Right).unwrap();
    let hand = arm.hand_in_torso(&arm.neutral) - arm.shoulder;
    assert!(hand.y < -0.6 * arm.reach, "{hand}");
    assert!(hand.z.abs() < 0.2 * arm.reach, "{hand}");
    assert_eq!(a.to_file().mount_roll_deg, Some(TABLE_ROLL_DEG));
    // A description file written before the mount gives the neutral posture but no mount: the
    // arm still cannot hang, and its neutral stays the file's.
    let older = AnatomySpec {
        neutral: a.to_file().neutral,
        ..AnatomySpec::default()
    };
    let b = Anatomy::load(&kuka, &older).unwrap();
    assert!(matches!(b.mount().reason, MountReason::CannotHang { .. }));
    assert_eq!(b.arm(Side::Right).unwrap().neutral, arm.neutral);
    // What the user says wins; a roll beyond ±180° is refused naming the file.
    let said = |deg: f64| AnatomySpec {
        mount_roll_deg: Some(deg),
        ..AnatomySpec::default()
    };
    let off = Anatomy::load(&kuka, &said(0.0)).unwrap();
    assert_eq!(off.mount(), Mount::given(0.0));
    let hand = off.arm(Side::Right).unwrap();
    assert!((hand.hand_in_torso(&hand.neutral) - hand.shoulder).z < 0.0);
    let err = Anatomy::load(&kuka, &said(270.0)).unwrap_err().to_string();
    assert!(
        err.contains("kuka_iiwa.urdf") && err.contains("mount roll 270"),
        "{err}"
    );
    let err = AnatomySpec::from_json(
        r#"{"sgplvm_anatomy": 1, "mount_roll_deg": 400}"#,
        Path::new("arm.anatomy.json"),
    )
    .unwrap_err()
    .to_string();
    assert!(
        err.contains("arm.anatomy.json") && err.contains("mount_roll_deg"),
        "{err}"
    );
    // Humanoids' arms hang: no mount.
    for name in ["walkman", "coman", "centauro", "human"] {
        let m = Anatomy::builtin(name).unwrap().mount();
        assert_eq!(m.roll_deg, 0.0, "{name}: {m:?}");
        assert!(
            matches!(m.reason, MountReason::Hangs { missed } if missed < 10.0),
            "{name}: {m:?}"
        );
    }
}

/// The length of an arm's forearm bone line (elbow centre to wrist centre) at the hold posture.
fn forearm_bone_line(a: &Anatomy, arm: &AnatomyArm) -> f64 {
    let m = arm.landmarks(a.robot());
    let ancestry = crate::kinematics::frames::Ancestry::of(a.robot());
    let frames =
        crate::kinematics::frames::RobotFrames::new(a.robot(), &ancestry, a.hold_configuration());
    (m.wrist.at(&frames) - m.elbow.at(&frames)).norm()
}

/// Two arms as Aldebaran draws NAO's: the shoulder's pitch and roll at one point, the elbow's
/// yaw (the upper arm's turn, along it) and roll (its bend) at one point, the forearm's yaw
/// 56 mm on, and on the wrist link a gripper joint, fingers and touch sensors' frames (one
/// 25 mm off the hand's side, named `…HandTouchLeft_frame`).
fn elbow_turning_and_bending_at_one_point() -> String {
    let joint = |name: &str,
                 kind: &str,
                 parent: &str,
                 child: &str,
                 xyz: &str,
                 axis: &str,
                 lim: (f64, f64)| {
        format!(
            r#"<link name="{child}"/><joint name="{name}" type="{kind}"><parent link="{parent}"/><child link="{child}"/><origin xyz="{xyz}"/><axis xyz="{axis}"/><limit lower="{}" upper="{}" velocity="5" effort="1"/></joint>"#,
            lim.0, lim.1
        )
    };
    let arm = |s: &str, lower: &str, sign: f64| {
        let m = |lo: f64, hi: f64| if sign > 0.0 { (lo, hi) } else { (-hi, -lo) };
        [
            joint(&format!("{s}ShoulderPitch"), "revolute", "torso", &format!("{s}Shoulder"), &format!("0 {} 0.1", 0.098 * sign), "0 1 0", (-2.08, 2.08)),
            joint(&format!("{s}ShoulderRoll"), "revolute", &format!("{s}Shoulder"), &format!("{s}Bicep"), "0 0 0", "0 0 1", m(-0.31, 1.33)),
            joint(&format!("{s}ElbowYaw"), "revolute", &format!("{s}Bicep"), &format!("{s}Elbow"), &format!("0.105 {} 0", 0.015 * sign), "1 0 0", (-2.08, 2.08)),
            joint(&format!("{s}ElbowRoll"), "revolute", &format!("{s}Elbow"), &format!("{s}ForeArm"), "0 0 0", "0 0 1", m(-1.54, -0.035)),
            joint(&format!("{s}WristYaw"), "revolute", &format!("{s}ForeArm"), &format!("{lower}_wrist"), "0.05595 0 0", "1 0 0", (-1.82, 1.82)),
            joint(&format!("{s}Hand"), "revolute", &format!("{lower}_wrist"), &format!("{lower}_gripper"), "0.05775 0 -0.01231", "1 0 0", (0.0, 1.0)),
            joint(&format!("{s}Finger11"), "revolute", &format!("{lower}_wrist"), &format!("{s}Finger11_link"), "0.069 0.012 -0.003", "0 1 0", (0.0, 1.0)),
            format!(
                r#"<link name="{s}HandTouchLeft_frame"/><joint name="{s}HandTouchLeft_fixed" type="fixed"><parent link="{lower}_wrist"/><child link="{s}HandTouchLeft_frame"/><origin xyz="0.032 0.025 0.003"/></joint>"#
            ),
        ]
        .concat()
    };
    format!(
        r#"<robot name="elbowyaw"><link name="torso"/>{}{}</robot>"#,
        arm("L", "l", 1.0),
        arm("R", "r", -1.0)
    )
}

#[test]
fn an_elbow_that_turns_and_bends_at_one_point_ends_its_forearm_at_the_wrist_not_a_sensor() {
    let robot =
        Robot::from_urdf_str(&elbow_turning_and_bending_at_one_point(), "nao.urdf").unwrap();
    let a = Anatomy::of(robot).unwrap();
    for (side, wrist) in [(Side::Left, "l_wrist"), (Side::Right, "r_wrist")] {
        let arm = a.arm(side).unwrap();
        // The hand is the wrist link, not a touch sensor's frame beside it.
        assert_eq!(arm.chain.tip(), wrist, "{side:?}");
        assert_eq!(
            a.robot().joint_names()[arm.chain.robot_indices()[arm.elbow]],
            format!("{}ElbowRoll", &format!("{side:?}")[..1])
        );
        // The forearm's bone line runs from the elbow to the wrist, 56 mm on (the elbow's bend
        // axis meets the forearm's yaw at the elbow: no wrist there).
        let forearm = forearm_bone_line(&a, arm);
        assert!((forearm - 0.05595).abs() < 1e-3, "{side:?}: {forearm}");
    }
}

/// Two arms as Poppy's: shoulder pitch and roll, the upper arm's turn, and the elbow, whose
/// link is the forearm with the hand (no link beyond it; its centre of mass 0.107 m on).
fn forearm_on_the_elbow_link() -> String {
    let arm = |s: &str, sign: f64| {
        let link = |name: &str, com: &str| {
            format!(
                r#"<link name="{s}_{name}"><inertial><origin xyz="{com}"/><mass value="0.1"/><inertia ixx="1e-4" iyy="1e-4" izz="1e-4" ixy="0" ixz="0" iyz="0"/></inertial></link>"#
            )
        };
        let joint = |name: &str, parent: &str, child: &str, xyz: String, axis: &str| {
            format!(
                r#"<joint name="{s}_{name}" type="revolute"><parent link="{parent}"/><child link="{s}_{child}"/><origin xyz="{xyz}"/><axis xyz="{axis}"/><limit lower="-2.5" upper="2.5" velocity="5" effort="1"/></joint>"#
            )
        };
        [
            link("shoulder", "0 0 0"),
            link("shoulder_motor", "0 0 -0.01"),
            link("upper_arm", "0 0 -0.06"),
            link("forearm", "0 0 -0.107"),
            joint(
                "shoulder_y",
                "chest",
                "shoulder",
                format!("0 {} 0.3", 0.08 * sign),
                "0 1 0",
            ),
            joint(
                "shoulder_x",
                &format!("{s}_shoulder"),
                "shoulder_motor",
                "0 0 0".into(),
                "1 0 0",
            ),
            joint(
                "arm_z",
                &format!("{s}_shoulder_motor"),
                "upper_arm",
                "0 0 -0.036".into(),
                "0 0 1",
            ),
            joint(
                "elbow_y",
                &format!("{s}_upper_arm"),
                "forearm",
                "0 0 -0.112".into(),
                "0 1 0",
            ),
        ]
        .concat()
    };
    format!(
        r#"<robot name="poppy"><link name="chest"/>{}{}</robot>"#,
        arm("l", 1.0),
        arm("r", -1.0)
    )
}

#[test]
fn a_forearm_on_the_elbow_s_own_link_ends_at_its_hand_point() {
    let robot = Robot::from_urdf_str(&forearm_on_the_elbow_link(), "poppy.urdf").unwrap();
    let a = Anatomy::of(robot).unwrap();
    for side in [Side::Left, Side::Right] {
        let arm = a.arm(side).unwrap();
        // The elbow is the last joint, the hand twice the forearm's centre of mass on.
        assert_eq!(arm.elbow, 3, "{side:?}");
        assert!((arm.hand_local - Vector3::new(0.0, 0.0, -0.214)).norm() < 1e-9);
        assert!(
            (arm.reach - (0.036 + 0.112 + 0.214)).abs() < 1e-3,
            "{}",
            arm.reach
        );
        // The forearm's bone line runs from the elbow to that hand point.
        let forearm = forearm_bone_line(&a, arm);
        assert!((forearm - 0.214).abs() < 1e-3, "{side:?}: {forearm}");
    }
}

#[test]
fn a_gripper_s_mimic_joints_are_no_arm_though_their_names_say_a_side_and_hand() {
    // Toyota's HSR: each finger of its gripper is four joints named `hand_l_…`/`hand_r_…`,
    // three of them `<mimic>` joints; by their names they were taken as the two arms (reach
    // 7 cm, the retarget report NaN). On KUKA's iiwa here: the one arm by structure.
    let kuka = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/kuka_iiwa.urdf");
    let xml = std::fs::read_to_string(kuka).unwrap();
    let finger = |s: &str, y: f64| {
        let mut text = revolute(
            &format!("hand_{s}_proximal_joint"),
            "lbr_iiwa_link_7",
            &format!("0 {y} 0.05"),
            "1 0 0",
            (-0.8, 0.8),
        );
        let mut parent = format!("hand_{s}_proximal_joint_link");
        for part in ["spring_proximal", "mimic_distal", "distal"] {
            let name = format!("hand_{s}_{part}_joint");
            text += &revolute(&name, &parent, "0 0 0.02", "1 0 0", (-0.8, 0.8)).replace(
                "</joint>",
                &format!(r#"<mimic joint="hand_{s}_proximal_joint" multiplier="1"/></joint>"#),
            );
            parent = format!("{name}_link");
        }
        text
    };
    let with_gripper = xml.replace(
        "</robot>",
        &format!("{}{}</robot>", finger("l", 0.02), finger("r", -0.02)),
    );
    let a = Anatomy::of(Robot::from_urdf_str(&with_gripper, "hsr_like.urdf").unwrap()).unwrap();
    assert_eq!(a.found(), &Found::Structure);
    assert_eq!(a.sides(), vec![Side::Right]);
    assert_eq!(a.arm(Side::Right).unwrap().chain.dof(), 7);
    assert!(a
        .arm_joint_names()
        .iter()
        .all(|n| n.starts_with("lbr_iiwa")));
}

#[test]
fn a_joint_with_one_value_allowed_is_no_arm_joint_and_is_held_at_that_value() {
    // Toyota's HSR: `wrist_ft_sensor_frame_joint` is revolute with lower = upper = 0; it was
    // commanded as an arm joint. Here KUKA's iiwa with its sixth joint allowed 0.4 rad only.
    let kuka = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/kuka_iiwa.urdf");
    let xml = std::fs::read_to_string(kuka).unwrap();
    let range = r#"lower="-2.09439510239" upper="2.09439510239""#;
    let at = xml.find("lbr_iiwa_joint_6").unwrap();
    let pinned = format!(
        "{}{}",
        &xml[..at],
        xml[at..].replacen(range, r#"lower="0.4" upper="0.4""#, 1)
    );
    let a = Anatomy::of(Robot::from_urdf_str(&pinned, "pinned.urdf").unwrap()).unwrap();
    let arm = a.arm(Side::Right).unwrap();
    assert_eq!(arm.chain.dof(), 6);
    assert!(!a
        .arm_joint_names()
        .contains(&"lbr_iiwa_joint_6".to_string()));
    assert!(a
        .held_joints()
        .contains(&("lbr_iiwa_joint_6".to_string(), 0.4)));
    // The arm's chain holds that joint at its value: its hand lies where the whole robot's is.
    let robot = a.robot();
    let mut q = a.hold_configuration().to_vec();
    let arm_q: Vec<f64> = (0..6).map(|i| 0.3 - 0.1 * f64::from(i)).collect();
    for (&i, &v) in arm.chain.robot_indices().iter().zip(&arm_q) {
        q[i] = v;
    }
    let base = robot.forward_kinematics(&q, arm.chain.base()).unwrap();
    let tip = robot.forward_kinematics(&q, arm.chain.tip()).unwrap();
    let chain_tip = arm.chain.forward(&arm_q);
    let gap = (base * chain_tip).translation.vector - tip.translation.vector;
    assert!(gap.norm() < 1e-12, "{gap}");
    assert!((base * chain_tip).rotation.angle_to(&tip.rotation) < 1e-12);
}

#[test]
fn a_head_turning_on_an_arm_s_first_link_does_not_end_the_arm_there() {
    // Rethink's Sawyer pans its head on `right_l0`, the link its arm's first joint turns: the
    // branch ended the arm's chain there, and its first joint was held. Here KUKA's iiwa with
    // a head on its first link.
    let kuka = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/kuka_iiwa.urdf");
    let xml = std::fs::read_to_string(kuka).unwrap();
    let head = revolute(
        "head_pan",
        "lbr_iiwa_link_1",
        "0 0 0.3",
        "0 0 1",
        (-1.0, 1.0),
    );
    let with_head = xml.replace("</robot>", &format!("{head}</robot>"));
    let a = Anatomy::of(Robot::from_urdf_str(&with_head, "sawyer_like.urdf").unwrap()).unwrap();
    assert_eq!(a.found(), &Found::Structure);
    assert_eq!(a.arm(Side::Right).unwrap().chain.dof(), 7);
    assert_eq!(a.held_joints(), vec![("head_pan".to_string(), 0.0)]);
}
