//! One frame of a scene, encoded without I/O: the messages sent once (each body's description
//! and `/tf_static`) and every frame's messages (joint states, `/tf`, arrays), checked and
//! encoded into reusable buffers ([`EncodedFrame`]) by the [`FrameEncoder`] that
//! [`SceneWriter`](super::SceneWriter) and [`SceneStream`](super::SceneStream) share.

use super::body::BodyChannel;
use super::channels::{ArrayKind, ArrayTopic};
use super::msgs;
use super::tf::{moving_transforms, static_transforms};
use crate::joint_state::{JointStateError, Result};

/// One frame's messages, encoded: `(channel, CDR payload)` in the order they are written. The
/// payload buffers are kept when a frame is reused, so that encoding allocates only at first.
#[derive(Default)]
pub(super) struct EncodedFrame {
    pub(super) time_ns: i64,
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
    pub(super) fn messages(&self) -> &[(u16, Vec<u8>)] {
        &self.messages[..self.len]
    }
}

/// The per-frame half of a [`SceneWriter`], without I/O: checks a frame's values and encodes
/// its joint states, transforms and arrays. [`write_scene_with_markers`] runs it on a thread of
/// its own while the file is written (compression is most of a scene's cost).
pub(super) struct FrameEncoder {
    pub(super) bodies: Vec<BodyChannel>,
    pub(super) arrays: Vec<(ArrayTopic, u16)>,
    /// Channels of `/tf_static` and `/tf`.
    pub(super) tf: Option<(u16, u16)>,
}

impl FrameEncoder {
    /// The messages sent once, at the first frame's time: each body's description and the
    /// fixed transforms (`/tf_static`, with each body's placement in the world); none without TF.
    pub(super) fn static_messages(&self, time_ns: i64) -> Result<Vec<(u16, Vec<u8>)>> {
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
        let transforms = static_transforms(&self.bodies);
        let mut buf = Vec::new();
        msgs::encode_tf_message(&mut buf, msgs::stamp(time_ns), &transforms);
        out.push((static_channel, buf));
        Ok(out)
    }

    /// Encodes frame number `frame` at `time_ns` into `out` (see [`SceneWriter::write_frame`]).
    pub(super) fn encode(
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
            let transforms = moving_transforms(&mut self.bodies, joints);
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
