//! A scene written frame by frame straight into its file ([`SceneWriter`], with its
//! [`SceneOptions`]): the MCAP file opened and its schemas, channels and metadata written, then
//! the static messages at the first frame, every frame's messages and marker arrays, each
//! marker topic's channel added at its first use, and the summary at the end.

use std::collections::{BTreeMap, BTreeSet};
use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};

use ::mcap::records::MessageHeader;
use ::mcap::WriteOptions;

use super::body::{prepare_bodies, PreparedBody, SceneBody};
use super::channels::{lay_out_channels, refuse_duplicate_topics, ArrayTopic};
use super::frame::{EncodedFrame, FrameEncoder};
use super::markers::{marker_fields, TimedMarkers};
use super::msgs::{
    self, JOINT_STATE_MSGDEF, MARKER_ARRAY_MSGDEF, MARKER_ARRAY_SCHEMA, STRING_MSGDEF,
    STRING_SCHEMA,
};
use super::tf::{TF_STATIC_TOPIC, TF_TOPIC};
use crate::joint_state::{Compression, JointStateError, Result, JOINT_STATE_SCHEMA, MCAP_LIBRARY};

/// Options of a scene file.
#[derive(Debug, Clone)]
pub struct SceneOptions {
    /// Chunk compression.
    pub compression: Compression,
    /// Write the descriptions, `/tf_static` and `/tf` (otherwise only joint states and arrays).
    pub tf: bool,
    /// Metadata records written first (name → key/value map), e.g. what the file holds.
    pub metadata: Vec<(String, BTreeMap<String, String>)>,
}

impl Default for SceneOptions {
    fn default() -> Self {
        SceneOptions {
            compression: Compression::Zstd,
            tf: true,
            metadata: Vec::new(),
        }
    }
}
/// The file half of a [`SceneWriter`]: the MCAP writer and what it has written.
pub(super) struct SceneSink {
    writer: ::mcap::Writer<BufWriter<File>>,
    path: PathBuf,
    /// Topic of every channel, for errors.
    topics: BTreeMap<u16, String>,
    /// Topics markers may not be written on: the joint, description, array and TF topics.
    reserved: BTreeSet<String>,
    flush_each_frame: bool,
    pub(super) frames: u32,
    buf: Vec<u8>,
    /// The MarkerArray schema and the channel of each marker topic, added at first use.
    marker_schema: Option<u16>,
    marker_channels: BTreeMap<String, (u16, u32)>,
}

impl SceneSink {
    fn mcap_err(&self, what: String) -> impl Fn(::mcap::McapError) -> JointStateError + '_ {
        mcap_error(&self.path, what)
    }

    /// Writes `data` on `channel`.
    pub(super) fn write(
        &mut self,
        channel: u16,
        sequence: u32,
        time_ns: i64,
        data: &[u8],
    ) -> Result<()> {
        let header = MessageHeader {
            channel_id: channel,
            sequence,
            log_time: time_ns as u64,
            publish_time: time_ns as u64,
        };
        let Self {
            writer,
            path,
            topics,
            ..
        } = self;
        writer
            .write_to_known_channel(&header, data)
            .map_err(|source| JointStateError::McapWrite {
                path: path.clone(),
                what: format!(
                    "message on `{}`",
                    topics.get(&channel).map_or("?", String::as_str)
                ),
                source,
            })
    }

    /// Writes `self.buf` on `channel`.
    fn write_buf(&mut self, channel: u16, sequence: u32, time_ns: i64) -> Result<()> {
        let buf = std::mem::take(&mut self.buf);
        let written = self.write(channel, sequence, time_ns, &buf);
        self.buf = buf;
        written
    }

    /// Writes an encoded frame (after the first frame's static messages).
    pub(super) fn write_frame(&mut self, frame: &EncodedFrame) -> Result<()> {
        let seq = self.frames;
        for (channel, data) in frame.messages() {
            self.write(*channel, seq, frame.time_ns, data)?;
        }
        self.frames += 1;
        if self.flush_each_frame {
            self.writer.flush().map_err(self.mcap_err("flush".into()))?;
        }
        Ok(())
    }

    /// Writes one `visualization_msgs/msg/MarkerArray` on `m.topic` at `m.time_ns` (the
    /// topic's channel is added at its first use; it must not be a joint or array topic).
    pub(super) fn write_markers(&mut self, m: &TimedMarkers) -> Result<()> {
        let bad = |detail: String| JointStateError::InvalidInput {
            what: format!("topic `{}`", m.topic),
            detail,
        };
        if m.time_ns < 0 {
            return Err(bad(format!(
                "negative timestamp {} ns (MCAP times are unsigned)",
                m.time_ns
            )));
        }
        if self.reserved.contains(&m.topic) {
            return Err(bad("already a topic of another type in this scene".into()));
        }
        let (channel, seq) = match self.marker_channels.get(&m.topic) {
            Some(&c) => c,
            None => {
                let schema = match self.marker_schema {
                    Some(s) => s,
                    None => {
                        let s = self
                            .writer
                            .add_schema(
                                MARKER_ARRAY_SCHEMA,
                                "ros2msg",
                                MARKER_ARRAY_MSGDEF.as_bytes(),
                            )
                            .map_err(self.mcap_err("schema".into()))?;
                        *self.marker_schema.insert(s)
                    }
                };
                let channel = self
                    .writer
                    .add_channel(schema, &m.topic, "cdr", &BTreeMap::new())
                    .map_err(self.mcap_err(format!("channel `{}`", m.topic)))?;
                self.topics.insert(channel, m.topic.clone());
                (channel, 0)
            }
        };
        let fields = marker_fields(m);
        msgs::encode_marker_array(&mut self.buf, msgs::stamp(m.time_ns), &fields);
        self.write_buf(channel, seq, m.time_ns)?;
        self.marker_channels
            .insert(m.topic.clone(), (channel, seq.wrapping_add(1)));
        if self.flush_each_frame {
            self.writer.flush().map_err(self.mcap_err("flush".into()))?;
        }
        Ok(())
    }
}

/// Writes a scene frame by frame straight into its file (see the module documentation).
pub struct SceneWriter {
    pub(super) encoder: FrameEncoder,
    pub(super) sink: SceneSink,
    /// A frame's messages between encoding and writing.
    scratch: EncodedFrame,
}

impl SceneWriter {
    /// Creates `path` (replacing it) and writes the header, schemas and channels. With
    /// `flush_each_frame`, every frame is a finished chunk on disk when
    /// [`SceneWriter::write_frame`] returns. `joint_names` of each body are the columns of the
    /// joint values given per frame; each must be a movable joint of the body's robot (joints
    /// not given stay at the robot's neutral configuration).
    pub fn create(
        path: impl AsRef<Path>,
        bodies: Vec<(SceneBody, Vec<String>)>,
        arrays: Vec<ArrayTopic>,
        options: &SceneOptions,
        flush_each_frame: bool,
    ) -> Result<Self> {
        let path = path.as_ref();
        Self::create_as(path, path, bodies, arrays, options, flush_each_frame)
    }

    /// [`SceneWriter::create`] writing `file` while naming `path` in errors.
    pub(super) fn create_as(
        file: &Path,
        path: &Path,
        bodies: Vec<(SceneBody, Vec<String>)>,
        arrays: Vec<ArrayTopic>,
        options: &SceneOptions,
        flush_each_frame: bool,
    ) -> Result<Self> {
        let prepared = prepare_bodies(bodies, options)?;
        let mut writer = open_mcap(file, path, options.compression)?;
        let mut topics: BTreeMap<u16, String> = BTreeMap::new();
        let encoder = add_channels(&mut writer, path, prepared, arrays, options.tf, &mut topics)?;
        refuse_duplicate_topics(
            encoder
                .bodies
                .iter()
                .map(|b| b.body.joint_topic.as_str())
                .chain(encoder.arrays.iter().map(|a| a.0.topic.as_str()))
                .collect(),
        )?;
        let reserved = reserved_topics(&encoder);
        write_metadata(&mut writer, path, &options.metadata)?;
        Ok(SceneWriter {
            encoder,
            sink: SceneSink {
                writer,
                path: path.to_path_buf(),
                topics,
                reserved,
                flush_each_frame,
                frames: 0,
                buf: Vec::with_capacity(4096),
                marker_schema: None,
                marker_channels: BTreeMap::new(),
            },
            scratch: EncodedFrame::default(),
        })
    }

    /// Writes one frame at `time_ns`: `joints[b]` holds body `b`'s values in the order of its
    /// joint names, `arrays[a]` the values of array topic `a`. The first frame also carries the
    /// descriptions and `/tf_static`.
    pub fn write_frame(
        &mut self,
        time_ns: i64,
        joints: &[&[f64]],
        arrays: &[&[f64]],
    ) -> Result<()> {
        let mut frame = std::mem::take(&mut self.scratch);
        let written = self
            .encoder
            .encode(self.sink.frames, time_ns, joints, arrays, &mut frame)
            .and_then(|()| self.write_encoded(&frame));
        self.scratch = frame;
        written
    }

    /// Writes an encoded frame, after the static messages if it is the first.
    fn write_encoded(&mut self, frame: &EncodedFrame) -> Result<()> {
        if self.sink.frames == 0 {
            self.write_static(frame.time_ns)?;
        }
        self.sink.write_frame(frame)
    }

    /// Writes one `visualization_msgs/msg/MarkerArray` on `m.topic` at `m.time_ns` (the
    /// topic's channel is added at its first use; it must not be a joint or array topic).
    pub fn write_markers(&mut self, m: &TimedMarkers) -> Result<()> {
        self.sink.write_markers(m)
    }

    /// The descriptions and `/tf_static`, once, at the first frame's time.
    pub(super) fn write_static(&mut self, time_ns: i64) -> Result<()> {
        for (channel, payload) in self.encoder.static_messages(time_ns)? {
            self.sink.write(channel, 0, time_ns, &payload)?;
        }
        Ok(())
    }

    /// Number of frames written so far.
    pub fn frames(&self) -> u32 {
        self.sink.frames
    }

    /// Writes the summary and footer and syncs the file.
    pub fn finish(mut self) -> Result<()> {
        let path = self.sink.path.clone();
        self.sink
            .writer
            .finish()
            .map_err(|source| JointStateError::McapWrite {
                path: path.clone(),
                what: "summary and footer".into(),
                source,
            })?;
        let file = self
            .sink
            .writer
            .into_inner()
            .into_inner()
            .map_err(|e| JointStateError::Io {
                path: path.clone(),
                action: "write",
                source: e.into_error(),
            })?;
        file.sync_all().map_err(|source| JointStateError::Io {
            path,
            action: "sync",
            source,
        })
    }
}

/// The MCAP writer's error while writing `what` to `path`.
fn mcap_error(path: &Path, what: String) -> impl Fn(::mcap::McapError) -> JointStateError + '_ {
    move |source| JointStateError::McapWrite {
        path: path.to_path_buf(),
        what: what.clone(),
        source,
    }
}

/// Creates `file` (naming `path` in errors) and starts an MCAP file in it: ROS 2 profile,
/// chunks compressed with `compression`.
fn open_mcap(
    file: &Path,
    path: &Path,
    compression: Compression,
) -> Result<::mcap::Writer<BufWriter<File>>> {
    let file_handle = File::create(file).map_err(|source| JointStateError::Io {
        path: path.to_path_buf(),
        action: "create",
        source,
    })?;
    WriteOptions::new()
        .profile("ros2")
        .library(MCAP_LIBRARY)
        .compression(match compression {
            Compression::Zstd => Some(::mcap::Compression::Zstd),
            Compression::Lz4 => Some(::mcap::Compression::Lz4),
            Compression::None => None,
        })
        .compression_threads(0)
        // Level 1 rather than the default 3: the transforms are most of a scene's bytes,
        // compress about as well (7.2 → 7.6 MB for the shipped data) at a third of the time.
        .compression_level(1)
        .create(BufWriter::new(file_handle))
        .map_err(mcap_error(path, "header".into()))
}

/// Adds a scene's schemas and channels to `writer` in [`lay_out_channels`]' order, each
/// channel's topic to `topics`. The JointState schema comes first and, with TF and bodies, the
/// String schema second, before any channel (as scene files have always had them); every other
/// schema just before its first channel (adding a schema again returns the one written).
fn add_channels(
    writer: &mut ::mcap::Writer<BufWriter<File>>,
    path: &Path,
    prepared: Vec<PreparedBody>,
    arrays: Vec<ArrayTopic>,
    tf: bool,
    topics: &mut BTreeMap<u16, String>,
) -> Result<FrameEncoder> {
    let no_meta = BTreeMap::new();
    writer
        .add_schema(JOINT_STATE_SCHEMA, "ros2msg", JOINT_STATE_MSGDEF.as_bytes())
        .map_err(mcap_error(path, "schema".into()))?;
    if tf && !prepared.is_empty() {
        writer
            .add_schema(STRING_SCHEMA, "ros2msg", STRING_MSGDEF.as_bytes())
            .map_err(mcap_error(path, "schema".into()))?;
    }
    lay_out_channels(prepared, arrays, tf, |topic, schema_name, schema| {
        let schema_id = writer
            .add_schema(schema_name, "ros2msg", schema.as_bytes())
            .map_err(mcap_error(path, "schema".into()))?;
        let channel = writer
            .add_channel(schema_id, &topic, "cdr", &no_meta)
            .map_err(mcap_error(path, format!("channel `{topic}`")))?;
        topics.insert(channel, topic);
        Ok(channel)
    })
}

/// Topics markers may not be written on: every body's joint and description topics, the array
/// topics and the TF topics.
fn reserved_topics(encoder: &FrameEncoder) -> BTreeSet<String> {
    encoder
        .bodies
        .iter()
        .flat_map(|b| [b.body.joint_topic.clone(), b.body.description_topic()])
        .chain(encoder.arrays.iter().map(|(a, _)| a.topic.clone()))
        .chain([TF_TOPIC.to_string(), TF_STATIC_TOPIC.to_string()])
        .collect()
}

/// Writes the metadata records (name → key/value map).
fn write_metadata(
    writer: &mut ::mcap::Writer<BufWriter<File>>,
    path: &Path,
    metadata: &[(String, BTreeMap<String, String>)],
) -> Result<()> {
    for (name, map) in metadata {
        writer
            .write_metadata(&::mcap::records::Metadata {
                name: name.clone(),
                metadata: map.clone(),
            })
            .map_err(mcap_error(path, format!("metadata `{name}`")))?;
    }
    Ok(())
}
