//! An arm given as its segments' poses in the world, the form a suit streams (Xsens MVN) and a
//! BVH importer computes for each joint: each segment's origin at the joint it hangs from (the
//! upper arm's at the shoulder, the forearm's at the elbow, the hand's at the wrist, the
//! clavicle's at the sternoclavicular joint on the upper torso), its orientation the identity
//! in the stream's null pose, whose axes are the body's (x forward, y left, z up: MVN §2.6.2,
//! "a perfect/ideal T-pose, where all segment orientations are set to identity"). So:
//!
//! - the upper torso's frame is the body axes of [`crate::Skeleton`];
//! - an arm point in body axes is `R_torsoᵀ (p − p_torso)`;
//! - a segment's turn from its rest orientation, in body axes, is `R_torsoᵀ R_segment`;
//! - the rest pose follows from any frame: each child's origin is a fixed point of its parent
//!   segment, `R_parentᵀ (p_child − p_parent)`, so the rest chain adds those offsets up with every
//!   rotation the identity;
//! - a stream with no point past the wrist (MVN's 23 segments end at the hand) ends the hand as
//!   the importer ends a BVH hand without an end: one forearm past the wrist at rest, turning
//!   with the hand (the fit uses only its direction, through the calibration).

use nalgebra::{Rotation3, Vector3};

use crate::skeleton::ArmPose;

/// A segment's pose in the world.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WorldPose {
    /// Position of the segment's origin.
    pub position: Vector3<f64>,
    /// Orientation: segment axes into world axes.
    pub rotation: Rotation3<f64>,
}

/// The upper torso and one arm's four segments in one frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ArmSegments {
    /// The upper torso the clavicle hangs from (MVN's `T8`).
    pub torso: WorldPose,
    /// The clavicle (MVN's `…Shoulder`).
    pub clavicle: WorldPose,
    /// The upper arm.
    pub upper_arm: WorldPose,
    /// The forearm.
    pub forearm: WorldPose,
    /// The hand.
    pub hand: WorldPose,
}

impl ArmSegments {
    /// The arm in this frame as the importer's [`ArmPose`]: points relative to the torso in its
    /// body axes; turns from the null pose in body axes.
    pub fn arm_pose(&self) -> ArmPose {
        let to_body = self.torso.rotation.inverse();
        let at = |p: &Vector3<f64>| to_body * (p - self.torso.position);
        let turn = |r: &Rotation3<f64>| to_body * r;
        let forearm_at_rest =
            self.forearm.rotation.inverse() * (self.hand.position - self.forearm.position);
        let wrist = at(&self.hand.position);
        ArmPose {
            clavicle: at(&self.clavicle.position),
            shoulder: at(&self.upper_arm.position),
            elbow: at(&self.forearm.position),
            wrist,
            hand_tip: wrist + turn(&self.hand.rotation) * forearm_at_rest,
            upper_arm_turn: turn(&self.upper_arm.rotation),
            hand_turn: turn(&self.hand.rotation),
        }
    }

    /// The arm in the null pose (every orientation the identity) with this frame's segment
    /// lengths: the importer's rest [`ArmPose`], what the calibration is made from.
    pub fn rest_arm_pose(&self) -> ArmPose {
        let offset = |parent: &WorldPose, child: &WorldPose| {
            parent.rotation.inverse() * (child.position - parent.position)
        };
        let c = offset(&self.torso, &self.clavicle);
        let s = c + offset(&self.clavicle, &self.upper_arm);
        let e = s + offset(&self.upper_arm, &self.forearm);
        let w = e + offset(&self.forearm, &self.hand);
        ArmPose {
            clavicle: c,
            shoulder: s,
            elbow: e,
            wrist: w,
            hand_tip: w + (w - e),
            upper_arm_turn: Rotation3::identity(),
            hand_turn: Rotation3::identity(),
        }
    }
}
