//! CDR encoders (XCDR1 little-endian, as ROS 2's Fast-CDR writes them) and the `ros2msg`
//! schema texts of the messages a scene file carries beside its joint states:
//! `tf2_msgs/msg/TFMessage`, `std_msgs/msg/String` and `std_msgs/msg/Float64MultiArray`.
//!
//! The schema texts are in the concatenated form rosbag2 stores: the message's own definition,
//! then every type it depends on (depth first, each once) after a line of 80 `=` and a
//! `MSG: pkg/Type` line. The layout rules are those of [`crate::joint_state`]'s JointState
//! codec: a 4-byte encapsulation header, alignment counted from byte 4, strings as a `uint32`
//! length including the NUL, sequences as a `uint32` count.

use nalgebra::Isometry3;

use crate::joint_state::cdr::Cdr;

/// Schema name of a TF message.
pub const TF_MESSAGE_SCHEMA: &str = "tf2_msgs/msg/TFMessage";
/// Schema name of a string message.
pub const STRING_SCHEMA: &str = "std_msgs/msg/String";
/// Schema name of an array of float64.
pub const FLOAT64_MULTI_ARRAY_SCHEMA: &str = "std_msgs/msg/Float64MultiArray";

/// The `ros2msg` definition of `tf2_msgs/msg/TFMessage` with its dependencies.
pub const TF_MESSAGE_MSGDEF: &str = "\
geometry_msgs/TransformStamped[] transforms

================================================================================
MSG: geometry_msgs/TransformStamped
# This expresses a transform from coordinate frame header.frame_id
# to the coordinate frame child_frame_id at the time of header.stamp
#
# This message is mostly used by the
# <a href=\"https://docs.ros.org/en/rolling/p/tf2/\">tf2</a> package.
# See its documentation for more information.
#
# The child_frame_id is necessary in addition to the frame_id
# in the Header to communicate the full reference for the transform
# in a self contained message.

# The frame id in the header is used as the reference frame of this transform.
std_msgs/Header header

# The frame id of the child frame to which this transform points.
string child_frame_id

# Translation and rotation in 3-dimensions of child_frame_id from header.frame_id.
Transform transform

================================================================================
MSG: std_msgs/Header
# Standard metadata for higher-level stamped data types.
# This is generally used to communicate timestamped data
# in a particular coordinate frame.

# Two-integer timestamp that is expressed as seconds and nanoseconds.
builtin_interfaces/Time stamp

# Transform frame with which this data is associated.
string frame_id

================================================================================
MSG: builtin_interfaces/Time
# This message communicates ROS Time defined here:
# https://design.ros2.org/articles/clock_and_time.html

# The seconds component, valid over all int32 values.
int32 sec

# The nanoseconds component, valid in the range [0, 1e9), to be added to the seconds component.
# e.g.
# The time -1.7 seconds is represented as {sec: -2, nanosec: 3e8}
# The time 1.7 seconds is represented as {sec: 1, nanosec: 7e8}
uint32 nanosec

================================================================================
MSG: geometry_msgs/Transform
# This represents the transform between two coordinate frames in free space.

Vector3 translation
Quaternion rotation

================================================================================
MSG: geometry_msgs/Vector3
# This represents a vector in free space.

# This is semantically different than a point.
# A vector is always anchored at the origin.
# When a transform is applied to a vector, only the rotational component is applied.

float64 x
float64 y
float64 z

================================================================================
MSG: geometry_msgs/Quaternion
# This represents an orientation in free space in quaternion form.

float64 x 0
float64 y 0
float64 z 0
float64 w 1
";

/// The `ros2msg` definition of `std_msgs/msg/String` (no dependencies).
pub const STRING_MSGDEF: &str = "\
# This was originally provided as an example message.
# It is deprecated as of Foxy
# It is recommended to create your own semantically meaningful message.
# However if you would like to continue using this please use the equivalent in example_msgs.

string data
";

/// The `ros2msg` definition of `std_msgs/msg/Float64MultiArray` with its dependencies.
pub const FLOAT64_MULTI_ARRAY_MSGDEF: &str = "\
# This was originally provided as an example message.
# It is deprecated as of Foxy
# It is recommended to create your own semantically meaningful message.
# However if you would like to continue using this please use the equivalent in example_msgs.

# Please look at the MultiArrayLayout message definition for
# documentation on all multiarrays.

MultiArrayLayout  layout        # specification of data layout
float64[]         data          # array of data

================================================================================
MSG: std_msgs/MultiArrayLayout
# The multiarray declares a generic multi-dimensional array of a
# particular data type.  Dimensions are ordered from outer most
# to inner most.
#
# Accessors should ALWAYS be written in terms of dimension stride
# and specified outer-most dimension first.
#
# multiarray(i,j,k) = data[data_offset + dim_stride[1]*i + dim_stride[2]*j + k]
#
# A standard, 3-channel 640x480 image with interleaved color channels
# would be specified as:
#
# dim[0].label  = \"height\"
# dim[0].size   = 480
# dim[0].stride = 3*640*480 = 921600  (note dim[0] stride is just size of image)
# dim[1].label  = \"width\"
# dim[1].size   = 640
# dim[1].stride = 3*640 = 1920
# dim[2].label  = \"channel\"
# dim[2].size   = 3
# dim[2].stride = 3
#
# multiarray(i,j,k) refers to the ith row, jth column, and kth channel.

MultiArrayDimension[] dim # Array of dimension properties
uint32 data_offset        # padding elements at front of data

================================================================================
MSG: std_msgs/MultiArrayDimension
string label   # label of given dimension
uint32 size    # size of given dimension (in type units)
uint32 stride  # stride of given dimension
";

/// `builtin_interfaces/Time` of a log time in nanoseconds.
pub(crate) fn stamp(time_ns: i64) -> (i32, u32) {
    (
        time_ns
            .div_euclid(1_000_000_000)
            .clamp(i32::MIN as i64, i32::MAX as i64) as i32,
        time_ns.rem_euclid(1_000_000_000) as u32,
    )
}

/// One transform of a TF message: `parent` → `child`, the pose of the child in the parent.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Transform<'a> {
    /// `header.frame_id`.
    pub parent: &'a str,
    /// `child_frame_id`.
    pub child: &'a str,
    /// Pose of the child frame in the parent frame.
    pub pose: Isometry3<f64>,
}

/// Encodes a `tf2_msgs/msg/TFMessage` with every transform stamped `stamp`.
pub(crate) fn encode_tf_message(buf: &mut Vec<u8>, stamp: (i32, u32), transforms: &[Transform]) {
    let mut w = Cdr::begin(buf);
    w.u32(transforms.len() as u32);
    for t in transforms {
        w.header(stamp, t.parent);
        w.string(t.child);
        let p = t.pose.translation.vector;
        let q = t.pose.rotation.quaternion();
        for v in [p.x, p.y, p.z, q.i, q.j, q.k, q.w] {
            w.f64(v);
        }
    }
}

/// Encodes a `std_msgs/msg/String`.
pub(crate) fn encode_string(buf: &mut Vec<u8>, data: &str) {
    Cdr::begin(buf).string(data);
}

/// Encodes a one-dimensional `std_msgs/msg/Float64MultiArray` whose dimension is `label`.
pub(crate) fn encode_float64_array(buf: &mut Vec<u8>, label: &str, data: &[f64]) {
    let mut w = Cdr::begin(buf);
    w.u32(1);
    w.string(label);
    w.u32(data.len() as u32);
    w.u32(data.len() as u32);
    w.u32(0);
    w.u32(data.len() as u32);
    for &v in data {
        w.f64(v);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Translation3, UnitQuaternion};

    #[test]
    fn tf_message_has_the_ros2_byte_layout() {
        let mut buf = Vec::new();
        let pose = Isometry3::from_parts(
            Translation3::new(1.0, 2.0, 3.0),
            UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(1.0, 0.0, 0.0, 0.0)),
        );
        let t = Transform {
            parent: "a",
            child: "bc",
            pose,
        };
        encode_tf_message(&mut buf, (5, 6), &[t]);
        let expected: Vec<u8> = [
            &[0u8, 1, 0, 0][..],
            &1u32.to_le_bytes(), // one transform (offset 0)
            &5i32.to_le_bytes(), // stamp.sec (4)
            &6u32.to_le_bytes(), // stamp.nanosec (8)
            &2u32.to_le_bytes(), // "a\0" (12)
            &[b'a', 0, 0, 0],    // + pad to 4 (16..20)
            &3u32.to_le_bytes(), // "bc\0" (20)
            &[b'b', b'c', 0],    // (24..27)
            &[0, 0, 0, 0, 0],    // pad to 8 (27..32)
            &1.0f64.to_le_bytes(),
            &2.0f64.to_le_bytes(),
            &3.0f64.to_le_bytes(),
            &0.0f64.to_le_bytes(),
            &0.0f64.to_le_bytes(),
            &0.0f64.to_le_bytes(),
            &1.0f64.to_le_bytes(), // w last
        ]
        .concat();
        assert_eq!(buf, expected);
    }

    #[test]
    fn float64_array_and_string_layouts() {
        let mut buf = Vec::new();
        encode_float64_array(&mut buf, "j", &[0.5]);
        let expected: Vec<u8> = [
            &[0u8, 1, 0, 0][..],
            &1u32.to_le_bytes(), // one dimension
            &2u32.to_le_bytes(), // label "j\0"
            &[b'j', 0, 0, 0],
            &1u32.to_le_bytes(), // size
            &1u32.to_le_bytes(), // stride
            &0u32.to_le_bytes(), // data_offset (offset 20)
            &1u32.to_le_bytes(), // data length (24)
            &[0, 0, 0, 0],       // pad: float64 aligned to 8 from byte 4 (28..32)
            &0.5f64.to_le_bytes(),
        ]
        .concat();
        assert_eq!(buf, expected);
        encode_string(&mut buf, "hi");
        assert_eq!(buf, [0, 1, 0, 0, 3, 0, 0, 0, b'h', b'i', 0]);
    }

    #[test]
    fn stamps_split_nanoseconds() {
        assert_eq!(stamp(1_500_000_000), (1, 500_000_000));
        assert_eq!(stamp(0), (0, 0));
    }

    #[test]
    fn schema_texts_separate_dependencies_as_rosbag2_does() {
        let sep = format!("\n{}\nMSG: ", "=".repeat(80));
        for (def, deps) in [
            (TF_MESSAGE_MSGDEF, 6),
            (FLOAT64_MULTI_ARRAY_MSGDEF, 2),
            (STRING_MSGDEF, 0),
        ] {
            assert_eq!(def.matches(&sep).count(), deps);
        }
    }
}
