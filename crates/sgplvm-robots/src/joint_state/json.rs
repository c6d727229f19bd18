//! The JSON codec of `sensor_msgs/msg/JointState`: one JSON object per message (as Foxglove
//! and many tools write it), `{"header": {"stamp": {"sec", "nanosec"}, "frame_id"}, "name",
//! "position", "velocity", "effort"}`, with its JSON Schema. Missing fields read as empty.

use serde::{Deserialize, Serialize};

/// JSON Schema written for `json`-encoded JointState channels.
pub(super) const JOINT_STATE_JSONSCHEMA: &str = r#"{"type":"object","title":"sensor_msgs/msg/JointState","properties":{"header":{"type":"object","properties":{"stamp":{"type":"object","properties":{"sec":{"type":"integer"},"nanosec":{"type":"integer"}}},"frame_id":{"type":"string"}}},"name":{"type":"array","items":{"type":"string"}},"position":{"type":"array","items":{"type":"number"}},"velocity":{"type":"array","items":{"type":"number"}},"effort":{"type":"array","items":{"type":"number"}}}}"#;

#[derive(Serialize, Deserialize, Default)]
struct JsonStamp {
    #[serde(default)]
    sec: i32,
    #[serde(default)]
    nanosec: u32,
}

#[derive(Serialize, Deserialize, Default)]
struct JsonHeader {
    #[serde(default)]
    stamp: JsonStamp,
    #[serde(default)]
    frame_id: String,
}

#[derive(Serialize)]
struct JsonJointStateOut<'a> {
    header: JsonHeader,
    name: &'a [String],
    position: &'a [f64],
    velocity: &'a [f64],
    effort: &'a [f64],
}

/// A decoded JSON JointState: what the reader needs of it.
#[derive(Deserialize)]
pub(super) struct JsonJointStateIn {
    #[serde(default)]
    header: JsonHeader,
    /// Joint names.
    #[serde(default)]
    pub(super) name: Vec<String>,
    /// Joint positions, one per name.
    #[serde(default)]
    pub(super) position: Vec<f64>,
}

impl JsonJointStateIn {
    /// `header.stamp` as (sec, nanosec).
    pub(super) fn stamp(&self) -> (i32, u32) {
        (self.header.stamp.sec, self.header.stamp.nanosec)
    }
}

/// Writes one JointState with `stamp`, an empty frame id, `names` and `position` (no
/// velocity or effort) into `buf` (cleared first).
pub(super) fn encode_joint_state(
    buf: &mut Vec<u8>,
    stamp: (i32, u32),
    names: &[String],
    position: &[f64],
) -> serde_json::Result<()> {
    buf.clear();
    let msg = JsonJointStateOut {
        header: JsonHeader {
            stamp: JsonStamp {
                sec: stamp.0,
                nanosec: stamp.1,
            },
            frame_id: String::new(),
        },
        name: names,
        position,
        velocity: &[],
        effort: &[],
    };
    serde_json::to_writer(buf, &msg)
}

/// Reads one JointState from a JSON message payload.
pub(super) fn decode_joint_state(payload: &[u8]) -> serde_json::Result<JsonJointStateIn> {
    serde_json::from_slice(payload)
}
