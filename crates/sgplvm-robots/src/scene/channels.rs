//! A scene's channels: the array topics that belong to no body ([`ArrayTopic`]), a channel as a
//! live viewer serves it ([`ChannelSpec`]), and the one layout of channels — bodies, TF, arrays
//! — that [`SceneWriter`](super::SceneWriter) and [`SceneStream`](super::SceneStream) share.

use super::body::{BodyChannel, PreparedBody};
use super::frame::FrameEncoder;
use super::msgs::{
    FLOAT64_MULTI_ARRAY_MSGDEF, FLOAT64_MULTI_ARRAY_SCHEMA, JOINT_STATE_MSGDEF, STRING_MSGDEF,
    STRING_SCHEMA, TF_MESSAGE_MSGDEF, TF_MESSAGE_SCHEMA,
};
use super::tf::{TF_STATIC_TOPIC, TF_TOPIC};
use crate::joint_state::{JointStateError, Result, JOINT_STATE_SCHEMA};

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
/// Lays out a scene's channels in the order both writers use: per body its joint states and,
/// with `tf`, its description; then, with `tf`, `/tf_static` and `/tf`; then the arrays. `add`
/// opens each channel — its topic, schema name and schema text — and returns its number.
pub(super) fn lay_out_channels(
    prepared: Vec<PreparedBody>,
    arrays: Vec<ArrayTopic>,
    tf: bool,
    mut add: impl FnMut(String, &'static str, &'static str) -> Result<u16>,
) -> Result<FrameEncoder> {
    let mut out_bodies = Vec::with_capacity(prepared.len());
    for (body, names, q_index) in prepared {
        let channel = add(
            body.joint_topic.clone(),
            JOINT_STATE_SCHEMA,
            JOINT_STATE_MSGDEF,
        )?;
        let description_channel = if tf {
            Some(add(body.description_topic(), STRING_SCHEMA, STRING_MSGDEF)?)
        } else {
            None
        };
        out_bodies.push(BodyChannel::new(
            body,
            names,
            q_index,
            channel,
            description_channel,
        ));
    }
    let tf = if tf {
        Some((
            add(TF_STATIC_TOPIC.into(), TF_MESSAGE_SCHEMA, TF_MESSAGE_MSGDEF)?,
            add(TF_TOPIC.into(), TF_MESSAGE_SCHEMA, TF_MESSAGE_MSGDEF)?,
        ))
    } else {
        None
    };
    let mut out_arrays = Vec::with_capacity(arrays.len());
    for a in arrays {
        let id = match a.kind {
            ArrayKind::JointState { .. } => {
                add(a.topic.clone(), JOINT_STATE_SCHEMA, JOINT_STATE_MSGDEF)?
            }
            ArrayKind::Float64MultiArray { .. } => add(
                a.topic.clone(),
                FLOAT64_MULTI_ARRAY_SCHEMA,
                FLOAT64_MULTI_ARRAY_MSGDEF,
            )?,
        };
        out_arrays.push((a, id));
    }
    Ok(FrameEncoder {
        bodies: out_bodies,
        arrays: out_arrays,
        tf,
    })
}

/// Refuses `topics` if one of them is given twice.
pub(super) fn refuse_duplicate_topics(mut topics: Vec<&str>) -> Result<()> {
    topics.sort_unstable();
    if let Some(w) = topics.windows(2).find(|w| w[0] == w[1]) {
        return Err(JointStateError::InvalidInput {
            what: format!("topic `{}`", w[0]),
            detail: "topic given twice".into(),
        });
    }
    Ok(())
}
