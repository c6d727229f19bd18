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
//!
//! # Layout
//! [`JointStates`] (`states`) is the series the other files pass around; `write` puts topics
//! into a file, `read` takes them out in one streaming pass, `align` puts several topics on one
//! clock, and the message codecs live in `cdr` (ROS 2 CDR, with the `ros2msg` schema) and
//! `json`. Every failure is a [`JointStateError`] naming the file and topic (`error`).

mod align;
pub(crate) mod cdr;
mod error;
mod json;
mod read;
mod states;
mod write;
pub(crate) use write::write_atomically;

pub use align::{align_onto_clock, read_aligned};
pub use cdr::JOINT_STATE_MSGDEF;
pub use error::{
    DemoError, JointStateError, Result, ALIGN_MIN_VALUES, ALIGN_VALUES_PER_VALUE_READ,
};
pub use read::{
    list_channels, read_joint_states, read_topics, record_length_limit, topic_for, ChannelInfo,
    TimeSource, TopicRequest, TopicsRead,
};
pub use states::JointStates;
pub use write::{
    write_joint_states, write_topics, Compression, MessageEncoding, TopicData, WriteSettings,
};

/// Schema name of ROS 2 joint states.
pub const JOINT_STATE_SCHEMA: &str = "sensor_msgs/msg/JointState";

/// Library string written into every MCAP header (fixed, so that files are reproducible).
pub const MCAP_LIBRARY: &str = "sgplvm";

/// Default rate of the common clock topics are aligned onto (the paper records at 40 Hz).
pub const DEFAULT_RATE_HZ: f64 = 40.0;

#[cfg(test)]
mod tests;
