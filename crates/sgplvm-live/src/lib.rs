//! sgplvm live: the trained model as a ROS 2 participant, without a ROS installation.
//!
//! - [`node`]: `sgplvm teleop`, the human's `sensor_msgs/msg/JointState` in, each robot's
//!   command out (the forms of [`commands`]), a `diagnostic_msgs/msg/DiagnosticArray` status;
//! - [`gate`]: the per-frame safety rule between the model and a robot (joint limits, the trust
//!   threshold on the model's own predictive standard deviation, stale input), plain functions
//!   that tests drive without a network;
//! - [`mod@replay`]: `sgplvm replay`, a recorded human published on the input topic;
//! - [`tf`]: a person's skeleton as ROS 2 TF frames (`teleop --input tf`, `replay --as tf`);
//! - [`view`]: the live view, a Foxglove WebSocket server with the scene files' topics;
//! - [`msgs`]: the ROS 2 messages, field for field.
//!
//! DDS is `ros2-client` over RustDDS (pure Rust, the ROS 2 wire protocol): type names go on the
//! wire in ROS 2's `pkg::msg::dds_::Type_` form and topics as `rt/...`, so that ROS 2 tools and
//! other DDS implementations (Cyclone DDS, Fast DDS) read what it publishes.

#![deny(clippy::unwrap_used)]

pub mod commands;
pub mod gate;
pub mod msgs;
pub mod mvn;
pub mod node;
pub mod replay;
pub mod tf;
pub mod view;

pub use commands::CommandForm;
pub use gate::{Gate, GateOptions};
pub use node::{teleop, Drive, Reliability, TeleopOptions, TeleopSummary, TfInputOptions};
pub use replay::{replay, replay_mvn, replay_tf, replay_tf_skeleton, ReplayOptions};

/// What went wrong in the live node.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum LiveError {
    /// The DDS participant or one of its entities could not be created.
    #[error("DDS: {message}")]
    Dds {
        /// The middleware's reason.
        message: String,
    },
    /// A topic or node name is not a valid ROS 2 name.
    #[error("`{name}` is not a valid ROS 2 name: {message}")]
    Name {
        /// The name.
        name: String,
        /// Why.
        message: String,
    },
    /// A message could not be published.
    #[error("publishing on {topic}: {message}")]
    Publish {
        /// The topic.
        topic: String,
        /// The middleware's reason.
        message: String,
    },
    /// The models, robots or options do not fit together.
    #[error("{0}")]
    Config(String),
    /// The live view could not start or send.
    #[error("live view: {0}")]
    View(String),
}
