//! A scene's channels: the array topics that belong to no body ([`ArrayTopic`]) and a channel as
//! a live viewer serves it ([`ChannelSpec`]).

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
