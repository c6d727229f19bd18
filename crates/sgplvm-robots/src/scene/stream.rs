//! A scene without a file ([`SceneStream`]): the channels and encoded messages a
//! [`SceneWriter`](super::SceneWriter) writes, for a live viewer to serve.

use super::body::{prepare_bodies, BodyChannel, SceneBody};
use super::channels::{ArrayKind, ArrayTopic, ChannelSpec};
use super::frame::{EncodedFrame, FrameEncoder};
use super::msgs::{
    FLOAT64_MULTI_ARRAY_MSGDEF, FLOAT64_MULTI_ARRAY_SCHEMA, JOINT_STATE_MSGDEF, STRING_MSGDEF,
    STRING_SCHEMA, TF_MESSAGE_MSGDEF, TF_MESSAGE_SCHEMA,
};
use super::tf::{TF_STATIC_TOPIC, TF_TOPIC};
use super::writer::SceneOptions;
use crate::joint_state::{JointStateError, Result, JOINT_STATE_SCHEMA};

/// A scene's channels and encoded messages without a file: the same messages a [`SceneWriter`](super::SceneWriter)
/// writes, for a live viewer to serve. Channel `k` of the messages is [`SceneStream::channels`]`[k]`.
pub struct SceneStream {
    encoder: FrameEncoder,
    channels: Vec<ChannelSpec>,
    frames: u32,
    scratch: EncodedFrame,
}

impl SceneStream {
    /// The channels of `bodies` and `arrays` as [`SceneWriter::create`](super::SceneWriter::create) lays them out.
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

    /// One frame's messages (joint states, `/tf`, arrays), as [`SceneWriter::write_frame`](super::SceneWriter::write_frame)
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
