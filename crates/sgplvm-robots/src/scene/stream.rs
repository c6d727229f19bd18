//! A scene without a file ([`SceneStream`]): the channels and encoded messages a
//! [`SceneWriter`](super::SceneWriter) writes, for a live viewer to serve.

use super::body::{prepare_bodies, SceneBody};
use super::channels::{lay_out_channels, refuse_duplicate_topics, ArrayTopic, ChannelSpec};
use super::frame::{EncodedFrame, FrameEncoder};
use super::writer::SceneOptions;
use crate::joint_state::Result;

/// A scene's channels and encoded messages without a file: the same messages a
/// [`SceneWriter`](super::SceneWriter) writes, for a live viewer to serve. Channel `k` of the
/// messages is [`SceneStream::channels`]`[k]`.
pub struct SceneStream {
    encoder: FrameEncoder,
    channels: Vec<ChannelSpec>,
    frames: u32,
    scratch: EncodedFrame,
}

impl SceneStream {
    /// The channels of `bodies` and `arrays` as
    /// [`SceneWriter::create`](super::SceneWriter::create) lays them out.
    pub fn new(
        bodies: Vec<(SceneBody, Vec<String>)>,
        arrays: Vec<ArrayTopic>,
        options: &SceneOptions,
    ) -> Result<Self> {
        let prepared = prepare_bodies(bodies, options)?;
        let mut channels: Vec<ChannelSpec> = Vec::new();
        let encoder = lay_out_channels(
            prepared,
            arrays,
            options.tf,
            |topic, schema_name, schema| {
                channels.push(ChannelSpec {
                    topic,
                    schema_name,
                    schema,
                });
                Ok((channels.len() - 1) as u16)
            },
        )?;
        refuse_duplicate_topics(channels.iter().map(|c| c.topic.as_str()).collect())?;
        Ok(SceneStream {
            encoder,
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

    /// One frame's messages (joint states, `/tf`, arrays), as
    /// [`SceneWriter::write_frame`](super::SceneWriter::write_frame) encodes them.
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
