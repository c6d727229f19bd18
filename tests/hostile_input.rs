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

/// The offset of the length field of the last record inside the first chunk of an MCAP
/// written without compression.
fn last_record_in_first_chunk(bytes: &[u8]) -> usize {
    let u64_at = |at: usize| u64::from_le_bytes(bytes[at..at + 8].try_into().expect("8 bytes"));
    let mut i = 8;
    while bytes[i] != 0x06 {
        i += 9 + u64_at(i + 1) as usize;
    }
    let body = i + 9;
    let clen = u32::from_le_bytes(bytes[body + 28..body + 32].try_into().expect("4")) as usize;
    assert_eq!(clen, 0, "an uncompressed chunk");
    let size = u64_at(body + 32) as usize;
    let (start, end) = (body + 40, body + 40 + size);
    let mut r = start;
    let mut last = None;
    while r < end {
        last = Some(r + 1);
        r += 9 + u64_at(r + 1) as usize;
    }
    assert_eq!(r, end, "the chunk's records fill it");
    last.expect("records in the chunk")
}

/// mcap 0.26 panics (an overflowing subtraction, checked in release builds too by the
/// workspace profile) on a record that claims more bytes than its uncompressed chunk holds when
/// the chunk has no CRC; the reader catches it. The user sees one line, not Rust's panic text.
#[test]
fn a_panic_caught_inside_the_mcap_reader_prints_one_line() {
    let dir = scratch("caught");
    let path = dir.join("caught.mcap");
    let states = JointStates::new(
        (0..40).map(|k| k * 25_000_000).collect(),
        vec!["j0".into(), "j1".into()],
        vec![0.1; 80],
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
            compression: Compression::None,
            ..WriteSettings::default()
        },
    )
    .expect("write");
    let mut bytes = std::fs::read(&path).expect("read");
    // The first chunk's CRC zeroed (not recorded), and its last record one byte longer.
    let mut i = 8;
    while bytes[i] != 0x06 {
        i += 9 + u64::from_le_bytes(bytes[i + 1..i + 9].try_into().expect("8")) as usize;
    }
    bytes[i + 9 + 24..i + 9 + 28].fill(0);
    let at = last_record_in_first_chunk(&bytes);
    let len = u64::from_le_bytes(bytes[at..at + 8].try_into().expect("8"));
    bytes[at..at + 8].copy_from_slice(&(len + 1).to_le_bytes());
    std::fs::write(&path, &bytes).expect("write");
    let err = fails_on_one_line(
        &["simulate", "--robot", "walkman", "--trajectory", s(&path)],
        &path,
    );
    assert!(err.contains("the mcap reader stopped"), "{err}");
    std::fs::remove_dir_all(&dir).ok();
}

/// The shipped demonstrations' first `n` human frames, and a model trained for two iterations.
fn human_frames_and_model(dir: &Path, n: usize) -> (JointStates, std::path::PathBuf) {
    let shipped = concat!(env!("CARGO_MANIFEST_DIR"), "/data/demos/bimanual.mcap");
    let all = sgplvm::robots::joint_state::read_joint_states(shipped, "/human/joint_states")
        .expect("shipped data");
    let d = all.names.len();
    let human = JointStates::new(
        all.times_ns[..n].to_vec(),
        all.names.clone(),
        all.positions[..n * d].to_vec(),
    )
    .expect("valid");
    let model = dir.join("m.sgp");
    common::ok(&[
        "train",
        "--robot",
        "walkman",
        "--max-iters",
        "2",
        "--validation",
        "none",
        "--out",
        s(&model),
    ]);
    (human, model)
}

/// A NaN in a human MCAP given to `predict` is refused naming the file, topic and joint (the
/// model's own check named only its space 'human').
#[test]
fn a_nan_in_a_human_mcap_names_the_file_and_joint() {
    let dir = scratch("nan-mcap");
    let (mut human, model) = human_frames_and_model(&dir, 12);
    let d = human.names.len();
    human.positions[3 * d + 2] = f64::NAN;
    let input = dir.join("human-nan.mcap");
    write_topics(
        &input,
        &[TopicData {
            topic: "/human/joint_states",
            states: &human,
            encoding: MessageEncoding::Cdr,
        }],
        &WriteSettings::default(),
    )
    .expect("write");
    let err = fails_on_one_line(
        &[
            "predict",
            "--model",
            s(&model),
            "--input",
            s(&input),
            "--robot",
            "walkman",
            "--out",
            s(&dir.join("o.csv")),
        ],
        &input,
    );
    let joint = &human.names[2];
    assert!(
        err.contains("topic /human/joint_states")
            && err.contains(&format!("joint '{joint}' is NaN in message 4")),
        "{err}"
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// A CSV whose times are negative predicts to CSV, but to MCAP (unsigned nanoseconds) it is
/// refused naming the output, the input and the frame — not "invalid data for joint states".
#[test]
fn negative_csv_times_into_an_mcap_output_name_both_files() {
    let dir = scratch("negative");
    let (human, model) = human_frames_and_model(&dir, 6);
    let d = human.names.len();
    let mut csv = format!("time,{}\n", human.names.join(","));
    for i in 0..human.len() {
        let row: Vec<String> = human.positions[i * d..(i + 1) * d]
            .iter()
            .map(|v| v.to_string())
            .collect();
        csv.push_str(&format!("{},{}\n", -1.0 + 0.025 * i as f64, row.join(",")));
    }
    let input = dir.join("negative.csv");
    std::fs::write(&input, &csv).expect("write");
    let out = dir.join("out.mcap");
    let args = |out: &Path| {
        vec![
            "predict".to_string(),
            "--model".into(),
            s(&model).into(),
            "--input".into(),
            s(&input).into(),
            "--robot".into(),
            "walkman".into(),
            "--out".into(),
            s(out).into(),
        ]
    };
    let mcap_args = args(&out);
    let argv: Vec<&str> = mcap_args.iter().map(String::as_str).collect();
    let err = fails_on_one_line(&argv, &out);
    assert!(
        err.contains("negative.csv") && err.contains("frame 1 ") && err.contains("-1 s"),
        "{err}"
    );
    assert!(!out.exists());
    let csv_out = dir.join("out.csv");
    let csv_args = args(&csv_out);
    let argv: Vec<&str> = csv_args.iter().map(String::as_str).collect();
    common::ok(&argv);
    // Streaming (teleoperation: CSV lines on stdin) into an MCAP: the same refusal, naming the
    // output and the line; the frames before it stay readable in the output.
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_sgplvm"))
        .args([
            "predict",
            "--model",
            s(&model),
            "--input",
            "-",
            "--robot",
            "walkman",
            "--out",
            s(&out),
        ])
        .stdin(std::process::Stdio::piped())
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("spawn");
    {
        use std::io::Write;
        let mut stdin = child.stdin.take().expect("stdin");
        let mut lines = csv.lines();
        let header = lines.next().expect("header");
        let rows: Vec<&str> = lines.collect();
        // Two frames at t ≥ 0, then the first row again (t = −1 s).
        let shift = |row: &str, t: f64| format!("{t},{}", row.split_once(',').expect("row").1);
        writeln!(
            stdin,
            "{header}\n{}\n{}\n{}",
            shift(rows[0], 0.0),
            shift(rows[1], 0.025),
            rows[0]
        )
        .expect("write");
    }
    let output = child.wait_with_output().expect("wait");
    assert_eq!(output.status.code(), Some(1));
    let err = String::from_utf8_lossy(&output.stderr);
    assert_eq!(err.trim_end().lines().count(), 1, "{err}");
    assert!(
        err.contains(s(&out)) && err.contains("line 4 of stdin") && err.contains("-1 s"),
        "{err}"
    );
    let kept = sgplvm::robots::joint_state::read_joint_states(&out, "/walkman/joint_command")
        .expect("the frames before the bad line");
    assert_eq!(kept.len(), 2);
    std::fs::remove_dir_all(&dir).ok();
}
