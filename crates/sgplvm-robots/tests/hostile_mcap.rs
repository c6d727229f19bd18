//! Hostile MCAP input (issue 13): corrupt length fields, corrupt compressed chunks, inserted
//! bytes, far-apart timestamps and huge joint lists must give a one-line typed error naming
//! the file without allocating beyond the stated bounds, never a panic or abort. Every input is
//! made here from a small valid file; nothing binary is committed. No test bounds wall-clock
//! time (the machines are shared).

use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::{Path, PathBuf};

use sgplvm_robots::dataset::load_demonstrations;
use sgplvm_robots::joint_state::{
    read_aligned, read_joint_states, read_topics, write_topics, Compression, JointStateError,
    JointStates, MessageEncoding, TopicData, TopicRequest, WriteSettings, DEFAULT_RATE_HZ,
};

/// A fresh directory, removed on drop.
struct TempDir(PathBuf);

impl TempDir {
    fn new(tag: &str) -> Self {
        let dir = std::env::temp_dir().join(format!("sgplvm-hostile-{tag}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).expect("create temp dir");
        Self(dir)
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

const TOPICS: [&str; 2] = ["/human/joint_states", "/walkman/joint_command"];

fn series(n: usize, joints: &[&str], t0: i64, dt: i64) -> JointStates {
    let times = (0..n as i64).map(|k| t0 + k * dt).collect();
    let pos = (0..n * joints.len())
        .map(|i| (i as f64 * 0.37).sin())
        .collect();
    JointStates::new(times, joints.iter().map(|s| s.to_string()).collect(), pos).expect("valid")
}

/// A small valid two-topic file.
fn small_file(path: &Path, compression: Compression, frames: usize) {
    let a = series(frames, &["a", "b", "c"], 1_000, 25_000_000);
    let b = series(frames, &["x", "y"], 2_000, 25_000_000);
    write_topics(
        path,
        &[
            TopicData {
                topic: TOPICS[0],
                states: &a,
                encoding: MessageEncoding::Cdr,
            },
            TopicData {
                topic: TOPICS[1],
                states: &b,
                encoding: MessageEncoding::Json,
            },
        ],
        &WriteSettings {
            compression,
            ..WriteSettings::default()
        },
    )
    .expect("write");
}

fn u64_at(b: &[u8], at: usize) -> u64 {
    u64::from_le_bytes(b[at..at + 8].try_into().expect("8 bytes"))
}

/// Byte offsets of every u64 length field of the file: each record's length, and inside each
/// chunk its uncompressed and compressed sizes (and, for uncompressed chunks, the lengths of
/// the records inside).
fn length_fields(b: &[u8]) -> Vec<usize> {
    fn walk(b: &[u8], mut i: usize, end: usize, out: &mut Vec<usize>) {
        while i + 9 <= end {
            let (op, len) = (b[i], u64_at(b, i + 1));
            out.push(i + 1);
            let body = i + 9;
            if op == 0x06 && body + 32 <= end {
                out.push(body + 16); // uncompressed size
                let clen = u32::from_le_bytes(b[body + 28..body + 32].try_into().expect("4"));
                let cs_at = body + 32 + clen as usize;
                if cs_at + 8 <= end {
                    out.push(cs_at); // compressed size
                    let compression = &b[body + 32..cs_at];
                    let records = cs_at + 8;
                    let size = u64_at(b, cs_at) as usize;
                    if compression.is_empty() && records + size <= end {
                        walk(b, records, records + size, out);
                    }
                }
            }
            if op == 0x02 {
                return; // footer
            }
            i = body + len as usize;
        }
    }
    let mut out = Vec::new();
    walk(b, 8, b.len(), &mut out);
    out
}

/// Runs `read` on `path` and checks the outcome: no panic, and an error is one plain line
/// naming the file. Returns whether it failed (true) or read the file (false).
fn check<T>(
    path: &Path,
    what: &str,
    read: impl FnOnce(&Path) -> Result<T, JointStateError>,
) -> bool {
    let outcome = catch_unwind(AssertUnwindSafe(|| read(path)));
    match outcome {
        Err(_) => panic!("{what}: the reader panicked on {}", path.display()),
        Ok(Ok(_)) => false,
        Ok(Err(e)) => {
            assert_one_line(&e, path, what);
            true
        }
    }
}

/// The message and every cause in its chain: one line each, no escape codes, no source paths,
/// the outermost naming the file.
fn assert_one_line(e: &JointStateError, path: &Path, what: &str) {
    let msg = e.to_string();
    if std::env::var_os("HOSTILE_PRINT").is_some() {
        eprintln!("{what}: {msg}");
    }
    let name = path
        .file_name()
        .and_then(|n| n.to_str())
        .expect("file name");
    assert!(
        msg.contains(name),
        "{what}: error does not name the file: {msg}"
    );
    assert!(
        !msg.trim_end().ends_with(':'),
        "{what}: the detail is empty: {msg}"
    );
    let mut cause: Option<&dyn std::error::Error> = Some(e);
    while let Some(c) = cause {
        let text = c.to_string();
        assert!(
            !text.contains('\n') && !text.contains('\u{1b}') && !text.contains(".rs:"),
            "{what}: not one plain line: {text:?}"
        );
        cause = c.source();
    }
}

fn read_all(path: &Path) -> Result<(), JointStateError> {
    read_topics(path, &TOPICS.map(TopicRequest::all)).map(|_| ())
}

fn load(path: &Path) -> Result<(), JointStateError> {
    load_demonstrations(path).map(|_| ())
}

#[test]
fn every_length_field_off_by_one_or_huge_gives_a_one_line_error() {
    let dir = TempDir::new("lengths");
    // Uncompressed chunks also without their CRC (0: not recorded), so that a changed length
    // inside a chunk reaches the record reader instead of the checksum.
    for (compression, zero_crcs) in [
        (Compression::None, false),
        (Compression::None, true),
        (Compression::Zstd, false),
    ] {
        let clean = dir.0.join(format!("clean-{compression:?}.mcap"));
        small_file(&clean, compression, 40);
        let mut bytes = std::fs::read(&clean).expect("read");
        if zero_crcs {
            let mut i = 8;
            while i + 9 <= bytes.len() && bytes[i] != 0x02 {
                if bytes[i] == 0x06 {
                    bytes[i + 9 + 24..i + 9 + 28].fill(0);
                }
                i += 9 + u64_at(&bytes, i + 1) as usize;
            }
        }
        let fields = length_fields(&bytes);
        assert!(
            fields.len() > 10,
            "{compression:?}: {} fields",
            fields.len()
        );
        let mut failed = 0;
        let mut tried = 0;
        for &at in &fields {
            let v = u64_at(&bytes, at);
            for new in [
                v.wrapping_add(1),
                v.wrapping_sub(1),
                1 << 62,
                1 << 63,
                u64::MAX,
            ] {
                let mut b = bytes.clone();
                b[at..at + 8].copy_from_slice(&new.to_le_bytes());
                let path = dir
                    .0
                    .join(format!("len-{compression:?}-{zero_crcs}-{at}-{new}.mcap"));
                std::fs::write(&path, &b).expect("write");
                let what = format!(
                    "{compression:?} (CRCs zeroed: {zero_crcs}): length at {at} set to {new}"
                );
                failed += usize::from(check(&path, &what, read_all));
                check(&path, &what, load);
                tried += 1;
                std::fs::remove_file(&path).expect("remove");
            }
        }
        assert!(
            failed * 2 > tried,
            "{compression:?}: only {failed} of {tried} rejected"
        );
    }
}

#[test]
fn corrupt_zstd_chunk_bytes_give_a_one_line_error() {
    let dir = TempDir::new("zstd");
    let clean = dir.0.join("clean.mcap");
    small_file(&clean, Compression::Zstd, 200);
    let bytes = std::fs::read(&clean).expect("read");
    // The first chunk's compressed data.
    let mut i = 8;
    while bytes[i] != 0x06 {
        i += 9 + u64_at(&bytes, i + 1) as usize;
    }
    let b0 = i + 9;
    let clen = u32::from_le_bytes(bytes[b0 + 28..b0 + 32].try_into().expect("4")) as usize;
    assert_eq!(&bytes[b0 + 32..b0 + 32 + clen], b"zstd");
    let data = b0 + 32 + clen + 8;
    let size = u64_at(&bytes, b0 + 32 + clen) as usize;
    let mut rejected = 0;
    for (k, at) in (data..data + size - 4).step_by(7).enumerate() {
        let mut b = bytes.clone();
        for (j, x) in b[at..at + 4].iter_mut().enumerate() {
            *x ^= 0xA5 ^ (k as u8).wrapping_mul(31).wrapping_add(j as u8);
        }
        let path = dir.0.join(format!("zstd-{at}.mcap"));
        std::fs::write(&path, &b).expect("write");
        rejected += usize::from(check(&path, &format!("zstd bytes at {at}"), read_all));
        std::fs::remove_file(&path).expect("remove");
    }
    assert!(rejected > 0);
}

#[test]
fn inserted_bytes_fail_fast() {
    let dir = TempDir::new("insert");
    let clean = dir.0.join("clean.mcap");
    small_file(&clean, Compression::None, 150);
    let bytes = std::fs::read(&clean).expect("read");
    for at in (8..bytes.len()).step_by(97) {
        let mut b = bytes.clone();
        b.splice(at..at, [0xff, 0xff, 0xff, 0x7f]);
        let path = dir.0.join(format!("insert-{at}.mcap"));
        std::fs::write(&path, &b).expect("write");
        check(&path, &format!("4 bytes inserted at {at}"), read_all);
        std::fs::remove_file(&path).expect("remove");
    }
}

#[test]
fn far_apart_timestamps_are_refused_before_aligning() {
    let dir = TempDir::new("far");
    let path = dir.0.join("far.mcap");
    let far = |joints: &[&str]| {
        let times = vec![0, 1_000_000_000_000_000];
        let pos = vec![0.0; 2 * joints.len()];
        JointStates::new(times, joints.iter().map(|s| s.to_string()).collect(), pos).expect("valid")
    };
    let (a, b) = (far(&["a", "b"]), far(&["x"]));
    write_topics(
        &path,
        &[
            TopicData {
                topic: TOPICS[0],
                states: &a,
                encoding: MessageEncoding::Cdr,
            },
            TopicData {
                topic: TOPICS[1],
                states: &b,
                encoding: MessageEncoding::Cdr,
            },
        ],
        &WriteSettings::default(),
    )
    .expect("write");
    let e = read_aligned(&path, &TOPICS.map(TopicRequest::all), DEFAULT_RATE_HZ)
        .expect_err("4e7 frames from 4 messages");
    assert!(matches!(e, JointStateError::TooManyFrames { .. }), "{e}");
    assert_one_line(&e, &path, "read_aligned");
    let e = load_demonstrations(&path).expect_err("the same through the dataset loader");
    assert!(matches!(e, JointStateError::TooManyFrames { .. }), "{e}");
    assert_one_line(&e, &path, "load_demonstrations");
}

#[test]
fn twenty_thousand_joint_names_are_read_back() {
    let dir = TempDir::new("names");
    let path = dir.0.join("names.mcap");
    let names: Vec<String> = (0..20_000).map(|j| format!("joint_{j}")).collect();
    let n = names.len();
    let s = JointStates::new(vec![0, 1], names, vec![0.5; 2 * n]).expect("valid");
    write_topics(
        &path,
        &[TopicData {
            topic: TOPICS[0],
            states: &s,
            encoding: MessageEncoding::Cdr,
        }],
        &WriteSettings::default(),
    )
    .expect("write");
    let read = read_joint_states(&path, TOPICS[0]).expect("read");
    assert_eq!(read.names, s.names);
}

/// An unchunked file with one JointState channel, a metadata record and one message, and the
/// offsets of its Schema, Channel and Metadata records.
fn unchunked(path: &Path) -> Vec<(u8, usize)> {
    let file = std::io::BufWriter::new(std::fs::File::create(path).expect("create"));
    let mut w = mcap::WriteOptions::new()
        .use_chunks(false)
        .create(file)
        .expect("writer");
    let sid = w
        .add_schema(
            "sensor_msgs/msg/JointState",
            "ros2msg",
            b"float64[] position",
        )
        .expect("schema");
    let mut meta = std::collections::BTreeMap::new();
    meta.insert("k".to_string(), "v".to_string());
    let ch = w
        .add_channel(sid, TOPICS[0], "cdr", &meta)
        .expect("channel");
    w.write_metadata(&mcap::records::Metadata {
        name: "m".into(),
        metadata: meta,
    })
    .expect("metadata");
    let header = mcap::records::MessageHeader {
        channel_id: ch,
        sequence: 0,
        log_time: 1,
        publish_time: 1,
    };
    w.write_to_known_channel(&header, &[0, 1, 0, 0])
        .expect("message");
    w.finish().expect("finish");
    drop(w);
    let b = std::fs::read(path).expect("read");
    let mut records = Vec::new();
    let mut i = 8;
    while i + 9 <= b.len() && b[i] != 0x02 {
        if matches!(b[i], 0x03 | 0x04 | 0x0c) {
            records.push((b[i], i + 9));
        }
        i += 9 + u64_at(&b, i + 1) as usize;
    }
    records
}

#[test]
fn string_lengths_inside_schema_channel_and_metadata_records_are_checked_before_parsing() {
    let dir = TempDir::new("strings");
    let clean = dir.0.join("clean.mcap");
    let records = unchunked(&clean);
    let ops: Vec<u8> = records.iter().map(|r| r.0).collect();
    assert!(
        ops.contains(&0x03) && ops.contains(&0x04) && ops.contains(&0x0c),
        "{ops:?}"
    );
    let bytes = std::fs::read(&clean).expect("read");
    for &(op, body) in &records {
        // The first string's length: after the id (Schema), the ids (Channel), at once (Metadata).
        let at = body
            + match op {
                0x03 => 2,
                0x04 => 4,
                _ => 0,
            };
        for len in [u32::MAX, 0xFFFF_FFF0, 1 << 31] {
            let mut b = bytes.clone();
            b[at..at + 4].copy_from_slice(&len.to_le_bytes());
            let path = dir.0.join(format!("str-{op}-{at}-{len}.mcap"));
            std::fs::write(&path, &b).expect("write");
            let what = format!("record {op:#04x}: string length {len}");
            assert!(check(&path, &what, read_all), "{what}: accepted");
            let e = read_topics(&path, &[]).expect_err("corrupt");
            assert!(matches!(e, JointStateError::Corrupt { .. }), "{e}");
            assert!(e.to_string().contains("declares"), "{e}");
            std::fs::remove_file(&path).expect("remove");
        }
    }
}
