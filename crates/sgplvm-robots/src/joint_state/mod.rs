//! ROS 2 `sensor_msgs/msg/JointState` channels in MCAP files: reading, writing and aligning.
//!
//! Files are written as ROS 2 (rosbag2) and Foxglove write them: profile `ros2`, schema
//! `sensor_msgs/msg/JointState` with schema encoding `ros2msg`, message encoding `cdr`, chunks
//! compressed with zstd, lz4 or not at all. Channels whose message encoding is `json` (a
//! JointState as a JSON object, as many tools write) are read too.
//!
//! Reading streams the file through mcap's sans-io reader: only the requested topics are
//! decoded, straight into flat row-major position arrays in the order the caller asks for.
//!
//! # Example
//! ```
//! use sgplvm_robots::joint_state::{read_joint_states, write_joint_states, Compression, JointStates};
//! let dir = std::env::temp_dir().join(format!("sgplvm-doc-js-{}", std::process::id()));
//! std::fs::create_dir_all(&dir).unwrap();
//! let path = dir.join("demo.mcap");
//! let states = JointStates::new(
//!     vec![0, 25_000_000],
//!     vec!["elbow".into(), "wrist".into()],
//!     vec![0.0, 0.1, 0.2, 0.3],
//! ).unwrap();
//! write_joint_states(&path, "/arm/joint_states", &states, Compression::Zstd).unwrap();
//! let back = read_joint_states(&path, "/arm/joint_states").unwrap();
//! assert_eq!(back, states);
//! # std::fs::remove_dir_all(&dir).unwrap();
//! ```

mod cdr;

use std::collections::BTreeMap;
use std::fs::File;
use std::io::{BufReader, BufWriter, Read};
use std::path::{Path, PathBuf};

use ::mcap::records::{op, MessageHeader, Metadata};
use ::mcap::sans_io::{LinearReadEvent, LinearReader, LinearReaderOptions};
use ::mcap::{McapError, WriteOptions};
use serde::{Deserialize, Serialize};

/// Schema name of ROS 2 joint states.
pub const JOINT_STATE_SCHEMA: &str = "sensor_msgs/msg/JointState";

/// Library string written into every MCAP header (fixed, so that files are reproducible).
pub const MCAP_LIBRARY: &str = "sgplvm";

/// Default rate of the common clock topics are aligned onto (the paper records at 40 Hz).
pub const DEFAULT_RATE_HZ: f64 = 40.0;

/// The `ros2msg` definition of `sensor_msgs/msg/JointState` with its dependencies, in the
/// concatenated form rosbag2 stores (each dependency after a line of 80 `=` and `MSG: pkg/Type`).
pub const JOINT_STATE_MSGDEF: &str = "\
# This is a message that holds data to describe the state of a set of torque controlled joints.
std_msgs/Header header

string[] name
float64[] position
float64[] velocity
float64[] effort

================================================================================
MSG: std_msgs/Header
# Standard metadata for higher-level stamped data types.
builtin_interfaces/Time stamp

# Transform frame with which this data is associated.
string frame_id

================================================================================
MSG: builtin_interfaces/Time
# The seconds component, valid over all int32 values.
int32 sec

# The nanoseconds component, valid in the range [0, 10e9).
uint32 nanosec
";

/// JSON Schema written for `json`-encoded JointState channels.
const JOINT_STATE_JSONSCHEMA: &str = r#"{"type":"object","title":"sensor_msgs/msg/JointState","properties":{"header":{"type":"object","properties":{"stamp":{"type":"object","properties":{"sec":{"type":"integer"},"nanosec":{"type":"integer"}}},"frame_id":{"type":"string"}}},"name":{"type":"array","items":{"type":"string"}},"position":{"type":"array","items":{"type":"number"}},"velocity":{"type":"array","items":{"type":"number"}},"effort":{"type":"array","items":{"type":"number"}}}}"#;

/// Errors of MCAP demonstration input and output. Every variant names the file, and where a
/// topic is involved, the topic.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum DemoError {
    /// The operating system refused an operation on the file.
    #[error("{path}: cannot {action}: {source}")]
    Io {
        /// File concerned.
        path: PathBuf,
        /// What was being done ("open", "write", "rename onto", ...).
        action: &'static str,
        /// The underlying error.
        source: std::io::Error,
    },
    /// The file ended in the middle of a record or before its footer.
    #[error("{path}: MCAP file is truncated (ended in the middle of a record or before the footer) while reading topic(s) {topics}")]
    Truncated {
        /// File concerned.
        path: PathBuf,
        /// The topics that were being read.
        topics: String,
    },
    /// The MCAP structure itself is invalid (bad magic, CRC mismatch, ...).
    #[error("{path}: invalid MCAP while reading topic(s) {topics}: {source}")]
    Mcap {
        /// File concerned.
        path: PathBuf,
        /// The topics that were being read.
        topics: String,
        /// The error reported by the mcap crate.
        source: McapError,
    },
    /// The MCAP writer failed.
    #[error("{path}: cannot write MCAP ({what}): {source}")]
    McapWrite {
        /// File concerned.
        path: PathBuf,
        /// What was being written.
        what: String,
        /// The error reported by the mcap crate.
        source: McapError,
    },
    /// A requested topic has no channel in the file.
    #[error("{path}: topic `{topic}` not found (topics present: {available:?})")]
    MissingTopic {
        /// File concerned.
        path: PathBuf,
        /// The topic asked for.
        topic: String,
        /// The topics the file does have.
        available: Vec<String>,
    },
    /// A requested topic has a channel but no messages.
    #[error("{path}: topic `{topic}` has no messages")]
    EmptyTopic {
        /// File concerned.
        path: PathBuf,
        /// The topic.
        topic: String,
    },
    /// A requested topic's schema is not a JointState schema in the expected encoding.
    #[error("{path}: topic `{topic}` has schema `{schema}` with schema encoding `{schema_encoding}`; expected `sensor_msgs/msg/JointState` with schema encoding `ros2msg` (or `ros2idl`) for cdr, or `jsonschema`/none for json")]
    WrongSchema {
        /// File concerned.
        path: PathBuf,
        /// The topic.
        topic: String,
        /// Schema name found (empty when the channel has no schema).
        schema: String,
        /// Schema encoding found.
        schema_encoding: String,
    },
    /// A requested topic's message encoding is neither `cdr` nor `json`.
    #[error("{path}: topic `{topic}` has message encoding `{encoding}`; expected `cdr` or `json`")]
    WrongEncoding {
        /// File concerned.
        path: PathBuf,
        /// The topic.
        topic: String,
        /// Message encoding found.
        encoding: String,
    },
    /// A message could not be decoded.
    #[error("{path}: topic `{topic}`, message #{index} (log time {log_time_ns} ns): {detail}")]
    Malformed {
        /// File concerned.
        path: PathBuf,
        /// The topic.
        topic: String,
        /// Index of the message within the topic (0-based).
        index: usize,
        /// The message's log time.
        log_time_ns: u64,
        /// What was wrong.
        detail: String,
    },
    /// Joints that the body model needs are absent from a message.
    #[error("{path}: topic `{topic}`, message #{index}: joints {missing:?} required by the body model are missing (the message has {present:?})")]
    MissingJoints {
        /// File concerned.
        path: PathBuf,
        /// The topic.
        topic: String,
        /// Index of the message within the topic.
        index: usize,
        /// Required joints that are absent.
        missing: Vec<String>,
        /// Joints the message does have.
        present: Vec<String>,
    },
    /// The topics to align have no common time span.
    #[error(
        "{path}: topics {topics} do not overlap in time (common span {start_ns}..{end_ns} ns)"
    )]
    NoOverlap {
        /// File concerned.
        path: PathBuf,
        /// The topics.
        topics: String,
        /// Latest first timestamp.
        start_ns: i64,
        /// Earliest last timestamp.
        end_ns: i64,
    },
    /// Data handed to a writer or aligner is inconsistent.
    #[error("invalid data for {what}: {detail}")]
    InvalidInput {
        /// The topic, body or argument concerned.
        what: String,
        /// What was expected.
        detail: String,
    },
    /// The `sgplvm.dataset` metadata of a demonstration file is unreadable or inconsistent.
    #[error("{path}: metadata `sgplvm.dataset` is invalid: {detail}")]
    BadDatasetMetadata {
        /// File concerned.
        path: PathBuf,
        /// What was wrong.
        detail: String,
    },
}

/// Result type of this module.
pub type Result<T> = std::result::Result<T, DemoError>;

/// Chunk compression of written MCAP files.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub enum Compression {
    /// zstd (the ROS 2 default).
    #[default]
    Zstd,
    /// lz4 frames.
    Lz4,
    /// Uncompressed chunks.
    None,
}

/// How the messages of a written channel are encoded.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum MessageEncoding {
    /// ROS 2 CDR with a `ros2msg` schema (what rosbag2 records).
    #[default]
    Cdr,
    /// One JSON object per message with a `jsonschema` schema.
    Json,
}

/// A time series of joint positions: one row per message.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct JointStates {
    /// Timestamps in nanoseconds (MCAP log time), one per row.
    pub times_ns: Vec<i64>,
    /// Joint names, one per column.
    pub names: Vec<String>,
    /// Positions, row-major: `positions[row * names.len() + col]`.
    pub positions: Vec<f64>,
}

impl JointStates {
    /// Builds a series after checking that `positions` has `times.len() × names.len()` values,
    /// names are unique and times are non-negative.
    pub fn new(times_ns: Vec<i64>, names: Vec<String>, positions: Vec<f64>) -> Result<Self> {
        let s = Self {
            times_ns,
            names,
            positions,
        };
        s.validate("joint states")?;
        Ok(s)
    }

    /// Number of rows (messages).
    pub fn len(&self) -> usize {
        self.times_ns.len()
    }

    /// Whether there are no rows.
    pub fn is_empty(&self) -> bool {
        self.times_ns.is_empty()
    }

    /// Number of joints (columns).
    pub fn dof(&self) -> usize {
        self.names.len()
    }

    /// Row `i` (panics if `i >= len()`, like slice indexing).
    pub fn row(&self, i: usize) -> &[f64] {
        let d = self.dof();
        &self.positions[i * d..(i + 1) * d]
    }

    /// Checks the invariants listed in [`JointStates::new`]; `what` names the data in errors.
    pub fn validate(&self, what: &str) -> Result<()> {
        let bad = |detail: String| DemoError::InvalidInput {
            what: what.to_string(),
            detail,
        };
        let expected = self.times_ns.len().checked_mul(self.names.len());
        if expected != Some(self.positions.len()) {
            return Err(bad(format!(
                "{} positions for {} times × {} joints",
                self.positions.len(),
                self.times_ns.len(),
                self.names.len()
            )));
        }
        if let Some(t) = self.times_ns.iter().find(|t| **t < 0) {
            return Err(bad(format!(
                "negative timestamp {t} ns (MCAP times are unsigned)"
            )));
        }
        for (i, n) in self.names.iter().enumerate() {
            if self.names[..i].contains(n) {
                return Err(bad(format!("joint name `{n}` appears twice")));
            }
        }
        Ok(())
    }

    /// Linear interpolation of every joint at `times_ns` (which must lie within this series'
    /// time span; rows must be sorted by time). At a time equal to a sample, the sample's values
    /// are returned exactly.
    pub fn resample(&self, times_ns: &[i64]) -> Result<JointStates> {
        let d = self.dof();
        let bad = |detail: String| DemoError::InvalidInput {
            what: "resample".into(),
            detail,
        };
        let (Some(&first), Some(&last)) = (self.times_ns.first(), self.times_ns.last()) else {
            return Err(bad("cannot resample an empty series".into()));
        };
        let mut out = Vec::with_capacity(times_ns.len() * d);
        let mut k = 0usize; // index of the left sample
        for &t in times_ns {
            if t < first || t > last {
                return Err(bad(format!(
                    "time {t} ns outside the series' span {first}..={last} ns"
                )));
            }
            if k > 0 && self.times_ns[k] > t {
                k = 0; // times not increasing: restart the search
            }
            while k + 1 < self.len() && self.times_ns[k + 1] <= t {
                k += 1;
            }
            let t0 = self.times_ns[k];
            if t == t0 || k + 1 == self.len() {
                out.extend_from_slice(self.row(k));
            } else {
                let t1 = self.times_ns[k + 1];
                let w = (t - t0) as f64 / (t1 - t0) as f64;
                let (a, b) = (self.row(k), self.row(k + 1));
                out.extend(a.iter().zip(b).map(|(x, y)| x + w * (y - x)));
            }
        }
        Ok(JointStates {
            times_ns: times_ns.to_vec(),
            names: self.names.clone(),
            positions: out,
        })
    }

    /// Sorts rows by time (stable), as messages may be logged out of order.
    fn sort_by_time(&mut self) {
        if self.times_ns.windows(2).all(|w| w[0] <= w[1]) {
            return;
        }
        let d = self.dof();
        let mut order: Vec<usize> = (0..self.len()).collect();
        order.sort_by_key(|&i| self.times_ns[i]);
        let times = order.iter().map(|&i| self.times_ns[i]).collect();
        let mut pos = Vec::with_capacity(self.positions.len());
        for &i in &order {
            pos.extend_from_slice(&self.positions[i * d..(i + 1) * d]);
        }
        self.times_ns = times;
        self.positions = pos;
    }
}

// ---------------------------------------------------------------------------------------------
// Writing

/// One channel to write: a topic, its joint states and how to encode them.
#[derive(Debug, Clone, Copy)]
pub struct TopicData<'a> {
    /// Topic name, e.g. `/human/joint_states`.
    pub topic: &'a str,
    /// The series.
    pub states: &'a JointStates,
    /// Message encoding of the channel.
    pub encoding: MessageEncoding,
}

/// Options of [`write_topics`].
#[derive(Debug, Clone, Default)]
pub struct WriteSettings {
    /// Chunk compression.
    pub compression: Compression,
    /// Metadata records written after the messages (name → key/value map).
    pub metadata: Vec<(String, BTreeMap<String, String>)>,
}

/// Writes one JointState topic (CDR) to `path`, atomically (temporary file + rename).
pub fn write_joint_states(
    path: impl AsRef<Path>,
    topic: &str,
    states: &JointStates,
    compression: Compression,
) -> Result<()> {
    write_topics(
        path,
        &[TopicData {
            topic,
            states,
            encoding: MessageEncoding::Cdr,
        }],
        &WriteSettings {
            compression,
            metadata: Vec::new(),
        },
    )
}

/// Writes several JointState topics into one MCAP (profile `ros2`), messages interleaved in
/// time order as a recorder would log them, then the metadata records. The file is written
/// to a temporary sibling and renamed onto `path`, so readers never see a partial file.
/// Output depends only on the inputs (fixed library string, single-threaded compression).
pub fn write_topics(
    path: impl AsRef<Path>,
    topics: &[TopicData<'_>],
    settings: &WriteSettings,
) -> Result<()> {
    let path = path.as_ref();
    for (i, t) in topics.iter().enumerate() {
        t.states.validate(&format!("topic `{}`", t.topic))?;
        if topics[..i].iter().any(|o| o.topic == t.topic) {
            return Err(DemoError::InvalidInput {
                what: format!("topic `{}`", t.topic),
                detail: "topic given twice".into(),
            });
        }
    }
    let file_name = path
        .file_name()
        .ok_or_else(|| DemoError::InvalidInput {
            what: path.display().to_string(),
            detail: "output path has no file name".into(),
        })?
        .to_string_lossy()
        .into_owned();
    let tmp = path.with_file_name(format!(".{file_name}.tmp{}", std::process::id()));
    let result = write_topics_to(&tmp, path, topics, settings).and_then(|()| {
        std::fs::rename(&tmp, path).map_err(|source| DemoError::Io {
            path: path.to_path_buf(),
            action: "rename the temporary file onto",
            source,
        })
    });
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}

fn write_topics_to(
    tmp: &Path,
    path: &Path,
    topics: &[TopicData<'_>],
    settings: &WriteSettings,
) -> Result<()> {
    let io_err = |action: &'static str| {
        move |source| DemoError::Io {
            path: path.to_path_buf(),
            action,
            source,
        }
    };
    let mcap_err = |what: &str| {
        let what = what.to_string();
        move |source| DemoError::McapWrite {
            path: path.to_path_buf(),
            what,
            source,
        }
    };
    let file = File::create(tmp).map_err(io_err("create a temporary file next to"))?;
    let mut options = WriteOptions::new()
        .profile("ros2")
        .library(MCAP_LIBRARY)
        .compression(match settings.compression {
            Compression::Zstd => Some(::mcap::Compression::Zstd),
            Compression::Lz4 => Some(::mcap::Compression::Lz4),
            Compression::None => None,
        });
    // Multithreaded zstd output differs from single-threaded: fix it for reproducible files.
    options = options.compression_threads(0);
    let mut writer = options
        .create(BufWriter::new(file))
        .map_err(mcap_err("header"))?;

    let mut channels = Vec::with_capacity(topics.len());
    let mut cdr_schema = None;
    let mut json_schema = None;
    for t in topics {
        let (schema_id, encoding) = match t.encoding {
            MessageEncoding::Cdr => {
                let id = match cdr_schema {
                    Some(id) => id,
                    None => {
                        let id = writer
                            .add_schema(
                                JOINT_STATE_SCHEMA,
                                "ros2msg",
                                JOINT_STATE_MSGDEF.as_bytes(),
                            )
                            .map_err(mcap_err("schema"))?;
                        cdr_schema = Some(id);
                        id
                    }
                };
                (id, "cdr")
            }
            MessageEncoding::Json => {
                let id = match json_schema {
                    Some(id) => id,
                    None => {
                        let id = writer
                            .add_schema(
                                JOINT_STATE_SCHEMA,
                                "jsonschema",
                                JOINT_STATE_JSONSCHEMA.as_bytes(),
                            )
                            .map_err(mcap_err("schema"))?;
                        json_schema = Some(id);
                        id
                    }
                };
                (id, "json")
            }
        };
        let id = writer
            .add_channel(schema_id, t.topic, encoding, &BTreeMap::new())
            .map_err(mcap_err(&format!("channel `{}`", t.topic)))?;
        channels.push(id);
    }

    // k-way merge by (time, topic order).
    let mut next = vec![0usize; topics.len()];
    let mut buf = Vec::with_capacity(1024);
    loop {
        let mut best: Option<(i64, usize)> = None;
        for (k, t) in topics.iter().enumerate() {
            if let Some(&time) = t.states.times_ns.get(next[k]) {
                if best.is_none_or(|(bt, _)| time < bt) {
                    best = Some((time, k));
                }
            }
        }
        let Some((time, k)) = best else { break };
        let t = &topics[k];
        let row = next[k];
        next[k] += 1;
        let stamp = (
            (time.div_euclid(1_000_000_000)).clamp(i32::MIN as i64, i32::MAX as i64) as i32,
            time.rem_euclid(1_000_000_000) as u32,
        );
        match t.encoding {
            MessageEncoding::Cdr => cdr::encode_joint_state(
                &mut buf,
                stamp,
                "",
                &t.states.names,
                t.states.row(row),
                &[],
                &[],
            ),
            MessageEncoding::Json => {
                buf.clear();
                let msg = JsonJointStateOut {
                    header: JsonHeader {
                        stamp: JsonStamp {
                            sec: stamp.0,
                            nanosec: stamp.1,
                        },
                        frame_id: String::new(),
                    },
                    name: &t.states.names,
                    position: t.states.row(row),
                    velocity: &[],
                    effort: &[],
                };
                serde_json::to_writer(&mut buf, &msg).map_err(|e| DemoError::InvalidInput {
                    what: format!("topic `{}`", t.topic),
                    detail: format!("cannot encode JSON: {e}"),
                })?;
            }
        }
        let header = MessageHeader {
            channel_id: channels[k],
            sequence: row as u32,
            log_time: time as u64,
            publish_time: time as u64,
        };
        writer
            .write_to_known_channel(&header, &buf)
            .map_err(mcap_err(&format!("message on `{}`", t.topic)))?;
    }
    for (name, map) in &settings.metadata {
        writer
            .write_metadata(&Metadata {
                name: name.clone(),
                metadata: map.clone(),
            })
            .map_err(mcap_err(&format!("metadata `{name}`")))?;
    }
    writer.finish().map_err(mcap_err("summary and footer"))?;
    let buffered = writer.into_inner();
    let file = buffered
        .into_inner()
        .map_err(|e| io_err("write")(e.into_error()))?;
    file.sync_all().map_err(io_err("sync"))?;
    Ok(())
}

#[derive(Serialize, Deserialize, Default)]
struct JsonStamp {
    #[serde(default)]
    sec: i32,
    #[serde(default)]
    nanosec: u32,
}

#[derive(Serialize, Deserialize, Default)]
struct JsonHeader {
    #[serde(default)]
    stamp: JsonStamp,
    #[serde(default)]
    frame_id: String,
}

#[derive(Serialize)]
struct JsonJointStateOut<'a> {
    header: JsonHeader,
    name: &'a [String],
    position: &'a [f64],
    velocity: &'a [f64],
    effort: &'a [f64],
}

#[derive(Deserialize)]
struct JsonJointStateIn {
    #[serde(default)]
    header: JsonHeader,
    #[serde(default)]
    name: Vec<String>,
    #[serde(default)]
    position: Vec<f64>,
}

// ---------------------------------------------------------------------------------------------
// Reading

/// Which timestamp of a message places it on the clock.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum TimeSource {
    /// The MCAP record's log time (when the recorder received it; what rosbag2 writes).
    #[default]
    LogTime,
    /// The message's `header.stamp` (when the sender measured it).
    HeaderStamp,
}

/// One topic to read and, optionally, the joints wanted from it in the wanted order.
#[derive(Debug, Clone, PartialEq)]
pub struct TopicRequest {
    /// Topic name.
    pub topic: String,
    /// Joints to extract, in this order (e.g. a body model's joint names); extra joints in the
    /// messages are ignored, missing ones are an error. `None` takes the first message's joints.
    pub joint_names: Option<Vec<String>>,
    /// Which timestamp to use.
    pub time_source: TimeSource,
}

impl TopicRequest {
    /// Request for all joints of `topic`, in the order of its first message.
    pub fn all(topic: impl Into<String>) -> Self {
        Self {
            topic: topic.into(),
            joint_names: None,
            time_source: TimeSource::LogTime,
        }
    }

    /// Request for the named joints of `topic`, in that order.
    pub fn joints(topic: impl Into<String>, names: &[String]) -> Self {
        Self {
            topic: topic.into(),
            joint_names: Some(names.to_vec()),
            time_source: TimeSource::LogTime,
        }
    }
}

/// What a streaming pass over an MCAP returns.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct TopicsRead {
    /// One series per request, in request order, rows sorted by time.
    pub states: Vec<JointStates>,
    /// All metadata records of the file (name → key/value map).
    pub metadata: BTreeMap<String, BTreeMap<String, String>>,
    /// All channels of the file: topic, schema name, message encoding.
    pub channels: Vec<ChannelInfo>,
}

/// A channel found in a file.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ChannelInfo {
    /// Topic name.
    pub topic: String,
    /// Schema name (empty without a schema).
    pub schema: String,
    /// Message encoding.
    pub message_encoding: String,
}

/// Reads all joints of one JointState topic, in the joint order of its first message (later
/// messages with another order are reordered; a message lacking one of them is an error).
pub fn read_joint_states(path: impl AsRef<Path>, topic: &str) -> Result<JointStates> {
    let mut read = read_topics(path, &[TopicRequest::all(topic)])?;
    Ok(read.states.remove(0))
}

/// Streams `path` once and extracts the requested topics, plus the file's metadata and
/// channel list. Messages of other topics are skipped without decoding.
pub fn read_topics(path: impl AsRef<Path>, requests: &[TopicRequest]) -> Result<TopicsRead> {
    let path = path.as_ref();
    let topics_str = requests
        .iter()
        .map(|r| format!("`{}`", r.topic))
        .collect::<Vec<_>>()
        .join(", ");
    let mut accs: Vec<TopicAcc> = requests
        .iter()
        .map(|r| TopicAcc {
            names: r.joint_names.clone().unwrap_or_default(),
            fixed_names: r.joint_names.is_some(),
            ..TopicAcc::default()
        })
        .collect();
    let mut schemas: BTreeMap<u16, (String, String)> = BTreeMap::new();
    // channel id -> (request index or usize::MAX, is_json)
    let mut channel_route: BTreeMap<u16, (usize, bool)> = BTreeMap::new();
    let mut channels: Vec<ChannelInfo> = Vec::new();
    let mut metadata = BTreeMap::new();
    let mut seen_topics: Vec<bool> = vec![false; requests.len()];

    let file = File::open(path).map_err(|source| DemoError::Io {
        path: path.to_path_buf(),
        action: "open",
        source,
    })?;
    // The reader asks for small pieces (one record of an uncompressed chunk at a time): a
    // large buffer turns those into few system calls.
    let mut file = BufReader::with_capacity(1 << 20, file);
    let mut reader = LinearReader::new_with_options(
        LinearReaderOptions::default().with_validate_chunk_crcs(true),
    );
    let mut names_scratch: Vec<(usize, usize)> = Vec::new();
    // Route of the last message's channel, to skip the map lookup in long runs.
    let mut last_route: Option<(u16, (usize, bool))> = None;
    while let Some(event) = reader.next_event() {
        let event = event.map_err(|e| match e {
            McapError::UnexpectedEof => DemoError::Truncated {
                path: path.to_path_buf(),
                topics: topics_str.clone(),
            },
            source => DemoError::Mcap {
                path: path.to_path_buf(),
                topics: topics_str.clone(),
                source,
            },
        })?;
        match event {
            LinearReadEvent::ReadRequest(need) => {
                let buf = reader.insert(need);
                let n = read_retrying(&mut file, buf).map_err(|source| DemoError::Io {
                    path: path.to_path_buf(),
                    action: "read",
                    source,
                })?;
                reader.notify_read(n);
            }
            LinearReadEvent::Record {
                opcode: op::MESSAGE,
                data,
            } => {
                if data.len() < 22 {
                    return Err(DemoError::Mcap {
                        path: path.to_path_buf(),
                        topics: topics_str.clone(),
                        source: McapError::UnexpectedEoc,
                    });
                }
                let channel_id = u16::from_le_bytes([data[0], data[1]]);
                let route = match last_route {
                    Some((id, route)) if id == channel_id => route,
                    _ => {
                        let route = channel_route
                            .get(&channel_id)
                            .copied()
                            .unwrap_or((usize::MAX, false));
                        last_route = Some((channel_id, route));
                        route
                    }
                };
                let (req, is_json) = route;
                if req == usize::MAX {
                    continue;
                }
                let log_time = u64::from_le_bytes(
                    data[6..14]
                        .try_into()
                        .expect("invariant: length checked above"),
                );
                let payload = &data[22..];
                let acc = &mut accs[req];
                let ctx = MsgCtx {
                    path,
                    topic: &requests[req].topic,
                    index: acc.count,
                    log_time,
                };
                let use_stamp = requests[req].time_source == TimeSource::HeaderStamp;
                if is_json {
                    let msg: JsonJointStateIn = serde_json::from_slice(payload)
                        .map_err(|e| ctx.malformed(format!("invalid JSON JointState: {e}")))?;
                    let stamp = msg.header.stamp;
                    let time = if use_stamp {
                        stamp_ns(stamp.sec, stamp.nanosec)
                    } else {
                        log_time_ns(&ctx)?
                    };
                    acc.ingest(
                        &ctx,
                        time,
                        msg.name.len(),
                        |i| msg.name[i].as_bytes(),
                        msg.position.len(),
                        |i| msg.position[i],
                    )?;
                } else {
                    let view = cdr::decode_joint_state(payload, &mut names_scratch)
                        .map_err(|d| ctx.malformed(format!("invalid CDR JointState: {d}")))?;
                    let time = if use_stamp {
                        stamp_ns(view.stamp.0, view.stamp.1)
                    } else {
                        log_time_ns(&ctx)?
                    };
                    acc.ingest(
                        &ctx,
                        time,
                        view.name_count(),
                        |i| view.name(i),
                        view.position_len(),
                        |i| view.position(i),
                    )?;
                }
            }
            LinearReadEvent::Record { opcode, data } => {
                let record =
                    ::mcap::parse_record(opcode, data).map_err(|source| DemoError::Mcap {
                        path: path.to_path_buf(),
                        topics: topics_str.clone(),
                        source,
                    })?;
                match record {
                    ::mcap::records::Record::Schema { header, .. } => {
                        schemas.insert(header.id, (header.name, header.encoding));
                    }
                    ::mcap::records::Record::Channel(ch) => {
                        if channel_route.contains_key(&ch.id) {
                            continue; // repeated in the summary section
                        }
                        last_route = None;
                        let (schema, schema_encoding) =
                            schemas.get(&ch.schema_id).cloned().unwrap_or_default();
                        let mut route = (usize::MAX, false);
                        if let Some(req) = requests.iter().position(|r| r.topic == ch.topic) {
                            seen_topics[req] = true;
                            let is_json = check_channel(
                                path,
                                &ch.topic,
                                &schema,
                                &schema_encoding,
                                &ch.message_encoding,
                            )?;
                            route = (req, is_json);
                        }
                        channel_route.insert(ch.id, route);
                        channels.push(ChannelInfo {
                            topic: ch.topic,
                            schema,
                            message_encoding: ch.message_encoding,
                        });
                    }
                    ::mcap::records::Record::Metadata(m) => {
                        metadata.insert(m.name, m.metadata);
                    }
                    _ => {}
                }
            }
        }
    }

    let mut states = Vec::with_capacity(requests.len());
    for ((req, acc), seen) in requests.iter().zip(accs).zip(seen_topics) {
        if !seen {
            let mut available: Vec<String> = channels.iter().map(|c| c.topic.clone()).collect();
            available.dedup();
            return Err(DemoError::MissingTopic {
                path: path.to_path_buf(),
                topic: req.topic.clone(),
                available,
            });
        }
        if acc.count == 0 {
            return Err(DemoError::EmptyTopic {
                path: path.to_path_buf(),
                topic: req.topic.clone(),
            });
        }
        let mut s = JointStates {
            times_ns: acc.times,
            names: acc.names,
            positions: acc.positions,
        };
        s.sort_by_time();
        states.push(s);
    }
    Ok(TopicsRead {
        states,
        metadata,
        channels,
    })
}

/// Lists the channels of a file (one streaming pass, no message decoded).
pub fn list_channels(path: impl AsRef<Path>) -> Result<Vec<ChannelInfo>> {
    Ok(read_topics(path, &[])?.channels)
}

/// Reads `requests` from `path` and aligns them onto one clock: from the latest first
/// timestamp to the earliest last one, every `1/rate_hz` s, by linear interpolation.
pub fn read_aligned(
    path: impl AsRef<Path>,
    requests: &[TopicRequest],
    rate_hz: f64,
) -> Result<Vec<JointStates>> {
    let path = path.as_ref();
    let read = read_topics(path, requests)?;
    align_onto_clock(&read.states, rate_hz).map_err(|e| match e {
        DemoError::NoOverlap {
            topics,
            start_ns,
            end_ns,
            ..
        } => DemoError::NoOverlap {
            path: path.to_path_buf(),
            topics,
            start_ns,
            end_ns,
        },
        other => other,
    })
}

/// Aligns series onto one clock at `rate_hz` covering their common time span (see
/// [`read_aligned`]). All returned series share the same `times_ns`.
pub fn align_onto_clock(series: &[JointStates], rate_hz: f64) -> Result<Vec<JointStates>> {
    if !(rate_hz.is_finite() && rate_hz > 0.0) {
        return Err(DemoError::InvalidInput {
            what: "rate_hz".into(),
            detail: format!("expected a positive finite rate, got {rate_hz}"),
        });
    }
    if series.is_empty() {
        return Ok(Vec::new());
    }
    let mut start = i64::MIN;
    let mut end = i64::MAX;
    for s in series {
        let (Some(&a), Some(&b)) = (s.times_ns.first(), s.times_ns.last()) else {
            return Err(DemoError::InvalidInput {
                what: "align".into(),
                detail: "a series is empty".into(),
            });
        };
        start = start.max(a);
        end = end.min(b);
    }
    if end < start {
        return Err(DemoError::NoOverlap {
            path: PathBuf::new(),
            topics: format!("{} series", series.len()),
            start_ns: start,
            end_ns: end,
        });
    }
    let period = 1e9 / rate_hz;
    let count = ((end - start) as f64 / period).floor() as usize + 1;
    let clock: Vec<i64> = (0..count)
        .map(|k| start + (k as f64 * period).round() as i64)
        .filter(|&t| t <= end)
        .collect();
    series.iter().map(|s| s.resample(&clock)).collect()
}

fn read_retrying(file: &mut impl Read, buf: &mut [u8]) -> std::io::Result<usize> {
    loop {
        match file.read(buf) {
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
            other => return other,
        }
    }
}

/// Validates a requested channel; returns whether its messages are JSON.
fn check_channel(
    path: &Path,
    topic: &str,
    schema: &str,
    schema_encoding: &str,
    message_encoding: &str,
) -> Result<bool> {
    let wrong_schema = || DemoError::WrongSchema {
        path: path.to_path_buf(),
        topic: topic.to_string(),
        schema: schema.to_string(),
        schema_encoding: schema_encoding.to_string(),
    };
    let is_joint_state = matches!(
        schema,
        "sensor_msgs/msg/JointState" | "sensor_msgs/JointState"
    );
    match message_encoding {
        "cdr" => {
            if !is_joint_state || !matches!(schema_encoding, "ros2msg" | "ros2idl") {
                return Err(wrong_schema());
            }
            Ok(false)
        }
        "json" => {
            let schema_ok = schema.is_empty() || is_joint_state;
            if !schema_ok || !matches!(schema_encoding, "" | "jsonschema") {
                return Err(wrong_schema());
            }
            Ok(true)
        }
        other => Err(DemoError::WrongEncoding {
            path: path.to_path_buf(),
            topic: topic.to_string(),
            encoding: other.to_string(),
        }),
    }
}

fn log_time_ns(ctx: &MsgCtx<'_>) -> Result<i64> {
    i64::try_from(ctx.log_time)
        .map_err(|_| ctx.malformed("log time exceeds i64 nanoseconds".into()))
}

fn stamp_ns(sec: i32, nanosec: u32) -> i64 {
    sec as i64 * 1_000_000_000 + nanosec as i64
}

struct MsgCtx<'a> {
    path: &'a Path,
    topic: &'a str,
    index: usize,
    log_time: u64,
}

impl MsgCtx<'_> {
    fn malformed(&self, detail: String) -> DemoError {
        DemoError::Malformed {
            path: self.path.to_path_buf(),
            topic: self.topic.to_string(),
            index: self.index,
            log_time_ns: self.log_time,
            detail,
        }
    }
}

/// Per-topic accumulation of decoded rows.
#[derive(Default)]
struct TopicAcc {
    /// Output joint names (requested, or taken from the first message).
    names: Vec<String>,
    /// Whether `names` came from the request.
    fixed_names: bool,
    times: Vec<i64>,
    positions: Vec<f64>,
    count: usize,
    /// Names of the last message whose mapping is cached, concatenated with NUL separators.
    cached_names: Vec<u8>,
    cached_count: usize,
    /// For each output joint, its index in the cached message layout.
    mapping: Vec<usize>,
}

impl TopicAcc {
    fn ingest<'n>(
        &mut self,
        ctx: &MsgCtx<'_>,
        time: i64,
        name_count: usize,
        name: impl Fn(usize) -> &'n [u8],
        position_len: usize,
        position: impl Fn(usize) -> f64,
    ) -> Result<()> {
        if position_len != name_count {
            return Err(ctx.malformed(format!(
                "{name_count} joint names but {position_len} positions"
            )));
        }
        if !self.same_layout(name_count, &name) {
            self.relayout(ctx, name_count, &name)?;
        }
        self.times.push(time);
        self.positions
            .extend(self.mapping.iter().map(|&i| position(i)));
        self.count += 1;
        Ok(())
    }

    fn same_layout<'n>(&self, name_count: usize, name: &impl Fn(usize) -> &'n [u8]) -> bool {
        if self.count == 0 || name_count != self.cached_count {
            return false;
        }
        let mut at = 0;
        for i in 0..name_count {
            let n = name(i);
            let end = at + n.len();
            if self.cached_names.get(at..end) != Some(n) || self.cached_names.get(end) != Some(&0) {
                return false;
            }
            at = end + 1;
        }
        at == self.cached_names.len()
    }

    fn relayout<'n>(
        &mut self,
        ctx: &MsgCtx<'_>,
        name_count: usize,
        name: &impl Fn(usize) -> &'n [u8],
    ) -> Result<()> {
        let mut present = Vec::with_capacity(name_count);
        for i in 0..name_count {
            let s = std::str::from_utf8(name(i))
                .map_err(|_| ctx.malformed(format!("joint name #{i} is not UTF-8")))?;
            if present.iter().any(|p: &String| p == s) {
                return Err(ctx.malformed(format!("joint name `{s}` appears twice")));
            }
            present.push(s.to_string());
        }
        if self.count == 0 && !self.fixed_names {
            self.names = present.clone();
        }
        let mut mapping = Vec::with_capacity(self.names.len());
        let mut missing = Vec::new();
        for n in &self.names {
            match present.iter().position(|p| p == n) {
                Some(i) => mapping.push(i),
                None => missing.push(n.clone()),
            }
        }
        if !missing.is_empty() {
            return Err(DemoError::MissingJoints {
                path: ctx.path.to_path_buf(),
                topic: ctx.topic.to_string(),
                index: ctx.index,
                missing,
                present,
            });
        }
        self.mapping = mapping;
        self.cached_names.clear();
        for p in &present {
            self.cached_names.extend_from_slice(p.as_bytes());
            self.cached_names.push(0);
        }
        self.cached_count = name_count;
        Ok(())
    }
}

#[cfg(test)]
mod tests;
