//! CDR encoders (XCDR1 little-endian, as ROS 2's Fast-CDR writes them) and the `ros2msg`
//! schema texts of the messages a scene file carries — `sensor_msgs/msg/JointState` (the text
//! every JointState file of this crate records; its `.msg` follows ros2/common_interfaces as
//! roslibrust's generated ROS 2 definitions carry it, that repository's copy not being in our
//! index), `tf2_msgs/msg/TFMessage`, `std_msgs/msg/String`, `std_msgs/msg/Float64MultiArray` and
//! `visualization_msgs/msg/MarkerArray`.
//!
//! The schema texts are in the concatenated form rosbag2 stores (ros2/rosbag2,
//! `rosbag2_cpp/src/rosbag2_cpp/message_definitions/local_message_definition_source.cpp`,
//! `get_full_text`): the message's own `.msg` file, then each type it depends on, once, depth
//! first, the dependencies of one file in sorted order (a `std::set`), each after a newline, a
//! line of 80 `=` and a `MSG: pkg/Type` line. The `.msg` files under `msg/` are verbatim copies
//! of the ROS 2 (rolling) definitions: ros2/common_interfaces (`geometry_msgs`, `std_msgs`,
//! `sensor_msgs`, `visualization_msgs`: TransformStamped and Marker at commit 9da4a197, the
//! `std_msgs` multi-arrays at 72dfe423), ros2/rcl_interfaces (`builtin_interfaces` Time and
//! Duration) and ros2/geometry2 (`tf2_msgs/msg/TFMessage.msg`). The unit tests rebuild every
//! text with rosbag2's algorithm from those files and pin their bytes.
//!
//! The layout rules are those of [`crate::joint_state`]'s JointState codec: a 4-byte
//! encapsulation header, alignment counted from byte 4, strings as a `uint32` length including
//! the NUL, sequences as a `uint32` count.

use nalgebra::Isometry3;

use crate::joint_state::cdr::Cdr;

/// Schema name of a TF message.
pub const TF_MESSAGE_SCHEMA: &str = "tf2_msgs/msg/TFMessage";
/// Schema name of a string message.
pub const STRING_SCHEMA: &str = "std_msgs/msg/String";
/// Schema name of an array of float64.
pub const FLOAT64_MULTI_ARRAY_SCHEMA: &str = "std_msgs/msg/Float64MultiArray";
/// Schema name of an array of markers.
pub const MARKER_ARRAY_SCHEMA: &str = "visualization_msgs/msg/MarkerArray";

/// The text of `msg/<pkg>/<Type>.msg`.
macro_rules! msg {
    ($name:literal) => {
        include_str!(concat!("msg/", $name, ".msg"))
    };
}

/// A dependency as rosbag2 appends it: newline, 80 `=`, `MSG: pkg/Type`, its `.msg` text.
macro_rules! dep {
    ($name:literal) => {
        concat!(
            "\n",
            "================================================================================\n",
            "MSG: ",
            $name,
            "\n",
            msg!($name)
        )
    };
}

/// The `ros2msg` definition of `tf2_msgs/msg/TFMessage` with its dependencies.
pub const TF_MESSAGE_MSGDEF: &str = concat!(
    msg!("tf2_msgs/TFMessage"),
    dep!("geometry_msgs/TransformStamped"),
    dep!("geometry_msgs/Transform"),
    dep!("geometry_msgs/Quaternion"),
    dep!("geometry_msgs/Vector3"),
    dep!("std_msgs/Header"),
    dep!("builtin_interfaces/Time"),
);

/// The `ros2msg` definition of `sensor_msgs/msg/JointState` with its dependencies.
pub const JOINT_STATE_MSGDEF: &str = concat!(
    msg!("sensor_msgs/JointState"),
    dep!("std_msgs/Header"),
    dep!("builtin_interfaces/Time"),
);

/// The `ros2msg` definition of `std_msgs/msg/String` (no dependencies).
pub const STRING_MSGDEF: &str = msg!("std_msgs/String");

/// The `ros2msg` definition of `std_msgs/msg/Float64MultiArray` with its dependencies.
pub const FLOAT64_MULTI_ARRAY_MSGDEF: &str = concat!(
    msg!("std_msgs/Float64MultiArray"),
    dep!("std_msgs/MultiArrayLayout"),
    dep!("std_msgs/MultiArrayDimension"),
);

/// The `ros2msg` definition of `visualization_msgs/msg/MarkerArray` with its dependencies.
pub const MARKER_ARRAY_MSGDEF: &str = concat!(
    msg!("visualization_msgs/MarkerArray"),
    dep!("visualization_msgs/Marker"),
    dep!("builtin_interfaces/Duration"),
    dep!("geometry_msgs/Point"),
    dep!("geometry_msgs/Pose"),
    dep!("geometry_msgs/Quaternion"),
    dep!("geometry_msgs/Vector3"),
    dep!("sensor_msgs/CompressedImage"),
    dep!("std_msgs/Header"),
    dep!("builtin_interfaces/Time"),
    dep!("std_msgs/ColorRGBA"),
    dep!("visualization_msgs/MeshFile"),
    dep!("visualization_msgs/UVCoordinate"),
);

/// `builtin_interfaces/Time` of a log time in nanoseconds.
/// (A duration's `builtin_interfaces/Duration` likewise.)
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

/// `visualization_msgs/msg/Marker` types this crate writes.
pub(crate) const MARKER_SPHERE: i32 = 2;
/// A text that always faces the viewer.
pub(crate) const MARKER_TEXT_VIEW_FACING: i32 = 9;

/// One `visualization_msgs/msg/Marker` (action ADD, no points, texture or mesh).
#[derive(Debug, Clone, Copy)]
pub(crate) struct MarkerFields<'a> {
    /// `header.frame_id`.
    pub frame: &'a str,
    /// `ns`.
    pub ns: &'a str,
    /// `id`.
    pub id: i32,
    /// `type`.
    pub kind: i32,
    /// `pose.position` (orientation identity).
    pub position: [f64; 3],
    /// `scale`.
    pub scale: [f64; 3],
    /// `color` (r, g, b, a).
    pub color: [f32; 4],
    /// `lifetime`, nanoseconds.
    pub lifetime_ns: i64,
    /// `text`.
    pub text: &'a str,
}

/// Encodes a `visualization_msgs/msg/MarkerArray`, every marker stamped `stamp`.
pub(crate) fn encode_marker_array(
    buf: &mut Vec<u8>,
    stamp: (i32, u32),
    markers: &[MarkerFields<'_>],
) {
    let mut w = Cdr::begin(buf);
    w.u32(markers.len() as u32);
    for m in markers {
        w.header(stamp, m.frame);
        w.string(m.ns);
        w.i32(m.id);
        w.i32(m.kind);
        w.i32(0); // action ADD
        for v in m.position {
            w.f64(v);
        }
        for v in [0.0, 0.0, 0.0, 1.0] {
            w.f64(v); // orientation x, y, z, w
        }
        for v in m.scale {
            w.f64(v);
        }
        for v in m.color {
            w.f32(v);
        }
        let (sec, nanosec) = self::stamp(m.lifetime_ns);
        w.i32(sec);
        w.u32(nanosec);
        w.bool(false); // frame_locked
        w.u32(0); // points
        w.u32(0); // colors
        w.string(""); // texture_resource
        w.header((0, 0), ""); // texture.header
        w.string(""); // texture.format
        w.u32(0); // texture.data
        w.u32(0); // uv_coordinates
        w.string(m.text);
        w.string(""); // mesh_resource
        w.string(""); // mesh_file.filename
        w.u32(0); // mesh_file.data
        w.bool(false); // mesh_use_embedded_materials
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

    /// Every `.msg` file under `msg/`, by `pkg/Type`.
    const FILES: &[(&str, &str)] = &[
        ("tf2_msgs/TFMessage", msg!("tf2_msgs/TFMessage")),
        (
            "geometry_msgs/TransformStamped",
            msg!("geometry_msgs/TransformStamped"),
        ),
        ("geometry_msgs/Transform", msg!("geometry_msgs/Transform")),
        ("geometry_msgs/Quaternion", msg!("geometry_msgs/Quaternion")),
        ("geometry_msgs/Vector3", msg!("geometry_msgs/Vector3")),
        ("geometry_msgs/Point", msg!("geometry_msgs/Point")),
        ("geometry_msgs/Pose", msg!("geometry_msgs/Pose")),
        ("std_msgs/Header", msg!("std_msgs/Header")),
        ("std_msgs/String", msg!("std_msgs/String")),
        ("std_msgs/ColorRGBA", msg!("std_msgs/ColorRGBA")),
        (
            "std_msgs/Float64MultiArray",
            msg!("std_msgs/Float64MultiArray"),
        ),
        (
            "std_msgs/MultiArrayLayout",
            msg!("std_msgs/MultiArrayLayout"),
        ),
        (
            "std_msgs/MultiArrayDimension",
            msg!("std_msgs/MultiArrayDimension"),
        ),
        ("builtin_interfaces/Time", msg!("builtin_interfaces/Time")),
        (
            "builtin_interfaces/Duration",
            msg!("builtin_interfaces/Duration"),
        ),
        (
            "sensor_msgs/CompressedImage",
            msg!("sensor_msgs/CompressedImage"),
        ),
        ("sensor_msgs/JointState", msg!("sensor_msgs/JointState")),
        (
            "visualization_msgs/MarkerArray",
            msg!("visualization_msgs/MarkerArray"),
        ),
        (
            "visualization_msgs/Marker",
            msg!("visualization_msgs/Marker"),
        ),
        (
            "visualization_msgs/MeshFile",
            msg!("visualization_msgs/MeshFile"),
        ),
        (
            "visualization_msgs/UVCoordinate",
            msg!("visualization_msgs/UVCoordinate"),
        ),
    ];

    /// rosbag2's `parse_msg_dependencies`: the first word of every line that is a type
    /// (`[a-zA-Z0-9_/]+`, an optional `[...]`, then white space), primitives left out, names
    /// without a package completed with the file's own; sorted (a `std::set`).
    fn dependencies(text: &str, package: &str) -> std::collections::BTreeSet<String> {
        const PRIMITIVES: [&str; 14] = [
            "bool", "byte", "char", "float32", "float64", "int8", "uint8", "int16", "uint16",
            "int32", "uint32", "int64", "uint64", "string",
        ];
        let mut out = std::collections::BTreeSet::new();
        for line in text.lines() {
            let line = line.trim_start();
            let end = line
                .find(|c: char| !(c.is_ascii_alphanumeric() || c == '_' || c == '/'))
                .unwrap_or(line.len());
            let (word, rest) = line.split_at(end);
            let rest = match rest.strip_prefix('[') {
                Some(r) => r.split_once(']').map_or("", |(_, after)| after),
                None => rest,
            };
            if word.is_empty() || !rest.starts_with(char::is_whitespace) {
                continue;
            }
            if PRIMITIVES.contains(&word) {
                continue;
            }
            out.insert(if word.contains('/') {
                word.to_string()
            } else {
                format!("{package}/{word}")
            });
        }
        out
    }

    /// rosbag2's `get_full_text` for a `.msg` root: its text, then each dependency not yet
    /// seen, depth first, after a newline and the two-line delimiter.
    fn full_text(name: &str, seen: &mut std::collections::BTreeSet<String>) -> String {
        let text = FILES
            .iter()
            .find(|(n, _)| *n == name)
            .unwrap_or_else(|| panic!("no msg/{name}.msg"))
            .1;
        let package = name.split('/').next().expect("package");
        let mut out = text.to_string();
        for dep in dependencies(text, package) {
            if seen.insert(dep.clone()) {
                out += &format!("\n{}\nMSG: {dep}\n", "=".repeat(80));
                out += &full_text(&dep, seen);
            }
        }
        out
    }

    /// FNV-1a, 64 bits: a fixed fingerprint of the bytes.
    fn fnv1a(bytes: &[u8]) -> u64 {
        bytes.iter().fold(0xcbf2_9ce4_8422_2325, |h, &b| {
            (h ^ b as u64).wrapping_mul(0x100_0000_01b3)
        })
    }

    #[test]
    fn schema_texts_are_what_rosbag2_builds_from_the_ros2_msg_files() {
        for (schema, def) in [
            (TF_MESSAGE_SCHEMA, TF_MESSAGE_MSGDEF),
            (crate::joint_state::JOINT_STATE_SCHEMA, JOINT_STATE_MSGDEF),
            (STRING_SCHEMA, STRING_MSGDEF),
            (FLOAT64_MULTI_ARRAY_SCHEMA, FLOAT64_MULTI_ARRAY_MSGDEF),
            (MARKER_ARRAY_SCHEMA, MARKER_ARRAY_MSGDEF),
        ] {
            let root = schema.replace("/msg/", "/");
            assert_eq!(def, full_text(&root, &mut Default::default()), "{schema}");
        }
        // As a rosbag2 recording orders TFMessage's dependencies.
        let order: Vec<&str> = TF_MESSAGE_MSGDEF
            .lines()
            .filter_map(|l| l.strip_prefix("MSG: "))
            .collect();
        assert_eq!(
            order,
            [
                "geometry_msgs/TransformStamped",
                "geometry_msgs/Transform",
                "geometry_msgs/Quaternion",
                "geometry_msgs/Vector3",
                "std_msgs/Header",
                "builtin_interfaces/Time"
            ]
        );
    }

    /// (length, FNV-1a) of TFMessage, String, Float64MultiArray, MarkerArray and JointState.
    const PINNED: [(usize, u64); 5] = [
        (2683, 0xe9bb_e709_f5e9_0018),
        (263, 0xbc47_e64e_7647_4eae),
        (2241, 0x6d76_9c22_7dc2_0db9),
        (9256, 0xbdb1_ea18_c962_5e52),
        (1955, 0xa5d6_f35c_30d0_4f48),
    ];

    #[test]
    fn schema_text_bytes_are_pinned() {
        let pinned: Vec<(usize, u64)> = [
            TF_MESSAGE_MSGDEF,
            STRING_MSGDEF,
            FLOAT64_MULTI_ARRAY_MSGDEF,
            MARKER_ARRAY_MSGDEF,
            JOINT_STATE_MSGDEF,
        ]
        .iter()
        .map(|d| (d.len(), fnv1a(d.as_bytes())))
        .collect();
        assert_eq!(pinned, PINNED, "{pinned:#x?}");
    }
}
