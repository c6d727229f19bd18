//! Files written by a foreign client (the Python `mcap` + `mcap-ros2-support` packages, see
//! fixtures/mcap/make_fixtures.py) read by our reader, bit for bit.

use std::path::PathBuf;

use sgplvm_robots::dataset::{load_demonstrations, load_demonstrations_with, LoadOptions};
use sgplvm_robots::joint_state::{
    read_aligned, read_joint_states, read_topics, DemoError, TimeSource, TopicRequest,
};

fn fixture(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures/mcap")
        .join(name)
}

/// The fixture script's formula.
fn value(k: usize, j: usize, offset: f64) -> f64 {
    k as f64 * 0.25 - j as f64 * 0.125 + offset
}

#[test]
fn python_ros2_files_read_exactly_with_both_compressions() {
    for name in ["python_ros2_zstd.mcap", "python_ros2_lz4.mcap"] {
        let h = read_joint_states(fixture(name), "/human/joint_states").expect("human");
        assert_eq!(h.names, ["h0", "h1", "h2"]);
        assert_eq!(h.len(), 50);
        for k in 0..50 {
            assert_eq!(h.times_ns[k], 1_000_000_000 + k as i64 * 20_000_000);
            for j in 0..3 {
                assert_eq!(h.row(k)[j], value(k, j, 0.0), "{name} k={k} j={j}");
            }
        }
        // Robot joints stored as r1, extra, r0: asked for in model order r0, r1.
        let want = vec!["r0".to_string(), "r1".to_string()];
        let read = read_topics(
            fixture(name),
            &[TopicRequest::joints("/bot/joint_command", &want)],
        )
        .expect("robot");
        let r = &read.states[0];
        assert_eq!(r.names, want);
        for k in 0..40 {
            assert_eq!(r.row(k), &[value(k, 0, 100.0), value(k, 1, 100.0)]);
        }
        // The header stamps agree with the log times in this file.
        let mut by_stamp = TopicRequest::all("/human/joint_states");
        by_stamp.time_source = TimeSource::HeaderStamp;
        let s = read_topics(fixture(name), &[by_stamp]).expect("stamps");
        assert_eq!(s.states[0].times_ns, h.times_ns);
    }
}

#[test]
fn python_file_aligns_onto_forty_hertz_and_loads_as_a_foreign_dataset() {
    let path = fixture("python_ros2_zstd.mcap");
    let aligned = read_aligned(
        &path,
        &[
            TopicRequest::all("/human/joint_states"),
            TopicRequest::all("/bot/joint_command"),
        ],
        40.0,
    )
    .expect("aligned");
    // Human spans 0..980 ms, robot 0..975 ms: 40 frames at 25 ms.
    assert_eq!(aligned[0].len(), 40);
    // Human at 25 ms lies between its samples at 20 and 40 ms: a quarter of the way.
    let expect = value(1, 0, 0.0) + 0.25 * (value(2, 0, 0.0) - value(1, 0, 0.0));
    assert!((aligned[0].row(1)[0] - expect).abs() < 1e-12);
    assert_eq!(aligned[1].row(7)[0], value(7, 1, 100.0)); // robot's own clock: exact

    let ds = load_demonstrations(&path).expect("foreign dataset");
    assert_eq!(ds.len(), 40);
    assert_eq!(ds.human.joint_names, ["h0", "h1", "h2"]);
    assert_eq!(ds.robot_names(), ["bot"]);
    assert_eq!(ds.robots[0].joint_names, ["r1", "extra", "r0"]);
    assert_eq!(ds.segments.len(), 1);
    assert_eq!(ds.train.len(), 40);

    // With the robot model's joint order, the extra joint is dropped and r0, r1 reordered.
    let mut options = LoadOptions::default();
    options.joint_order.insert(
        "/bot/joint_command".into(),
        vec!["r0".to_string(), "r1".to_string()],
    );
    let ds = load_demonstrations_with(&path, &options).expect("ordered");
    assert_eq!(ds.robots[0].joint_names, ["r0", "r1"]);
    assert_eq!(ds.robots[0].positions[(7, 0)], value(7, 0, 100.0));
    assert_eq!(ds.robots[0].positions[(7, 1)], value(7, 1, 100.0));
}

#[test]
fn json_encoded_joint_states_read_exactly() {
    let s = read_joint_states(fixture("python_json.mcap"), "/json/joint_states").expect("json");
    assert_eq!(s.names, ["a", "b"]);
    for k in 0..10 {
        assert_eq!(s.row(k), &[value(k, 0, 0.0), value(k, 1, 0.0)]);
    }
}

#[test]
fn truncated_python_file_names_file_and_topic() {
    let bytes = std::fs::read(fixture("python_ros2_zstd.mcap")).expect("fixture");
    let dir = std::env::temp_dir().join(format!("sgplvm-interop-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("mkdir");
    let p = dir.join("half.mcap");
    std::fs::write(&p, &bytes[..bytes.len() * 2 / 3]).expect("write");
    let err = read_joint_states(&p, "/human/joint_states").unwrap_err();
    assert!(matches!(err, DemoError::Truncated { .. }), "{err}");
    let msg = err.to_string();
    assert!(
        msg.contains("half.mcap") && msg.contains("/human/joint_states"),
        "{msg}"
    );
    let _ = std::fs::remove_dir_all(dir);
}
