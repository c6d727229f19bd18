//! Our JSON encoding of `sensor_msgs/msg/JointState` in MCAP, as a foreign reader sees it: this
//! test writes a file with the JSON encoding (and, beside it, a CDR channel) and checks that it
//! is byte-identical to the committed `crates/sgplvm-py/tests/fixtures/sgplvm_json.mcap`, which
//! the Python `mcap` package decodes in `crates/sgplvm-py/tests/test_mcap_interop.py`
//! (`test_python_client_decodes_our_json_encoding`). A change of the encoding therefore fails
//! here until the fixture is regenerated (`SGPLVM_REGENERATE_FIXTURES=1 cargo test --release
//! --test mcap_json_fixture`) and then has to pass the foreign reader too.

use std::path::PathBuf;

use sgplvm_robots::joint_state::{
    read_joint_states, write_topics, Compression, JointStates, MessageEncoding, TopicData,
    WriteSettings,
};

/// Column multipliers that need every digit of a float64 (and its exponent) in JSON.
const SCALES: [f64; 4] = [1.0, 1e-300, -2.5e300, 1e-5];

/// The value of frame `k`, joint `j` (the Python test computes the same, correctly rounded).
fn value(k: usize, j: usize) -> f64 {
    (k as f64 + 1.0) / 3.0 * SCALES[j]
}

fn states(frames: usize, names: &[&str], t0: i64) -> JointStates {
    let cols = names.len();
    JointStates::new(
        (0..frames).map(|k| t0 + k as i64 * 25_000_000).collect(),
        names.iter().map(|s| s.to_string()).collect(),
        (0..frames * cols)
            .map(|i| value(i / cols, i % cols))
            .collect(),
    )
    .expect("valid joint states")
}

#[test]
fn our_json_encoding_matches_the_fixture_the_python_client_decodes() {
    let fixture = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("crates/sgplvm-py/tests/fixtures/sgplvm_json.mcap");
    // Stamps across a second boundary and before 1970 + 1 s (sec 0): both header fields used.
    let json = states(12, &["a", "b", "c", "d"], 999_900_000);
    let cdr = states(3, &["x", "y"], 2_000_000_000);
    let dir = std::env::temp_dir().join(format!("sgplvm-json-fixture-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let path = dir.join("sgplvm_json.mcap");
    write_topics(
        &path,
        &[
            TopicData {
                topic: "/json/joint_states",
                states: &json,
                encoding: MessageEncoding::Json,
            },
            TopicData {
                topic: "/cdr/joint_command",
                states: &cdr,
                encoding: MessageEncoding::Cdr,
            },
        ],
        &WriteSettings {
            compression: Compression::None,
            ..WriteSettings::default()
        },
    )
    .expect("write");
    // Our own reader first: the values survive bit for bit.
    let back = read_joint_states(&path, "/json/joint_states").expect("read back");
    assert_eq!(back, json);
    let written = std::fs::read(&path).expect("written");
    let _ = std::fs::remove_dir_all(&dir);
    if std::env::var_os("SGPLVM_REGENERATE_FIXTURES").is_some() {
        std::fs::write(&fixture, &written).expect("fixture written");
    }
    let committed = std::fs::read(&fixture).expect("committed fixture");
    assert!(
        committed == written,
        "our MCAP bytes changed: regenerate {} (SGPLVM_REGENERATE_FIXTURES=1) and run the Python \
         test that decodes it with the `mcap` package",
        fixture.display()
    );
}
