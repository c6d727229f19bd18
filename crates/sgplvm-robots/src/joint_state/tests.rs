use super::*;
use std::collections::BTreeMap;
use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};

use ::mcap::records::MessageHeader;
use ::mcap::WriteOptions;
use std::sync::atomic::{AtomicUsize, Ordering};

/// A fresh directory under the system temp dir, removed on drop.
pub(super) struct TempDir(pub PathBuf);

impl TempDir {
    pub(super) fn new(tag: &str) -> Self {
        static COUNTER: AtomicUsize = AtomicUsize::new(0);
        let n = COUNTER.fetch_add(1, Ordering::Relaxed);
        let dir = std::env::temp_dir().join(format!("sgplvm-js-{tag}-{}-{n}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).expect("create temp dir");
        Self(dir)
    }
    pub(super) fn file(&self, name: &str) -> PathBuf {
        self.0.join(name)
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

pub(super) fn names(list: &[&str]) -> Vec<String> {
    list.iter().map(|s| s.to_string()).collect()
}

pub(super) fn sample(n: usize, joints: &[&str], t0: i64, dt: i64, phase: f64) -> JointStates {
    let d = joints.len();
    let times = (0..n as i64).map(|k| t0 + k * dt).collect();
    let mut pos = Vec::with_capacity(n * d);
    for k in 0..n {
        for j in 0..d {
            // Values with full mantissas so that any rounding would show.
            pos.push((k as f64 * 0.1 + j as f64 + phase).sin() * std::f64::consts::E);
        }
    }
    JointStates::new(times, names(joints), pos).expect("valid")
}

#[test]
fn round_trip_is_bit_exact_for_every_compression_and_encoding() {
    let dir = TempDir::new("rt");
    let states = sample(300, &["a", "b", "c"], 1_000, 25_000_000, 0.3);
    for compression in [Compression::Zstd, Compression::Lz4, Compression::None] {
        for encoding in [MessageEncoding::Cdr, MessageEncoding::Json] {
            let path = dir.file(&format!("{compression:?}-{encoding:?}.mcap"));
            write_topics(
                &path,
                &[TopicData {
                    topic: "/x/joint_states",
                    states: &states,
                    encoding,
                }],
                &WriteSettings {
                    compression,
                    metadata: vec![],
                },
            )
            .expect("write");
            let back = read_joint_states(&path, "/x/joint_states").expect("read");
            assert_eq!(back.times_ns, states.times_ns);
            assert_eq!(back.names, states.names);
            let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&back.positions), bits(&states.positions));
        }
    }
}

#[test]
fn writing_is_deterministic_and_leaves_no_temporary_file() {
    let dir = TempDir::new("det");
    let s = sample(100, &["a", "b"], 0, 25_000_000, 0.0);
    let (p1, p2) = (dir.file("1.mcap"), dir.file("2.mcap"));
    write_joint_states(&p1, "/t", &s, Compression::Zstd).expect("write 1");
    write_joint_states(&p2, "/t", &s, Compression::Zstd).expect("write 2");
    let b1 = std::fs::read(&p1).expect("read 1");
    assert_eq!(b1, std::fs::read(&p2).expect("read 2"));
    assert!(b1.windows(6).any(|w| w == b"sgplvm"), "library string");
    let entries: Vec<_> = std::fs::read_dir(&dir.0).expect("ls").collect();
    assert_eq!(entries.len(), 2, "no temporary files remain");
}

#[test]
fn writing_into_a_missing_directory_fails_cleanly() {
    let dir = TempDir::new("nodir");
    let s = sample(3, &["a"], 0, 1, 0.0);
    let err =
        write_joint_states(dir.file("missing/out.mcap"), "/t", &s, Compression::None).unwrap_err();
    assert!(matches!(err, DemoError::Io { .. }), "{err}");
    assert!(err.to_string().contains("out.mcap"), "{err}");
    assert!(!err.to_string().contains(".tmp"), "{err}");
}

/// The id of a process that has exited (and been reaped).
fn dead_pid() -> u32 {
    let mut child = std::process::Command::new("true")
        .spawn()
        .expect("spawn true");
    let pid = child.id();
    child.wait().expect("wait");
    pid
}

#[test]
fn a_killed_writers_temporary_is_removed_by_the_next_write() {
    let dir = TempDir::new("stale");
    let target = dir.file("out.mcap");
    let dead = dead_pid();
    let stale = dir.file(&format!(".out.mcap.tmp{dead}"));
    let stale_other_form = dir.file(&format!(".tmp-{dead}-out.mcap"));
    // A writer that still runs (pid 1), another target's temporary, an unrelated file.
    let live = dir.file(".out.mcap.tmp1");
    let other = dir.file(&format!(".other.mcap.tmp{dead}"));
    let unrelated = dir.file("out.mcap.tmp-notes");
    for p in [&stale, &stale_other_form, &live, &other, &unrelated] {
        std::fs::write(p, b"half a file").expect("write");
    }
    let s = sample(10, &["a"], 0, 25_000_000, 0.0);
    write_joint_states(&target, "/t", &s, Compression::Zstd).expect("write");
    assert!(target.exists());
    assert!(
        !stale.exists() && !stale_other_form.exists(),
        "stale temporaries left"
    );
    for kept in [&live, &other, &unrelated] {
        assert!(kept.exists(), "{} removed", kept.display());
    }
}

#[test]
fn requested_joint_order_is_applied_and_extra_joints_ignored() {
    let dir = TempDir::new("order");
    let path = dir.file("o.mcap");
    let s = sample(10, &["x", "y", "z", "extra"], 0, 10, 0.0);
    write_joint_states(&path, "/r", &s, Compression::Lz4).expect("write");
    let want = names(&["z", "x"]);
    let read = read_topics(&path, &[TopicRequest::joints("/r", &want)]).expect("read");
    let got = &read.states[0];
    assert_eq!(got.names, want);
    for k in 0..10 {
        assert_eq!(got.row(k), &[s.row(k)[2], s.row(k)[0]]);
    }
    let err = read_topics(
        &path,
        &[TopicRequest::joints("/r", &names(&["x", "w", "v"]))],
    )
    .unwrap_err();
    match &err {
        DemoError::MissingJoints { topic, missing, .. } => {
            assert_eq!(topic, "/r");
            assert_eq!(missing, &names(&["w", "v"]));
        }
        other => panic!("unexpected {other}"),
    }
    assert!(err.to_string().contains("o.mcap"));
}

#[test]
fn messages_with_changing_joint_order_are_reordered() {
    // Two channels on the same topic with different joint orders (e.g. a recording that was
    // split and re-merged): rows must come back in the first message's order.
    let dir = TempDir::new("reorder");
    let path = dir.file("r.mcap");
    let file = File::create(&path).expect("create");
    let mut w = WriteOptions::new()
        .profile("ros2")
        .create(BufWriter::new(file))
        .expect("writer");
    let sid = w
        .add_schema(JOINT_STATE_SCHEMA, "ros2msg", JOINT_STATE_MSGDEF.as_bytes())
        .expect("schema");
    let ch = w
        .add_channel(sid, "/j", "cdr", &BTreeMap::new())
        .expect("ch");
    let mut buf = Vec::new();
    let layouts = [
        (names(&["a", "b"]), [1.0, 2.0]),
        (names(&["b", "a"]), [4.0, 3.0]),
    ];
    for (i, (n, p)) in layouts.iter().enumerate() {
        cdr::encode_joint_state(&mut buf, (0, 0), "", n, p, &[], &[]);
        let h = MessageHeader {
            channel_id: ch,
            sequence: i as u32,
            log_time: i as u64 * 10,
            publish_time: 0,
        };
        w.write_to_known_channel(&h, &buf).expect("msg");
    }
    w.finish().expect("finish");
    drop(w);
    let s = read_joint_states(&path, "/j").expect("read");
    assert_eq!(s.names, names(&["a", "b"]));
    assert_eq!(s.positions, vec![1.0, 2.0, 3.0, 4.0]);
}

#[test]
fn multiple_topics_are_interleaved_by_time_and_read_independently() {
    let dir = TempDir::new("multi");
    let path = dir.file("m.mcap");
    let a = sample(40, &["h1", "h2"], 5, 25_000_000, 0.0);
    let b = sample(30, &["r1"], 0, 33_333_333, 1.0);
    write_topics(
        &path,
        &[
            TopicData {
                topic: "/human/joint_states",
                states: &a,
                encoding: MessageEncoding::Cdr,
            },
            TopicData {
                topic: "/robot/joint_command",
                states: &b,
                encoding: MessageEncoding::Json,
            },
        ],
        &WriteSettings::default(),
    )
    .expect("write");
    let read = read_topics(
        &path,
        &[
            TopicRequest::all("/robot/joint_command"),
            TopicRequest::all("/human/joint_states"),
        ],
    )
    .expect("read");
    assert_eq!(read.states[0], b);
    assert_eq!(read.states[1], a);
    assert_eq!(read.channels.len(), 2);
    assert_eq!(read.channels[1].message_encoding, "json");
}

fn write_good(path: &Path) -> JointStates {
    let s = sample(2000, &["a", "b", "c"], 0, 25_000_000, 0.0);
    write_joint_states(path, "/good", &s, Compression::Zstd).expect("write");
    s
}

#[test]
fn a_truncated_file_is_an_error_naming_file_and_topic() {
    let dir = TempDir::new("trunc");
    let path = dir.file("full.mcap");
    write_good(&path);
    let bytes = std::fs::read(&path).expect("read");
    for cut in [bytes.len() - 1, bytes.len() - 30, bytes.len() / 2, 100, 10] {
        let p = dir.file("cut.mcap");
        std::fs::write(&p, &bytes[..cut]).expect("write cut");
        let err = read_joint_states(&p, "/good").unwrap_err();
        assert!(
            matches!(err, DemoError::Truncated { .. } | DemoError::Mcap { .. }),
            "cut {cut}: {err}"
        );
        let msg = err.to_string();
        assert!(msg.contains("cut.mcap") && msg.contains("/good"), "{msg}");
    }
    let p = dir.file("cut.mcap");
    std::fs::write(&p, &bytes[..bytes.len() / 2]).expect("write cut");
    assert!(matches!(
        read_joint_states(&p, "/good").unwrap_err(),
        DemoError::Truncated { .. }
    ));
}

/// Writes a one-message channel with the given schema and encodings.
fn write_custom(path: &Path, schema: Option<(&str, &str)>, encoding: &str) {
    let file = File::create(path).expect("create");
    let mut w = WriteOptions::new()
        .create(BufWriter::new(file))
        .expect("writer");
    let sid = match schema {
        Some((name, enc)) => w.add_schema(name, enc, b"whatever").expect("schema"),
        None => 0,
    };
    let ch = w
        .add_channel(sid, "/t", encoding, &BTreeMap::new())
        .expect("ch");
    let mut buf = Vec::new();
    cdr::encode_joint_state(&mut buf, (0, 0), "", &names(&["a"]), &[1.0], &[], &[]);
    let h = MessageHeader {
        channel_id: ch,
        sequence: 0,
        log_time: 1,
        publish_time: 1,
    };
    w.write_to_known_channel(&h, &buf).expect("msg");
    w.finish().expect("finish");
}

#[test]
fn wrong_schema_wrong_encoding_and_missing_topic_are_distinct_errors() {
    let dir = TempDir::new("bad");
    let p = dir.file("bad.mcap");

    write_custom(&p, Some(("sensor_msgs/msg/Imu", "ros2msg")), "cdr");
    let err = read_joint_states(&p, "/t").unwrap_err();
    assert!(matches!(err, DemoError::WrongSchema { .. }), "{err}");
    assert!(err.to_string().contains("sensor_msgs/msg/Imu") && err.to_string().contains("`/t`"));

    write_custom(&p, Some((JOINT_STATE_SCHEMA, "ros1msg")), "cdr");
    assert!(matches!(
        read_joint_states(&p, "/t").unwrap_err(),
        DemoError::WrongSchema { .. }
    ));

    write_custom(&p, Some((JOINT_STATE_SCHEMA, "ros2msg")), "protobuf");
    let err = read_joint_states(&p, "/t").unwrap_err();
    assert!(matches!(err, DemoError::WrongEncoding { .. }), "{err}");
    assert!(err.to_string().contains("protobuf") && err.to_string().contains("bad.mcap"));

    write_custom(&p, Some((JOINT_STATE_SCHEMA, "ros2msg")), "cdr");
    assert_eq!(
        read_joint_states(&p, "/t").expect("good").positions,
        vec![1.0]
    );
    let err = read_joint_states(&p, "/nope").unwrap_err();
    match &err {
        DemoError::MissingTopic {
            topic, available, ..
        } => {
            assert_eq!(topic, "/nope");
            assert_eq!(available, &names(&["/t"]));
        }
        other => panic!("unexpected {other}"),
    }

    // JSON schema-less channel whose payload is CDR: a malformed-message error.
    write_custom(&p, None, "json");
    let err = read_joint_states(&p, "/t").unwrap_err();
    assert!(
        matches!(err, DemoError::Malformed { index: 0, .. }),
        "{err}"
    );

    std::fs::write(&p, b"not an mcap at all").expect("write");
    let err = read_joint_states(&p, "/t").unwrap_err();
    assert!(err.to_string().contains("bad.mcap"), "{err}");
    let err = read_joint_states(dir.file("absent.mcap"), "/t").unwrap_err();
    assert!(matches!(err, DemoError::Io { .. }), "{err}");
}

#[test]
fn metadata_records_are_returned() {
    let dir = TempDir::new("meta");
    let p = dir.file("m.mcap");
    let s = sample(5, &["a"], 0, 1, 0.0);
    let mut map = BTreeMap::new();
    map.insert("k".to_string(), "v".to_string());
    write_topics(
        &p,
        &[TopicData {
            topic: "/a",
            states: &s,
            encoding: MessageEncoding::Cdr,
        }],
        &WriteSettings {
            compression: Compression::None,
            metadata: vec![("my.meta".into(), map.clone())],
        },
    )
    .expect("write");
    let read = read_topics(&p, &[]).expect("read");
    assert_eq!(read.metadata.get("my.meta"), Some(&map));
    assert_eq!(list_channels(&p).expect("list")[0].topic, "/a");
}

#[test]
fn header_stamps_can_place_messages_on_the_clock() {
    let dir = TempDir::new("stamp");
    let p = dir.file("s.mcap");
    let file = File::create(&p).expect("create");
    let mut w = WriteOptions::new()
        .create(BufWriter::new(file))
        .expect("writer");
    let sid = w
        .add_schema(JOINT_STATE_SCHEMA, "ros2msg", JOINT_STATE_MSGDEF.as_bytes())
        .expect("schema");
    let ch = w
        .add_channel(sid, "/j", "cdr", &BTreeMap::new())
        .expect("ch");
    let mut buf = Vec::new();
    for (i, stamp) in [(5, 250_000_000u32), (5, 500_000_000)].iter().enumerate() {
        cdr::encode_joint_state(&mut buf, *stamp, "", &names(&["a"]), &[i as f64], &[], &[]);
        let h = MessageHeader {
            channel_id: ch,
            sequence: 0,
            log_time: 100 + i as u64,
            publish_time: 0,
        };
        w.write_to_known_channel(&h, &buf).expect("msg");
    }
    w.finish().expect("finish");
    drop(w);
    let mut req = TopicRequest::all("/j");
    assert_eq!(
        read_topics(&p, &[req.clone()]).expect("log").states[0].times_ns,
        vec![100, 101]
    );
    req.time_source = TimeSource::HeaderStamp;
    assert_eq!(
        read_topics(&p, &[req]).expect("stamp").states[0].times_ns,
        vec![5_250_000_000, 5_500_000_000]
    );
}

#[test]
fn empty_topics_are_an_error_and_unrequested_foreign_topics_are_skipped() {
    let dir = TempDir::new("empty");
    let p = dir.file("e.mcap");
    let empty = JointStates::new(vec![], names(&["a"]), vec![]).expect("empty");
    write_joint_states(&p, "/quiet", &empty, Compression::Zstd).expect("write");
    let err = read_joint_states(&p, "/quiet").unwrap_err();
    assert!(matches!(err, DemoError::EmptyTopic { .. }), "{err}");
    assert!(err.to_string().contains("/quiet") && err.to_string().contains("e.mcap"));

    // An Imu channel next to a JointState one: only the requested topic is decoded.
    let q = dir.file("mixed.mcap");
    let file = File::create(&q).expect("create");
    let mut w = WriteOptions::new()
        .create(BufWriter::new(file))
        .expect("writer");
    let imu = w
        .add_schema("sensor_msgs/msg/Imu", "ros2msg", b"...")
        .expect("imu schema");
    let js = w
        .add_schema(JOINT_STATE_SCHEMA, "ros2msg", JOINT_STATE_MSGDEF.as_bytes())
        .expect("js schema");
    let imu_ch = w
        .add_channel(imu, "/imu", "cdr", &BTreeMap::new())
        .expect("imu ch");
    let js_ch = w
        .add_channel(js, "/joints", "cdr", &BTreeMap::new())
        .expect("js ch");
    let mut buf = Vec::new();
    for k in 0..5u64 {
        let h = MessageHeader {
            channel_id: imu_ch,
            sequence: 0,
            log_time: k,
            publish_time: k,
        };
        w.write_to_known_channel(&h, b"\x00\x01\x00\x00garbage")
            .expect("imu msg");
        cdr::encode_joint_state(&mut buf, (0, 0), "", &names(&["a"]), &[k as f64], &[], &[]);
        let h = MessageHeader {
            channel_id: js_ch,
            sequence: 0,
            log_time: k,
            publish_time: k,
        };
        w.write_to_known_channel(&h, &buf).expect("js msg");
    }
    w.finish().expect("finish");
    drop(w);
    let s = read_joint_states(&q, "/joints").expect("joints");
    assert_eq!(s.positions, vec![0.0, 1.0, 2.0, 3.0, 4.0]);
    assert!(matches!(
        read_joint_states(&q, "/imu").unwrap_err(),
        DemoError::WrongSchema { .. }
    ));
}

#[test]
fn a_negative_header_stamp_is_an_error_naming_file_topic_and_message() {
    let dir = TempDir::new("negstamp");
    let p = dir.file("neg.mcap");
    let file = File::create(&p).expect("create");
    let mut w = WriteOptions::new()
        .create(BufWriter::new(file))
        .expect("writer");
    let sid = w
        .add_schema(JOINT_STATE_SCHEMA, "ros2msg", JOINT_STATE_MSGDEF.as_bytes())
        .expect("schema");
    let ch = w
        .add_channel(sid, "/j", "cdr", &BTreeMap::new())
        .expect("ch");
    let mut buf = Vec::new();
    for (i, stamp) in [(1, 0u32), (-3, 5)].iter().enumerate() {
        cdr::encode_joint_state(&mut buf, *stamp, "", &names(&["a"]), &[1.0], &[], &[]);
        let h = MessageHeader {
            channel_id: ch,
            sequence: 0,
            log_time: 100 + i as u64,
            publish_time: 0,
        };
        w.write_to_known_channel(&h, &buf).expect("msg");
    }
    w.finish().expect("finish");
    drop(w);
    let mut req = TopicRequest::all("/j");
    req.time_source = TimeSource::HeaderStamp;
    let e = read_topics(&p, &[req]).expect_err("negative stamp");
    assert!(
        matches!(e, JointStateError::Malformed { index: 1, .. }),
        "{e}"
    );
    let msg = e.to_string();
    assert!(
        msg.contains("neg.mcap") && msg.contains("`/j`") && msg.contains("-3 s"),
        "{msg}"
    );
}

#[test]
fn long_joint_lists_are_shortened_in_messages() {
    let present: Vec<String> = (0..5_000).map(|j| format!("joint_{j}")).collect();
    let e = JointStateError::MissingJoints {
        path: PathBuf::from("x.mcap"),
        topic: "/t".into(),
        index: 0,
        missing: vec!["elbow".into()],
        present,
    };
    let msg = e.to_string();
    assert!(
        msg.contains("1 of the joints the body model needs is missing: \"elbow\";")
            && msg.contains("the message has 5000 joints: \"joint_0\"")
            && msg.contains("and 4995 more"),
        "{msg}"
    );
    assert!(msg.len() < 300, "{} bytes", msg.len());
}

#[test]
fn the_human_topic_is_the_one_named_for_it_before_one_that_holds_the_word() {
    let robot = "/berkeley-humanoid-lite/joint_command";
    assert_eq!(
        topic_for(&["/human/joint_states", robot], "human"),
        Some("/human/joint_states")
    );
    assert_eq!(
        topic_for(&["/person_human_fit", "/coman/x"], "human"),
        Some("/person_human_fit")
    );
    assert_eq!(topic_for(&[robot, "/another_human_x"], "human"), None);
    assert_eq!(topic_for(&["/coman/joint_command"], "human"), None);
}
