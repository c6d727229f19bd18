//! The BVH (Biovision Hierarchy) reader: a skeleton of joints with offsets and channels, then
//! one line of channel values per frame.
//!
//! ```text
//! HIERARCHY
//! ROOT Hips                      one or more joints, nested in braces
//! {
//!   OFFSET 0 0 0                 from the parent joint, in the parent's frame
//!   CHANNELS 6 Xposition Yposition Zposition Zrotation Yrotation Xrotation
//!   JOINT Spine { ... }
//!   End Site { OFFSET 0 10 0 }   a segment's far end, no channels
//! }
//! MOTION
//! Frames: 2
//! Frame Time: 0.0083333
//! 0 90 0 0 0 0 ...               one line per frame, one value per declared channel
//! ```
//!
//! Any channel order is read (CMU's ZYX, Xsens's ZXY, 6-channel joints). Rotations are in
//! degrees and compose in the order the channels are listed (`Zrotation Xrotation Yrotation`
//! gives `R = Rz · Rx · Ry`, the convention of every BVH writer). Position channels, where a
//! joint has them, replace its OFFSET as the translation from its parent (Blender's reading),
//! at rest too ([`Bvh::rest_translation`]: files that give them on every joint may not repeat
//! the offsets in them).
//!
//! Every problem is a [`BvhError`] naming the file, the line and what was expected. Memory is
//! bounded by the file's size: a declared frame count is checked against the bytes that follow
//! before anything is allocated for it, and the hierarchy is read without recursion, with a
//! depth limit ([`MAX_DEPTH`]).
//!
//! The reader's parts: `parser` (words, numbers and the file's outline), `hierarchy` (the
//! joints) and `motion` (the frames).

mod hierarchy;
mod motion;
mod parser;

use std::path::Path;

use nalgebra::{Rotation3, Vector3};

use parser::Parser;

/// Deepest nesting of joints accepted (real skeletons have fewer than 30 levels).
pub const MAX_DEPTH: usize = 1000;

/// Longest frame time accepted, seconds (a capture samples many times a second).
pub const MAX_FRAME_TIME_S: f64 = 10.0;

/// Most joints accepted in one hierarchy.
pub const MAX_JOINTS: usize = 10_000;

/// A problem with a capture file (BVH, or CMU's ASF/AMC read into one): the file, the line
/// (1-based; 0 when it concerns the file as a whole) and what was expected.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum BvhError {
    /// The file could not be read.
    #[error("{file}: cannot read the file: {source}")]
    Io {
        /// The file.
        file: String,
        /// The operating system's reason.
        #[source]
        source: std::io::Error,
    },
    /// The text does not follow the BVH grammar, or a value is out of range.
    #[error("{file}:{line}: {message}")]
    Syntax {
        /// The file.
        file: String,
        /// 1-based line.
        line: usize,
        /// What was found and what was expected.
        message: String,
    },
}

/// One kind of channel.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Channel {
    /// Translation along x.
    Xposition,
    /// Translation along y.
    Yposition,
    /// Translation along z.
    Zposition,
    /// Rotation about x, degrees.
    Xrotation,
    /// Rotation about y, degrees.
    Yrotation,
    /// Rotation about z, degrees.
    Zrotation,
}

impl Channel {
    fn parse(word: &str) -> Option<Channel> {
        Some(match word.to_ascii_lowercase().as_str() {
            "xposition" => Channel::Xposition,
            "yposition" => Channel::Yposition,
            "zposition" => Channel::Zposition,
            "xrotation" => Channel::Xrotation,
            "yrotation" => Channel::Yrotation,
            "zrotation" => Channel::Zrotation,
            _ => return None,
        })
    }

    /// The axis index 0, 1, 2 (x, y, z).
    pub fn axis(self) -> usize {
        match self {
            Channel::Xposition | Channel::Xrotation => 0,
            Channel::Yposition | Channel::Yrotation => 1,
            Channel::Zposition | Channel::Zrotation => 2,
        }
    }

    /// Whether this is a rotation channel.
    pub fn is_rotation(self) -> bool {
        matches!(
            self,
            Channel::Xrotation | Channel::Yrotation | Channel::Zrotation
        )
    }
}

/// One joint of the hierarchy.
#[derive(Debug, Clone, PartialEq)]
pub struct BvhJoint {
    /// Name as written (e.g. `LeftForeArm`, `mixamorig:LeftArm`).
    pub name: String,
    /// Index of the parent joint; `None` for the root.
    pub parent: Option<usize>,
    /// Offset from the parent joint in the parent's frame (file units).
    pub offset: Vector3<f64>,
    /// Channels in the order of the frame values.
    pub channels: Vec<Channel>,
    /// Index of this joint's first channel within a frame.
    pub first_channel: usize,
    /// Offset of the End Site, if the joint ends a chain.
    pub end_site: Option<Vector3<f64>>,
    /// Line of the joint's declaration.
    pub line: usize,
}

impl BvhJoint {
    /// The local transform of this joint in one frame (`values` = that frame's channels):
    /// translation from the parent (offset, or the position channels where present) and
    /// rotation (the rotation channels composed in order).
    pub fn local(&self, values: &[f64]) -> (Vector3<f64>, Rotation3<f64>) {
        let mut t = self.offset;
        let mut r = Rotation3::identity();
        for (k, &c) in self.channels.iter().enumerate() {
            let v = values[self.first_channel + k];
            if c.is_rotation() {
                r *= axis_rotation(c.axis(), v.to_radians());
            } else {
                t[c.axis()] = v;
            }
        }
        (t, r)
    }

    /// Whether the joint has position channels.
    pub fn has_position(&self) -> bool {
        self.channels.iter().any(|c| !c.is_rotation())
    }
}

/// Rotation by `angle` radians about axis 0, 1 or 2.
pub(crate) fn axis_rotation(axis: usize, angle: f64) -> Rotation3<f64> {
    let (s, c) = angle.sin_cos();
    let m = match axis {
        0 => nalgebra::Matrix3::new(1.0, 0.0, 0.0, 0.0, c, -s, 0.0, s, c),
        1 => nalgebra::Matrix3::new(c, 0.0, s, 0.0, 1.0, 0.0, -s, 0.0, c),
        _ => nalgebra::Matrix3::new(c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0),
    };
    Rotation3::from_matrix_unchecked(m)
}

/// A parsed BVH file.
#[derive(Debug, Clone, PartialEq)]
pub struct Bvh {
    /// The joints, parents before children (declaration order).
    pub joints: Vec<BvhJoint>,
    /// Seconds between frames.
    pub frame_time: f64,
    /// Channels per frame.
    pub channels: usize,
    /// Frame values, row-major: frame `f` is `values[f * channels..(f + 1) * channels]`.
    pub values: Vec<f64>,
    /// Frame lines after the `Frames:` count, left out (an exporter's count one short: assimp's
    /// `Boxing_Toes.bvh`); 0 for a file that holds what it declares.
    pub frame_lines_left_out: usize,
}

impl Bvh {
    /// Reads and parses a BVH file.
    pub fn read(path: impl AsRef<Path>) -> Result<Bvh, BvhError> {
        let path = path.as_ref();
        let file = path.display().to_string();
        let bytes = std::fs::read(path).map_err(|source| BvhError::Io {
            file: file.clone(),
            source,
        })?;
        let text = String::from_utf8_lossy(&bytes);
        Bvh::parse(&text, &file)
    }

    /// Parses BVH text; `file` names it in errors.
    pub fn parse(text: &str, file: &str) -> Result<Bvh, BvhError> {
        Parser::new(text, file).parse()
    }

    /// Number of frames.
    pub fn frames(&self) -> usize {
        self.values.len().checked_div(self.channels).unwrap_or(0)
    }

    /// Channel values of frame `f`.
    pub fn frame(&self, f: usize) -> &[f64] {
        &self.values[f * self.channels..(f + 1) * self.channels]
    }

    /// Frames per second.
    pub fn frame_rate(&self) -> f64 {
        1.0 / self.frame_time
    }

    /// Index of the joint called `name` (exact match).
    pub fn joint(&self, name: &str) -> Option<usize> {
        self.joints.iter().position(|j| j.name == name)
    }

    /// Children of joint `j`, in declaration order.
    pub fn children(&self, j: usize) -> impl Iterator<Item = usize> + '_ {
        self.joints
            .iter()
            .enumerate()
            .filter(move |(_, c)| c.parent == Some(j))
            .map(|(i, _)| i)
    }

    /// Joints from `ancestor` (exclusive) down to `joint` (inclusive), top first; `None` if
    /// `ancestor` is not above `joint`.
    pub fn path(&self, ancestor: usize, joint: usize) -> Option<Vec<usize>> {
        let mut path = Vec::new();
        let mut cur = joint;
        while cur != ancestor {
            path.push(cur);
            cur = self.joints[cur].parent?;
        }
        path.reverse();
        Some(path)
    }

    /// Position of `joint` in the frame of `ancestor` with every rotation channel at zero (the
    /// file's rest pose), each joint translated from its parent as [`Bvh::rest_translation`].
    pub fn rest_position(&self, ancestor: usize, joint: usize) -> Option<Vector3<f64>> {
        Some(
            self.path(ancestor, joint)?
                .iter()
                .map(|&j| self.rest_translation(j))
                .sum(),
        )
    }

    /// Translation of `joint` from its parent at rest: its offset, or where the joint has
    /// position channels, their values in the first frame — a file that carries positions on
    /// every joint (Perception Neuron's exports) moves its bones by them, not by the offsets,
    /// and a stream of it (each joint's translation as the frame gives it) rests so.
    pub fn rest_translation(&self, joint: usize) -> Vector3<f64> {
        let j = &self.joints[joint];
        if j.has_position() && self.frames() > 0 {
            j.local(self.frame(0)).0
        } else {
            j.offset
        }
    }
}

#[cfg(test)]
mod tests;
