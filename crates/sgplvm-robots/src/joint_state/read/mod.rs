//! Reading JointState topics from an MCAP file in one streaming pass (mcap's sans-io reader,
//! chunk CRCs checked): only the requested topics are decoded, straight into row-major
//! position arrays in the joint order the caller asks for; messages that list their joints
//! in another order are reordered, and a message lacking a wanted joint is an error. Rows
//! come back sorted by time.
//!
//! The reader's parts: `stream` (the state of one pass: channels, routes, messages),
//! `topic` (one topic's rows, in the joint order asked for) and `guard` (what corrupt input
//! becomes: an error naming the file, never a panic or an allocation the file cannot back).

mod guard;
mod stream;
mod topic;

use std::collections::BTreeMap;
use std::fs::File;
use std::io::{BufReader, Read};
use std::path::Path;

use ::mcap::records::op;
use ::mcap::sans_io::{LinearReadEvent, LinearReader, LinearReaderOptions};
use ::mcap::McapError;

use super::{JointStateError, JointStates, Result};
use guard::{next_event, strings_fit};
use stream::Stream;

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
    let file = File::open(path).map_err(|source| JointStateError::Io {
        path: path.to_path_buf(),
        action: "open",
        source,
    })?;
    let file_len = file
        .metadata()
        .map_err(|source| JointStateError::Io {
            path: path.to_path_buf(),
            action: "read the size of",
            source,
        })?
        .len();
    // The reader asks for small pieces (one record of an uncompressed chunk at a time): a
    // large buffer turns those into few system calls.
    let mut stream = Stream::new(path, file_len, requests);
    let mut file = BufReader::with_capacity(1 << 20, file);
    // Every record, and every chunk's decompressed content, is checked against a limit derived
    // from the file's size before anything is allocated for it; chunks are decompressed whole
    // and their CRC checked before any record inside is parsed.
    let mut reader = LinearReader::new_with_options(
        LinearReaderOptions::default()
            .with_validate_chunk_crcs(true)
            .with_prevalidate_chunk_crcs(true)
            .with_record_length_limit(record_length_limit(file_len)),
    );
    while let Some(event) = next_event(&mut reader).map_err(|detail| stream.corrupt(detail))? {
        let event = event.map_err(|e| match e {
            McapError::UnexpectedEof => JointStateError::Truncated {
                path: path.to_path_buf(),
                topics: stream.topics_str.clone(),
            },
            source => stream.invalid(source),
        })?;
        match event {
            LinearReadEvent::ReadRequest(need) => {
                let buf = reader.insert(need);
                let n = read_retrying(&mut file, buf).map_err(|source| JointStateError::Io {
                    path: path.to_path_buf(),
                    action: "read",
                    source,
                })?;
                reader.notify_read(n);
            }
            LinearReadEvent::Record {
                opcode: op::MESSAGE,
                data,
            } => stream.message(data)?,
            // Only these records are used; the others are not even parsed.
            LinearReadEvent::Record {
                opcode: opcode @ (op::SCHEMA | op::CHANNEL | op::METADATA),
                data,
            } => {
                // mcap's parser reserves a string's declared length before reading it: check
                // every length against the record first.
                strings_fit(opcode, data).map_err(|detail| stream.corrupt(detail))?;
                let record = ::mcap::parse_record(opcode, data).map_err(|e| stream.invalid(e))?;
                stream.record(record)?;
            }
            LinearReadEvent::Record { .. } => {}
        }
    }
    stream.finish()
}

/// The largest record, or decompressed chunk, that [`read_topics`] accepts in a file of
/// `file_len` bytes: 16 MiB plus 16 times the file's size (the shipped demonstrations compress
/// 7.5 : 1 in chunks of under 1 MiB), so that a corrupt length field cannot make the reader
/// allocate more than that.
pub fn record_length_limit(file_len: u64) -> usize {
    const FLOOR: u64 = 16 << 20;
    const RATIO: u64 = 16;
    usize::try_from(file_len.saturating_mul(RATIO).saturating_add(FLOOR)).unwrap_or(usize::MAX)
}

/// Of `topics`, the one named for `word`: the single one with a path part `word`
/// (`/human/joint_states`), else the single one whose name contains it; `None` when neither is
/// single. A robot named `berkeley-humanoid-lite` puts `human` in its own topic.
pub fn topic_for<'a>(topics: &[&'a str], word: &str) -> Option<&'a str> {
    let named: Vec<&str> = topics
        .iter()
        .copied()
        .filter(|t| t.split('/').any(|part| part == word))
        .collect();
    let containing: Vec<&str> = topics
        .iter()
        .copied()
        .filter(|t| t.contains(word))
        .collect();
    match (named.as_slice(), containing.as_slice()) {
        ([one], _) | ([], [one]) => Some(one),
        _ => None,
    }
}

/// Lists the channels of a file (one streaming pass, no message decoded).
pub fn list_channels(path: impl AsRef<Path>) -> Result<Vec<ChannelInfo>> {
    Ok(read_topics(path, &[])?.channels)
}

fn read_retrying(file: &mut impl Read, buf: &mut [u8]) -> std::io::Result<usize> {
    loop {
        match file.read(buf) {
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
            other => return other,
        }
    }
}
