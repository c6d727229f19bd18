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

use super::body::{prepare_bodies, BodyChannel, SceneBody};
use super::channels::{ArrayKind, ArrayTopic};
use super::frame::{EncodedFrame, FrameEncoder};
use super::markers::{marker_fields, TimedMarkers};
use super::msgs::{
    self, FLOAT64_MULTI_ARRAY_MSGDEF, FLOAT64_MULTI_ARRAY_SCHEMA, JOINT_STATE_MSGDEF,
    MARKER_ARRAY_MSGDEF, MARKER_ARRAY_SCHEMA, STRING_MSGDEF, STRING_SCHEMA, TF_MESSAGE_MSGDEF,
    TF_MESSAGE_SCHEMA,
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
        move |source| JointStateError::McapWrite {
            path: self.path.clone(),
            what: what.clone(),
            source,
        }
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
        let mcap_err = |what: String| {
            move |source| JointStateError::McapWrite {
                path: path.to_path_buf(),
                what: what.clone(),
                source,
            }
        };
        let prepared = prepare_bodies(bodies, options)?;
        let file_handle = File::create(file).map_err(|source| JointStateError::Io {
            path: path.to_path_buf(),
            action: "create",
            source,
        })?;
        let mut writer = WriteOptions::new()
            .profile("ros2")
            .library(MCAP_LIBRARY)
            .compression(match options.compression {
                Compression::Zstd => Some(::mcap::Compression::Zstd),
                Compression::Lz4 => Some(::mcap::Compression::Lz4),
                Compression::None => None,
            })
            .compression_threads(0)
            // Level 1 rather than the default 3: the transforms are most of a scene's bytes,
            // compress about as well (7.2 → 7.6 MB for the shipped data) at a third of the time.
            .compression_level(1)
            .create(BufWriter::new(file_handle))
            .map_err(mcap_err("header".into()))?;
        let no_meta = BTreeMap::new();
        let js_schema = writer
            .add_schema(JOINT_STATE_SCHEMA, "ros2msg", JOINT_STATE_MSGDEF.as_bytes())
            .map_err(mcap_err("schema".into()))?;
        let mut out_bodies = Vec::with_capacity(prepared.len());
        let string_schema = if options.tf && !prepared.is_empty() {
            Some(
                writer
                    .add_schema(STRING_SCHEMA, "ros2msg", STRING_MSGDEF.as_bytes())
                    .map_err(mcap_err("schema".into()))?,
            )
        } else {
            None
        };
        for (body, names, q_index) in prepared {
            let channel = writer
                .add_channel(js_schema, &body.joint_topic, "cdr", &no_meta)
                .map_err(mcap_err(format!("channel `{}`", body.joint_topic)))?;
            let description_channel = match string_schema {
                Some(s) => {
                    let topic = body.description_topic();
                    Some(
                        writer
                            .add_channel(s, &topic, "cdr", &no_meta)
                            .map_err(mcap_err(format!("channel `{topic}`")))?,
                    )
                }
                None => None,
            };
            out_bodies.push(BodyChannel::new(
                body,
                names,
                q_index,
                channel,
                description_channel,
            ));
        }
        let tf = if options.tf {
            let s = writer
                .add_schema(TF_MESSAGE_SCHEMA, "ros2msg", TF_MESSAGE_MSGDEF.as_bytes())
                .map_err(mcap_err("schema".into()))?;
            let stat = writer
                .add_channel(s, TF_STATIC_TOPIC, "cdr", &no_meta)
                .map_err(mcap_err(format!("channel `{TF_STATIC_TOPIC}`")))?;
            let dynamic = writer
                .add_channel(s, TF_TOPIC, "cdr", &no_meta)
                .map_err(mcap_err(format!("channel `{TF_TOPIC}`")))?;
            Some((stat, dynamic))
        } else {
            None
        };
        let mut out_arrays = Vec::with_capacity(arrays.len());
        let mut array_schema = None;
        for a in arrays {
            let schema = match a.kind {
                ArrayKind::JointState { .. } => js_schema,
                ArrayKind::Float64MultiArray { .. } => match array_schema {
                    Some(s) => s,
                    None => {
                        let s = writer
                            .add_schema(
                                FLOAT64_MULTI_ARRAY_SCHEMA,
                                "ros2msg",
                                FLOAT64_MULTI_ARRAY_MSGDEF.as_bytes(),
                            )
                            .map_err(mcap_err("schema".into()))?;
                        *array_schema.insert(s)
                    }
                },
            };
            let id = writer
                .add_channel(schema, &a.topic, "cdr", &no_meta)
                .map_err(mcap_err(format!("channel `{}`", a.topic)))?;
            out_arrays.push((a, id));
        }
        let mut all_topics: Vec<&str> = out_bodies
            .iter()
            .map(|b| b.body.joint_topic.as_str())
            .chain(out_arrays.iter().map(|a| a.0.topic.as_str()))
            .collect();
        all_topics.sort_unstable();
        if let Some(w) = all_topics.windows(2).find(|w| w[0] == w[1]) {
            return Err(JointStateError::InvalidInput {
                what: format!("topic `{}`", w[0]),
                detail: "topic given twice".into(),
            });
        }
        let mut topics: BTreeMap<u16, String> = BTreeMap::new();
        for b in &out_bodies {
            topics.insert(b.channel, b.body.joint_topic.clone());
            if let Some(c) = b.description_channel {
                topics.insert(c, b.body.description_topic());
            }
        }
        for (a, c) in &out_arrays {
            topics.insert(*c, a.topic.clone());
        }
        if let Some((stat, dynamic)) = tf {
            topics.insert(stat, TF_STATIC_TOPIC.into());
            topics.insert(dynamic, TF_TOPIC.into());
        }
        let reserved = out_bodies
            .iter()
            .flat_map(|b| [b.body.joint_topic.clone(), b.body.description_topic()])
            .chain(out_arrays.iter().map(|(a, _)| a.topic.clone()))
            .chain([TF_TOPIC.to_string(), TF_STATIC_TOPIC.to_string()])
            .collect();
        for (name, map) in &options.metadata {
            writer
                .write_metadata(&::mcap::records::Metadata {
                    name: name.clone(),
                    metadata: map.clone(),
                })
                .map_err(mcap_err(format!("metadata `{name}`")))?;
        }
        Ok(SceneWriter {
            encoder: FrameEncoder {
                bodies: out_bodies,
                arrays: out_arrays,
                tf,
            },
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
