//! The generator on the shipped body models: reproducible files, IK that reaches the key
//! poses, joint limits, and the train/test split of Section IV-A.

use sgplvm_robots::dataset::load_demonstrations;
use sgplvm_robots::generator::{
    generate, generate_to_dir, generate_to_file, GeneratorConfig, KeyPose, FLEET_FILE_NAME,
    KEY_POSES, NEUTRAL,
};
use sgplvm_robots::{Arm, Robot, Side};

/// How far (m) `arm`'s hand at posture `q` is from `pose`'s target for it: the target relative
/// to the shoulder at the `zero` posture, in units of the arm's length.
fn hand_off_target(robot: &Robot, arm: &Arm, zero: &[f64], q: &[f64], pose: &KeyPose) -> f64 {
    let position = |q: &[f64], link: &str| {
        robot
            .forward_kinematics(q, link)
            .expect("link")
            .translation
            .vector
    };
    let rel = if arm.side == Side::Left {
        pose.left
    } else {
        pose.right
    };
    let target = position(zero, &arm.shoulder_link) + arm.length * nalgebra::Vector3::from(rel);
    (position(q, &arm.hand_link) - target).norm()
}

/// The configuration of `data/demos/fleet.mcap`: the paper's robots and the 6-joint `ur5e`.
fn fleet() -> GeneratorConfig {
    let mut config = GeneratorConfig::default();
    config.robots.push("ur5e".into());
    config
}

fn temp(tag: &str) -> std::path::PathBuf {
    let d = std::env::temp_dir().join(format!("sgplvm-gen-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

#[test]
fn generated_file_is_byte_identical_across_runs_and_loads_back_exactly() {
    let config = GeneratorConfig::default();
    let (a, b) = (temp("a"), temp("b"));
    let (pa, ga) = generate_to_dir(&config, &a).expect("first");
    let (pb, _) = generate_to_dir(&config, &b).expect("second");
    let bytes = std::fs::read(&pa).expect("read a");
    assert_eq!(
        bytes,
        std::fs::read(&pb).expect("read b"),
        "byte-identical regeneration"
    );
    assert!(bytes.len() < 4_000_000, "a few MB at most: {}", bytes.len());
    let loaded = load_demonstrations(&pa).expect("load");
    assert_eq!(loaded, ga.dataset);
    let _ = std::fs::remove_dir_all(a);
    let _ = std::fs::remove_dir_all(b);
}

#[test]
fn every_body_reaches_every_key_pose_within_limits() {
    let generated = generate(&GeneratorConfig::default()).expect("generate");
    let ds = &generated.dataset;
    assert_eq!(ds.human.positions.ncols(), 18);
    assert_eq!(ds.robot_names(), ["walkman", "coman", "centauro"]);
    for body in &generated.bodies {
        let robot = Robot::builtin(&body.name).expect("model");
        assert_eq!(body.reports.len(), 2 * KEY_POSES.len());
        let unreached: Vec<_> = body.unreached().collect();
        assert!(unreached.is_empty(), "{}: {unreached:?}", body.name);
        // The hands really are at the scaled targets (FK of the stored postures).
        let arms = robot.arms().expect("arms");
        let zero = robot.neutral_configuration();
        for (p, pose) in KEY_POSES.iter().enumerate() {
            let q = &body.postures[p];
            for arm in &arms {
                let off = hand_off_target(&robot, arm, &zero, q, pose);
                assert!(
                    off < 1e-4,
                    "{} {} {:?}: {} m off",
                    body.name,
                    pose.name,
                    arm.side,
                    off
                );
            }
        }
        // Every frame of every body within its joint limits.
        let data = if body.name == "human" {
            &ds.human
        } else {
            ds.robot(&body.name).expect("robot data")
        };
        for (j, (lo, hi)) in robot.joint_limits().iter().enumerate() {
            let col = data.positions.column(j);
            assert!(
                col.min() >= *lo && col.max() <= *hi,
                "{} joint {j}: [{}, {}] outside [{lo}, {hi}]",
                body.name,
                col.min(),
                col.max()
            );
        }
        // Postures stay natural and continuous (the IK posture task pulls towards neutral):
        // no wrapped-around joint, and on average a moderate change from the neutral posture.
        let moves: Vec<f64> = body
            .postures
            .iter()
            .map(|q| {
                q.iter()
                    .zip(&body.postures[NEUTRAL])
                    .map(|(a, b)| (a - b).abs())
                    .fold(0.0, f64::max)
            })
            .collect();
        let worst = moves.iter().cloned().fold(0.0, f64::max);
        let mean = moves.iter().sum::<f64>() / (moves.len() - 1) as f64;
        assert!(worst < 3.5, "{}: {worst} rad from neutral", body.name);
        assert!(mean < 1.5, "{}: mean {mean} rad from neutral", body.name);
    }
}

#[test]
fn default_split_sizes_follow_the_paper() {
    let ds = generate(&GeneratorConfig::default())
        .expect("generate")
        .dataset;
    assert!(
        (200..=300).contains(&ds.train.len()),
        "train {}",
        ds.train.len()
    );
    assert!(
        (200..=600).contains(&ds.test.len()),
        "test {}",
        ds.test.len()
    );
    assert!(ds.train.iter().all(|f| ds.test.binary_search(f).is_err()));
    // All 15 non-neutral poses appear as training targets.
    let mut targets: Vec<usize> = ds
        .train
        .iter()
        .filter_map(|&f| ds.segment_of(f).and_then(|s| s.to_pose))
        .collect();
    targets.sort();
    targets.dedup();
    assert_eq!(targets, (1..16).collect::<Vec<_>>());
}

#[test]
fn shipped_demonstrations_are_what_the_generator_makes_today() {
    let shipped =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/demos/bimanual.mcap");
    let dir = temp("shipped");
    let (fresh, _) = generate_to_dir(&GeneratorConfig::default(), &dir).expect("generate");
    let same = std::fs::read(&shipped).expect("data/demos/bimanual.mcap is shipped")
        == std::fs::read(&fresh).expect("fresh file");
    let _ = std::fs::remove_dir_all(dir);
    assert!(
        same,
        "data/demos/bimanual.mcap is stale: regenerate it with \
         `cargo run --release -p sgplvm-robots --example generate -- data/demos`"
    );
}

#[test]
fn a_fourth_robot_leaves_the_human_and_the_paper_robots_bit_identical() {
    let three = generate(&GeneratorConfig::default())
        .expect("three robots")
        .dataset;
    let four = generate(&fleet()).expect("four robots").dataset;
    assert_eq!(four.robot_names(), ["walkman", "coman", "centauro", "ur5e"]);
    let bits = |m: &nalgebra::DMatrix<f64>| m.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
    assert_eq!(three.times_ns, four.times_ns);
    assert_eq!(three.human.joint_names, four.human.joint_names);
    assert_eq!(bits(&three.human.positions), bits(&four.human.positions));
    for (a, b) in three.robots.iter().zip(&four.robots) {
        assert_eq!(
            (&a.name, &a.topic, &a.joint_names),
            (&b.name, &b.topic, &b.joint_names)
        );
        assert_eq!(bits(&a.positions), bits(&b.positions), "{}", a.name);
    }
    assert_eq!(three.pose_names, four.pose_names);
    assert_eq!(three.segments, four.segments);
    assert_eq!((&three.train, &three.test), (&four.train, &four.test));
    let ur = four.robot("ur5e").expect("ur5e");
    assert_eq!(ur.topic, "/ur5e/joint_command");
    assert_eq!(ur.positions.shape(), (four.len(), 12));
}

#[test]
fn ur5e_reaches_every_key_pose_within_its_limits() {
    let generated = generate(&fleet()).expect("generate");
    let body = generated
        .bodies
        .iter()
        .find(|b| b.name == "ur5e")
        .expect("ur5e solved");
    let robot = Robot::builtin("ur5e").expect("model");
    assert_eq!(body.reports.len(), 2 * KEY_POSES.len());
    let unreached: Vec<_> = body.unreached().collect();
    assert!(unreached.is_empty(), "{unreached:?}");
    // The hands are at the targets scaled by the UR5e's own arm length (FK of the postures).
    let arms = robot.arms().expect("arms");
    let zero = vec![0.0; 12];
    let mut worst: f64 = 0.0;
    for (p, pose) in KEY_POSES.iter().enumerate() {
        for arm in &arms {
            worst = worst.max(hand_off_target(&robot, arm, &zero, &body.postures[p], pose));
        }
    }
    assert!(worst < 1e-6, "{worst} m off");
    // Every command within the joint limits and the UR5e's 180°/s.
    let ds = &generated.dataset;
    let q = &ds.robot("ur5e").expect("ur5e data").positions;
    let velocity = robot.velocity_limits();
    for (j, &(lo, hi)) in robot.joint_limits().iter().enumerate() {
        let col = q.column(j);
        assert!(col.min() >= lo && col.max() <= hi, "joint {j}");
        let fastest = (1..q.nrows())
            .map(|k| (q[(k, j)] - q[(k - 1, j)]).abs() * GeneratorConfig::default().rate_hz)
            .fold(0.0, f64::max);
        assert!(fastest < velocity[j], "joint {j}: {fastest} rad/s");
    }
    // No wrapped-around joint: key postures within 3.5 rad of the neutral one.
    for q in &body.postures {
        for (a, b) in q.iter().zip(&body.postures[NEUTRAL]) {
            assert!((a - b).abs() < 3.5, "{a} vs {b}");
        }
    }
}

#[test]
fn shipped_fleet_demonstrations_are_what_the_generator_makes_today() {
    let shipped = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../data/demos")
        .join(FLEET_FILE_NAME);
    let dir = temp("fleet");
    let fresh = dir.join(FLEET_FILE_NAME);
    generate_to_file(&fleet(), &fresh).expect("generate");
    let same = std::fs::read(&shipped).expect("data/demos/fleet.mcap is shipped")
        == std::fs::read(&fresh).expect("fresh file");
    let _ = std::fs::remove_dir_all(dir);
    assert!(
        same,
        "data/demos/fleet.mcap is stale: regenerate it with `cargo run --release -p \
         sgplvm-robots --example generate -- data/demos walkman,coman,centauro,ur5e fleet.mcap`"
    );
}
