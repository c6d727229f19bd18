//! Whole-arm retargeting's postures: the person's posture within limits and out of
//! self-collision, a function of the pose, live equal to file, the distances it is judged by,
//! and continuity where the person moves a little.

use super::*;
use crate::series::median;

/// The arm postures of a retargeted robot (left, right) at every frame, measured apart from
/// the code under test's targets: directions between its landmarks in its body frame.
fn robot_postures(anatomy: &Anatomy, out: &Retargeted) -> Vec<Vec<whole_arm::ArmPosture>> {
    let gauge = whole_arm::PostureGauge::of(anatomy);
    (0..out.body.positions.nrows())
        .map(|f| {
            let row: Vec<f64> = out.body.positions.row(f).iter().copied().collect();
            let q = anatomy.configuration(&out.body.joint_names, &row).unwrap();
            gauge.measure(anatomy, &q)
        })
        .collect()
}

#[test]
fn whole_arm_takes_the_person_s_posture_within_limits_and_out_of_self_collision() {
    // Through every key pose, hands meeting in front of the chest included.
    let ds = human_tour(&[0, 1, 5, 6, 14, 8, 4, 15, 0], 40);
    let limited = RetargetOptions {
        velocity_limits: true,
        ..RetargetOptions::default()
    };
    let out = retarget(&ds, &coman(), &limited).unwrap().remove(0);
    let report = out.report.posture.as_ref().unwrap();
    assert!(
        report.upper_arm_deg[0] < 10.0 && report.forearm_deg[0] < 10.0,
        "{report:?}"
    );
    // The hand's and the upper arm's orientations follow the person's turns.
    assert!(
        report.hand_orientation_deg[0] < 20.0 && report.upper_arm_orientation_deg[0] < 20.0,
        "{report:?}"
    );
    assert_eq!(report.colliding_frames, 0, "{report:?}");
    assert!(
        report.closest_m.is_none_or(|d| d > report.margin_m - 2e-3),
        "{report:?}"
    );
    assert!(report.pairs > 0 && report.unchecked.is_empty());
    // The robot's own postures measured here agree with the report's targets: the person's.
    let anatomy = Anatomy::builtin("coman").unwrap();
    let human = Anatomy::builtin("human").unwrap();
    let human_gauge = whole_arm::PostureGauge::of(&human);
    let got = robot_postures(&anatomy, &out);
    let mut errors = Vec::new();
    for (f, g) in got.iter().enumerate() {
        let q: Vec<f64> = ds.human.positions.row(f).iter().copied().collect();
        let want = human_gauge.measure(&human, &q);
        for s in 0..2 {
            errors.push(g[s].upper_arm.angle(&want[s].upper_arm).to_degrees());
        }
    }
    let median = crate::series::median(&mut errors);
    assert!(
        (median - report.upper_arm_deg[0]).abs() < 1e-6,
        "{median} vs {report:?}"
    );
    // Limits: positions within the URDF's, steps within the velocity limits.
    let limits = anatomy.robot().joint_limits();
    let speed = anatomy.robot().velocity_limits();
    let names = anatomy.robot().joint_names();
    let mut at_limit = [0usize; 14];
    for f in 0..ds.len() {
        for j in 0..14 {
            let v = out.body.positions[(f, j)];
            assert!(v >= limits[j].0 - 1e-9 && v <= limits[j].1 + 1e-9);
            if f > 0 {
                let step = (v - out.body.positions[(f - 1, j)]).abs();
                assert!(
                    step <= speed[j] * 0.025 + 1e-9,
                    "joint {j} frame {f}: {step}"
                );
                at_limit[j] += usize::from(step >= speed[j] * 0.025 - 1e-9);
            }
        }
    }
    // Which position limits the commands sat on: exactly the frames counted here.
    let mut on_bound = std::collections::BTreeMap::new();
    for f in 0..ds.len() {
        for j in 0..14 {
            let v = out.body.positions[(f, j)];
            for (upper, bound) in [(false, limits[j].0), (true, limits[j].1)] {
                if (v - bound).abs() <= whole_arm::AT_BOUND_RAD {
                    *on_bound.entry((names[j].clone(), upper)).or_insert(0usize) += 1;
                }
            }
        }
    }
    let reported: std::collections::BTreeMap<(String, bool), usize> = report
        .position_limited_joints
        .iter()
        .map(|b| ((b.joint.clone(), b.upper), b.frames))
        .collect();
    assert_eq!(reported, on_bound);
    assert_eq!(report.frames, ds.len());
    // The report says which velocity limits held how many frames: each joint it names moved
    // by its limit's whole step in at least those frames, and the frames add up to at least
    // the frames held by velocity.
    assert!(report.velocity_limited_frames > 0, "{report:?}");
    let mut most = 0;
    for h in &report.velocity_limited_joints {
        let j = names.iter().position(|n| *n == h.joint).unwrap();
        assert!(
            h.frames <= at_limit[j],
            "{h:?}: {} at the limit",
            at_limit[j]
        );
        assert_eq!(h.limit, speed[j]);
        most = most.max(h.frames);
    }
    assert!(most > 0 && most <= report.velocity_limited_frames + report.collision_limited_frames);
    // And which pairs the self-collision limit kept apart, each named once.
    for h in &report.collision_limited_pairs {
        assert!(h.frames > 0 && h.link_a < h.link_b, "{h:?}");
        assert!(h.closest_m < report.margin_m + 1.1e-3, "{h:?}");
    }
}

#[test]
fn whole_arm_posture_is_a_function_of_the_pose_not_of_the_path() {
    // A capture played forwards, and frame by frame in a shuffled order: the same pose, the
    // same posture, to the last digit (no frame starts from the one before).
    let forwards = human_tour(&[0, 1, 3, 4, 8, 9, 0], 30);
    let n = forwards.len();
    let order: Vec<usize> = (0..n).map(|i| (i * 37 + 11) % n).collect();
    assert_eq!(
        order
            .iter()
            .collect::<std::collections::BTreeSet<_>>()
            .len(),
        n,
        "a permutation"
    );
    let mut shuffled = forwards.clone();
    shuffled.human.positions = DMatrix::from_fn(order.len(), 18, |i, j| {
        forwards.human.positions[(order[i], j)]
    });
    shuffled.times_ns = (0..order.len() as i64)
        .map(|i| 1_000_000_000 + i * 25_000_000)
        .collect();
    shuffled.segments[0].end = order.len();
    shuffled.train = (0..order.len()).collect();
    // No velocity limit: the commands are the solutions themselves.
    let options = RetargetOptions {
        velocity_limits: false,
        ..RetargetOptions::default()
    };
    let a = retarget(&forwards, &coman(), &options).unwrap().remove(0);
    let b = retarget(&shuffled, &coman(), &options).unwrap().remove(0);
    let mut worst = 0.0_f64;
    for (i, &f) in order.iter().enumerate() {
        for j in 0..14 {
            worst = worst.max((a.body.positions[(f, j)] - b.body.positions[(i, j)]).abs());
        }
    }
    assert!(worst < 1e-9, "{}°", worst.to_degrees());
}

#[test]
fn a_frame_retargeted_alone_is_the_file_s_frame() {
    // Live retargeting (one frame at a time) gives each frame the posture the file's retargeting
    // gives it (without the self-collision step, which the live node's gate keeps itself).
    let tour = human_tour(&[0, 2, 5, 9, 0], 20);
    let mut options = RetargetOptions {
        velocity_limits: false,
        ..RetargetOptions::default()
    };
    options.whole_arm.self_collision = false;
    let robots = coman();
    let file = retarget(&tour, &robots, &options).unwrap().remove(0);
    let mut live = FrameRetargeter::new(&robots[0].1, &options).unwrap();
    let names = live.joint_names().to_vec();
    let column: Vec<usize> = names
        .iter()
        .map(|n| file.body.joint_names.iter().position(|m| m == n).unwrap())
        .collect();
    let mut out = vec![0.0; names.len()];
    let mut worst = 0.0_f64;
    for f in (0..tour.len()).rev() {
        let h: Vec<f64> = tour.human.positions.row(f).iter().copied().collect();
        live.retarget(&h, &mut out).unwrap();
        for (k, &c) in column.iter().enumerate() {
            worst = worst.max((out[k] - file.body.positions[(f, c)]).abs());
        }
    }
    assert!(worst < 1e-9, "{}°", worst.to_degrees());
    // A bad frame is an error, not a posture.
    let e = live.retarget(&[f64::NAN; 18], &mut out).unwrap_err();
    assert!(e.to_string().contains("finite"), "{e}");
    let e = live.retarget(&[0.0; 17], &mut out).unwrap_err();
    assert!(e.to_string().contains("expected 18"), "{e}");
}

#[test]
fn posture_distance_is_zero_for_one_posture_and_an_elbow_s_turn_for_the_forearm_alone() {
    let anatomy = Anatomy::builtin("walkman").unwrap();
    let names = anatomy.robot().joint_names();
    let elbow = names.iter().position(|n| n == "LElbj").unwrap();
    let mut a = anatomy.hold_configuration().to_vec();
    a[elbow] = -0.6;
    let distance = whole_arm::PostureDistance::new(&anatomy);
    for arm in distance.between(&a, &a) {
        assert!(
            arm.upper_arm_deg < 1e-6 && arm.forearm_deg < 1e-6,
            "{arm:?}"
        );
    }
    let mut b = a.clone();
    b[elbow] = -0.6 - 0.3;
    let [left, right] = distance.between(&a, &b)[..] else {
        panic!("two arms")
    };
    assert!(left.upper_arm_deg < 1e-6, "{left:?}");
    // The elbow's axis is (within a few thousandths of a degree) square to the forearm's bone
    // line: it turns by the joint's turn.
    assert!(
        (left.forearm_deg - 0.3f64.to_degrees()).abs() < 0.01,
        "{left:?}"
    );
    assert!(
        right.upper_arm_deg < 1e-9 && right.forearm_deg < 1e-9,
        "{right:?}"
    );
}

#[test]
fn person_distance_measures_what_retargeting_reports_and_the_person_s_own_arms_at_zero() {
    // The key-pose tour onto COMAN: the distance of each retargeted frame from the person, on
    // bone lines, has the medians retargeting's own report gives (the same measure, computed
    // apart from the solve).
    let tour = human_tour(&[0, 1, 4, 9, 13, 0], 20);
    let options = RetargetOptions {
        velocity_limits: false,
        ..RetargetOptions::default()
    };
    let robots = coman();
    let anatomy = &robots[0].1;
    let out = retarget(&tour, &robots, &options).unwrap().remove(0);
    let report = out.report.posture.as_ref().unwrap();
    let distance = whole_arm::PersonDistance::new(anatomy).unwrap();
    let (mut upper, mut fore) = (Vec::new(), Vec::new());
    for f in 0..tour.len() {
        let row: Vec<f64> = out.body.positions.row(f).iter().copied().collect();
        let q = anatomy.configuration(&out.body.joint_names, &row).unwrap();
        let h: Vec<f64> = tour.human.positions.row(f).iter().copied().collect();
        for arm in distance.between(&q, &h) {
            upper.push(arm.upper_arm_deg);
            fore.push(arm.forearm_deg);
        }
    }
    assert!((median(&mut upper) - report.upper_arm_deg[0]).abs() < 1e-9);
    assert!((median(&mut fore) - report.forearm_deg[0]).abs() < 1e-9);
    // The human model against itself: no distance.
    let human = Anatomy::builtin("human").unwrap();
    let own = whole_arm::PersonDistance::new(&human).unwrap();
    let q = solve_key_poses("human").unwrap().postures[9].clone();
    for arm in own.between(&q, &q) {
        assert!(
            arm.upper_arm_deg < 1e-6 && arm.forearm_deg < 1e-6,
            "{arm:?}"
        );
    }
}

#[test]
fn a_person_moving_a_little_moves_the_robot_a_little() {
    // The shipped captured motion onto COMAN, whose shoulder fits a raised arm two ways (turned
    // half round, one of them at its limits). Choosing per frame whichever fits a hair better
    // swung the shoulder by up to 3 rad between frames where the person moved < 0.2 rad, 46
    // times in this file; following each frame's path from the person's neutral leaves the
    // few places where the path itself meets a fold of the limits (3 here).
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../data/demos/captured.mcap"
    );
    let mut data = crate::dataset::load_demonstrations(path).unwrap();
    data.robots.clear();
    let options = RetargetOptions {
        velocity_limits: false,
        ..RetargetOptions::default()
    };
    let out = retarget(&data, &coman(), &options).unwrap().remove(0);
    let (h, y) = (&data.human.positions, &out.body.positions);
    let jumps = (1..data.len())
        .filter(|&f| data.segment_of(f).map(|s| s.start) == data.segment_of(f - 1).map(|s| s.start))
        .filter(|&f| (h.row(f) - h.row(f - 1)).norm() < 0.2)
        .filter(|&f| (y.row(f) - y.row(f - 1)).amax() > 1.0)
        .count();
    assert!(
        jumps <= 6,
        "{jumps} jumps of > 1 rad where the person moved < 0.2 rad"
    );
    // The report counts them too (each joint of the person within 0.3 rad, the command's
    // whole jump over 1 rad), and names the joints: counted here apart from it, on the commands
    // (those of the captured file are consecutive within each segment).
    let report = out.report.posture.as_ref().unwrap();
    let counted = (1..data.len())
        .filter(|&f| data.segment_of(f).map(|s| s.start) == data.segment_of(f - 1).map(|s| s.start))
        .filter(|&f| (h.row(f) - h.row(f - 1)).amax() < whole_arm::STILL_RAD)
        .filter(|&f| (y.row(f) - y.row(f - 1)).amax() > whole_arm::JUMP_RAD)
        .count();
    assert_eq!(report.jump_frames, counted);
    // Without velocity limits no frame is said to be held by one.
    assert_eq!(report.velocity_limited_frames, 0);
    assert_eq!(
        report
            .jumping_joints
            .iter()
            .map(|j| j.frames)
            .max()
            .unwrap_or(0)
            > 0,
        counted > 0
    );
}

#[test]
fn a_single_arm_follows_the_person_s_arm_of_its_side_as_one_of_two_would() {
    // COMAN with its right arm alone named: a single-arm robot driven by the person's right
    // arm, its left arm held. Its postures are the two-armed COMAN's right arm's, to what the
    // solver's shared trust region leaves between them.
    let both = Anatomy::builtin("coman").unwrap();
    let right = both.arm(crate::models::Side::Right).unwrap();
    let mut spec = crate::anatomy::AnatomySpec::default();
    spec.set_arm(&format!(
        "right={}:{}",
        right.chain.base(),
        right.chain.tip()
    ))
    .unwrap();
    let one = Anatomy::new(both.robot().clone(), &spec).unwrap();
    assert_eq!(one.arms().len(), 1);
    let tour = human_tour(&[0, 1, 4, 9, 13, 0], 20);
    let options = RetargetOptions {
        velocity_limits: false,
        ..RetargetOptions::default()
    };
    let robots = vec![
        ("coman".to_string(), both.clone()),
        ("coman_right".to_string(), one.clone()),
    ];
    let out = retarget(&tour, &robots, &options).unwrap();
    // The commands name the right arm alone: the left is held, never commanded.
    assert_eq!(out[1].body.joint_names, right.chain.joint_names().to_vec());
    let (d2, d1) = (
        whole_arm::PersonDistance::new(&both).unwrap(),
        whole_arm::PersonDistance::new(&one).unwrap(),
    );
    let (mut two_right, mut single) = (Vec::new(), Vec::new());
    for f in 0..tour.len() {
        let h: Vec<f64> = tour.human.positions.row(f).iter().copied().collect();
        let at = |k: usize, a: &Anatomy| {
            let row: Vec<f64> = out[k].body.positions.row(f).iter().copied().collect();
            a.configuration(&out[k].body.joint_names, &row).unwrap()
        };
        let q1 = at(1, &one);
        let angles = d1.between(&q1, &h);
        assert_eq!(angles.len(), 1);
        single.push(angles[0].upper_arm_deg);
        two_right.push(d2.between(&at(0, &both), &h)[1].upper_arm_deg);
    }
    let report = out[1].report.posture.as_ref().unwrap();
    assert!((median(&mut single.clone()) - report.upper_arm_deg[0]).abs() < 1e-9);
    let (m1, m2) = (median(&mut single), median(&mut two_right));
    assert!(
        m1 < 5.0 && (m1 - m2).abs() < 1.0,
        "single {m1}°, of two {m2}°"
    );
    assert_eq!(out[1].report.targets, tour.len());
}
