//! The error of MCAP JointState input and output: every variant names the file, and where a
//! topic is involved, the topic (and where a message is, its index and log time).

use std::path::PathBuf;

use ::mcap::McapError;

/// Errors of MCAP demonstration input and output. Every variant names the file, and where a
/// topic is involved, the topic.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum JointStateError {
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
    #[error("{path}: MCAP file is truncated (ended in the middle of a record or before the footer) while {topics}")]
    Truncated {
        /// File concerned.
        path: PathBuf,
        /// What was being read: `reading topic(s) `/a`, `/b`` or `listing its channels and
        /// metadata`.
        topics: String,
    },
    /// The MCAP structure itself is invalid (bad magic, CRC mismatch, ...).
    #[error("{path}: invalid MCAP while {topics}: {source}")]
    Mcap {
        /// File concerned.
        path: PathBuf,
        /// What was being read (as for [`JointStateError::Truncated`]).
        topics: String,
        /// The error reported by the mcap crate.
        source: McapError,
    },
    /// A record of the MCAP file cannot be parsed (the mcap crate's parser message, reduced to
    /// one plain line), or a record or chunk declares a length beyond what the file can hold.
    #[error("{path}: corrupt MCAP record while {topics}: {detail}")]
    Corrupt {
        /// File concerned.
        path: PathBuf,
        /// What was being read (as for [`JointStateError::Truncated`]).
        topics: String,
        /// What is wrong, on one line.
        detail: String,
    },
    /// Aligning the topics onto one clock would make more frames than the data justifies
    /// (see [`align_onto_clock`](super::align_onto_clock)).
    #[error("{path}: aligning topics {topics} at {rate_hz} Hz over their common span of {span_s} s would make {frames} frames of {values_per_frame} values, more than the limit of {limit} values (the larger of {ALIGN_VALUES_PER_VALUE_READ} per value read and {ALIGN_MIN_VALUES}); check the timestamps, or align at a lower rate")]
    TooManyFrames {
        /// File concerned (empty when aligning series in memory).
        path: PathBuf,
        /// The topics.
        topics: String,
        /// The clock's rate.
        rate_hz: f64,
        /// Length of the common span, seconds.
        span_s: f64,
        /// Frames the clock would have.
        frames: u64,
        /// Joint values per frame over all series.
        values_per_frame: usize,
        /// The largest number of values allowed in the aligned series.
        limit: u64,
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
    #[error(
        "{path}: topic `{topic}` not found (topics present: {})",
        short_list(available)
    )]
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
    #[error(
        "{path}: topic `{topic}`, message #{index}: {} of the joints the body model needs {} \
         missing: {}; the message has {}: {}",
        missing.len(),
        if missing.len() == 1 { "is" } else { "are" },
        crate::names::few(missing, crate::names::SHOWN),
        crate::names::count(present.len(), "joint"),
        crate::names::few(present, crate::names::SHOWN)
    )]
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

/// [`align_onto_clock`](super::align_onto_clock) refuses a clock whose aligned series would
/// hold more than this many values per value read (or [`ALIGN_MIN_VALUES`], if larger).
pub const ALIGN_VALUES_PER_VALUE_READ: u64 = 64;

/// The number of aligned values [`align_onto_clock`](super::align_onto_clock) always allows
/// (16 Mi values, 128 MiB).
pub const ALIGN_MIN_VALUES: u64 = 1 << 24;

impl JointStateError {
    /// This error with `path` (and `topics`) filled in where alignment leaves them empty.
    pub(crate) fn in_file(self, file: &std::path::Path, names: Option<String>) -> Self {
        match self {
            JointStateError::NoOverlap {
                topics,
                start_ns,
                end_ns,
                ..
            } => JointStateError::NoOverlap {
                path: file.to_path_buf(),
                topics: names.unwrap_or(topics),
                start_ns,
                end_ns,
            },
            JointStateError::TooManyFrames {
                topics,
                rate_hz,
                span_s,
                frames,
                values_per_frame,
                limit,
                ..
            } => JointStateError::TooManyFrames {
                path: file.to_path_buf(),
                topics: names.unwrap_or(topics),
                rate_hz,
                span_s,
                frames,
                values_per_frame,
                limit,
            },
            other => other,
        }
    }
}

/// At most the first 20 names of `names`, quoted, then how many more there are: messages stay
/// readable when a message lists thousands of joints.
fn short_list(names: &[String]) -> String {
    const SHOWN: usize = 20;
    let mut out = String::from("[");
    for (i, n) in names.iter().take(SHOWN).enumerate() {
        if i > 0 {
            out.push_str(", ");
        }
        out.push_str(&format!("{n:?}"));
    }
    if names.len() > SHOWN {
        out.push_str(&format!(", … {} more", names.len() - SHOWN));
    }
    out.push(']');
    out
}

/// Result type of this module.
pub type Result<T> = std::result::Result<T, JointStateError>;

/// The former name of [`JointStateError`], kept so that code written against it compiles.
pub type DemoError = JointStateError;
