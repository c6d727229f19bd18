//! Import tests on files written here (the human model's own motion, hand-computed poses);
//! real captures are tested in `tests/capture_real.rs` and the Python suite.

use nalgebra::Vector3;

use super::*;
use sgplvm_robots::Robot;

/// Writes `rows` as a BVH in a fresh temporary folder and imports it.
fn round_trip(rows: &[[f64; 18]], frame_time: f64, options: &ImportOptions) -> CapturedMotion {
    let dir = std::env::temp_dir().join(format!(
        "sgplvm-capture-{}-{}",
        std::process::id(),
        rows.len()
    ));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("motion.bvh");
    write_bvh(&path, frame_time, rows).unwrap();
    let m = import_bvh(&path, options).unwrap();
    std::fs::remove_dir_all(&dir).ok();
    m
}

#[test]
fn hand_computed_poses_come_back() {
    // Frame 0 the zero pose; frame 1 left elbow flexed 90° (forearm forward), right shoulder
    // flexed 90° (arm forward): by hand, only those angles are non-zero.
    let mut rows = vec![[0.0; 18]; 3];
    rows[1][5] = std::f64::consts::FRAC_PI_2;
    rows[1][9 + 2] = std::f64::consts::FRAC_PI_2;
    rows[1][9 + 5] = 0.3;
    rows[2] = rows[1];
    let m = round_trip(&rows, 0.025, &ImportOptions::default());
    assert_eq!(m.positions.nrows(), 3);
    for (k, want) in rows[1].iter().enumerate() {
        assert!(
            (m.positions[(1, k)] - want).abs() < 1e-6,
            "joint {k}: {}",
            m.positions[(1, k)]
        );
    }
    assert!(m.source.fit.within_limits());
    assert_eq!(
        m.source.skeleton,
        "Xsens MVN / Rigify (Shoulder, UpperArm, ForeArm, Hand)"
    );
    assert_eq!(m.source.units, "cm");
    assert!(
        !m.source.calibration_frame_dropped,
        "a real first frame is kept"
    );
}

#[test]
fn the_model_s_own_motion_round_trips_and_resamples() {
    // A smooth motion within limits at 120 Hz, imported at 40 Hz.
    let robot = Robot::builtin("human").unwrap();
    let limits = robot.joint_limits();
    let rows: Vec<[f64; 18]> = (0..241)
        .map(|f| {
            let t = f as f64 / 120.0;
            let mut q = [0.0; 18];
            for k in 0..18 {
                let (lo, hi) = limits[k];
                let mid = 0.5 * (lo + hi);
                let amp = 0.3 * (hi - lo);
                q[k] = mid + amp * (1.3 * t + k as f64).sin();
                if k % 9 == 5 {
                    q[k] = q[k].max(0.2); // a bent elbow: the hinge plane is defined
                }
            }
            q
        })
        .collect();
    let m = round_trip(&rows, 1.0 / 120.0, &ImportOptions::default());
    assert_eq!(m.positions.nrows(), 81);
    assert_eq!(m.times_ns[1] - m.times_ns[0], 25_000_000);
    for (k_out, f) in (0..81).map(|k| (k, 3 * k)) {
        for (j, want) in rows[f].iter().enumerate() {
            assert!(
                (m.positions[(k_out, j)] - want).abs() < 1e-5,
                "frame {f} joint {j}"
            );
        }
    }
    let fit = &m.source.fit;
    assert!(
        fit.elbow_worst_m < 1e-6 && fit.wrist_worst_m < 1e-6,
        "{fit:?}"
    );
    assert_eq!(fit.frames_beyond, 0);
}

#[test]
fn a_calibration_first_frame_is_dropped() {
    let mut rows = vec![[0.0; 18]; 40];
    for (f, r) in rows.iter_mut().enumerate() {
        r[5] = 1.0 + 0.01 * f as f64;
        r[14] = 1.0;
    }
    rows[0] = [0.0; 18];
    rows[0][3] = 1.5; // a T-pose-like first frame
    rows[0][0] = 1.2; // its clavicle beyond the elevation limit (0.79)
    let m = round_trip(&rows, 1.0 / 120.0, &ImportOptions::default());
    assert!(m.source.calibration_frame_dropped);
    assert!((m.positions[(0, 5)] - 1.01).abs() < 1e-6);
    // The frame left out is not counted at a limit.
    assert!(
        m.source.fit.at_limit.is_empty(),
        "{:?}",
        m.source.fit.at_limit
    );
}

#[test]
fn time_range_and_rate_are_checked() {
    let rows = vec![[0.0; 18]; 10];
    let dir = std::env::temp_dir().join(format!("sgplvm-capture-opts-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("m.bvh");
    write_bvh(&path, 0.1, &rows).unwrap();
    let e = import_bvh(
        &path,
        &ImportOptions {
            from_s: Some(5.0),
            ..Default::default()
        },
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("m.bvh") && e.contains("time range"), "{e}");
    let e = import_bvh(
        &path,
        &ImportOptions {
            rate_hz: 0.0,
            ..Default::default()
        },
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("rate 0 Hz"), "{e}");
    let m = import_bvh(
        &path,
        &ImportOptions {
            from_s: Some(0.2),
            to_s: Some(0.6),
            rate_hz: 10.0,
            ..Default::default()
        },
    )
    .unwrap();
    assert_eq!(m.positions.nrows(), 5);
    assert!((m.source.span_s.0 - 0.2).abs() < 1e-9);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn unknown_skeletons_list_their_segments_nearest_the_root_first() {
    // `jaw` is declared before `tail` but lies deeper: listed after it (a face's many bones
    // declared before the arms would otherwise fill the list).
    let joint = |name: &str, inner: &str| {
        format!("JOINT {name}\n{{\nOFFSET 0 -1 0\nCHANNELS 3 Zrotation Xrotation Yrotation\n{inner}}}\n")
    };
    let end = "End Site\n{\nOFFSET 0 -1 0\n}\n";
    let text = format!(
        "HIERARCHY\nROOT pelvis\n{{\nOFFSET 0 0 0\nCHANNELS 3 Zrotation Xrotation Yrotation\n{}{}}}\nMOTION\nFrames: 2\nFrame Time: 0.1\n{}\n{}\n",
        joint("head", &joint("jaw", end)),
        joint("tail", end),
        ["0"; 12].join(" "),
        ["0"; 12].join(" "),
    );
    let text = text.as_str();
    let bvh = Bvh::parse(text, "robot.bvh").unwrap();
    let e = import_parsed(&bvh, "robot.bvh", &ImportOptions::default())
        .unwrap_err()
        .to_string();
    assert!(
        e.starts_with("robot.bvh: cannot tell which segments are the arms"),
        "{e}"
    );
    assert!(
        e.contains("4 segments, nearest the root first: pelvis, head, tail, jaw")
            && e.contains("--map"),
        "{e}"
    );
}

#[test]
fn naming_schemes_are_recognised() {
    let skeleton = |names: [&str; 4], right: [&str; 4]| {
        let mut t = String::from("HIERARCHY\nROOT Hips\n{\nOFFSET 0 0 0\nCHANNELS 3 Zrotation Xrotation Yrotation\nJOINT Chest\n{\nOFFSET 0 10 0\nCHANNELS 3 Zrotation Xrotation Yrotation\nJOINT Neck\n{\nOFFSET 0 10 0\nEnd Site\n{\nOFFSET 0 5 0\n}\n}\n");
        for (arm, x) in [(names, 1.0), (right, -1.0)] {
            let offs = [
                [x * 2.0, 8.0, 0.0],
                [x * 14.0, 0.0, 0.0],
                [x * 28.0, 0.0, 0.0],
                [x * 24.0, 0.0, 0.0],
            ];
            for (n, o) in arm.iter().zip(offs) {
                t.push_str(&format!(
                    "JOINT {n}\n{{\nOFFSET {} {} {}\nCHANNELS 3 Zrotation Xrotation Yrotation\n",
                    o[0], o[1], o[2]
                ));
            }
            t.push_str(&format!(
                "End Site\n{{\nOFFSET {} 0 0\n}}\n}}\n}}\n}}\n}}\n",
                x * 18.0
            ));
        }
        t.push_str("}\n}\nMOTION\nFrames: 1\nFrame Time: 0.1\n");
        t.push_str(&["0"; 30].join(" "));
        t.push('\n');
        Bvh::parse(&t, "s.bvh").unwrap()
    };
    let cases = [
        (
            ["LeftShoulder", "LeftArm", "LeftForeArm", "LeftHand"],
            ["RightShoulder", "RightArm", "RightForeArm", "RightHand"],
            "CMU",
        ),
        (
            [
                "mixamorig:LeftShoulder",
                "mixamorig:LeftArm",
                "mixamorig:LeftForeArm",
                "mixamorig:LeftHand",
            ],
            [
                "mixamorig:RightShoulder",
                "mixamorig:RightArm",
                "mixamorig:RightForeArm",
                "mixamorig:RightHand",
            ],
            "CMU",
        ),
        (
            ["LeftShoulder", "LeftUpperArm", "LeftForeArm", "LeftHand"],
            [
                "RightShoulder",
                "RightUpperArm",
                "RightForeArm",
                "RightHand",
            ],
            "Xsens MVN",
        ),
        (
            ["LeftCollar", "LeftShoulder", "LeftElbow", "LeftWrist"],
            ["RightCollar", "RightShoulder", "RightElbow", "RightWrist"],
            "Xsens BVH",
        ),
        (
            ["lCollar", "lShldr", "lForeArm", "lHand"],
            ["rCollar", "rShldr", "rForeArm", "rHand"],
            "Poser",
        ),
        (
            ["lcollar", "lshoulder", "lelbow", "lhand"],
            ["rcollar", "rshoulder", "relbow", "rhand"],
            "MakeHuman",
        ),
        (
            [
                "CC_Base_L_Clavicle",
                "CC_Base_L_Upperarm",
                "CC_Base_L_Forearm",
                "CC_Base_L_Hand",
            ],
            [
                "CC_Base_R_Clavicle",
                "CC_Base_R_Upperarm",
                "CC_Base_R_Forearm",
                "CC_Base_R_Hand",
            ],
            "Unreal",
        ),
        (
            ["shoulder.L", "upper_arm.L", "forearm.L", "hand.L"],
            ["shoulder.R", "upper_arm.R", "forearm.R", "hand.R"],
            "Rigify",
        ),
        (
            [
                "DEF-shoulder.L",
                "DEF-upper_arm.L",
                "DEF-forearm.L",
                "DEF-hand.L",
            ],
            [
                "DEF-shoulder.R",
                "DEF-upper_arm.R",
                "DEF-forearm.R",
                "DEF-hand.R",
            ],
            "Rigify",
        ),
        (
            ["lCollar", "lShldrBend", "lForearmBend", "lHand"],
            ["rCollar", "rShldrBend", "rForearmBend", "rHand"],
            "DAZ",
        ),
        (
            ["LShoulder", "LUArm", "LFArm", "LHand"],
            ["RShoulder", "RUArm", "RFArm", "RHand"],
            "OptiTrack Motive",
        ),
        (
            ["LeftCollar", "LeftUpArm", "LeftLowArm", "LeftHand"],
            ["RightCollar", "RightUpArm", "RightLowArm", "RightHand"],
            "Biovision",
        ),
    ];
    for (left, right, scheme) in cases {
        let bvh = skeleton(left, right);
        let s = Skeleton::identify(&bvh, None, "s.bvh").unwrap_or_else(|e| panic!("{left:?}: {e}"));
        assert!(s.scheme.contains(scheme), "{left:?} → {}", s.scheme);
        assert_eq!(bvh.joints[s.arms[0].upper_arm].name, left[1]);
        assert_eq!(bvh.joints[s.arms[1].hand].name, right[3]);
        assert_eq!(bvh.joints[s.arms[0].clavicle.unwrap()].name, left[0]);
        // Body axes: x forward (file z), y left (file x), z up (file y).
        let fwd = s.axes * Vector3::x();
        assert!((fwd - Vector3::z()).norm() < 1e-9, "{fwd:?}");
    }
    // A map names anything.
    let bvh = skeleton(["a1", "a2", "a3", "a4"], ["b1", "b2", "b3", "b4"]);
    let map: ArmMap = serde_json::from_str(r#"{"jLeftC7Shoulder": "a1", "jLeftShoulder": "a2", "jLeftElbow": "a3", "jLeftWrist": "a4", "right_clavicle": "b1", "right_upper_arm": "b2", "right_forearm": "b3", "right_hand": "b4"}"#).unwrap();
    let s = Skeleton::identify(&bvh, Some(&map), "s.bvh").unwrap();
    assert_eq!(bvh.joints[s.arms[1].forearm].name, "b3");
    let wrong: ArmMap = serde_json::from_str(r#"{"jLeftShoulder": "nope"}"#).unwrap();
    let e = Skeleton::identify(&bvh, Some(&wrong), "s.bvh")
        .unwrap_err()
        .to_string();
    assert!(e.contains("`jLeftShoulder` names segment `nope`"), "{e}");
}

/// MakeHuman's game rig (its `zombieWalk1.bvh`, in decimetres): `Clavicle_L`, `UpArm_L`,
/// `LoArm_L`, `Hand_L`, each clavicle below a helper joint `__Clavicle_L` on the spine whose
/// name is the clavicle's but for its underscores.
#[test]
fn makehuman_s_game_rig_is_recognised_in_decimetres_past_its_helper_joints() {
    let joint = |name: &str, o: [f64; 3]| {
        format!(
            "JOINT {name}\n{{\nOFFSET {} {} {}\nCHANNELS 3 Xrotation Yrotation Zrotation\n",
            o[0], o[1], o[2]
        )
    };
    let mut t = String::from("HIERARCHY\nROOT Root\n{\nOFFSET 0 0 0\nCHANNELS 6 Xposition Yposition Zposition Xrotation Yrotation Zrotation\n");
    t += &joint("Spine3", [0.0, 4.0, 0.0]);
    t += &joint("Neck", [0.0, 1.5, 0.0]);
    t += "End Site\n{\nOFFSET 0 1 0\n}\n}\n";
    for (s, x) in [("L", 1.0), ("R", -1.0)] {
        let chain = [
            (format!("__Clavicle_{s}"), [0.0, 1.2, 0.0]),
            (format!("Clavicle_{s}"), [x * 0.3, -0.3, 0.1]),
            (format!("UpArm_{s}"), [x * 1.5, 0.0, 0.0]),
            (format!("LoArm_{s}"), [x * 2.0, 0.0, 0.0]),
            (format!("Hand_{s}"), [x * 2.4, 0.0, 0.0]),
        ];
        for (name, o) in &chain {
            t += &joint(name, *o);
        }
        t += &format!("End Site\n{{\nOFFSET {} 0 0\n}}\n", x * 1.0);
        t += &"}\n".repeat(chain.len());
    }
    t += "}\n}\nMOTION\nFrames: 1\nFrame Time: 0.04\n";
    t += &["0"; 6 + 3 * 12].join(" ");
    t.push('\n');
    let bvh = Bvh::parse(&t, "game.bvh").unwrap();
    let s = Skeleton::identify(&bvh, None, "game.bvh").unwrap();
    assert!(s.scheme.contains("MakeHuman game rig"), "{}", s.scheme);
    for (arm, side) in s.arms.iter().zip(["L", "R"]) {
        let name = |j: usize| bvh.joints[j].name.as_str();
        assert_eq!(name(arm.clavicle.unwrap()), format!("Clavicle_{side}"));
        assert_eq!(name(arm.upper_arm), format!("UpArm_{side}"));
        assert_eq!(name(arm.forearm), format!("LoArm_{side}"));
        assert_eq!(name(arm.hand), format!("Hand_{side}"));
    }
    // Upper arm and forearm: 4.4 units, 44 cm in decimetres (in CMU's units, 24.8 cm).
    assert!((s.arm_length - 4.4).abs() < 1e-12, "{}", s.arm_length);
    assert_eq!(Units::guess(s.arm_length), Some(Units::Decimetres));
}

#[test]
fn decimetres_are_a_unit_and_other_units_are_guessed_as_before() {
    assert_eq!(Units::parse("dm"), Some(Units::Decimetres));
    assert_eq!(Units::Decimetres.name(), "dm");
    assert_eq!(Units::Decimetres.metres(), 0.1);
    assert_eq!(Units::choices(), "m, dm, cm, mm, in or cmu");
    // MakeHuman's game rig: 43.8 cm of arm.
    assert_eq!(Units::guess(4.38), Some(Units::Decimetres));
    // An adult's arm in each of the other units, and CMU's subject 13 (51.3 cm).
    assert_eq!(Units::guess(0.54), Some(Units::Metres));
    assert_eq!(Units::guess(54.0), Some(Units::Centimetres));
    assert_eq!(Units::guess(540.0), Some(Units::Millimetres));
    assert_eq!(Units::guess(21.3), Some(Units::Inches));
    assert_eq!(Units::guess(0.513 / Units::Cmu.metres()), Some(Units::Cmu));
}

/// A two-arm skeleton under a floor joint: `clavicle` and `upper_arm` are the left arm's
/// offsets (the right arm mirrors x), `neck` the neck's from the chest.
fn floor_skeleton(clavicle: [f64; 3], upper_arm: [f64; 3], neck: [f64; 3]) -> Bvh {
    let mut t = String::from("HIERARCHY\nROOT floor\n{\nOFFSET 0 0 0\nCHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation\nJOINT Hips\n{\nOFFSET 0 90 0\nCHANNELS 3 Zrotation Xrotation Yrotation\nJOINT LeftUpLeg\n{\nOFFSET 10 0 0\nEnd Site\n{\nOFFSET 0 -40 0\n}\n}\nJOINT RightUpLeg\n{\nOFFSET -10 0 0\nEnd Site\n{\nOFFSET 0 -40 0\n}\n}\nJOINT Chest\n{\nOFFSET 0 30 0\nCHANNELS 3 Zrotation Xrotation Yrotation\n");
    t.push_str(&format!(
        "JOINT Neck\n{{\nOFFSET {} {} {}\nEnd Site\n{{\nOFFSET 0 10 0\n}}\n}}\n",
        neck[0], neck[1], neck[2]
    ));
    for (side, x) in [("Left", 1.0), ("Right", -1.0)] {
        let offs = [
            clavicle,
            upper_arm,
            [x * 28.0, 0.0, 0.0],
            [x * 25.0, 0.0, 0.0],
        ];
        for (k, (name, o)) in ["Shoulder", "Arm", "ForeArm", "Hand"]
            .iter()
            .zip(offs)
            .enumerate()
        {
            let ox = if k < 2 { x * o[0] } else { o[0] };
            t.push_str(&format!(
                "JOINT {side}{name}\n{{\nOFFSET {ox} {} {}\nCHANNELS 3 Zrotation Xrotation Yrotation\n",
                o[1], o[2]
            ));
        }
        t.push_str("End Site\n{\nOFFSET 0 0 0\n}\n}\n}\n}\n}\n");
    }
    t.push_str("}\n}\n}\nMOTION\nFrames: 1\nFrame Time: 0.1\n");
    t.push_str(&["0"; 36].join(" "));
    t.push('\n');
    Bvh::parse(&t, "floor.bvh").unwrap()
}

#[test]
fn body_axes_come_from_the_clavicles_and_the_spine_not_the_floor_joint() {
    // Clavicles up the spine in the zero pose (as where bones lie along local x): the roots of
    // the clavicles still give left, the spine from the hips (where the legs part) up; the
    // floor joint's 90 below the hips plays no part.
    let bvh = floor_skeleton([3.0, 15.0, 0.0], [0.0, 15.0, 0.0], [0.0, 20.0, 0.0]);
    let s = Skeleton::identify(&bvh, None, "floor.bvh").unwrap();
    let axes = s.axes.matrix();
    let expect = [Vector3::z(), Vector3::x(), Vector3::y()];
    for (k, e) in expect.iter().enumerate() {
        assert!((axes.column(k) - e).norm() < 1e-12, "{axes}");
    }
    assert_eq!(
        s.axes_from,
        "left from `RightShoulder` to `LeftShoulder` (fixed in `Chest`), up from `Hips` to `Neck` along the spine"
    );
    // Clavicles starting at the chest joint: the shoulders, at the clavicles' zero rotation.
    let bvh = floor_skeleton([0.0, 0.0, 0.0], [15.0, 2.0, 0.0], [0.0, 20.0, 0.0]);
    let s = Skeleton::identify(&bvh, None, "floor.bvh").unwrap();
    assert!((s.axes * Vector3::y() - Vector3::x()).norm() < 1e-12);
    assert!(
        s.axes_from.starts_with(
            "left from `RightArm` to `LeftArm` (the joints above them at zero rotation)"
        ),
        "{}",
        s.axes_from
    );
}

#[test]
fn a_spine_that_folds_at_rest_takes_up_along_the_bones_above_the_fold() {
    // As Rokoko Studio exports: the pelvis in the world's axes, its first spine bone along y,
    // every bone above it along its own x (the shoulders apart along y). Summed at zero
    // rotation, the line from the pelvis to the neck leans 13° towards the left shoulder; the
    // spine above the fold runs along x.
    let mut t = String::from("HIERARCHY\nROOT Hips\n{\nOFFSET 0 90 0\nCHANNELS 6 Xposition Yposition Zposition Yrotation Xrotation Zrotation\nJOINT LeftUpLeg\n{\nOFFSET 10 0 0\nCHANNELS 3 Yrotation Xrotation Zrotation\nEnd Site\n{\nOFFSET 40 0 0\n}\n}\nJOINT RightUpLeg\n{\nOFFSET -10 0 0\nCHANNELS 3 Yrotation Xrotation Zrotation\nEnd Site\n{\nOFFSET 40 0 0\n}\n}\nJOINT Spine\n{\nOFFSET 0 10 0\nCHANNELS 3 Yrotation Xrotation Zrotation\nJOINT Spine1\n{\nOFFSET 12 0 0\nCHANNELS 3 Yrotation Xrotation Zrotation\nJOINT Spine2\n{\nOFFSET 12 0 0\nCHANNELS 3 Yrotation Xrotation Zrotation\nJOINT Neck\n{\nOFFSET 18 0 0\nCHANNELS 3 Yrotation Xrotation Zrotation\nEnd Site\n{\nOFFSET 10 0 0\n}\n}\n");
    for (side, y) in [("Left", 7.0), ("Right", -7.0)] {
        t.push_str(&format!(
            "JOINT {side}Shoulder\n{{\nOFFSET 10 {y} 0\nCHANNELS 3 Yrotation Xrotation Zrotation\n"
        ));
        for (name, x) in [("Arm", 13.0), ("ForeArm", 26.0), ("Hand", 29.0)] {
            t.push_str(&format!("JOINT {side}{name}\n{{\nOFFSET {x} 0 0\nCHANNELS 3 Yrotation Xrotation Zrotation\n"));
        }
        t.push_str("End Site\n{\nOFFSET 5 0 0\n}\n}\n}\n}\n}\n");
    }
    t.push_str("}\n}\n}\n}\nMOTION\nFrames: 1\nFrame Time: 0.1\n");
    t.push_str(&["0"; 48].join(" "));
    t.push('\n');
    let bvh = Bvh::parse(&t, "rokoko.bvh").unwrap();
    let s = Skeleton::identify(&bvh, None, "rokoko.bvh").unwrap();
    let axes = s.axes.matrix();
    let expect = [-Vector3::z(), Vector3::y(), Vector3::x()];
    for (k, e) in expect.iter().enumerate() {
        assert!((axes.column(k) - e).norm() < 1e-12, "{axes}");
    }
    assert!(
        s.axes_from
            .ends_with("up from `Spine` to `Neck` along the spine"),
        "{}",
        s.axes_from
    );
}

#[test]
fn a_torso_whose_axes_cannot_be_told_is_an_error_naming_the_joints() {
    // Both arms start at one place all the way down to the shoulders.
    let bvh = floor_skeleton([0.0, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, 20.0, 0.0]);
    let e = Skeleton::identify(&bvh, None, "floor.bvh")
        .unwrap_err()
        .to_string();
    assert!(
        e.starts_with("floor.bvh: cannot tell the torso's axes: the arms `LeftArm` and `RightArm` start at the same place"),
        "{e}"
    );
    // Clavicles apart only along the spine (one above the other cannot be: mirrored in x,
    // so left and up coincide when the spine runs along x).
    let bvh = floor_skeleton([3.0, 0.0, 0.0], [10.0, 0.0, 0.0], [0.0, 0.0, 0.0]);
    let text = bvh_with_spine_along_x(&bvh);
    let e = Skeleton::identify(&text, None, "floor.bvh")
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("cannot tell the torso's axes: the line from `RightShoulder` to `LeftShoulder` (left) runs along the spine from `Hips` to `Neck` (up)"),
        "{e}"
    );
}

/// `bvh` with the chest above the hips along x (and the neck on the chest joint).
fn bvh_with_spine_along_x(bvh: &Bvh) -> Bvh {
    let mut b = bvh.clone();
    let chest = b.joint("Chest").unwrap();
    b.joints[chest].offset = Vector3::new(30.0, 0.0, 0.0);
    b
}
