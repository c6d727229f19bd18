//! MCAP "scene" files that open in Foxglove with the bodies animated: beside each body's
//! `sensor_msgs/msg/JointState` topic, the robot description (`std_msgs/msg/String`, the URDF
//! with every link prefixed by the body's name, once at the first frame), `/tf_static` (the
//! fixed joints, and a transform from `world` placing each body) and `/tf` (every movable joint
//! of every body at every frame, from [`JointInfo::transform`](crate::JointInfo::transform),
//! as ROS 2's `robot_state_publisher` publishes them), plus any number of
//! `std_msgs/msg/Float64MultiArray` topics (the predictive standard deviation, the latent point)
//! and `visualization_msgs/msg/MarkerArray` topics of events (a joint beyond its limit, a
//! collision), each published at the event's time with the event's duration as lifetime.
//!
//! Frames are named `<body>/<link>` (`human/DWYTorso`...) so that two bodies with equal link
//! names share one TF tree; the description topic of body `b` is `/b/robot_description`.
//!
//! [`SceneWriter`] writes frame by frame straight into the file, flushing a finished chunk
//! after every frame when asked (teleoperation: a killed process leaves a file readable up to
//! its last whole frame); [`write_scene`] writes a whole series atomically (temporary file and
//! rename, as [`crate::joint_state::write_topics`] does), encoding frames on a thread of its own
//! while the calling thread compresses and writes them.
//!
//! # Example
//! ```
//! use sgplvm_robots::scene::{write_scene, SceneBody, SceneOptions, SceneSeries};
//! use sgplvm_robots::joint_state::JointStates;
//! use sgplvm_robots::Robot;
//! let dir = std::env::temp_dir().join(format!("sgplvm-doc-scene-{}", std::process::id()));
//! std::fs::create_dir_all(&dir).unwrap();
//! let body = SceneBody::builtin("coman", "/coman/joint_command", [0.0, 0.0, 0.0]).unwrap();
//! let robot = Robot::builtin("coman").unwrap();
//! let q = robot.neutral_configuration();
//! let states = JointStates::new(vec![0, 25_000_000], robot.joint_names(), [q.clone(), q].concat()).unwrap();
//! write_scene(dir.join("coman.mcap"), &[SceneSeries { body: &body, states: &states }], &[], &SceneOptions::default()).unwrap();
//! # std::fs::remove_dir_all(&dir).unwrap();
//! ```

mod events;
mod msgs;

pub use events::{
    replay_markers, COLLISION_NS, JOINT_LIMIT_NS, MIN_MARKER_LIFETIME_NS, VELOCITY_LIMIT_NS,
};

pub use msgs::{
    FLOAT64_MULTI_ARRAY_MSGDEF, FLOAT64_MULTI_ARRAY_SCHEMA, JOINT_STATE_MSGDEF,
    MARKER_ARRAY_MSGDEF, MARKER_ARRAY_SCHEMA, STRING_MSGDEF, STRING_SCHEMA, TF_MESSAGE_MSGDEF,
    TF_MESSAGE_SCHEMA,
};

use std::collections::{BTreeMap, BTreeSet};
use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};
use std::sync::mpsc;

use ::mcap::records::MessageHeader;
use ::mcap::WriteOptions;
use nalgebra::{Isometry3, Translation3};

use crate::joint_state::{
    write_atomically, Compression, JointStateError, JointStates, Result, JOINT_STATE_SCHEMA,
    MCAP_LIBRARY,
};
use crate::urdf::Robot;
use msgs::Transform;

/// The frame every body is placed in.
pub const WORLD_FRAME: &str = "world";

/// Topic of the static transforms.
pub const TF_STATIC_TOPIC: &str = "/tf_static";

/// Topic of the moving transforms.
pub const TF_TOPIC: &str = "/tf";

/// One body of a scene: its kinematic model, where it stands, and the topic and joint order
/// of its joint states.
#[derive(Debug, Clone)]
pub struct SceneBody {
    /// Name of the body: the prefix of its frames (`<name>/<link>`) and of its description topic.
    pub name: String,
    /// The kinematic model.
    pub robot: Robot,
    /// Pose of the body's root link in [`WORLD_FRAME`].
    pub placement: Isometry3<f64>,
    /// Topic of its joint states, e.g. `/coman/joint_command`.
    pub joint_topic: String,
}

impl SceneBody {
    /// A built-in body (see [`Robot::builtin`]) named after itself, its root link at
    /// `position` (metres, in [`WORLD_FRAME`]).
    pub fn builtin(name: &str, joint_topic: &str, position: [f64; 3]) -> Result<Self> {
        let robot = Robot::builtin(name).map_err(|e| JointStateError::InvalidInput {
            what: format!("body `{name}`"),
            detail: e.to_string(),
        })?;
        Ok(SceneBody {
            name: name.to_string(),
            robot,
            placement: Isometry3::from_parts(
                Translation3::new(position[0], position[1], position[2]),
                nalgebra::UnitQuaternion::identity(),
            ),
            joint_topic: joint_topic.to_string(),
        })
    }

    /// Topic of the body's description: `/<name>/robot_description`.
    pub fn description_topic(&self) -> String {
        format!("/{}/robot_description", self.name)
    }

    /// The body's URDF with every link renamed `<name>/<link>` (joints keep their names), as
    /// written on the description topic.
    pub fn prefixed_urdf(&self) -> Result<String> {
        let mut urdf = self.robot.urdf().clone();
        let p = |s: &mut String| *s = format!("{}/{s}", self.name);
        urdf.links.iter_mut().for_each(|l| p(&mut l.name));
        for j in &mut urdf.joints {
            p(&mut j.parent.link);
            p(&mut j.child.link);
        }
        urdf_rs::write_to_string(&urdf).map_err(|e| JointStateError::InvalidInput {
            what: format!("body `{}`", self.name),
            detail: format!("cannot write its URDF: {e}"),
        })
    }

    /// Frame name of link `link` of this body.
    fn frame(&self, link: usize) -> String {
        format!("{}/{}", self.name, self.robot.links[link])
    }
}

/// A topic of per-frame values that belongs to no body: a `std_msgs/msg/Float64MultiArray`
/// (shown by Foxglove's Plot panel as `/topic.data[i]`) or a `sensor_msgs/msg/JointState`.
#[derive(Debug, Clone)]
pub struct ArrayTopic {
    /// Topic name, e.g. `/coman/prediction_std`.
    pub topic: String,
    /// Number of values per frame.
    pub len: usize,
    /// Message type.
    pub kind: ArrayKind,
}

/// Message type of an [`ArrayTopic`].
#[derive(Debug, Clone, PartialEq)]
pub enum ArrayKind {
    /// `std_msgs/msg/Float64MultiArray` of one dimension labelled so (`layout.dim[0].label`).
    Float64MultiArray {
        /// Label of the dimension, e.g. `joint` or `latent`.
        label: String,
    },
    /// `sensor_msgs/msg/JointState` with these joint names (one per value).
    JointState {
        /// Joint names.
        names: Vec<String>,
    },
}

impl ArrayTopic {
    /// A Float64MultiArray topic of `len` values whose dimension is labelled `label`.
    pub fn float64(topic: &str, label: &str, len: usize) -> Self {
        ArrayTopic {
            topic: topic.to_string(),
            len,
            kind: ArrayKind::Float64MultiArray {
                label: label.to_string(),
            },
        }
    }

    /// A JointState topic with these joint names.
    pub fn joint_state(topic: &str, names: Vec<String>) -> Self {
        ArrayTopic {
            topic: topic.to_string(),
            len: names.len(),
            kind: ArrayKind::JointState { names },
        }
    }
}

/// What a [`SceneMarker`] draws.
#[derive(Debug, Clone, PartialEq)]
pub enum MarkerShape {
    /// A sphere (`SPHERE`) of diameters `scale`.
    Sphere,
    /// A text facing the viewer (`TEXT_VIEW_FACING`), `scale[2]` high.
    Text(String),
}

/// One `visualization_msgs/msg/Marker` (action ADD, orientation identity).
#[derive(Debug, Clone, PartialEq)]
pub struct SceneMarker {
    /// Frame it is drawn in, e.g. `coman/LElb` or [`WORLD_FRAME`].
    pub frame: String,
    /// Namespace (`ns`): with `id`, what names the marker.
    pub ns: String,
    /// Identifier within the namespace.
    pub id: i32,
    /// What it draws.
    pub shape: MarkerShape,
    /// Position in `frame`, metres.
    pub position: [f64; 3],
    /// Size, metres.
    pub scale: [f64; 3],
    /// Colour (red, green, blue, alpha in [0, 1]).
    pub color: [f32; 4],
    /// How long it stays after its time, nanoseconds (0: forever).
    pub lifetime_ns: i64,
}

/// Markers published together (one `visualization_msgs/msg/MarkerArray`) on `topic` at
/// `time_ns` (log time and every marker's stamp).
#[derive(Debug, Clone, PartialEq)]
pub struct TimedMarkers {
    /// Topic, e.g. `/coman/events`.
    pub topic: String,
    /// Time, nanoseconds (≥ 0).
    pub time_ns: i64,
    /// The markers.
    pub markers: Vec<SceneMarker>,
}

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

/// One body's joint states, for [`write_scene`].
#[derive(Debug, Clone, Copy)]
pub struct SceneSeries<'a> {
    /// The body.
    pub body: &'a SceneBody,
    /// Its joint states (the same times for every body of a scene).
    pub states: &'a JointStates,
}

/// One array topic's values, for [`write_scene`]: `values` is row-major, `len` per frame.
#[derive(Debug, Clone, Copy)]
pub struct ArraySeries<'a> {
    /// The topic.
    pub topic: &'a ArrayTopic,
    /// Row-major values, one row per frame.
    pub values: &'a [f64],
}

/// Frames encoded per batch while [`write_scene_with_markers`] writes the batch before.
const ENCODE_BATCH: usize = 64;

/// Writes a whole scene to `path` atomically (temporary sibling, then rename). Every body's
/// series and every array must have one row per frame of the first body's times.
pub fn write_scene(
    path: impl AsRef<Path>,
    series: &[SceneSeries<'_>],
    arrays: &[ArraySeries<'_>],
    options: &SceneOptions,
) -> Result<()> {
    write_scene_with_markers(path, series, arrays, &[], options)
}

/// [`write_scene`] with marker arrays besides, each written after the last frame before its
/// time (so that a file read in log-time order meets the descriptions and `/tf_static`
/// first).
pub fn write_scene_with_markers(
    path: impl AsRef<Path>,
    series: &[SceneSeries<'_>],
    arrays: &[ArraySeries<'_>],
    markers: &[TimedMarkers],
    options: &SceneOptions,
) -> Result<()> {
    let path = path.as_ref();
    let mut order: Vec<&TimedMarkers> = markers.iter().collect();
    order.sort_by_key(|m| m.time_ns);
    let times = series.first().map_or(&[][..], |s| &s.states.times_ns[..]);
    for s in series {
        s.states
            .validate(&format!("topic `{}`", s.body.joint_topic))?;
        if s.states.times_ns != times {
            return Err(JointStateError::InvalidInput {
                what: format!("topic `{}`", s.body.joint_topic),
                detail: "its times differ from the first body's".into(),
            });
        }
    }
    for a in arrays {
        if a.values.len() != times.len() * a.topic.len {
            return Err(JointStateError::InvalidInput {
                what: format!("topic `{}`", a.topic.topic),
                detail: format!(
                    "{} values for {} frames × {}",
                    a.values.len(),
                    times.len(),
                    a.topic.len
                ),
            });
        }
    }
    let bodies: Vec<(SceneBody, Vec<String>)> = series
        .iter()
        .map(|s| (s.body.clone(), s.states.names.clone()))
        .collect();
    let topics: Vec<ArrayTopic> = arrays.iter().map(|a| a.topic.clone()).collect();
    write_atomically(path, |tmp| {
        let mut w = SceneWriter::create_as(tmp, path, bodies, topics, options, false)?;
        if let Some(&t0) = times.first() {
            w.write_static(t0)?;
        }
        let SceneWriter { encoder, sink, .. } = &mut w;
        // One thread encodes batches of frames while this one writes (and compresses) them;
        // written batches go back to be refilled, so the buffers are allocated once.
        let (batches, encoded) = mpsc::sync_channel::<Result<Vec<EncodedFrame>>>(2);
        let (recycle, written) = mpsc::channel::<Vec<EncodedFrame>>();
        std::thread::scope(|scope| {
            scope.spawn(move || {
                let mut joints: Vec<&[f64]> = Vec::with_capacity(series.len());
                let mut values: Vec<&[f64]> = Vec::with_capacity(arrays.len());
                for start in (0..times.len()).step_by(ENCODE_BATCH) {
                    let end = (start + ENCODE_BATCH).min(times.len());
                    let mut batch = written.try_recv().unwrap_or_default();
                    batch.resize_with(end - start, EncodedFrame::default);
                    let mut done = Ok(());
                    for (i, frame) in (start..end).zip(batch.iter_mut()) {
                        joints.clear();
                        joints.extend(series.iter().map(|s| s.states.row(i)));
                        values.clear();
                        values.extend(
                            arrays
                                .iter()
                                .map(|a| &a.values[i * a.topic.len..(i + 1) * a.topic.len]),
                        );
                        done = encoder.encode(i as u32, times[i], &joints, &values, frame);
                        if done.is_err() {
                            break;
                        }
                    }
                    let failed = done.is_err();
                    // A closed channel means the writer stopped on an error of its own.
                    if batches.send(done.map(|()| batch)).is_err() || failed {
                        return;
                    }
                }
            });
            for batch in encoded {
                let batch = batch?;
                for frame in &batch {
                    sink.write_frame(frame)?;
                    let i = sink.frames as usize;
                    let until = times.get(i).copied().unwrap_or(i64::MAX);
                    while let Some(m) = order.first().filter(|m| m.time_ns < until) {
                        sink.write_markers(m)?;
                        order.remove(0);
                    }
                }
                // The encoder may have finished: then nobody takes the batch back.
                let _ = recycle.send(batch);
            }
            Ok::<(), JointStateError>(())
        })?;
        if let Some(m) = order.first() {
            return Err(JointStateError::InvalidInput {
                what: format!("topic `{}`", m.topic),
                detail: "markers in a scene without frames".into(),
            });
        }
        w.finish()
    })
}

/// One channel of a scene: its topic and the ROS 2 message it carries (`ros2msg` schema,
/// `cdr` messages), for a sink other than a file (a live viewer).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ChannelSpec {
    /// Topic.
    pub topic: String,
    /// Schema name, e.g. `tf2_msgs/msg/TFMessage`.
    pub schema_name: &'static str,
    /// Schema text (`ros2msg`: the definition and its dependencies).
    pub schema: &'static str,
}

/// A scene's channels and encoded messages without a file: the same messages a [`SceneWriter`]
/// writes, for a live viewer to serve. Channel `k` of the messages is [`SceneStream::channels`]`[k]`.
pub struct SceneStream {
    encoder: FrameEncoder,
    channels: Vec<ChannelSpec>,
    frames: u32,
    scratch: EncodedFrame,
}

impl SceneStream {
    /// The channels of `bodies` and `arrays` as [`SceneWriter::create`] lays them out.
    pub fn new(
        bodies: Vec<(SceneBody, Vec<String>)>,
        arrays: Vec<ArrayTopic>,
        options: &SceneOptions,
    ) -> Result<Self> {
        let prepared = prepare_bodies(bodies, options)?;
        let mut channels: Vec<ChannelSpec> = Vec::new();
        let mut add = |topic: String, schema_name: &'static str, schema: &'static str| -> u16 {
            channels.push(ChannelSpec {
                topic,
                schema_name,
                schema,
            });
            (channels.len() - 1) as u16
        };
        let mut out_bodies = Vec::with_capacity(prepared.len());
        for (body, names, q_index) in prepared {
            let channel = add(
                body.joint_topic.clone(),
                JOINT_STATE_SCHEMA,
                JOINT_STATE_MSGDEF,
            );
            let description_channel = options
                .tf
                .then(|| add(body.description_topic(), STRING_SCHEMA, STRING_MSGDEF));
            out_bodies.push(BodyChannel::new(
                body,
                names,
                q_index,
                channel,
                description_channel,
            ));
        }
        let tf = options.tf.then(|| {
            (
                add(TF_STATIC_TOPIC.into(), TF_MESSAGE_SCHEMA, TF_MESSAGE_MSGDEF),
                add(TF_TOPIC.into(), TF_MESSAGE_SCHEMA, TF_MESSAGE_MSGDEF),
            )
        });
        let out_arrays = arrays
            .into_iter()
            .map(|a| {
                let id = match a.kind {
                    ArrayKind::JointState { .. } => {
                        add(a.topic.clone(), JOINT_STATE_SCHEMA, JOINT_STATE_MSGDEF)
                    }
                    ArrayKind::Float64MultiArray { .. } => add(
                        a.topic.clone(),
                        FLOAT64_MULTI_ARRAY_SCHEMA,
                        FLOAT64_MULTI_ARRAY_MSGDEF,
                    ),
                };
                (a, id)
            })
            .collect::<Vec<_>>();
        let mut topics: Vec<&str> = channels.iter().map(|c| c.topic.as_str()).collect();
        topics.sort_unstable();
        if let Some(w) = topics.windows(2).find(|w| w[0] == w[1]) {
            return Err(JointStateError::InvalidInput {
                what: format!("topic `{}`", w[0]),
                detail: "topic given twice".into(),
            });
        }
        Ok(SceneStream {
            encoder: FrameEncoder {
                bodies: out_bodies,
                arrays: out_arrays,
                tf,
            },
            channels,
            frames: 0,
            scratch: EncodedFrame::default(),
        })
    }

    /// The channels, in the order message channel numbers refer to.
    pub fn channels(&self) -> &[ChannelSpec] {
        &self.channels
    }

    /// The messages a viewer needs once (each body's description, `/tf_static`), stamped
    /// `time_ns`: a live viewer sends them again for clients that join later.
    pub fn static_messages(&self, time_ns: i64) -> Result<Vec<(u16, Vec<u8>)>> {
        self.encoder.static_messages(time_ns)
    }

    /// One frame's messages (joint states, `/tf`, arrays), as [`SceneWriter::write_frame`]
    /// encodes them.
    pub fn frame(
        &mut self,
        time_ns: i64,
        joints: &[&[f64]],
        arrays: &[&[f64]],
    ) -> Result<&[(u16, Vec<u8>)]> {
        self.encoder
            .encode(self.frames, time_ns, joints, arrays, &mut self.scratch)?;
        self.frames += 1;
        Ok(self.scratch.messages())
    }
}

/// A body with its joint names and, per name, the joint's index in its robot's configuration.
type PreparedBody = (SceneBody, Vec<String>, Vec<Option<usize>>);

/// Checks the bodies of a scene (unique names without `/`; with TF, every joint a movable joint
/// of the body's robot) and finds each joint in its robot's configuration.
fn prepare_bodies(
    bodies: Vec<(SceneBody, Vec<String>)>,
    options: &SceneOptions,
) -> Result<Vec<PreparedBody>> {
    let mut prepared: Vec<PreparedBody> = Vec::with_capacity(bodies.len());
    for (i, (body, names)) in bodies.into_iter().enumerate() {
        if prepared.iter().any(|b| b.0.name == body.name)
            || body.name.is_empty()
            || body.name.contains('/')
        {
            return Err(JointStateError::InvalidInput {
                what: format!("body {i} `{}`", body.name),
                detail: "expected a unique, non-empty body name without `/`".into(),
            });
        }
        let mut q_index = Vec::with_capacity(names.len());
        for n in &names {
            let qi = body.robot.joint_index(n);
            if qi.is_none() && options.tf {
                return Err(JointStateError::InvalidInput {
                    what: format!("topic `{}`", body.joint_topic),
                    detail: format!(
                        "joint `{n}` is not a movable joint of robot `{}` (expected one of {:?})",
                        body.robot.name(),
                        body.robot.joint_names()
                    ),
                });
            }
            q_index.push(qi);
        }
        prepared.push((body, names, q_index));
    }
    Ok(prepared)
}

/// A body being written: its model, where its columns go in the robot's configuration, its
/// channel and the scratch configuration.
struct BodyChannel {
    body: SceneBody,
    names: Vec<String>,
    /// For each column of the joint states, its index in the robot's configuration (if any).
    q_index: Vec<Option<usize>>,
    q: Vec<f64>,
    channel: u16,
    description_channel: Option<u16>,
    /// Frame names of every link, `<body>/<link>`.
    frames: Vec<String>,
}

impl BodyChannel {
    /// A body on its channels, at the robot's neutral configuration.
    fn new(
        body: SceneBody,
        names: Vec<String>,
        q_index: Vec<Option<usize>>,
        channel: u16,
        description_channel: Option<u16>,
    ) -> BodyChannel {
        BodyChannel {
            q: body.robot.neutral_configuration(),
            frames: (0..body.robot.links.len()).map(|l| body.frame(l)).collect(),
            body,
            names,
            q_index,
            channel,
            description_channel,
        }
    }
}

/// One frame's messages, encoded: `(channel, CDR payload)` in the order they are written. The
/// payload buffers are kept when a frame is reused, so that encoding allocates only at first.
#[derive(Default)]
struct EncodedFrame {
    time_ns: i64,
    messages: Vec<(u16, Vec<u8>)>,
    /// How many of `messages` belong to this frame.
    len: usize,
}

impl EncodedFrame {
    /// The buffer of the next message, on `channel` (cleared by the encoder it is given to).
    fn next(&mut self, channel: u16) -> &mut Vec<u8> {
        if self.len == self.messages.len() {
            self.messages.push((channel, Vec::new()));
        }
        let slot = &mut self.messages[self.len];
        slot.0 = channel;
        self.len += 1;
        &mut slot.1
    }

    /// The frame's messages.
    fn messages(&self) -> &[(u16, Vec<u8>)] {
        &self.messages[..self.len]
    }
}

/// The per-frame half of a [`SceneWriter`], without I/O: checks a frame's values and encodes
/// its joint states, transforms and arrays. [`write_scene_with_markers`] runs it on a thread of
/// its own while the file is written (compression is most of a scene's cost).
struct FrameEncoder {
    bodies: Vec<BodyChannel>,
    arrays: Vec<(ArrayTopic, u16)>,
    /// Channels of `/tf_static` and `/tf`.
    tf: Option<(u16, u16)>,
}

impl FrameEncoder {
    /// The messages sent once, at the first frame's time: each body's description and the
    /// fixed transforms (`/tf_static`, with each body's placement in the world); none without TF.
    fn static_messages(&self, time_ns: i64) -> Result<Vec<(u16, Vec<u8>)>> {
        let Some((static_channel, _)) = self.tf else {
            return Ok(Vec::new());
        };
        let mut out = Vec::with_capacity(self.bodies.len() + 1);
        for b in &self.bodies {
            if let Some(ch) = b.description_channel {
                let mut buf = Vec::new();
                msgs::encode_string(&mut buf, &b.body.prefixed_urdf()?);
                out.push((ch, buf));
            }
        }
        let mut transforms = Vec::new();
        for body in &self.bodies {
            let robot = &body.body.robot;
            transforms.push(Transform {
                parent: WORLD_FRAME,
                child: &body.frames[robot.root],
                pose: body.body.placement,
            });
            for joint in robot.joints() {
                if joint.q_index.is_none() {
                    transforms.push(Transform {
                        parent: &body.frames[joint.parent],
                        child: &body.frames[joint.child],
                        pose: joint.transform(0.0),
                    });
                }
            }
        }
        let mut buf = Vec::new();
        msgs::encode_tf_message(&mut buf, msgs::stamp(time_ns), &transforms);
        out.push((static_channel, buf));
        Ok(out)
    }

    /// Encodes frame number `frame` at `time_ns` into `out` (see [`SceneWriter::write_frame`]).
    fn encode(
        &mut self,
        frame: u32,
        time_ns: i64,
        joints: &[&[f64]],
        arrays: &[&[f64]],
        out: &mut EncodedFrame,
    ) -> Result<()> {
        let bad = |what: String, detail: String| JointStateError::InvalidInput { what, detail };
        if time_ns < 0 {
            return Err(bad(
                format!("frame {frame}"),
                format!("negative timestamp {time_ns} ns (MCAP times are unsigned)"),
            ));
        }
        if joints.len() != self.bodies.len() || arrays.len() != self.arrays.len() {
            return Err(bad(
                format!("frame {frame}"),
                format!(
                    "{} bodies and {} arrays given; expected {} and {}",
                    joints.len(),
                    arrays.len(),
                    self.bodies.len(),
                    self.arrays.len()
                ),
            ));
        }
        for (b, v) in self.bodies.iter().zip(joints) {
            if v.len() != b.names.len() {
                return Err(bad(
                    format!("topic `{}`, frame {frame}", b.body.joint_topic),
                    format!("{} values for {} joints", v.len(), b.names.len()),
                ));
            }
        }
        for ((a, _), v) in self.arrays.iter().zip(arrays) {
            if v.len() != a.len {
                return Err(bad(
                    format!("topic `{}`, frame {frame}", a.topic),
                    format!("{} values; expected {}", v.len(), a.len),
                ));
            }
        }
        out.time_ns = time_ns;
        out.len = 0;
        let stamp = msgs::stamp(time_ns);
        for (body, values) in self.bodies.iter().zip(joints) {
            crate::joint_state::cdr::encode_joint_state(
                out.next(body.channel),
                stamp,
                "",
                &body.names,
                values,
                &[],
                &[],
            );
        }
        if let Some((_, tf_channel)) = self.tf {
            let mut transforms = Vec::new();
            for (body, values) in self.bodies.iter_mut().zip(joints) {
                for (qi, &v) in body.q_index.iter().zip(values.iter()) {
                    if let Some(qi) = *qi {
                        body.q[qi] = v;
                    }
                }
            }
            for body in &self.bodies {
                for joint in body.body.robot.joints() {
                    if let Some(qi) = joint.q_index {
                        transforms.push(Transform {
                            parent: &body.frames[joint.parent],
                            child: &body.frames[joint.child],
                            pose: joint.transform(body.q[qi]),
                        });
                    }
                }
            }
            msgs::encode_tf_message(out.next(tf_channel), stamp, &transforms);
        }
        for ((topic, channel), values) in self.arrays.iter().zip(arrays) {
            let buf = out.next(*channel);
            match &topic.kind {
                ArrayKind::Float64MultiArray { label } => {
                    msgs::encode_float64_array(buf, label, values)
                }
                ArrayKind::JointState { names } => crate::joint_state::cdr::encode_joint_state(
                    buf,
                    stamp,
                    "",
                    names,
                    values,
                    &[],
                    &[],
                ),
            }
        }
        Ok(())
    }
}

/// The file half of a [`SceneWriter`]: the MCAP writer and what it has written.
struct SceneSink {
    writer: ::mcap::Writer<BufWriter<File>>,
    path: PathBuf,
    /// Topic of every channel, for errors.
    topics: BTreeMap<u16, String>,
    /// Topics markers may not be written on: the joint, description, array and TF topics.
    reserved: BTreeSet<String>,
    flush_each_frame: bool,
    frames: u32,
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
    fn write(&mut self, channel: u16, sequence: u32, time_ns: i64, data: &[u8]) -> Result<()> {
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
    fn write_frame(&mut self, frame: &EncodedFrame) -> Result<()> {
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
    fn write_markers(&mut self, m: &TimedMarkers) -> Result<()> {
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
        let fields: Vec<msgs::MarkerFields<'_>> = m
            .markers
            .iter()
            .map(|k| {
                let (kind, text) = match &k.shape {
                    MarkerShape::Sphere => (msgs::MARKER_SPHERE, ""),
                    MarkerShape::Text(t) => (msgs::MARKER_TEXT_VIEW_FACING, t.as_str()),
                };
                msgs::MarkerFields {
                    frame: &k.frame,
                    ns: &k.ns,
                    id: k.id,
                    kind,
                    position: k.position,
                    scale: k.scale,
                    color: k.color,
                    lifetime_ns: k.lifetime_ns,
                    text,
                }
            })
            .collect();
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
    encoder: FrameEncoder,
    sink: SceneSink,
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
    fn create_as(
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
    fn write_static(&mut self, time_ns: i64) -> Result<()> {
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

#[cfg(test)]
mod tests;
