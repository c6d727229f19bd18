//! A latent space per arm from the command line (issue 49): `train --parts arms` on generated
//! data, `transfer` and `predict` of the model it writes, `joints` of it, the commands that take
//! one shared latent space refusing it by name, bad flags refused, and `experiment --parts`
//! recording and judging the study.

use std::path::PathBuf;

mod common;
use common::{fails, fails_on_one_line, ok, s, scratch};

/// Generated demonstrations (every 24th training frame) in a scratch folder.
fn data(name: &str) -> (PathBuf, PathBuf) {
    let dir = scratch(name);
    ok(&["generate", "--out", s(&dir), "--subsample", "24"]);
    let data = dir.join("bimanual.mcap");
    (dir, data)
}

#[test]
fn train_transfer_and_predict_a_latent_space_per_arm() {
    let (dir, data) = data("parts-cli");
    let arms = dir.join("arms.sgp");
    let text = ok(&[
        "train",
        "--data",
        s(&data),
        "--robot",
        "walkman",
        "--parts",
        "arms",
        "--parent-latent-dim",
        "2",
        "--max-iters",
        "15",
        "--out",
        s(&arms),
    ]);
    assert!(
        text.contains("with a latent space per part (left_arm, right_arm; a parent of Q = 2)")
            && text.contains("  left_arm: ")
            && text.contains("  parent: "),
        "{text}"
    );
    let bytes = std::fs::read(&arms).unwrap();
    assert_eq!(u32::from_le_bytes(bytes[8..12].try_into().unwrap()), 4);
    let model = sgplvm::PartsGplvm::load(&arms).unwrap();
    assert_eq!(
        model.part_columns("left_arm", "walkman"),
        Some(&[0, 1, 2, 3, 4, 5, 6][..])
    );
    assert_eq!(
        model.part_columns("right_arm", "human").map(|c| c[0]),
        Some(9)
    );
    assert_eq!(model.parent().map(|p| p.config().latent_dim), Some(2));

    let coman = dir.join("arms-coman.sgp");
    let json = ok(&[
        "transfer",
        "--model",
        s(&arms),
        "--data",
        s(&data),
        "--robot",
        "coman",
        "--max-iters",
        "10",
        "--json",
        "--out",
        s(&coman),
    ]);
    let v: serde_json::Value = serde_json::from_str(&json).unwrap();
    assert_eq!(v["robots"], serde_json::json!(["walkman", "coman"]));
    assert!(v["parts"]["right_arm"]["iterations"].is_u64(), "{json}");
    assert!(
        v["parent"].is_null(),
        "the transfer trains no parent: {json}"
    );
    let joints = ok(&["joints", "--model", s(&coman)]);
    assert!(joints.contains("coman: LShSag,"), "{joints}");

    let human = dir.join("human.csv");
    ok(&[
        "export",
        "--data",
        s(&data),
        "--body",
        "human",
        "--out",
        s(&human),
    ]);
    let out = dir.join("coman.csv");
    ok(&[
        "predict",
        "--model",
        s(&coman),
        "--input",
        s(&human),
        "--robot",
        "coman",
        "--raw",
        "--out",
        s(&out),
    ]);
    let csv = std::fs::read_to_string(&out).unwrap();
    let first: Vec<f64> = csv
        .lines()
        .nth(1)
        .unwrap()
        .split(',')
        .map(|v| v.parse().unwrap())
        .collect();
    // The file predicts what the model does: each arm from its own human arm, the person's
    // clavicles aligned to the model's people as predict gives them (the first frame: its own
    // clavicles moved to the people's mean).
    let mut h: Vec<f64> = std::fs::read_to_string(&human)
        .unwrap()
        .lines()
        .nth(1)
        .unwrap()
        .split(',')
        .skip(1)
        .map(|v| v.parse().unwrap())
        .collect();
    let loaded = sgplvm::PartsGplvm::load(&coman).unwrap();
    sgplvm::girdle::for_model(&sgplvm::AnyModel::Parts(loaded.clone()))
        .expect("a model of the human's arms")
        .align(&mut h);
    let mut expected = vec![0.0; 14];
    loaded.predict_frame(&h, "coman", &mut expected).unwrap();
    for (a, b) in first[1..].iter().zip(&expected) {
        assert!((a - b).abs() < 1e-9, "{a} vs {b}");
    }

    refuses_what_a_per_arm_model_cannot_do(&dir, &data, &arms, &coman, &human);
}

/// What takes a per-arm model (evaluate, simulate), and what refuses it — transfer to a robot it
/// has, bad flags, a newer file — by name with nothing written.
fn refuses_what_a_per_arm_model_cannot_do(
    dir: &std::path::Path,
    data: &std::path::Path,
    arms: &std::path::Path,
    coman: &std::path::Path,
    human: &std::path::Path,
) {
    let out = dir.join("refused.csv");
    // evaluate takes it (each arm gating its own share of the pose), and so does simulate
    // (the prediction replayed within the robot's limits).
    let report = ok(&[
        "evaluate",
        "--model",
        s(coman),
        "--robot",
        "coman",
        "--data",
        s(data),
    ]);
    assert!(
        report.contains("coman: test MSE")
            && report.contains("gate (a latent space per part)")
            && report.contains("known *"),
        "{report}"
    );
    let replay = dir.join("replay.mcap");
    let summary = ok(&[
        "simulate",
        "--model",
        s(coman),
        "--input",
        s(human),
        "--robot",
        "coman",
        "--json",
        "--out",
        s(&replay),
    ]);
    let report: serde_json::Value = serde_json::from_str(&summary).unwrap();
    assert!(report["diverged"].is_null(), "{report}");
    assert_eq!(report["joints"].as_array().unwrap().len(), 14, "{report}");
    assert!(replay.exists());
    let e = fails_on_one_line(&[
        "transfer",
        "--model",
        s(arms),
        "--data",
        s(data),
        "--robot",
        "walkman",
        "--out",
        s(&out),
    ]);
    assert!(e.contains("already predicts for 'walkman'"), "{e}");
    let e = fails(
        &[
            "train",
            "--data",
            s(data),
            "--robot",
            "walkman",
            "--parts",
            "legs",
            "--out",
            s(&out),
        ],
        2,
    );
    assert!(
        e.contains("unknown body parts 'legs'; expected one of: arms"),
        "{e}"
    );
    let e = fails(
        &[
            "train",
            "--data",
            s(data),
            "--robot",
            "walkman",
            "--parent-latent-dim",
            "2",
            "--out",
            s(&out),
        ],
        2,
    );
    assert!(e.contains("--parts"), "{e}");
    let e = fails_on_one_line(&[
        "train",
        "--data",
        s(data),
        "--robot",
        "walkman",
        "--parts",
        "arms",
        "--urdf",
        "coman=x.urdf",
        "--out",
        s(&dir.join("never.sgp")),
    ]);
    assert!(
        e.contains("'coman' is not one of the robots trained on"),
        "{e}"
    );
    assert!(!dir.join("never.sgp").exists());
    // A file from a newer sgplvm.
    let mut newer = std::fs::read(coman).unwrap();
    newer[8..12].copy_from_slice(&5u32.to_le_bytes());
    let path = dir.join("newer.sgp");
    std::fs::write(&path, newer).unwrap();
    let e = fails_on_one_line(&[
        "predict",
        "--model",
        s(&path),
        "--input",
        s(human),
        "--robot",
        "coman",
        "--out",
        s(&out),
    ]);
    assert!(
        e.contains("newer.sgp") && e.contains("version 5 is not supported"),
        "{e}"
    );
}

#[test]
fn the_experiment_compares_a_latent_space_per_arm_on_recombined_motions() {
    let (dir, data) = data("parts-experiment");
    let out = dir.join("out");
    ok(&[
        "experiment",
        "--quick",
        "--parts",
        "--runs",
        "1",
        "--max-iters",
        "5",
        "--data",
        s(&data),
        "--out",
        s(&out),
    ]);
    let results: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("results.json")).unwrap()).unwrap();
    assert_eq!(results["config"]["parts"], true);
    let records = results["parts"].as_array().unwrap();
    // Per robot: both models trained, both transferred to the two others, two regressions.
    assert_eq!(records.len(), 3 * (2 + 2 * 2 + 2));
    for r in records {
        for key in ["test_mse", "recombined_test_mse", "recombined_train_mse"] {
            assert!(
                r[key].as_f64().is_some_and(|v| v.is_finite() && v > 0.0),
                "{r}"
            );
        }
        // Each arm from its own: the recombined test frames are the test frames' arms.
        if r["model"] == "parts" || r["model"] == "direct_per_arm" {
            let (a, b) = (
                r["test_mse"].as_f64().unwrap(),
                r["recombined_test_mse"].as_f64().unwrap(),
            );
            assert!((a - b).abs() <= 1e-9 * a, "{r}");
        }
    }
    let report = std::fs::read_to_string(out.join("report.md")).unwrap();
    assert!(
        report.contains("## A latent space per arm on recombined motions"),
        "{report:.300}"
    );
}
