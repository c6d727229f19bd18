//! Skeletons whose arms carry twist bones in the chain (DAZ's Genesis 3 and 8, Rigify's
//! deforming bones): the same motion with part of each segment's twist moved into its twist
//! bone must import to the same human angles as without the twist bones.

use crate::bvh::{Bvh, BvhJoint, Channel};
use crate::{import_parsed, write_bvh, ImportOptions};
use sgplvm_robots::Side;

/// A smooth motion of the human model within its joint limits, elbows bent.
fn motion(frames: usize) -> Vec<[f64; 18]> {
    let limits = sgplvm_robots::Robot::builtin("human")
        .unwrap()
        .joint_limits();
    (0..frames)
        .map(|f| {
            let t = f as f64 / 40.0;
            let mut q = [0.0; 18];
            for (k, v) in q.iter_mut().enumerate() {
                let (lo, hi) = limits[k];
                *v = 0.5 * (lo + hi) + 0.3 * (hi - lo) * (1.1 * t + k as f64).sin();
                if k % 9 == 5 {
                    *v = v.max(0.3);
                }
            }
            q
        })
        .collect()
}

/// A joint's name in a convention from the side (`Left`, `Right`) and the segment (`Shoulder`,
/// `UpperArm`, `ForeArm`, `Hand`).
type Namer = dyn Fn(&str, &str) -> String;

/// `bvh` (the human model's own BVH: `Left`/`Right` + `Shoulder`, `UpperArm`, `ForeArm`,
/// `Hand`, each with `Zrotation Xrotation Yrotation`, bones along the file's y at rest) renamed
/// by `name` (side, segment → name), with a twist bone (`twist(side, segment)`) inserted
/// halfway down the upper arm and the forearm. The twist bone turns about the bone's own axis
/// by `twist_deg(frame, side)` and the segment's own joint by as much less, so every position
/// and every segment's orientation below the twist bone is unchanged.
fn with_twist_bones(
    bvh: &Bvh,
    name: &Namer,
    twist: &Namer,
    twist_deg: &dyn Fn(usize, usize) -> f64,
) -> Bvh {
    let mut joints: Vec<BvhJoint> = Vec::new();
    // Old joint index → new, and per new twist joint: (old segment it splits, side index).
    let mut new_index = vec![0; bvh.joints.len()];
    let mut twists: Vec<(usize, usize)> = Vec::new();
    for (i, j) in bvh.joints.iter().enumerate() {
        let mut joint = j.clone();
        joint.parent = j.parent.map(|p| new_index[p]);
        let side = ["Left", "Right"]
            .into_iter()
            .find(|s| j.name.starts_with(s));
        if let Some(side) = side {
            let segment = &j.name[side.len()..];
            joint.name = name(side, segment);
            let parent_name = j.parent.and_then(|p| bvh.joints[p].name.strip_prefix(side));
            if matches!(parent_name, Some("UpperArm" | "ForeArm")) {
                // Hang this joint from a twist bone halfway down its parent.
                let half = j.offset / 2.0;
                let parent = joint.parent.unwrap();
                joints.push(BvhJoint {
                    name: twist(side, parent_name.unwrap()),
                    parent: Some(parent),
                    offset: half,
                    channels: vec![Channel::Yrotation],
                    first_channel: 0,
                    end_site: None,
                    line: 0,
                });
                twists.push((j.parent.unwrap(), usize::from(side == "Right")));
                joint.parent = Some(joints.len() - 1);
                joint.offset = half;
            }
        }
        new_index[i] = joints.len();
        joints.push(joint);
    }
    let mut channels = 0;
    for j in &mut joints {
        j.first_channel = channels;
        channels += j.channels.len();
    }
    let mut values = Vec::with_capacity(bvh.frames() * channels);
    for f in 0..bvh.frames() {
        let old = bvh.frame(f);
        let start = values.len();
        values.resize(start + channels, 0.0);
        let row = &mut values[start..];
        for (i, j) in bvh.joints.iter().enumerate() {
            let n = &joints[new_index[i]];
            row[n.first_channel..n.first_channel + j.channels.len()]
                .copy_from_slice(&old[j.first_channel..j.first_channel + j.channels.len()]);
        }
        for &(segment, side) in &twists {
            // The forearm's twist bone takes half as much as the upper arm's.
            let share = if bvh.joints[segment].name.ends_with("UpperArm") {
                1.0
            } else {
                0.5
            };
            let a = twist_deg(f, side) * share;
            // The twist bone: a turn about y; its segment's last channel (Yrotation) less as much:
            // Rz Rx Ry(c − a) Ry(a) = Rz Rx Ry(c).
            let twist_joint = joints
                .iter()
                .position(|j| {
                    j.channels == [Channel::Yrotation] && j.parent == Some(new_index[segment])
                })
                .unwrap();
            row[joints[twist_joint].first_channel] = a;
            let s = &joints[new_index[segment]];
            assert_eq!(s.channels[2], Channel::Yrotation);
            row[s.first_channel + 2] -= a;
        }
    }
    Bvh {
        joints,
        frame_time: bvh.frame_time,
        channels,
        values,
        frame_lines_left_out: 0,
    }
}

/// Imports `bvh` with the default options: (scheme, angles).
fn import(bvh: &Bvh) -> (String, nalgebra::DMatrix<f64>) {
    let m = import_parsed(bvh, "twist.bvh", &ImportOptions::default()).unwrap();
    (m.source.skeleton, m.positions)
}

#[test]
fn twist_bones_in_the_arm_chain_import_as_the_arm_without_them() {
    let dir = std::env::temp_dir().join(format!("sgplvm-twist-bones-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("plain.bvh");
    write_bvh(&path, 1.0 / 40.0, &motion(200)).unwrap();
    let plain = Bvh::read(&path).unwrap();
    std::fs::remove_dir_all(&dir).ok();
    let (_, want) = import(&plain);
    // A twist that moves on its own: up to 50° in the upper arm, 25° in the forearm.
    let twist_deg = |f: usize, side: usize| 50.0 * (0.07 * f as f64 + side as f64).sin();
    let genesis = |side: &str, segment: &str| {
        let s = &side[..1].to_lowercase();
        let base = match segment {
            "Shoulder" => "Collar",
            "UpperArm" => "ShldrBend",
            "ForeArm" => "ForearmBend",
            _ => "Hand",
        };
        format!("{s}{base}")
    };
    let genesis_twist = |side: &str, segment: &str| {
        let s = &side[..1].to_lowercase();
        let base = if segment == "UpperArm" {
            "ShldrTwist"
        } else {
            "ForearmTwist"
        };
        format!("{s}{base}")
    };
    let rigify = |side: &str, segment: &str| {
        let base = match segment {
            "Shoulder" => "shoulder",
            "UpperArm" => "upper_arm",
            "ForeArm" => "forearm",
            _ => "hand",
        };
        format!("DEF-{base}.{}", &side[..1])
    };
    let rigify_twist = |side: &str, segment: &str| {
        let base = if segment == "UpperArm" {
            "upper_arm"
        } else {
            "forearm"
        };
        format!("DEF-{base}.{}.001", &side[..1])
    };
    let cases: [(&Namer, &Namer, &str); 2] = [
        (&genesis, &genesis_twist, "DAZ"),
        (&rigify, &rigify_twist, "Rigify"),
    ];
    for (name, twist, scheme) in cases {
        let bvh = with_twist_bones(&plain, name, twist, &twist_deg);
        assert_eq!(bvh.joints.len(), plain.joints.len() + 4);
        // The twist bones do move: the wrist is where it was, the upper-arm joint is not.
        let wrist = bvh.joint(&name("Left", "Hand")).unwrap();
        let rest_length = bvh.rest_position(bvh.joint(&name("Left", "UpperArm")).unwrap(), wrist);
        assert!((rest_length.unwrap().norm() - 53.55).abs() < 1e-3);
        let (found, got) = import(&bvh);
        assert!(found.contains(scheme), "{scheme}: identified as {found}");
        assert_eq!(got.shape(), want.shape());
        let worst = (&got - &want).abs().max();
        assert!(worst < 1e-9, "{scheme}: angles differ by up to {worst} rad");
    }
    // The test can fail: with the twist bones' turns left out, the segments above them are
    // turned back by as much, and the shoulders' and forearms' angles change.
    let mut untwisted = with_twist_bones(&plain, &genesis, &genesis_twist, &twist_deg);
    for j in untwisted.joints.clone() {
        if j.channels == [Channel::Yrotation] {
            for f in 0..untwisted.frames() {
                untwisted.values[f * untwisted.channels + j.first_channel] = 0.0;
            }
        }
    }
    let moved = (&import(&untwisted).1 - &want).abs().max();
    assert!(
        moved > 0.3,
        "leaving the twist bones out moved the angles by {moved} rad only"
    );
}

/// A BVH joint's opening lines: its name, offset and three rotation channels.
fn joint(name: &str, offset: [f64; 3]) -> String {
    format!(
        "JOINT {name}\n{{\nOFFSET {} {} {}\nCHANNELS 3 Zrotation Xrotation Yrotation\n",
        offset[0], offset[1], offset[2]
    )
}

/// A BVH End Site.
fn end(offset: [f64; 3]) -> String {
    format!(
        "End Site\n{{\nOFFSET {} {} {}\n}}\n",
        offset[0], offset[1], offset[2]
    )
}

/// A Genesis 8 skeleton (its names, twist bones, a carpal bone before each finger) in a T-pose,
/// one frame at rest: the hand ends at the middle finger's base past its carpal bone.
#[test]
fn a_hand_ends_at_the_middle_finger_past_a_carpal_bone() {
    let mut t = String::from(
        "HIERARCHY\nROOT hip\n{\nOFFSET 0 100 0\nCHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation\n",
    );
    for (s, x) in [("l", 1.0), ("r", -1.0)] {
        t += &joint(&format!("{s}ThighBend"), [x * 9.0, -5.0, 0.0]);
        t += &end([0.0, -40.0, 0.0]);
        t += "}\n";
    }
    t += &joint("chestUpper", [0.0, 40.0, 0.0]);
    t += &joint("neckLower", [0.0, 15.0, 0.0]);
    t += &end([0.0, 10.0, 0.0]);
    t += "}\n";
    let mut channels = 6 + 3 * 3 + 3;
    for (s, x) in [("l", 1.0), ("r", -1.0)] {
        let chain = [
            ("Collar", [x * 3.0, 12.0, 0.0]),
            ("ShldrBend", [x * 14.0, 0.0, 0.0]),
            ("ShldrTwist", [x * 13.0, 0.0, 0.0]),
            ("ForearmBend", [x * 15.0, 0.0, 0.0]),
            ("ForearmTwist", [x * 12.0, 0.0, 0.0]),
            ("Hand", [x * 13.0, 0.0, 0.0]),
        ];
        for (name, offset) in chain {
            t += &joint(&format!("{s}{name}"), offset);
        }
        t += &joint(&format!("{s}Thumb1"), [x * 2.0, -1.0, 3.0]);
        t += &end([x * 3.0, 0.0, 0.0]);
        t += "}\n";
        t += &joint(&format!("{s}Carpal2"), [x * 1.0, 0.0, 0.5]);
        t += &joint(&format!("{s}Mid1"), [x * 7.0, 0.0, 0.0]);
        t += &end([x * 4.0, 0.0, 0.0]);
        t += "}\n}\n";
        t += &"}\n".repeat(chain.len());
        channels += 3 * (chain.len() + 3);
    }
    t += "}\n}\nMOTION\nFrames: 1\nFrame Time: 0.025\n";
    t += &vec!["0"; channels].join(" ");
    t.push('\n');
    let bvh = Bvh::parse(&t, "genesis.bvh").unwrap();
    let s = crate::Skeleton::identify(&bvh, None, "genesis.bvh").unwrap();
    assert!(s.scheme.contains("DAZ"), "{}", s.scheme);
    for (arm, x) in s.arms.iter().zip([1.0, -1.0]) {
        assert_eq!(bvh.joints[arm.upper_arm].name[1..], *"ShldrBend");
        assert_eq!(bvh.joints[arm.forearm].name[1..], *"ForearmBend");
        let tip = arm.hand_tip.unwrap();
        assert!(
            (tip - nalgebra::Vector3::new(x * 8.0, 0.0, 0.5)).norm() < 1e-12,
            "{tip}"
        );
    }
    // Upper arm and forearm over their twist bones: 28 + 25 cm.
    assert!((s.arm_length - 53.0).abs() < 1e-12, "{}", s.arm_length);
}

/// MakeHuman's default rig (as MocapNET's files have it) numbers the fingers from the thumb:
/// `finger2-1.l` is the index finger, `finger3-1.l` the middle one, each past a metacarpal bone,
/// the index finger's first in the file. The hand ends at the middle finger's base (it ended at
/// the index finger's, the first finger found, and the wrist's angles were 9–10° off).
#[test]
fn a_makehuman_hand_ends_at_finger_3_the_middle_one() {
    let mut t = String::from(
        "HIERARCHY\nROOT hip\n{\nOFFSET 0 100 0\nCHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation\n",
    );
    t += &joint("abdomen", [0.0, 20.0, 0.0]);
    t += &joint("chest", [0.0, 20.0, 0.0]);
    t += &joint("neck", [0.0, 15.0, 0.0]);
    t += &end([0.0, 10.0, 0.0]);
    t += "}\n";
    let mut channels = 6 + 3 * 3;
    for (s, x) in [("l", 1.0), ("r", -1.0)] {
        let arm = [
            (format!("{s}collar"), [x * 3.0, 12.0, 0.0]),
            (format!("{s}shoulder"), [x * 14.0, 0.0, 0.0]),
            (format!("{s}elbow"), [x * 28.0, 0.0, 0.0]),
            (format!("{s}hand"), [x * 25.0, 0.0, 0.0]),
        ];
        for (name, offset) in &arm {
            t += &joint(name, *offset);
        }
        // Metacarpal bones fanning out from the wrist, each finger's base past its own; the
        // thumb (finger 1) and the ring and little fingers past two bones.
        let fingers = [
            (vec![(format!("metacarpal1.{s}"), 0.5)], "finger2-1", 2.0),
            (vec![(format!("metacarpal2.{s}"), 0.5)], "finger3-1", 0.0),
            (
                vec![
                    (format!("__metacarpal3.{s}"), 0.5),
                    (format!("metacarpal3.{s}"), 0.0),
                ],
                "finger4-1",
                -2.0,
            ),
            (
                vec![
                    (format!("__metacarpal4.{s}"), 0.5),
                    (format!("metacarpal4.{s}"), 0.0),
                ],
                "finger5-1",
                -4.0,
            ),
            (
                vec![(format!("__{s}thumb"), 0.5), (format!("{s}thumb"), 1.0)],
                "finger1-2",
                3.0,
            ),
        ];
        for (bones, base, z) in fingers {
            for (bone, dx) in &bones {
                t += &joint(bone, [x * dx, 0.0, 0.0]);
            }
            t += &joint(&format!("{base}.{s}"), [x * 8.0, 0.0, z]);
            t += &end([x * 4.0, 0.0, 0.0]);
            t += &"}\n".repeat(bones.len() + 1);
            channels += 3 * (bones.len() + 1);
        }
        t += &"}\n".repeat(arm.len());
        channels += 3 * arm.len();
    }
    t += "}\n}\n}\nMOTION\nFrames: 1\nFrame Time: 0.025\n";
    t += &vec!["0"; channels].join(" ");
    t.push('\n');
    let bvh = Bvh::parse(&t, "makehuman.bvh").unwrap();
    assert!(bvh.joint("__lthumb").is_some() && bvh.joint("finger3-1.r").is_some());
    let s = crate::Skeleton::identify(&bvh, None, "makehuman.bvh").unwrap();
    assert!(s.scheme.contains("MakeHuman"), "{}", s.scheme);
    for (arm, x) in s.arms.iter().zip([1.0, -1.0]) {
        let tip = arm.hand_tip.unwrap();
        // metacarpal2 (0.5) and finger3-1 (8, straight on), not finger2-1 (2 towards z).
        let want = nalgebra::Vector3::new(x * 8.5, 0.0, 0.0);
        assert!((tip - want).norm() < 1e-12, "{tip} (want {want})");
        assert_eq!(arm.hand_end, crate::HandEnd::Measured);
    }
}

/// A skeleton labelled as a Kinect v1 / OpenNI recording labels it: the person's left arm
/// named `Right…` and the right one `Left…`. Every bent elbow bends backwards in the body axes
/// the labels give; the import says so and names the map that swaps the sides, which imports
/// it as the correctly labelled file.
#[test]
fn a_mirror_labelled_skeleton_is_said_to_be_so_with_the_map_that_swaps_its_sides() {
    let dir = std::env::temp_dir().join(format!("sgplvm-mirrored-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("plain.bvh");
    // Natural motion: the arms hanging to raised forwards and sideways, turned inwards and
    // outwards, the elbows bending (every angle within the model's limits).
    let ranges = [
        (-0.1, 0.4),
        (-0.3, 0.3),
        (-0.5, 1.6),
        (0.0, 1.6),
        (-1.0, 1.2),
        (0.3, 2.4),
        (-1.0, 1.0),
        (-0.5, 0.5),
        (-0.2, 0.3),
    ];
    let natural: Vec<[f64; 18]> = (0..400)
        .map(|f| {
            let t = f as f64 / 40.0;
            std::array::from_fn(|k| {
                let (lo, hi) = ranges[k % 9];
                let wave = (0.7 + 0.13 * k as f64) * t + k as f64;
                lo + (hi - lo) * 0.5 * (1.0 + wave.sin())
            })
        })
        .collect();
    write_bvh(&path, 1.0 / 40.0, &natural).unwrap();
    let plain = Bvh::read(&path).unwrap();
    std::fs::remove_dir_all(&dir).ok();
    let mut mirrored = plain.clone();
    for joint in &mut mirrored.joints {
        let name = &joint.name;
        joint.name = if let Some(rest) = name.strip_prefix("Left") {
            format!("Right{rest}")
        } else if let Some(rest) = name.strip_prefix("Right") {
            format!("Left{rest}")
        } else {
            name.clone()
        };
    }
    let import = |bvh: &Bvh, map: Option<crate::ArmMap>| {
        let options = ImportOptions {
            map,
            ..ImportOptions::default()
        };
        import_parsed(bvh, "mirrored.bvh", &options).unwrap()
    };
    let want = import(&plain, None);
    assert_eq!(want.source.sides_mirrored, None);
    let mut bends = crate::ElbowBends::new(plain.frame_rate());
    let skeleton = crate::Skeleton::identify(&plain, None, "plain.bvh").unwrap();
    for f in 0..plain.frames() {
        let poses = [Side::Left, Side::Right].map(|s| skeleton.arm_pose(&plain, plain.frame(f), s));
        bends.add([&poses[0], &poses[1]]);
    }
    assert_eq!(bends.backwards(), 0, "of {} judged", bends.judged());
    let got = import(&mirrored, None);
    let found = got
        .source
        .sides_mirrored
        .expect("the sides are said to be mirrored");
    assert!(
        found.judged >= 100 && found.backwards == found.judged,
        "{} of {} judged frames backwards",
        found.backwards,
        found.judged
    );
    let text = found.describe();
    assert!(
        text.contains(r#""jLeftShoulder": "RightUpperArm""#)
            && text.contains(r#""jLeftWrist": "RightHand""#)
            && text.contains(r#""jRightC7Shoulder": "LeftShoulder""#),
        "{text}"
    );
    // Not swapped by the import: the angles are the mislabelled sides'.
    assert!((&got.positions - &want.positions).abs().max() > 0.1);
    // The map it names imports the file as the correctly labelled one, to the last bit.
    let swapped = import(&mirrored, Some(crate::ArmMap(found.swapped_map)));
    assert_eq!(swapped.source.sides_mirrored, None);
    assert_eq!(swapped.positions, want.positions);
}

/// GAMES-105's character: its arms `lTorso_Clavicle` → `lShoulder` → `lElbow` → `lWrist`, found
/// by the Xsens scheme (`Shoulder` the upper arm), whose clavicle is `Collar`: the arms are
/// found without a clavicle, and the skeleton says which joint is named like one.
#[test]
fn a_joint_named_like_a_clavicle_left_out_is_said() {
    let build = |clavicle: &str| {
        let mut t = String::from(
            "HIERARCHY\nROOT RootJoint\n{\nOFFSET 0 100 0\nCHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation\n",
        );
        t += &joint("lowerback_torso", [0.0, 40.0, 0.0]);
        t += &joint("torso_head", [0.0, 15.0, 0.0]);
        t += &end([0.0, 10.0, 0.0]);
        t += "}\n";
        for (s, x) in [("l", 1.0), ("r", -1.0)] {
            let chain = [
                (format!("{s}{clavicle}"), [x * 3.0, 12.0, 0.0]),
                (format!("{s}Shoulder"), [x * 14.0, 0.0, 0.0]),
                (format!("{s}Elbow"), [x * 28.0, 0.0, 0.0]),
                (format!("{s}Wrist"), [x * 25.0, 0.0, 0.0]),
            ];
            for (name, offset) in &chain {
                t += &joint(name, *offset);
            }
            t += &end([x * 8.0, 0.0, 0.0]);
            t += &"}\n".repeat(chain.len());
        }
        t += "}\n}\nMOTION\nFrames: 1\nFrame Time: 0.025\n";
        t += &vec!["0"; 6 + 3 * 2 + 2 * 3 * 4].join(" ");
        t.push('\n');
        let bvh = Bvh::parse(&t, "games105.bvh").unwrap();
        crate::Skeleton::identify(&bvh, None, "games105.bvh").unwrap()
    };
    let s = build("Torso_Clavicle");
    assert!(s.arms.iter().all(|a| a.clavicle.is_none()));
    let note = s.clavicle_note.unwrap();
    assert!(
        note.contains("`lTorso_Clavicle` and `rTorso_Clavicle`")
            && note.contains("jLeftC7Shoulder"),
        "{note}"
    );
    // Named as the scheme names it, the clavicle is found and nothing is said.
    let s = build("Collar");
    assert!(s.arms.iter().all(|a| a.clavicle.is_some()));
    assert_eq!(s.clavicle_note, None);
}
