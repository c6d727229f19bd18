use super::split::{split_into_blocks, SplitOptions, SplitRule};
use super::*;
use crate::dataset::Segment;
use crate::generator::solve_key_poses;
use crate::retarget::whole_arm;

mod postures;

/// A human moving through its key postures (smoothstep between them), `per_motion` frames each
/// at 40 Hz, as one unlabelled segment.
fn human_tour(poses: &[usize], per_motion: usize) -> Dataset {
    let human = solve_key_poses("human").unwrap();
    let mut rows: Vec<Vec<f64>> = Vec::new();
    for w in poses.windows(2) {
        let (a, b) = (&human.postures[w[0]], &human.postures[w[1]]);
        for k in 0..per_motion {
            let s = k as f64 / per_motion as f64;
            let s = s * s * (3.0 - 2.0 * s);
            rows.push(a.iter().zip(b).map(|(x, y)| x + s * (y - x)).collect());
        }
    }
    let n = rows.len();
    let positions = DMatrix::from_fn(n, 18, |i, j| rows[i][j]);
    let times = (0..n as i64)
        .map(|i| 1_000_000_000 + i * 25_000_000)
        .collect();
    let human = BodyData {
        name: "human".into(),
        topic: "/human/joint_states".into(),
        joint_names: human.joint_names.clone(),
        positions,
    };
    Dataset::unlabelled(times, human, Vec::new())
}

fn coman() -> Vec<(String, Anatomy)> {
    vec![("coman".to_string(), Anatomy::builtin("coman").unwrap())]
}

/// Where a body's hands are relative to their shoulders, in reach units, in its body frame:
/// measured by the robot's forward kinematics of a whole configuration, apart from the code
/// under test.
fn relative_hands(anatomy: &Anatomy, q: &[f64]) -> [Vector3<f64>; 2] {
    let robot = anatomy.robot();
    let torso = robot.forward_kinematics(q, anatomy.torso_link()).unwrap();
    [0, 1].map(|s| {
        let arm = &anatomy.arms()[s];
        let hand = torso.inverse() * robot.forward_kinematics(q, arm.chain.tip()).unwrap();
        // Hands are placed relative to the shoulder where it is with the arm's joints at 0.
        anatomy.body_in_torso().inverse() * (hand.translation.vector - arm.shoulder) / arm.reach
    })
}

#[test]
fn hands_follow_the_human_s_hands_scaled_within_limits_and_speeds() {
    let ds = human_tour(&[0, 1, 3, 4, 8, 0], 40);
    let hands = RetargetOptions {
        mode: Match::Hands,
        velocity_limits: true,
        ..RetargetOptions::default()
    };
    let out = retarget(&ds, &coman(), &hands).unwrap();
    let r = &out[0];
    let robot = Robot::builtin("coman").unwrap();
    let (ra, ha) = (
        Anatomy::builtin("coman").unwrap(),
        Anatomy::builtin("human").unwrap(),
    );
    let limits = robot.joint_limits();
    let speed = robot.velocity_limits();
    assert_eq!(r.report.targets, 2 * ds.len());
    assert!(r.report.worst_m.unwrap() <= 0.005, "{:?}", r.report);
    let mut reached = 0;
    for f in 0..ds.len() {
        let q: Vec<f64> = r.body.positions.row(f).iter().copied().collect();
        let qh: Vec<f64> = ds.human.positions.row(f).iter().copied().collect();
        for (j, v) in q.iter().enumerate() {
            assert!(
                *v >= limits[j].0 - 1e-12 && *v <= limits[j].1 + 1e-12,
                "joint {j} at {v}"
            );
            if f > 0 {
                let step = (v - r.body.positions[(f - 1, j)]).abs();
                assert!(
                    step <= speed[j] * 0.025 + 1e-9,
                    "joint {j} moved {step} in one frame"
                );
            }
        }
        // Independent check: robot hand relative to its shoulder, in arm lengths, equals the
        // human's.
        let (rh, hh) = (relative_hands(&ra, &q), relative_hands(&ha, &qh));
        for s in 0..2 {
            if (rh[s] - hh[s]).norm() * ra.arms()[s].reach <= 0.005 {
                reached += 1;
            }
        }
    }
    let missed = 2 * ds.len() - reached;
    assert_eq!(
        missed,
        r.report.unreachable + r.report.velocity_limited + r.report.other_configuration,
        "{:?}",
        r.report
    );
    assert_eq!(reached, r.report.reached);
    // A fast tour (a key pose a second): the arm must change configuration on the way
    // overhead, which its velocity limits stretch over a few frames.
    assert!(
        reached as f64 >= 0.85 * (2 * ds.len()) as f64,
        "{:?}",
        r.report
    );
    assert_eq!(r.report.unreachable, 0);
}

#[test]
fn elbows_and_poses_cost_reach_but_match_more() {
    let ds = human_tour(&[0, 1, 2, 5, 0], 30);
    let run = |mode| {
        retarget(
            &ds,
            &coman(),
            &RetargetOptions {
                mode,
                ..Default::default()
            },
        )
        .unwrap()
        .remove(0)
    };
    let hands = run(Match::Hands);
    let elbows = run(Match::HandsAndElbows);
    let poses = run(Match::Poses);
    assert!(elbows.report.elbow_median_m.is_some() && hands.report.elbow_median_m.is_none());
    // The elbow task moves the elbows towards the human's (measured with the same yardstick).
    let anatomy = Anatomy::builtin("coman").unwrap();
    let robot = RobotArms::new("coman", &anatomy);
    let human = HumanArms::new(Robot::builtin("human").unwrap()).unwrap();
    let elbow_miss = |out: &Retargeted| -> f64 {
        let mut total = 0.0;
        for f in 0..ds.len() {
            let q: Vec<f64> = out.body.positions.row(f).iter().copied().collect();
            let qh: Vec<f64> = ds.human.positions.row(f).iter().copied().collect();
            let rel = human.relative(&qh);
            for (s, (arm, r)) in anatomy.arms().iter().zip(&rel).enumerate() {
                let qa = arm.chain.extract(&q).unwrap();
                let e = arm.chain.joint_origins(&qa)[arm.elbow];
                total += (e - robot.place(s, &r.elbow)).norm();
            }
        }
        total
    };
    assert!(
        elbow_miss(&elbows) < elbow_miss(&hands),
        "{} vs {}",
        elbow_miss(&elbows),
        elbow_miss(&hands)
    );
    assert!(elbows.report.worst_m.unwrap() <= 0.005);
    let o = poses.report.orientation_median_rad.unwrap();
    assert!(o < 0.05, "orientation median {o}");
}

#[test]
fn a_human_with_other_joints_is_refused() {
    let mut ds = human_tour(&[0, 1], 5);
    ds.human.joint_names[3] = "elbow".into();
    let e = retarget(&ds, &coman(), &RetargetOptions::default())
        .unwrap_err()
        .to_string();
    assert!(e.contains("\"elbow\""), "{e}");
}

#[test]
fn a_capture_too_short_for_a_test_block_trains_on_every_frame_and_says_why() {
    // 2.4 s at 40 Hz: one block of 4 s, where one in 4 would test.
    let mut ds = human_tour(&[0, 1, 2, 3], 32);
    assert_eq!(ds.len(), 96);
    let summary = split_into_blocks(&mut ds, &SplitOptions::default()).unwrap();
    assert_eq!((summary.blocks, summary.test_blocks), (1, 0));
    // A short capture keeps every frame it has, up to the 200 it should (not 1 in 12: 8).
    assert_eq!((summary.train_frames, summary.test_frames), (96, 0));
    assert_eq!(summary.train_step, 1);
    assert!(ds.test.is_empty() && ds.train == (0..96).collect::<Vec<_>>());
    let why = summary.fallback.expect("the fallback says why");
    assert!(
        why.contains("1 block of 4 s") && why.contains("`train` needs no test frames"),
        "{why}"
    );
    // The step as asked for when the lower bound is off.
    let mut ds = human_tour(&[0, 1, 2, 3], 32);
    let asked = SplitOptions {
        min_train_frames: 0,
        ..SplitOptions::default()
    };
    let summary = split_into_blocks(&mut ds, &asked).unwrap();
    assert_eq!((summary.train_frames, summary.train_step), (8, 12));
    // Asked for by name: no fallback to explain, every frame with a subsample of 1.
    let mut ds = human_tour(&[0, 1, 2, 3], 32);
    let summary = split_into_blocks(
        &mut ds,
        &SplitOptions {
            rule: SplitRule::AllTraining,
            train_subsample: 1,
            ..SplitOptions::default()
        },
    )
    .unwrap();
    assert_eq!(summary.fallback, None);
    assert_eq!((summary.train_frames, summary.test_frames), (96, 0));
    assert_eq!(ds.train.len(), 96);
    // Enough blocks: the split asked for, as before.
    let mut ds = human_tour(&[0, 1, 2, 3, 4, 5], 130);
    let summary = split_into_blocks(&mut ds, &SplitOptions::default()).unwrap();
    assert!(summary.fallback.is_none() && summary.test_frames > 0);
}

#[test]
fn blocks_split_with_guards_and_no_test_frame_in_training() {
    // Two files of 10 s and 6.2 s at 40 Hz.
    let mut ds = human_tour(&[0, 1, 2, 3, 4, 5], 130);
    let n = ds.len();
    ds.segments = vec![
        Segment {
            start: 0,
            end: 400,
            from_pose: None,
            to_pose: None,
            repetition: None,
            person: None,
        },
        Segment {
            start: 400,
            end: n,
            from_pose: None,
            to_pose: None,
            repetition: None,
            person: None,
        },
    ];
    let opts = SplitOptions {
        rule: SplitRule::Blocks { test_every: 2 },
        block_s: 4.0,
        guard_s: 0.5,
        train_subsample: 1,
        test_subsample: 1,
        min_train_frames: 0,
    };
    let summary = split_into_blocks(&mut ds, &opts).unwrap();
    // File 1: blocks 0–4 s, 4–10 s (the 2 s tail joins); file 2: 0–4 s, 4–6.2 s.
    assert_eq!(summary.blocks, 4, "{:?}", ds.segments);
    assert_eq!(
        ds.segments[1],
        Segment {
            start: 160,
            end: 400,
            from_pose: None,
            to_pose: None,
            repetition: None,
            person: None,
        }
    );
    assert_eq!(summary.test_blocks, 2);
    assert!(ds.test.iter().all(|f| (160..400).contains(f) || *f >= 560));
    // Guards: 0.5 s (20 frames) each side of the train/test boundaries inside a file.
    assert!(
        !ds.train.contains(&159)
            && !ds.test.contains(&160)
            && !ds.train.contains(&140)
            && ds.train.contains(&139)
    );
    assert_eq!(summary.guard_frames, 20 + 20 + 20 + 20);
    assert_eq!(
        summary.train_frames + summary.test_frames + summary.guard_frames,
        n
    );
    // By file, subsampled.
    let mut ds = human_tour(&[0, 1, 2, 3, 4, 5], 130);
    ds.segments = vec![
        Segment {
            start: 0,
            end: 400,
            from_pose: None,
            to_pose: None,
            repetition: None,
            person: None,
        },
        Segment {
            start: 400,
            end: n,
            from_pose: None,
            to_pose: None,
            repetition: None,
            person: None,
        },
    ];
    let opts = SplitOptions {
        rule: SplitRule::Files { test: vec![1] },
        train_subsample: 10,
        test_subsample: 2,
        min_train_frames: 0,
        ..SplitOptions::default()
    };
    split_into_blocks(&mut ds, &opts).unwrap();
    assert!(ds.test.iter().all(|f| *f >= 400) && ds.train.iter().all(|f| *f < 400));
    assert_eq!(ds.train.len(), 40);
    let mut ds = human_tour(&[0, 1, 2, 3, 4, 5], 130);
    ds.segments = vec![
        Segment {
            start: 0,
            end: 400,
            from_pose: None,
            to_pose: None,
            repetition: None,
            person: None,
        },
        Segment {
            start: 400,
            end: n,
            from_pose: None,
            to_pose: None,
            repetition: None,
            person: None,
        },
    ];
    let e = split_into_blocks(
        &mut ds,
        &SplitOptions {
            rule: SplitRule::Files { test: vec![0, 1] },
            ..SplitOptions::default()
        },
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("at least one must test and one train"), "{e}");
}
