//! Files of format version 1 (written before the sparse model, #14) still load and predict
//! what they predicted when they were written.
//!
//! The fixture `fixtures/model_v1.sgplvm` and its predictions `fixtures/model_v1_predictions.json`
//! were written by this test with `SGPLVM_WRITE_V1_FIXTURE=1` at format version 1; never
//! regenerate them with a newer library.

use std::path::PathBuf;

use sgplvm_core::{Mat, ModelConfig, SharedGplvm, TrainOptions};

fn fixture(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("tests")
        .join("fixtures")
        .join(name)
}

fn data() -> (Mat<f64>, Mat<f64>) {
    let n = 24;
    let h = Mat::from_fn(n, 3, |i, j| ((i as f64) * 0.25 + j as f64).sin());
    let r = Mat::from_fn(n, 2, |i, j| ((i as f64) * 0.25 + 0.5 * j as f64).cos());
    (h, r)
}

#[test]
fn a_version_1_file_still_loads_and_predicts_as_written() {
    let (h, r) = data();
    if std::env::var_os("SGPLVM_WRITE_V1_FIXTURE").is_some() {
        assert_eq!(
            sgplvm_core::FORMAT_VERSION,
            1,
            "the fixture must be of version 1"
        );
        let config = ModelConfig::default().with_latent_dim(2);
        let options = TrainOptions::default().with_max_iters(20);
        let model = SharedGplvm::fit(
            &config,
            &[("human", h.as_ref()), ("robot", r.as_ref())],
            "human",
            &options,
            None,
        )
        .expect("fit");
        model.save(&fixture("model_v1.sgplvm")).expect("save");
        let p = model.predict(h.as_ref(), "robot", true).expect("predict");
        let v = p.variance.expect("variance");
        let mean: Vec<f64> = (0..h.nrows())
            .flat_map(|i| (0..2).map(move |j| (i, j)))
            .map(|(i, j)| p.mean[(i, j)])
            .collect();
        let var: Vec<f64> = (0..h.nrows()).map(|i| v[(i, 0)]).collect();
        let json = serde_json::json!({ "mean": mean, "variance": var });
        std::fs::write(fixture("model_v1_predictions.json"), json.to_string()).expect("write");
    }
    let bytes = std::fs::read(fixture("model_v1.sgplvm")).expect("fixture");
    assert_eq!(
        u32::from_le_bytes([bytes[8], bytes[9], bytes[10], bytes[11]]),
        1
    );
    let model = SharedGplvm::load(&fixture("model_v1.sgplvm")).expect("a version-1 file loads");
    let expected: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(fixture("model_v1_predictions.json")).expect("predictions"),
    )
    .expect("json");
    let p = model.predict(h.as_ref(), "robot", true).expect("predict");
    let v = p.variance.expect("variance");
    let close = |a: f64, b: f64| (a - b).abs() <= 1e-9 * (1.0 + b.abs());
    for i in 0..h.nrows() {
        for j in 0..2 {
            let e = expected["mean"][i * 2 + j].as_f64().expect("number");
            assert!(
                close(p.mean[(i, j)], e),
                "mean ({i}, {j}): {} vs {e}",
                p.mean[(i, j)]
            );
        }
        let e = expected["variance"][i].as_f64().expect("number");
        assert!(close(v[(i, 0)], e), "variance {i}: {} vs {e}", v[(i, 0)]);
    }
    let _ = r;
}
