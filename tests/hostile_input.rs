//! The `sgplvm` program on hostile files (issue 13): a corrupt MCAP trajectory and a URDF
//! nested 25,000 levels deep must end with exit code 1 and one plain line naming the file,
//! never an abort, a stack overflow or a panic. The files are made by the test.

use std::path::Path;

mod common;
use common::{s, scratch, sgplvm};

use sgplvm::robots::joint_state::{
    write_topics, Compression, JointStates, MessageEncoding, TopicData, WriteSettings,
};

/// Runs a command that must fail cleanly; returns its stderr.
fn fails_on_one_line(args: &[&str], file: &Path) -> String {
    let out = sgplvm(args);
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert_eq!(out.status.code(), Some(1), "sgplvm {args:?}: {stderr}");
    assert_eq!(stderr.trim_end().lines().count(), 1, "{stderr}");
    assert!(
        !stderr.contains('\u{1b}') && !stderr.contains(".rs:"),
        "{stderr}"
    );
    assert!(!stderr.contains("panicked"), "{stderr}");
    let name = file.file_name().and_then(|n| n.to_str()).expect("name");
    assert!(stderr.contains(name), "{stderr}");
    stderr
}

#[test]
fn a_corrupt_record_length_in_a_trajectory_is_one_line() {
    let dir = scratch("mcap");
    let path = dir.join("trajectory.mcap");
    let names: Vec<String> = (0..3).map(|j| format!("j{j}")).collect();
    let states = JointStates::new(
        (0..40).map(|k| k * 25_000_000).collect(),
        names,
        vec![0.1; 120],
    )
    .expect("valid");
    write_topics(
        &path,
        &[TopicData {
            topic: "/walkman/joint_command",
            states: &states,
            encoding: MessageEncoding::Cdr,
        }],
        &WriteSettings {
            compression: Compression::Zstd,
            ..WriteSettings::default()
        },
    )
    .expect("write");
    let mut bytes = std::fs::read(&path).expect("read");
    // The first record after the magic is the header; its length field set to u64::MAX.
    bytes[9..17].copy_from_slice(&u64::MAX.to_le_bytes());
    std::fs::write(&path, &bytes).expect("write");
    let err = fails_on_one_line(
        &["simulate", "--robot", "walkman", "--trajectory", s(&path)],
        &path,
    );
    assert!(err.contains("corrupt MCAP record"), "{err}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_urdf_nested_25000_levels_is_one_line() {
    let dir = scratch("urdf");
    let urdf = dir.join("deep.urdf");
    let n = 25_000;
    let text = format!(
        "<robot name=\"deep\"><link name=\"base\">{}{}</link></robot>",
        "<a>".repeat(n),
        "</a>".repeat(n)
    );
    std::fs::write(&urdf, text).expect("write");
    let csv = dir.join("t.csv");
    std::fs::write(&csv, "time,j\n0,0\n0.025,0\n").expect("write");
    let err = fails_on_one_line(
        &["simulate", "--urdf", s(&urdf), "--trajectory", s(&csv)],
        &urdf,
    );
    assert!(err.contains("nest deeper than"), "{err}");
    std::fs::remove_dir_all(&dir).ok();
}
