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
//! | file | what it holds |
//! |---|---|
//! | `body.rs` | [`SceneBody`], the checks of a scene's bodies, a body being encoded |
//! | `channels.rs` | [`ArrayTopic`], [`ChannelSpec`] and the channel layout both writers share |
//! | `tf.rs` | the TF tree: [`WORLD_FRAME`], [`TF_STATIC_TOPIC`], [`TF_TOPIC`] and their transforms |
//! | `markers.rs` | [`SceneMarker`], [`TimedMarkers`] and their fields as encoded |
//! | `events.rs` | a physics replay's events as markers ([`replay_markers`]) |
//! | `frame.rs` | a frame's messages, checked and encoded without I/O |
//! | `writer.rs` | [`SceneWriter`], frame by frame into a file, and [`SceneOptions`] |
//! | `whole_scene.rs` | [`write_scene`]: a whole series at once, encoded on a thread of its own |
//! | `stream.rs` | [`SceneStream`]: the same channels and messages without a file |
//! | `msgs.rs` | the CDR encoders and `ros2msg` schema texts of the messages |
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

mod body;
mod channels;
mod events;
mod frame;
mod markers;
mod msgs;
mod stream;
mod tf;
mod whole_scene;
mod writer;

pub use body::SceneBody;
pub use channels::{ArrayKind, ArrayTopic, ChannelSpec};
pub use events::{
    replay_markers, COLLISION_NS, JOINT_LIMIT_NS, MIN_MARKER_LIFETIME_NS, VELOCITY_LIMIT_NS,
};
pub use markers::{MarkerShape, SceneMarker, TimedMarkers};
pub use msgs::{
    FLOAT64_MULTI_ARRAY_MSGDEF, FLOAT64_MULTI_ARRAY_SCHEMA, JOINT_STATE_MSGDEF,
    MARKER_ARRAY_MSGDEF, MARKER_ARRAY_SCHEMA, STRING_MSGDEF, STRING_SCHEMA, TF_MESSAGE_MSGDEF,
    TF_MESSAGE_SCHEMA,
};
pub use stream::SceneStream;
pub use tf::{TF_STATIC_TOPIC, TF_TOPIC, WORLD_FRAME};
pub use whole_scene::{write_scene, write_scene_with_markers, ArraySeries, SceneSeries};
pub use writer::{SceneOptions, SceneWriter};

#[cfg(test)]
mod tests;
