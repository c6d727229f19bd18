//! The ROS 2 messages the live node reads and writes, field for field as their `.msg`
//! definitions (CDR through serde, as `ros2-client` encodes them), with their type names.
//!
//! Type names go on the wire as ROS 2 writes them (`sensor_msgs::msg::dds_::JointState_`):
//! [`ros2_client::MessageTypeName`] builds that form from the package and type names below, so
//! that `ros2 topic echo`, Foxglove and any ROS 2 node decode what we publish.

use serde::{Deserialize, Serialize};

/// `builtin_interfaces/msg/Time`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct Time {
    /// Seconds.
    pub sec: i32,
    /// Nanoseconds, below 10⁹.
    pub nanosec: u32,
}

impl Time {
    /// From nanoseconds since the epoch (negative times clamp to 0; beyond 2038 to i32::MAX).
    pub fn from_ns(ns: i64) -> Time {
        let ns = ns.max(0);
        Time {
            sec: (ns / 1_000_000_000).min(i32::MAX as i64) as i32,
            nanosec: (ns % 1_000_000_000) as u32,
        }
    }

    /// Nanoseconds since the epoch.
    pub fn to_ns(self) -> i64 {
        self.sec as i64 * 1_000_000_000 + self.nanosec as i64
    }
}

/// `builtin_interfaces/msg/Duration`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct Duration {
    /// Seconds.
    pub sec: i32,
    /// Nanoseconds, below 10⁹.
    pub nanosec: u32,
}

/// `std_msgs/msg/Header`.
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct Header {
    /// When the data was measured (for commands: the human frame they answer).
    pub stamp: Time,
    /// Coordinate frame.
    pub frame_id: String,
}

/// `sensor_msgs/msg/JointState`.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct JointState {
    /// Stamp and frame.
    pub header: Header,
    /// Joint names.
    pub name: Vec<String>,
    /// Positions (rad or m).
    pub position: Vec<f64>,
    /// Velocities.
    pub velocity: Vec<f64>,
    /// Efforts.
    pub effort: Vec<f64>,
}

/// `std_msgs/msg/MultiArrayDimension`.
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct MultiArrayDimension {
    /// Label of the dimension.
    pub label: String,
    /// Size of the dimension.
    pub size: u32,
    /// Stride of the dimension.
    pub stride: u32,
}

/// `std_msgs/msg/MultiArrayLayout`.
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct MultiArrayLayout {
    /// Dimensions.
    pub dim: Vec<MultiArrayDimension>,
    /// Padding elements at the front of `data`.
    pub data_offset: u32,
}

/// `std_msgs/msg/Float64MultiArray`: what ros2_control's forward position controller takes.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct Float64MultiArray {
    /// Layout (one dimension named `joints` here).
    pub layout: MultiArrayLayout,
    /// Values.
    pub data: Vec<f64>,
}

/// `trajectory_msgs/msg/JointTrajectoryPoint`.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct JointTrajectoryPoint {
    /// Positions.
    pub positions: Vec<f64>,
    /// Velocities.
    pub velocities: Vec<f64>,
    /// Accelerations.
    pub accelerations: Vec<f64>,
    /// Efforts.
    pub effort: Vec<f64>,
    /// When the point is to be reached, from the trajectory's start.
    pub time_from_start: Duration,
}

/// `trajectory_msgs/msg/JointTrajectory`: what ros2_control's joint trajectory controller takes.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct JointTrajectory {
    /// Stamp (the human frame answered) and frame.
    pub header: Header,
    /// Joint names.
    pub joint_names: Vec<String>,
    /// The points (one here).
    pub points: Vec<JointTrajectoryPoint>,
}

/// `xbot_msgs/msg/JointCommand`, the command of XBot2 (the middleware of WALK-MAN, COMAN and
/// CENTAURO), as its ROS 2 package defines it (ADVRHumanoids/xbot_msgs, `msg/JointCommand.msg`
/// at commit 61f26da).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct XbotJointCommand {
    /// Stamp and frame.
    pub header: Header,
    /// Joint names.
    pub name: Vec<String>,
    /// Stamp feedback.
    pub stamp_rx_feedback: u64,
    /// Desired positions.
    pub position: Vec<f32>,
    /// Desired velocities.
    pub velocity: Vec<f32>,
    /// Desired efforts.
    pub effort: Vec<f32>,
    /// Stiffness.
    pub stiffness: Vec<f32>,
    /// Damping.
    pub damping: Vec<f64>,
    /// Per joint, which of the fields above apply (a bit mask; 1 = position).
    pub ctrl_mode: Vec<u8>,
    /// Name of the auxiliary field.
    pub aux_name: String,
    /// Auxiliary values.
    pub aux: Vec<f32>,
}

/// XBot2's control-mode bit for position.
pub const XBOT_CTRL_POSITION: u8 = 1;

/// `diagnostic_msgs/msg/KeyValue`.
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct KeyValue {
    /// Key.
    pub key: String,
    /// Value.
    pub value: String,
}

/// `diagnostic_msgs/msg/DiagnosticStatus`.
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct DiagnosticStatus {
    /// [`OK`], [`WARN`], [`ERROR`] or [`STALE`].
    pub level: u8,
    /// What is described (here `sgplvm/ROBOT`).
    pub name: String,
    /// A readable summary.
    pub message: String,
    /// Hardware identifier (the robot).
    pub hardware_id: String,
    /// Details.
    pub values: Vec<KeyValue>,
}

/// Diagnostic level: fine.
pub const OK: u8 = 0;
/// Diagnostic level: a warning.
pub const WARN: u8 = 1;
/// Diagnostic level: an error.
pub const ERROR: u8 = 2;
/// Diagnostic level: stale input.
pub const STALE: u8 = 3;

/// `diagnostic_msgs/msg/DiagnosticArray`.
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct DiagnosticArray {
    /// Stamp.
    pub header: Header,
    /// One status per robot (and one for the node).
    pub status: Vec<DiagnosticStatus>,
}

/// `geometry_msgs/msg/Vector3`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Vector3 {
    /// x.
    pub x: f64,
    /// y.
    pub y: f64,
    /// z.
    pub z: f64,
}

/// `geometry_msgs/msg/Quaternion` (x, y, z, w in this order on the wire).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Quaternion {
    /// i part.
    pub x: f64,
    /// j part.
    pub y: f64,
    /// k part.
    pub z: f64,
    /// Real part.
    pub w: f64,
}

impl Default for Quaternion {
    /// The identity, as the `.msg` file's default (`w 1`).
    fn default() -> Self {
        Quaternion {
            x: 0.0,
            y: 0.0,
            z: 0.0,
            w: 1.0,
        }
    }
}

/// `geometry_msgs/msg/Transform`: a child frame's pose in its parent's frame.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Transform {
    /// The child's origin in the parent's frame, metres.
    pub translation: Vector3,
    /// The child's axes in the parent's frame.
    pub rotation: Quaternion,
}

/// `geometry_msgs/msg/TransformStamped`.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct TransformStamped {
    /// Stamp, and the parent frame in `frame_id`.
    pub header: Header,
    /// The child frame.
    pub child_frame_id: String,
    /// The child's pose in the parent's frame.
    pub transform: Transform,
}

/// `tf2_msgs/msg/TFMessage`: what `/tf` and `/tf_static` carry.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct TFMessage {
    /// The transforms.
    pub transforms: Vec<TransformStamped>,
}

/// ROS 2 package and type name of each message above.
pub mod types {
    /// `sensor_msgs/msg/JointState`.
    pub const JOINT_STATE: (&str, &str) = ("sensor_msgs", "JointState");
    /// `std_msgs/msg/Float64MultiArray`.
    pub const FLOAT64_MULTI_ARRAY: (&str, &str) = ("std_msgs", "Float64MultiArray");
    /// `trajectory_msgs/msg/JointTrajectory`.
    pub const JOINT_TRAJECTORY: (&str, &str) = ("trajectory_msgs", "JointTrajectory");
    /// `xbot_msgs/msg/JointCommand`.
    pub const XBOT_JOINT_COMMAND: (&str, &str) = ("xbot_msgs", "JointCommand");
    /// `diagnostic_msgs/msg/DiagnosticArray`.
    pub const DIAGNOSTIC_ARRAY: (&str, &str) = ("diagnostic_msgs", "DiagnosticArray");
    /// `tf2_msgs/msg/TFMessage`.
    pub const TF_MESSAGE: (&str, &str) = ("tf2_msgs", "TFMessage");
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn times_convert_both_ways() {
        let t = Time::from_ns(1_700_000_000_123_456_789);
        assert_eq!((t.sec, t.nanosec), (1_700_000_000, 123_456_789));
        assert_eq!(t.to_ns(), 1_700_000_000_123_456_789);
        assert_eq!(Time::from_ns(-5), Time::default());
    }
}
