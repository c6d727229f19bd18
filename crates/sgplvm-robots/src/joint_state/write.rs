//! Writing JointState topics into an MCAP file as ROS 2 records them: profile `ros2`, one
//! schema per message encoding, messages of all topics interleaved in time order, metadata
//! records after them. Files are written to a temporary sibling and renamed (see
//! [`crate::files`]: the next write removes what a killed writer left), and depend only on
//! their inputs (fixed library string, single-threaded compression).

use std::collections::BTreeMap;
use std::fs::File;
use std::io::BufWriter;
use std::path::Path;

use ::mcap::records::{MessageHeader, Metadata};
use ::mcap::{McapError, WriteOptions};
use serde::{Deserialize, Serialize};

use super::{
    cdr, json, JointStateError, JointStates, Result, JOINT_STATE_MSGDEF, JOINT_STATE_SCHEMA,
    MCAP_LIBRARY,
};
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
            return Err(JointStateError::InvalidInput {
                what: format!("topic `{}`", t.topic),
                detail: "topic given twice".into(),
            });
        }
    }
    write_atomically(path, |tmp| write_topics_to(tmp, path, topics, settings))
}

/// Runs `write` on a temporary sibling of `path` (after removing those a killed run left) and
/// renames it onto `path`; on an error the temporary file is removed and `path` untouched, so
/// readers never see a partial file.
pub(crate) fn write_atomically(path: &Path, write: impl FnOnce(&Path) -> Result<()>) -> Result<()> {
    if path.file_name().is_none() {
        return Err(JointStateError::InvalidInput {
            what: path.display().to_string(),
            detail: "output path has no file name".into(),
        });
    }
    crate::files::remove_stale_temporaries(path);
    let tmp = crate::files::temporary_path(path);
    let result = write(&tmp).and_then(|()| {
        std::fs::rename(&tmp, path).map_err(|source| JointStateError::Io {
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

/// The MCAP writer of this module, over a buffered file.
type Writer = ::mcap::Writer<BufWriter<File>>;

/// Turns the errors of writing `path` into [`JointStateError`]s.
#[derive(Clone, Copy)]
struct WriteErr<'a> {
    path: &'a Path,
}

impl<'a> WriteErr<'a> {
    fn io(self, action: &'static str) -> impl Fn(std::io::Error) -> JointStateError + use<'a> {
        move |source| JointStateError::Io {
            path: self.path.to_path_buf(),
            action,
            source,
        }
    }

    fn mcap(self, what: &str) -> impl Fn(McapError) -> JointStateError + use<'a> {
        let what = what.to_string();
        move |source| JointStateError::McapWrite {
            path: self.path.to_path_buf(),
            what: what.clone(),
            source,
        }
    }
}

/// Writes the file at `tmp` (`path` names it in errors).
fn write_topics_to(
    tmp: &Path,
    path: &Path,
    topics: &[TopicData<'_>],
    settings: &WriteSettings,
) -> Result<()> {
    let err = WriteErr { path };
    let file = File::create(tmp).map_err(err.io("create a temporary file next to it"))?;
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
        .map_err(err.mcap("header"))?;
    let channels = add_channels(&mut writer, topics, err)?;
    write_messages(&mut writer, topics, &channels, err)?;
    for (name, map) in &settings.metadata {
        writer
            .write_metadata(&Metadata {
                name: name.clone(),
                metadata: map.clone(),
            })
            .map_err(err.mcap(&format!("metadata `{name}`")))?;
    }
    writer.finish().map_err(err.mcap("summary and footer"))?;
    let buffered = writer.into_inner();
    let file = buffered
        .into_inner()
        .map_err(|e| err.io("write")(e.into_error()))?;
    file.sync_all().map_err(err.io("sync"))?;
    Ok(())
}

/// Adds one channel per topic (and each encoding's schema once, when first needed); returns
/// the channel ids in topic order.
fn add_channels(
    writer: &mut Writer,
    topics: &[TopicData<'_>],
    err: WriteErr<'_>,
) -> Result<Vec<u16>> {
    let mut channels = Vec::with_capacity(topics.len());
    let mut cdr_schema = None;
    let mut json_schema = None;
    for t in topics {
        let (schema, encoding, schema_encoding, definition) = match t.encoding {
            MessageEncoding::Cdr => (&mut cdr_schema, "cdr", "ros2msg", JOINT_STATE_MSGDEF),
            MessageEncoding::Json => (
                &mut json_schema,
                "json",
                "jsonschema",
                json::JOINT_STATE_JSONSCHEMA,
            ),
        };
        let schema_id = match *schema {
            Some(id) => id,
            None => {
                let id = writer
                    .add_schema(JOINT_STATE_SCHEMA, schema_encoding, definition.as_bytes())
                    .map_err(err.mcap("schema"))?;
                *schema = Some(id);
                id
            }
        };
        let id = writer
            .add_channel(schema_id, t.topic, encoding, &BTreeMap::new())
            .map_err(err.mcap(&format!("channel `{}`", t.topic)))?;
        channels.push(id);
    }
    Ok(channels)
}

/// Writes every row of every topic as a message, merged by (time, topic order).
fn write_messages(
    writer: &mut Writer,
    topics: &[TopicData<'_>],
    channels: &[u16],
    err: WriteErr<'_>,
) -> Result<()> {
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
        let (names, position) = (&t.states.names, t.states.row(row));
        match t.encoding {
            MessageEncoding::Cdr => {
                cdr::encode_joint_state(&mut buf, stamp, "", names, position, &[], &[])
            }
            MessageEncoding::Json => json::encode_joint_state(&mut buf, stamp, names, position)
                .map_err(|e| JointStateError::InvalidInput {
                    what: format!("topic `{}`", t.topic),
                    detail: format!("cannot encode JSON: {e}"),
                })?,
        }
        let header = MessageHeader {
            channel_id: channels[k],
            sequence: row as u32,
            log_time: time as u64,
            publish_time: time as u64,
        };
        writer
            .write_to_known_channel(&header, &buf)
            .map_err(err.mcap(&format!("message on `{}`", t.topic)))?;
    }
    Ok(())
}
