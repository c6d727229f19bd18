//! The human model's motion as a BVH file, for any animation tool (Blender, MotionBuilder)
//! and as the way back into [`crate::import_bvh`].
//!
//! The skeleton follows Xsens MVN's segment names (`T8`, `Neck`, `LeftShoulder` the clavicle,
//! `LeftUpperArm`, `LeftForeArm`, `LeftHand`), centimetres, y up, z forward, rotations as
//! `Zrotation Xrotation Yrotation` (MVN's order). Every channel at zero is the model's zero
//! configuration: arms hanging, palms towards the body.

use std::io::Write;
use std::path::Path;

use nalgebra::{Matrix3, Rotation3, Vector3};

use sgplvm_robots::joint_state::{JointStateError, Result};

/// Body axes (x forward, y left, z up) to the file's (x left, y up, z forward).
fn to_file() -> Matrix3<f64> {
    Matrix3::new(0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 1.0, 0.0, 0.0)
}

/// `Zrotation Xrotation Yrotation` angles (degrees) of `r`: `r = Rz(a) Rx(b) Ry(c)`.
fn zxy_degrees(r: &Matrix3<f64>) -> [f64; 3] {
    let b = r[(2, 1)].clamp(-1.0, 1.0).asin();
    let c = (-r[(2, 0)]).atan2(r[(2, 2)]);
    let a = (-r[(0, 1)]).atan2(r[(1, 1)]);
    [a.to_degrees(), b.to_degrees(), c.to_degrees()]
}

/// One arm's segment rotations (clavicle, upper arm, forearm, hand) relative to their parents,
/// in body axes, from its 9 angles; `left` chooses the axes' mirror.
fn segment_rotations(q: &[f64], left: bool) -> [Rotation3<f64>; 4] {
    // Axes of the left arm; the right arm's are (x, −y, z) negated.
    let about = |axis: [f64; 3], angle: f64| -> Rotation3<f64> {
        let a = if left {
            Vector3::from(axis)
        } else {
            -Vector3::new(axis[0], -axis[1], axis[2])
        };
        Rotation3::from_axis_angle(&nalgebra::Unit::new_normalize(a), angle)
    };
    [
        about([1.0, 0.0, 0.0], q[0]) * about([0.0, 0.0, -1.0], q[1]),
        about([0.0, -1.0, 0.0], q[2])
            * about([1.0, 0.0, 0.0], q[3])
            * about([0.0, 0.0, -1.0], q[4]),
        about([0.0, -1.0, 0.0], q[5]) * about([0.0, 0.0, 1.0], q[6]),
        about([-1.0, 0.0, 0.0], q[7]) * about([0.0, -1.0, 0.0], q[8]),
    ]
}

/// Segment offsets of the shipped human, metres, body axes: sternoclavicular joint from `T8`,
/// shoulder from it, elbow, wrist, hand end (left arm; the right mirrors y).
const OFFSETS: [[f64; 3]; 5] = [
    [0.0, 0.028, 0.15],
    [0.0, 0.14875, 0.0],
    [0.0, 0.0, -0.294],
    [0.0, 0.0, -0.2415],
    [0.0, 0.0, -0.189],
];

/// Writes `angles` (rows of the human model's 18 joint angles, left arm then right, radians)
/// at `frame_time` seconds per frame as a BVH file, atomically.
pub fn write_bvh(path: impl AsRef<Path>, frame_time: f64, angles: &[[f64; 18]]) -> Result<()> {
    let path = path.as_ref();
    let mut text = String::new();
    let b = to_file();
    let cm = |v: [f64; 3], left: bool| -> Vector3<f64> {
        let v = Vector3::new(v[0], if left { v[1] } else { -v[1] }, v[2]);
        b * v * 100.0
    };
    let v3 = |v: Vector3<f64>| format!("{:.4} {:.4} {:.4}", v.x, v.y, v.z);
    text.push_str("HIERARCHY\nROOT T8\n{\n  OFFSET 0 0 0\n  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation\n");
    text.push_str("  JOINT Neck\n  {\n    OFFSET 0 20 0\n    CHANNELS 3 Zrotation Xrotation Yrotation\n    End Site\n    {\n      OFFSET 0 10 0\n    }\n  }\n");
    for (side, left) in [("Left", true), ("Right", false)] {
        let names = ["Shoulder", "UpperArm", "ForeArm", "Hand"];
        for (depth, name) in names.iter().enumerate() {
            let pad = "  ".repeat(depth + 1);
            text.push_str(&format!(
                "{pad}JOINT {side}{name}\n{pad}{{\n{pad}  OFFSET {}\n{pad}  CHANNELS 3 Zrotation Xrotation Yrotation\n",
                v3(cm(OFFSETS[depth], left))
            ));
        }
        let pad = "  ".repeat(5);
        text.push_str(&format!(
            "{pad}End Site\n{pad}{{\n{pad}  OFFSET {}\n{pad}}}\n",
            v3(cm(OFFSETS[4], left))
        ));
        for depth in (0..4).rev() {
            text.push_str(&format!("{}}}\n", "  ".repeat(depth + 1)));
        }
    }
    text.push_str(&format!(
        "}}\nMOTION\nFrames: {}\nFrame Time: {frame_time:.8}\n",
        angles.len()
    ));
    for row in angles {
        let mut values: Vec<f64> = vec![0.0; 6 + 3];
        for (left, q) in [(true, &row[..9]), (false, &row[9..])] {
            for r in segment_rotations(q, left) {
                let m = b * r.matrix() * b.transpose();
                values.extend(zxy_degrees(&m));
            }
        }
        let line: Vec<String> = values.iter().map(|v| format!("{v:.6}")).collect();
        text.push_str(&line.join(" "));
        text.push('\n');
    }
    let tmp = sgplvm_robots::files::temporary_path(path);
    let io = |action: &'static str, source: std::io::Error| JointStateError::Io {
        path: path.to_path_buf(),
        action,
        source,
    };
    let mut f = std::fs::File::create(&tmp).map_err(|e| io("create", e))?;
    f.write_all(text.as_bytes()).map_err(|e| io("write", e))?;
    drop(f);
    std::fs::rename(&tmp, path).map_err(|e| io("rename into place", e))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bvh::axis_rotation;

    #[test]
    fn zxy_round_trips() {
        let r = axis_rotation(2, 0.3) * axis_rotation(0, -0.4) * axis_rotation(1, 1.1);
        let [a, b, c] = zxy_degrees(r.matrix());
        assert!((a - 0.3f64.to_degrees()).abs() < 1e-9);
        assert!((b + 0.4f64.to_degrees()).abs() < 1e-9);
        assert!((c - 1.1f64.to_degrees()).abs() < 1e-9);
    }
}
