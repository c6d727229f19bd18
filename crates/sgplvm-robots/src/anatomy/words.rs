//! What a link or joint name says about the part of the body it belongs to: its side (`left`,
//! `l_`, `_L`, `Left…`, `LSh…`) and its kind (arm, leg, head, gripper …), read from the name's
//! words as makers write them (`left_shoulder_pitch_joint`, `arm_left_1_link`, `l_shoulder_1`,
//! `LShSag`, `shoulder.L`, `j_arm1_1`).

use crate::models::Side;

/// The words of a name, lower case: split at every non-alphanumeric character, between a
/// lower-case letter and an upper-case one (`LeftArm` → `left`, `arm`), before the last capital
/// of a run followed by a lower-case letter (`LShSag` → `l`, `sh`, `sag`) and between letters
/// and digits (`arm1` → `arm`, `1`).
pub fn words(name: &str) -> Vec<String> {
    let chars: Vec<char> = name.chars().collect();
    let mut out = Vec::new();
    let mut cur = String::new();
    for (i, &c) in chars.iter().enumerate() {
        if !c.is_alphanumeric() {
            if !cur.is_empty() {
                out.push(std::mem::take(&mut cur));
            }
            continue;
        }
        if let Some(&prev) = i.checked_sub(1).and_then(|p| chars.get(p)) {
            let next = chars.get(i + 1).copied();
            let boundary = (prev.is_lowercase() && c.is_uppercase())
                || (prev.is_uppercase()
                    && c.is_uppercase()
                    && next.is_some_and(char::is_lowercase))
                || (prev.is_ascii_digit() != c.is_ascii_digit() && prev.is_alphanumeric());
            if boundary && !cur.is_empty() {
                out.push(std::mem::take(&mut cur));
            }
        }
        cur.extend(c.to_lowercase());
    }
    if !cur.is_empty() {
        out.push(cur);
    }
    out
}

/// The side a name's first side word gives: `left`, `l`, `lft`, `lt` or `right`, `r`, `rgt`,
/// `rt` (`r_gripper_l_finger` is on the right).
pub fn side_of(name: &str) -> Option<Side> {
    words(name).iter().find_map(|w| match w.as_str() {
        "left" | "l" | "lft" | "lt" => Some(Side::Left),
        "right" | "r" | "rgt" | "rt" => Some(Side::Right),
        _ => None,
    })
}

/// What part of a body a name belongs to, as far as its words say.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Part {
    /// Shoulder, arm, elbow, forearm, wrist, hand …
    Arm,
    /// Fingers, grippers, jaws: the hand's own joints, never the arm's.
    Gripper,
    /// Hip, leg, knee, ankle, foot …
    Leg,
    /// Head, neck, eyes, cameras.
    Head,
    /// Waist, torso, chest, spine, trunk.
    Torso,
    /// Nothing the words tell.
    Unknown,
}

const GRIPPER: &[&str] = &[
    "gripper",
    "finger",
    "fingers",
    "fngr",
    "fingertip",
    "thumb",
    "index",
    "middle",
    "ring",
    "pinky",
    "little",
    "jaw",
    "claw",
    "knuckle",
    "grasp",
    // LimX's TRON2: `grasper_base_L_Joint` turns the grasper on the wrist.
    "grasper",
];
const LEG: &[&str] = &[
    "leg", "hip", "knee", "ankle", "foot", "feet", "toe", "thigh", "shin", "calf", "crus", "sole",
    "heel", "wheel",
];
const HEAD: &[&str] = &["head", "neck", "eye", "eyes", "camera", "cam", "lidar"];
const TORSO: &[&str] = &[
    "waist", "torso", "chest", "spine", "trunk", "pelvis", "lumbar", "back",
];
const ARM: &[&str] = &[
    "arm", "shoulder", "sh", "sho", "shld", "shldr", "elbow", "elb", "el", "forearm", "upperarm",
    "wrist", "wr", "hand", "palm", "clavicle", "collar", "e", "s", "w",
];

/// Whether a name says a finger or jaw (a gripper word other than `gripper`, `grasp` and
/// `grasper`, which makers also give the gripper's base, carried by the wrist).
pub fn names_a_finger(name: &str) -> bool {
    words(name).iter().any(|w| {
        GRIPPER.contains(&w.as_str()) && !["gripper", "grasp", "grasper"].contains(&w.as_str())
    })
}

/// Whether a name says which part of the arm it is (`shoulder`, `elbow`, `wrist`, …), not only
/// `arm`: `arm_` is as often a namespace (Boston Dynamics' Spot: `arm_sh0` … `arm_wr1`, and its
/// jaw `arm_f1x`).
pub fn names_an_arm_part(name: &str) -> bool {
    words(name)
        .iter()
        .any(|w| ARM.contains(&w.as_str()) && w != "arm")
}

/// The part a name's words say it belongs to; gripper, leg and head words win over arm words
/// (`left_hand_thumb_joint` is a gripper joint, `hand` notwithstanding).
pub fn part_of(name: &str) -> Part {
    let w = words(name);
    let has = |list: &[&str]| w.iter().any(|x| list.contains(&x.as_str()));
    if has(GRIPPER) {
        Part::Gripper
    } else if has(LEG) {
        Part::Leg
    } else if has(HEAD) {
        Part::Head
    } else if has(TORSO) && !w.iter().any(|x| x == "arm" || x == "shoulder") {
        Part::Torso
    } else if has(ARM) {
        Part::Arm
    } else {
        Part::Unknown
    }
}

/// Words of a sensor's frame, never a hand's point however its name goes on (Aldebaran's NAO
/// and Pepper put `LHandTouchLeft_frame`, a touch sensor 25 mm off the hand's side, on the
/// wrist beside the gripper).
const SENSOR: &[&str] = &[
    "touch", "sensor", "camera", "cam", "optical", "imu", "laser", "tactile", "skin", "marker",
    "led", "contact",
];

/// How strongly a link name says "this is the hand / end effector" (higher is more): `hand`,
/// `palm`, `tool`, `tcp`, `ee`, `flange`, `gripper`; 0 for none, and for a sensor's frame.
pub fn hand_score(name: &str) -> u32 {
    let w = words(name);
    if w.iter().any(|x| SENSOR.contains(&x.as_str())) {
        return 0;
    }
    w.iter()
        .map(|w| match w.as_str() {
            "hand" | "palm" => 3,
            "tool" | "tcp" | "ee" | "effector" | "flange" => 2,
            "gripper" | "endpoint" => 1,
            _ => 0,
        })
        .max()
        .unwrap_or(0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn words_split_as_makers_write_names() {
        assert_eq!(
            words("left_shoulder_pitch_joint"),
            ["left", "shoulder", "pitch", "joint"]
        );
        assert_eq!(words("LShSag"), ["l", "sh", "sag"]);
        assert_eq!(words("LeftForeArm"), ["left", "fore", "arm"]);
        assert_eq!(words("j_arm1_1"), ["j", "arm", "1", "1"]);
        assert_eq!(words("shoulder.L"), ["shoulder", "l"]);
        assert_eq!(words("mixamorig:LeftHand"), ["mixamorig", "left", "hand"]);
        assert_eq!(words("RWrj2"), ["r", "wrj", "2"]);
    }

    #[test]
    fn sides_and_parts() {
        for (name, side) in [
            ("left_shoulder_pitch_joint", Some(Side::Left)),
            ("arm_right_3_joint", Some(Side::Right)),
            ("l_elbow", Some(Side::Left)),
            ("RShLat", Some(Side::Right)),
            ("upperarm_l", Some(Side::Left)),
            ("r_gripper_l_finger_joint", Some(Side::Right)),
            ("j_arm1_1", None),
            ("torso_1_joint", None),
        ] {
            assert_eq!(side_of(name), side, "{name}");
        }
        assert_eq!(part_of("left_hand_thumb_0_joint"), Part::Gripper);
        assert_eq!(part_of("gripper_left_inner_double_joint"), Part::Gripper);
        assert_eq!(part_of("grasper_base_L_Joint"), Part::Gripper);
        assert_eq!(part_of("left_hip_pitch_joint"), Part::Leg);
        assert_eq!(part_of("head_2_joint"), Part::Head);
        assert_eq!(part_of("waist_yaw_joint"), Part::Torso);
        assert_eq!(part_of("left_shoulder_roll_joint"), Part::Arm);
        assert_eq!(part_of("left_e1"), Part::Arm);
        assert_eq!(part_of("l_wrist_prosup"), Part::Arm);
        assert!(hand_score("left_rubber_hand") > hand_score("wrist_left_ft_link"));
        assert_eq!(hand_score("LHandTouchLeft_frame"), 0);
        assert_eq!(hand_score("l_hand_camera_optical_frame"), 0);
    }
}
