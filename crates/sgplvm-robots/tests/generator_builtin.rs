//! The generator on the shipped body models: reproducible files, IK that reaches the key
//! poses, joint limits, and the train/test split of Section IV-A.

use sgplvm_robots::dataset::load_demonstrations;
use sgplvm_robots::generator::{generate, generate_to_dir, GeneratorConfig, KEY_POSES, NEUTRAL};
use sgplvm_robots::{Robot, Side};

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
                let shoulder = robot
                    .forward_kinematics(&zero, &arm.shoulder_link)
                    .expect("shoulder")
                    .translation
                    .vector;
                let hand = robot
                    .forward_kinematics(q, &arm.hand_link)
                    .expect("hand")
                    .translation
                    .vector;
                let rel = if arm.side == Side::Left {
                    pose.left
                } else {
                    pose.right
                };
                let target = shoulder + arm.length * nalgebra::Vector3::from(rel);
                assert!(
                    (hand - target).norm() < 1e-4,
                    "{} {} {:?}: {} m off",
                    body.name,
                    pose.name,
                    arm.side,
                    (hand - target).norm()
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
