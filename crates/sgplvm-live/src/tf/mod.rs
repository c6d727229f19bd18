//! A person's skeleton as ROS 2 TF frames (`tf2_msgs/msg/TFMessage` on `/tf` and
//! `/tf_static`), as a mocap driver publishes one: IIT's `xsens_mvn_ros` bridge, a skeleton
//! tracker, a BVH replayed. `sgplvm teleop --input tf` takes it, `sgplvm replay --as tf`
//! publishes one.
//!
//! - [`buffer`]: the transforms received, per child frame (a short stamped history for `/tf`,
//!   the latched transform for `/tf_static`), a frame's pose composed along the tree, and
//!   whether a set of frames is complete at one stamp;
//! - [`fit`]: the tree through the capture importer's own steps: the frames named as `sgplvm
//!   import` names a file's joints (its naming schemes, namespace prefixes such as `actor1/`,
//!   or `--map FILE`), the tree's rest pose (every rotation the identity) the calibration, and
//!   each complete set fitted by the importer's [`PoseFitter`](sgplvm_capture::PoseFitter);
//! - [`sets`]: which complete set to fit next, and what became of the others;
//! - [`HumanTf`]: the human model's angles as a TF tree (what `replay --as tf` publishes).
//!
//! # Frame sets
//!
//! A TF publisher may put all of a time's transforms in one message or send them one by one;
//! either way a *frame set* is the transforms stamped with one time. The fit needs every frame
//! from the torso (the frame both arms hang from) down to both hands; a set is complete when
//! each of those has a transform stamped within [`STAMP_TOLERANCE_NS`] of the set's stamp, or
//! came on `/tf_static`. Frames above the torso (the world, the pelvis, the spine below it) are
//! not needed: the arms are fitted in the torso's own axes, so the whole body's motion stays
//! out. Each time the node looks, the newest complete set not used yet is fitted; older sets
//! not used are counted as superseded (complete) or incomplete (with the frames they lacked).

pub mod buffer;
pub mod fit;
pub mod sets;

use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};

use crate::msgs::{self, Header, TFMessage, Time, TransformStamped};
use crate::mvn::{HumanSegments, MvnError};

pub use buffer::{frame_id, ComposeError, TfBuffer, TransformError};
pub use fit::{identify, skeleton_of, Fitted, SetNotFitted};
pub use sets::{FrameSets, Next, SetCounts};

/// How far apart the stamps of one frame set's transforms may be, ns.
pub const STAMP_TOLERANCE_NS: i64 = 1_000_000;

/// The TF topic.
pub const TF_TOPIC: &str = "/tf";
/// The latched TF topic.
pub const TF_STATIC_TOPIC: &str = "/tf_static";

/// A TF transform from an isometry (child in parent).
pub fn transform(parent: &str, child: &str, stamp: Time, iso: &Isometry3<f64>) -> TransformStamped {
    let t = iso.translation.vector;
    let q = iso.rotation;
    TransformStamped {
        header: Header {
            stamp,
            frame_id: parent.to_string(),
        },
        child_frame_id: child.to_string(),
        transform: msgs::Transform {
            translation: msgs::Vector3 {
                x: t.x,
                y: t.y,
                z: t.z,
            },
            rotation: msgs::Quaternion {
                x: q.i,
                y: q.j,
                z: q.k,
                w: q.w,
            },
        },
    }
}

/// The human model's segments as a TF tree with Xsens MVN's names (one of the importer's
/// naming schemes), each name after a prefix (a namespace such as `actor1/`, or none):
///
/// - on `/tf_static`: `world` → `Pelvis` (1 m up), `Pelvis` → `T8` (0.42 m up), `T8` → `Neck`
///   (0.2 m up): the torso upright, every rotation the identity;
/// - on `/tf`, per frame: `T8` → `LeftShoulder` → `LeftUpperArm` → `LeftForeArm` →
///   `LeftHand`, the same on the right: each segment's pose in its parent's, the segments
///   placed and turned as [`HumanSegments`] places them (the human model's links at the
///   frame's angles, every orientation the identity in the T-pose).
pub struct HumanTf {
    segments: HumanSegments,
    prefix: String,
}

/// The dynamic frames of [`HumanTf`] and their parents.
const ARM_TREE: [(&str, &str); 8] = [
    ("T8", "LeftShoulder"),
    ("LeftShoulder", "LeftUpperArm"),
    ("LeftUpperArm", "LeftForeArm"),
    ("LeftForeArm", "LeftHand"),
    ("T8", "RightShoulder"),
    ("RightShoulder", "RightUpperArm"),
    ("RightUpperArm", "RightForeArm"),
    ("RightForeArm", "RightHand"),
];

impl HumanTf {
    /// The human model's tree, its frame names after `prefix`.
    pub fn new(prefix: &str) -> Result<HumanTf, MvnError> {
        Ok(HumanTf {
            segments: HumanSegments::new()?,
            prefix: prefix.to_string(),
        })
    }

    fn name(&self, frame: &str) -> String {
        format!("{}{frame}", self.prefix)
    }

    /// The static part of the tree (stamped `stamp`).
    pub fn static_message(&self, stamp: Time) -> TFMessage {
        let up = |z: f64| {
            Isometry3::from_parts(Translation3::new(0.0, 0.0, z), UnitQuaternion::identity())
        };
        let tree = [
            ("world", "Pelvis", 1.0),
            ("Pelvis", "T8", 0.42),
            ("T8", "Neck", 0.2),
        ];
        TFMessage {
            transforms: tree
                .iter()
                .map(|(p, c, z)| transform(&self.name(p), &self.name(c), stamp, &up(*z)))
                .collect(),
        }
    }

    /// The arms at the human model's angles `q` (its joint order), stamped `stamp`.
    pub fn message(&self, q: &[f64], stamp: Time) -> Result<TFMessage, MvnError> {
        let poses = self.segments.world_poses(q)?;
        let world = |name: &str| -> Result<Isometry3<f64>, MvnError> {
            let (_, p) =
                poses
                    .iter()
                    .find(|(n, _)| *n == name)
                    .ok_or_else(|| MvnError::Segment {
                        name: name.to_string(),
                        message: "not among the human model's segments".into(),
                    })?;
            Ok(Isometry3::from_parts(
                Translation3::from(Vector3::from(p.position)),
                UnitQuaternion::from_rotation_matrix(&p.rotation),
            ))
        };
        let mut transforms = Vec::with_capacity(ARM_TREE.len());
        for (parent, child) in ARM_TREE {
            let local = world(parent)?.inverse() * world(child)?;
            transforms.push(transform(
                &self.name(parent),
                &self.name(child),
                stamp,
                &local,
            ));
        }
        Ok(TFMessage { transforms })
    }
}

#[cfg(test)]
mod tests;
