//! The upper torso's body axes whatever the capture's zero pose looks like (issue 44 §2).
//!
//! One motion of a whole body (walking forward, turning, leaning and twisting; arms hanging,
//! then waving) is written through three rigs of the same skeleton: a T-pose whose joints
//! have the world's axes, an A-pose, and a rig whose every bone lies along its joint's local
//! x with six channels on every joint under a floor joint (as the Bandai Namco Research motion
//! datasets are; their zero pose is a line of bones up the spine, no pose a person takes).
//! Every rig must import to the arm the motion holds, seen from the chest: the same segment
//! directions, so hanging arms hang; the T- and A-pose rigs to the same 18 angles.
//!
//! `SGPLVM_REST_POSE_BVH=FILE.bvh` (or a folder of them) also measures real captures of that
//! kind: the imported upper arm and forearm against the capture's own, seen in a frame built
//! from its chest's children (left from the right clavicle's root to the left's, up from the
//! chest to the neck), and prints the hand's height below the shoulder in arm lengths.
//! `SGPLVM_REST_POSE_WRITE=FOLDER` keeps the three synthetic rigs' files there, for other tools.

use std::path::PathBuf;

use nalgebra::{Matrix3, Rotation3, Vector3};
use sgplvm_capture::{import_parsed, Bvh, CapturedMotion, ImportOptions};
use sgplvm_robots::Robot;

/// A rotation about body axis 0, 1, 2 (x forward, y left, z up) by `a` radians.
fn rot(axis: usize, a: f64) -> Rotation3<f64> {
    Rotation3::from_axis_angle(&Vector3::ith_axis(axis), a)
}

/// Body axes (x forward, y left, z up) to the file's (x left, y up, z forward).
fn b() -> Matrix3<f64> {
    Matrix3::new(0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 1.0, 0.0, 0.0)
}

/// `Zrotation Xrotation Yrotation` degrees of `r` (`r = Rz Rx Ry`).
fn zxy(r: &Matrix3<f64>) -> [f64; 3] {
    let x = r[(2, 1)].clamp(-1.0, 1.0).asin();
    let y = (-r[(2, 0)]).atan2(r[(2, 2)]);
    let z = (-r[(0, 1)]).atan2(r[(1, 1)]);
    [z.to_degrees(), x.to_degrees(), y.to_degrees()]
}

/// Joints: name, parent, offset in the T-pose (body axes, cm).
const JOINTS: [(&str, Option<usize>, [f64; 3]); 18] = [
    ("joint_Root", None, [0.0, 0.0, 0.0]),
    ("Hips", Some(0), [0.0, 0.0, 94.0]),
    ("Spine", Some(1), [0.0, 0.0, 12.0]),
    ("Chest", Some(2), [0.0, 0.0, 12.0]),
    ("Neck", Some(3), [0.0, 0.0, 22.0]),
    ("Head", Some(4), [1.0, 0.0, 8.0]),
    ("Shoulder_L", Some(3), [0.0, 3.0, 17.0]),
    ("UpperArm_L", Some(6), [0.0, 15.0, 0.0]),
    ("LowerArm_L", Some(7), [0.0, 28.0, 0.0]),
    ("Hand_L", Some(8), [0.0, 25.0, 0.0]),
    ("Shoulder_R", Some(3), [0.0, -3.0, 17.0]),
    ("UpperArm_R", Some(10), [0.0, -15.0, 0.0]),
    ("LowerArm_R", Some(11), [0.0, -28.0, 0.0]),
    ("Hand_R", Some(12), [0.0, -25.0, 0.0]),
    ("UpperLeg_L", Some(1), [0.0, 9.0, -4.0]),
    ("LowerLeg_L", Some(14), [0.0, 0.0, -42.0]),
    ("UpperLeg_R", Some(1), [0.0, -9.0, -4.0]),
    ("LowerLeg_R", Some(16), [0.0, 0.0, -42.0]),
];

/// End Sites (T-pose, body axes) of the joints that end a chain.
fn end_site(j: usize) -> Option<Vector3<f64>> {
    match JOINTS[j].0 {
        "Head" => Some(Vector3::new(0.0, 0.0, 10.0)),
        "Hand_L" => Some(Vector3::new(0.0, 18.0, 0.0)),
        "Hand_R" => Some(Vector3::new(0.0, -18.0, 0.0)),
        "LowerLeg_L" | "LowerLeg_R" => Some(Vector3::new(0.0, 0.0, -40.0)),
        _ => None,
    }
}

/// How a rig holds each joint: its local frame in the T-pose (body axes), and whether every
/// joint has six channels.
struct Rig {
    frames: Vec<Rotation3<f64>>,
    six_channels: bool,
}

impl Rig {
    /// The joints have the world's axes; the zero pose is the T-pose.
    fn t_pose() -> Rig {
        Rig {
            frames: vec![Rotation3::identity(); JOINTS.len()],
            six_channels: false,
        }
    }

    /// The arms 45° down from the T-pose in the zero pose.
    fn a_pose() -> Rig {
        let mut frames = vec![Rotation3::identity(); JOINTS.len()];
        for f in &mut frames[7..=9] {
            *f = rot(0, 45f64.to_radians());
        }
        for f in &mut frames[11..=13] {
            *f = rot(0, -45f64.to_radians());
        }
        Rig {
            frames,
            six_channels: false,
        }
    }

    /// Every bone along its joint's local x (the right side's along −x, as Maya mirrors it),
    /// the frames turned about their bones (by one angle along each arm, as a rig's chains
    /// are oriented, another for every other joint), six channels on every joint; the floor
    /// joint keeps the world's axes.
    fn x_bones() -> Rig {
        let mut frames = vec![Rotation3::identity(); JOINTS.len()];
        for (j, frame) in frames.iter_mut().enumerate().skip(1) {
            let child = (0..JOINTS.len()).find(|&c| JOINTS[c].1 == Some(j));
            let bone = child
                .map(|c| Vector3::from(JOINTS[c].2))
                .or_else(|| end_site(j))
                .expect("a bone");
            let right = JOINTS[j].0.ends_with("_R");
            let along = if right { -bone } else { bone };
            let swing = Rotation3::rotation_between(&Vector3::x(), &along)
                .unwrap_or_else(|| rot(2, std::f64::consts::PI));
            let twist = match j {
                7..=9 => 0.8,
                11..=13 => -1.2,
                _ => 0.4 * j as f64,
            };
            *frame = swing * rot(0, twist);
        }
        Rig {
            frames,
            six_channels: true,
        }
    }
}

/// The motion: per frame, the root's place and every joint's rotation relative to its parent
/// in the T-pose rig (body axes). Frames 0–29 hang the arms (elbows a little bent), 30–59
/// raise the left arm and wave.
fn motion(frames: usize) -> Motion {
    (0..frames)
        .map(|f| {
            let t = f as f64 / 30.0;
            let mut m = vec![Rotation3::identity(); JOINTS.len()];
            m[0] = rot(2, 0.3 * t);
            m[1] = rot(1, 0.05 * (3.0 * t).sin());
            m[2] = rot(1, 0.15) * rot(2, 0.1 * (2.0 * t).sin());
            m[3] = rot(0, 0.05) * rot(2, 0.1);
            m[6] = rot(0, 0.05);
            m[10] = rot(0, -0.05);
            let wave = f >= 30;
            m[7] = if wave {
                rot(0, 0.6) * rot(1, -0.3)
            } else {
                rot(0, -1.45) * rot(2, -0.1 * (2.0 * t).sin())
            };
            m[8] = if wave {
                rot(2, -1.3 - 0.4 * (6.0 * t).sin()) * rot(1, -0.2)
            } else {
                rot(2, -0.25)
            };
            m[9] = rot(0, 0.2) * rot(2, 0.1 * t);
            m[11] = rot(0, 1.5) * rot(2, 0.1 * (2.0 * t).sin());
            m[12] = rot(2, 0.25 + 0.05 * t);
            m[13] = rot(0, -0.1);
            m[14] = rot(1, -0.3 * (4.0 * t).sin());
            m[16] = rot(1, 0.3 * (4.0 * t).sin());
            (Vector3::new(40.0 * t, 0.0, 0.0), m)
        })
        .collect()
}

/// World places and rotations (body axes) of every joint of the T-pose rig in one frame.
fn world(root: &Vector3<f64>, m: &[Rotation3<f64>]) -> (Vec<Vector3<f64>>, Vec<Rotation3<f64>>) {
    let mut p = vec![Vector3::zeros(); JOINTS.len()];
    let mut w = vec![Rotation3::identity(); JOINTS.len()];
    for (j, (_, parent, offset)) in JOINTS.iter().enumerate() {
        match parent {
            None => {
                p[j] = *root;
                w[j] = m[j];
            }
            Some(q) => {
                p[j] = p[*q] + w[*q] * Vector3::from(*offset);
                w[j] = w[*q] * m[j];
            }
        }
    }
    (p, w)
}

/// The motion written through `rig` as BVH text: every joint's world rotation is the T-pose
/// rig's times its rig frame, its offset the T-pose offset in its parent's rig frame.
fn write(rig: &Rig, motion: &Motion) -> String {
    let b = b();
    let v3 = |v: Vector3<f64>| {
        let f = b * v;
        format!("{:.9} {:.9} {:.9}", f.x, f.y, f.z)
    };
    let local_offset = |j: usize, v: Vector3<f64>| match JOINTS[j].1 {
        Some(p) => rig.frames[p].inverse() * v,
        None => v,
    };
    let six = "CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation";
    let three = "CHANNELS 3 Zrotation Xrotation Yrotation";
    let mut text = String::from("HIERARCHY\n");
    let depth = |mut j: usize| {
        let mut d = 0;
        while let Some(p) = JOINTS[j].1 {
            d += 1;
            j = p;
        }
        d
    };
    for (j, &(name, parent, offset)) in JOINTS.iter().enumerate() {
        let pad = "  ".repeat(depth(j));
        let kind = if parent.is_none() { "ROOT" } else { "JOINT" };
        let channels = if rig.six_channels || j < 2 {
            six
        } else {
            three
        };
        text.push_str(&format!(
            "{pad}{kind} {name}\n{pad}{{\n{pad}  OFFSET {}\n{pad}  {channels}\n",
            v3(local_offset(j, Vector3::from(offset)))
        ));
        if let Some(e) = end_site(j) {
            let e = rig.frames[j].inverse() * e;
            text.push_str(&format!(
                "{pad}  End Site\n{pad}  {{\n{pad}    OFFSET {}\n{pad}  }}\n",
                v3(e)
            ));
        }
        // Close this joint and the ones it ends.
        let next_depth = if j + 1 < JOINTS.len() {
            depth(j + 1)
        } else {
            0
        };
        for d in (next_depth..=depth(j)).rev() {
            text.push_str(&format!("{}}}\n", "  ".repeat(d)));
        }
    }
    text.push_str(&format!(
        "MOTION\nFrames: {}\nFrame Time: 0.0333333333\n",
        motion.len()
    ));
    for (root, m) in motion {
        let (p, w) = world(root, m);
        let mut values = Vec::new();
        for j in 0..JOINTS.len() {
            let wj = w[j] * rig.frames[j];
            let local = match JOINTS[j].1 {
                Some(q) => (w[q] * rig.frames[q]).inverse() * wj,
                None => wj,
            };
            if rig.six_channels || j < 2 {
                let t = match JOINTS[j].1 {
                    None => p[j],
                    Some(_) => local_offset(j, Vector3::from(JOINTS[j].2)),
                };
                values.extend((b * t).iter().copied());
            }
            values.extend(zxy(&(b * local.matrix() * b.transpose())));
        }
        let line: Vec<String> = values.iter().map(|v| format!("{v:.9}")).collect();
        text.push_str(&line.join(" "));
        text.push('\n');
    }
    text
}

/// Imports BVH `text` at the capture's own rate (30 Hz: one output frame per captured one).
fn import(text: &str, name: &str) -> CapturedMotion {
    let bvh = Bvh::parse(text, name).unwrap_or_else(|e| panic!("{name}: {e}"));
    import_parsed(
        &bvh,
        name,
        &ImportOptions {
            rate_hz: 30.0,
            ..Default::default()
        },
    )
    .unwrap_or_else(|e| panic!("{name}: {e}"))
}

/// One arm of the imported model: upper-arm and forearm directions and the wrist's height
/// below the shoulder in arm lengths, torso (`T8`) frame.
type ModelArm = (Vector3<f64>, Vector3<f64>, f64);

/// One arm of the motion: upper-arm and forearm directions seen from the chest.
type TrueArm = (Vector3<f64>, Vector3<f64>);

/// Per frame, the root's place and every joint's rotation relative to its parent.
type Motion = Vec<(Vector3<f64>, Vec<Rotation3<f64>>)>;

/// Per frame and arm (left, right): the imported model's arm.
fn model_arms(m: &CapturedMotion) -> Vec<[ModelArm; 2]> {
    let human = Robot::builtin("human").expect("human");
    (0..m.positions.nrows())
        .map(|r| {
            let q: Vec<f64> = m.positions.row(r).iter().copied().collect();
            ["left", "right"].map(|s| {
                let at = |l: &str| {
                    human
                        .forward_kinematics(&q, &format!("{s}_{l}"))
                        .expect("fk")
                        .translation
                        .vector
                };
                let (sh, el, wr) = (at("upper_arm_flex"), at("forearm_flex"), at("hand_flex"));
                let length = (el - sh).norm() + (wr - el).norm();
                (
                    (el - sh).normalize(),
                    (wr - el).normalize(),
                    (wr - sh).z / length,
                )
            })
        })
        .collect()
}

/// Per frame and arm: the motion's upper-arm and forearm directions seen from the chest.
fn true_arms(motion: &Motion) -> Vec<[TrueArm; 2]> {
    motion
        .iter()
        .map(|(root, m)| {
            let (p, w) = world(root, m);
            let chest = w[3].inverse();
            let dir = |a: usize, b: usize| (chest * (p[b] - p[a])).normalize();
            [(dir(7, 8), dir(8, 9)), (dir(11, 12), dir(12, 13))]
        })
        .collect()
}

/// Elevation above the horizontal and heading (from forward towards the left) of `d`, degrees.
fn elevation_heading(d: &Vector3<f64>) -> (f64, f64) {
    (
        d.z.clamp(-1.0, 1.0).asin().to_degrees(),
        d.y.atan2(d.x).to_degrees(),
    )
}

/// Largest angle between the imported and the true segment directions, degrees.
fn worst_direction_error(model: &[[ModelArm; 2]], truth: &[[TrueArm; 2]]) -> f64 {
    let angle = |a: &Vector3<f64>, b: &Vector3<f64>| a.dot(b).clamp(-1.0, 1.0).acos().to_degrees();
    model
        .iter()
        .zip(truth)
        .flat_map(|(m, t)| {
            (0..2).flat_map(move |s| [angle(&m[s].0, &t[s].0), angle(&m[s].1, &t[s].1)])
        })
        .fold(0.0, f64::max)
}

#[test]
fn every_rig_of_one_motion_imports_to_the_arm_it_holds() {
    let motion = motion(60);
    let truth = true_arms(&motion);
    // The motion itself: hanging arms hang (the wrist about 0.95 arm lengths below the
    // shoulder), the waving hand is above the shoulder.
    let mut imported = Vec::new();
    for (name, rig) in [
        ("t-pose.bvh", Rig::t_pose()),
        ("a-pose.bvh", Rig::a_pose()),
        ("x-bones.bvh", Rig::x_bones()),
    ] {
        let text = write(&rig, &motion);
        if let Some(d) = std::env::var_os("SGPLVM_REST_POSE_WRITE") {
            std::fs::write(PathBuf::from(d).join(name), &text).expect("write");
        }
        let m = import(&text, name);
        let arms = model_arms(&m);
        let worst = worst_direction_error(&arms, &truth);
        println!("{name}: segment directions {worst:.2e}° off the motion's at worst");
        assert!(
            worst < 1e-4,
            "{name}: a segment is {worst:.3}° off the motion's ({})",
            m.source.body_axes
        );
        for (f, a) in arms.iter().enumerate().take(30) {
            for (side, (_, _, height)) in a.iter().enumerate() {
                assert!(
                    (-0.99..=-0.93).contains(height),
                    "{name} frame {f} arm {side}: wrist {height:.3} arm lengths below the shoulder"
                );
            }
        }
        let (elevation, heading) = elevation_heading(&arms[45][0].0);
        let (e0, h0) = elevation_heading(&truth[45][0].0);
        assert!((elevation - e0).abs() < 1e-3 && (heading - h0).abs() < 1e-3);
        assert!(
            arms[45][0].2 > 0.0,
            "{name}: the waving hand is above the shoulder"
        );
        assert!(m.source.fit.within_limits(), "{name}: {:?}", m.source.fit);
        imported.push(m);
    }
    // The same 18 angles, twists included: the A-pose's rest gives them as it is; the T-pose
    // (flat clavicles) and the line of bones are at the shoulder's gimbal point, where the
    // elbow's hinge in the motion tells the twist.
    for (k, name) in [(1, "A-pose"), (2, "x-bone")] {
        let worst = (imported[0].positions.clone() - imported[k].positions.clone()).amax();
        assert!(worst < 1e-6, "T-pose and {name} rigs differ by {worst} rad");
    }
    assert!(
        imported[2]
            .source
            .body_axes
            .contains("`Shoulder_R` to `Shoulder_L` (fixed in `Chest`)")
            && imported[2]
                .source
                .body_axes
                .contains("up from `Hips` to `Neck`"),
        "{}",
        imported[2].source.body_axes
    );
}

/// The BVH files `SGPLVM_REST_POSE_BVH` names (a file or a folder of them).
fn real_files() -> Vec<PathBuf> {
    let Some(path) = std::env::var_os("SGPLVM_REST_POSE_BVH").map(PathBuf::from) else {
        return Vec::new();
    };
    if path.is_dir() {
        let mut files: Vec<PathBuf> = std::fs::read_dir(&path)
            .expect("folder")
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| p.extension().is_some_and(|e| e == "bvh"))
            .collect();
        files.sort();
        files
    } else {
        vec![path]
    }
}

/// World places and rotations of every joint of `bvh` in frame `f`.
fn bvh_world(bvh: &Bvh, f: usize) -> (Vec<Vector3<f64>>, Vec<Rotation3<f64>>) {
    let values = bvh.frame(f);
    let mut p = vec![Vector3::zeros(); bvh.joints.len()];
    let mut w = vec![Rotation3::identity(); bvh.joints.len()];
    for (j, joint) in bvh.joints.iter().enumerate() {
        let (t, r) = joint.local(values);
        match joint.parent {
            None => (p[j], w[j]) = (t, r),
            Some(q) => (p[j], w[j]) = (p[q] + w[q] * t, w[q] * r),
        }
    }
    (p, w)
}

#[test]
fn real_captures_named_by_the_environment_import_to_their_arms() {
    for path in real_files() {
        let name = path.display().to_string();
        let bvh = Bvh::read(&path).expect("bvh");
        let m = import(&std::fs::read_to_string(&path).expect("read"), &name);
        let arms = model_arms(&m);
        let joint = |n: &str| bvh.joint(n).unwrap_or_else(|| panic!("{name}: no `{n}`"));
        let [cl, cr, ul, ur, fl, fr, hl, hr, chest, neck] = [
            "Shoulder_L",
            "Shoulder_R",
            "UpperArm_L",
            "UpperArm_R",
            "LowerArm_L",
            "LowerArm_R",
            "Hand_L",
            "Hand_R",
            "Chest",
            "Neck",
        ]
        .map(joint);
        // Per frame and arm: the upper arm's direction error, its elevation and heading errors
        // (heading where the arm is more than 20° from vertical), the forearm's direction error
        // (degrees), and the wrist's height below the shoulder (arm lengths), imported and
        // captured.
        let (mut upper, mut elevation, mut heading, mut fore) = (vec![], vec![], vec![], vec![]);
        let mut heights = Vec::new();
        let angle =
            |a: &Vector3<f64>, b: &Vector3<f64>| a.dot(b).clamp(-1.0, 1.0).acos().to_degrees();
        for (f, a) in arms.iter().enumerate() {
            let (p, _) = bvh_world(&bvh, f);
            let up = (p[neck] - p[chest]).normalize();
            let left = p[cl] - p[cr];
            let left = (left - up * left.dot(&up)).normalize();
            let to_body = Matrix3::from_rows(&[
                left.cross(&up).transpose(),
                left.transpose(),
                up.transpose(),
            ]);
            for (s, (u, fo, wr)) in [(0, (ul, fl, hl)), (1, (ur, fr, hr))] {
                let u_true = (to_body * (p[fo] - p[u])).normalize();
                let f_true = (to_body * (p[wr] - p[fo])).normalize();
                let length = (p[fo] - p[u]).norm() + (p[wr] - p[fo]).norm();
                let (e0, h0) = elevation_heading(&u_true);
                let (e1, h1) = elevation_heading(&a[s].0);
                upper.push(angle(&a[s].0, &u_true));
                elevation.push((e1 - e0).abs());
                if e0.abs() < 70.0 {
                    heading.push(((h1 - h0 + 540.0) % 360.0 - 180.0).abs());
                }
                fore.push(angle(&a[s].1, &f_true));
                heights.push((a[s].2, (to_body * (p[wr] - p[u])).z / length));
            }
        }
        let median = |v: &mut Vec<f64>| {
            v.sort_by(f64::total_cmp);
            v.get(v.len() / 2).copied().unwrap_or(f64::NAN)
        };
        let worst = |v: &[f64]| v.iter().copied().fold(0.0, f64::max);
        let lowest = heights.iter().map(|h| h.0).fold(f64::INFINITY, f64::min);
        let lowest_true = heights.iter().map(|h| h.1).fold(f64::INFINITY, f64::min);
        let (wu, wf) = (worst(&upper), worst(&fore));
        let (mu, mf) = (median(&mut upper), median(&mut fore));
        println!(
            "{name}: upper arm {mu:.2}° median, {wu:.2}° worst (elevation {:.2}°, heading {:.2}° median); forearm {mf:.2}° median, {wf:.2}° worst; lowest wrist {lowest:.3} arm lengths below the shoulder (capture {lowest_true:.3}); body axes {}",
            median(&mut elevation),
            median(&mut heading),
            m.source.body_axes
        );
        assert!(
            mu < 2.0 && mf < 2.0,
            "{name}: upper arm {mu:.2}°, forearm {mf:.2}° median"
        );
    }
}
