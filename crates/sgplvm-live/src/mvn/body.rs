//! A frame as the capture importer sees a skeleton: named segment world poses (what a BVH
//! importer computes for each joint), and each arm as the importer's per-frame
//! [`ArmPose`], in the torso's body axes.
//!
//! MVN's segment frames make this direct. Each segment's origin is the joint it hangs from
//! (`RightUpperArm` at the shoulder, `RightForeArm` at the elbow, `RightHand` at the wrist,
//! `RightShoulder` at the sternoclavicular joint on `T8`), and in MVN's null pose every
//! orientation is the identity with the axes x forward, y left, z up (§2.6.2: "a perfect/ideal
//! T-pose, where all segment orientations are set to identity"). So:
//!
//! - `T8`'s frame is the body axes of [`Skeleton`](sgplvm_capture::Skeleton) (the
//!   torso the clavicles hang from, x forward, y left, z up, as the human model's `T8`);
//! - an arm point in body axes is `R_T8ᵀ (p − p_T8)`;
//! - a segment's turn from its rest orientation, in body axes, is `R_T8ᵀ R_segment` (its
//!   rest, the null pose, is the identity relative to `T8` as well);
//! - the rest pose (T-pose) follows from any frame: each child's origin is a fixed point of its
//!   parent segment, `R_parentᵀ (p_child − p_parent)`, so the rest chain adds those offsets up
//!   with every rotation the identity;
//! - MVN streams no point past the wrist (the 23 segments end at `Hand`), so the hand's end is
//!   taken as the importer takes it for a BVH hand without an end: one forearm vector past the
//!   wrist at rest (`wrist + (wrist − elbow)`), turning with the hand. The fit uses only its
//!   direction.
//!
//! # Feeding the importer's fit (what the node calls)
//!
//! ```text
//! let model = HumanArms::new(&Robot::builtin("human")?)?;          // once
//! let rest = pose.rest_arm_pose(side)?;                             // once, or on recalibration
//! // calibration, as capture::import's `calibrate` does with a BVH rest pose:
//! //   t = arm_target(&rest, side, true, identity frames); hand = direction(rest.wrist → rest.hand_tip)
//! //   rest_frames = model.rest_frames(t.clavicle, t.upper_arm, t.forearm, hand)  (right arm mirrored)
//! let arm = pose.arm_pose(side)?;                                   // every frame
//! //   target = arm_target(&arm, side, true, &calibration); fit = model.fit(side, &target, prev)
//! ```
//!
//! `arm_target` and `calibrate` are private to `sgplvm_capture::import` today (and the
//! mirror helpers `pub(crate)`); the node needs them public, or a public
//! `fit_arm(&ArmPose, &ArmPose rest, side, prev)` in that crate, to call the very steps a BVH
//! frame goes through. This module's tests run those steps on an MVN frame.

use std::collections::BTreeMap;

use nalgebra::{Quaternion, Rotation3, UnitQuaternion, Vector3};
use sgplvm_capture::ArmPose;
use sgplvm_robots::Side;

use super::datagram::{MvnPose, PoseType, SegmentCounts, SegmentPose};
use super::segments::{segment_id, segment_name, BODY_SEGMENTS, FINGER_SEGMENTS, PROP_SEGMENTS};
use super::MvnError;

/// A segment's pose in the world, the form a BVH importer gives each joint.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WorldPose {
    /// Position of the segment's origin, metres, MVN's Z-up global frame.
    pub position: Vector3<f64>,
    /// Orientation: segment axes into global axes.
    pub rotation: Rotation3<f64>,
}

impl SegmentPose {
    /// The pose in f64, the quaternion normalised.
    pub fn world(&self) -> WorldPose {
        let [w, x, y, z] = self.orientation.map(f64::from);
        let q = UnitQuaternion::from_quaternion(Quaternion::new(w, x, y, z));
        WorldPose {
            position: Vector3::from(self.position.map(f64::from)),
            rotation: q.to_rotation_matrix(),
        }
    }

    /// Segment `id` at `pose` (rounded to the f32 that travel).
    pub fn from_world(id: u32, pose: &WorldPose) -> SegmentPose {
        let q = UnitQuaternion::from_rotation_matrix(&pose.rotation);
        SegmentPose {
            id,
            position: [pose.position.x, pose.position.y, pose.position.z].map(|v| v as f32),
            orientation: [q.w, q.i, q.j, q.k].map(|v| v as f32),
        }
    }
}

/// The arm segments of `side`, MVN names: clavicle, upper arm, forearm, hand.
fn arm_names(side: Side) -> [&'static str; 4] {
    match side {
        Side::Left => ["LeftShoulder", "LeftUpperArm", "LeftForeArm", "LeftHand"],
        Side::Right => [
            "RightShoulder",
            "RightUpperArm",
            "RightForeArm",
            "RightHand",
        ],
    }
}

impl MvnPose {
    /// The props count its segment IDs assume (4 allowed from a legacy header).
    pub fn props(&self) -> u8 {
        self.counts.map_or(4, |c| c.props)
    }

    /// Segment `id`, if the frame has it.
    pub fn segment(&self, id: u32) -> Option<&SegmentPose> {
        self.segments.iter().find(|s| s.id == id)
    }

    /// The world pose of the segment MVN calls `name` (`Pelvis`, `T8`, `RightUpperArm`, …).
    pub fn named(&self, name: &str) -> Option<WorldPose> {
        let id = segment_id(name, self.props())?;
        self.segment(id).map(SegmentPose::world)
    }

    /// Every segment's world pose by MVN name.
    pub fn world_poses(&self) -> BTreeMap<&'static str, WorldPose> {
        let props = self.props();
        self.segments
            .iter()
            .filter_map(|s| Some((segment_name(s.id, props)?, s.world())))
            .collect()
    }

    /// A type 02 frame from named world poses: body segments, props (`Prop1`… in order) and
    /// finger segments by MVN name, sent in ID order with the header counts of an MVN 2019+
    /// sender (23 body segments). This is what `sgplvm replay --as mvn` sends a capture as.
    pub fn from_world_poses<'a>(
        sample_counter: u32,
        time_code_ms: u32,
        character_id: u8,
        poses: impl IntoIterator<Item = (&'a str, WorldPose)>,
    ) -> Result<MvnPose, MvnError> {
        let poses: Vec<(&str, WorldPose)> = poses.into_iter().collect();
        let props = PROP_SEGMENTS
            .iter()
            .take_while(|p| poses.iter().any(|(n, _)| n == *p))
            .count();
        let fingers = poses
            .iter()
            .any(|(n, _)| FINGER_SEGMENTS.contains(n))
            .then_some(40u8);
        let props = u8::try_from(props).unwrap_or(4);
        let mut segments = Vec::with_capacity(poses.len());
        for (name, pose) in &poses {
            let id = segment_id(name, props).ok_or_else(|| MvnError::Segment {
                name: name.to_string(),
                message: format!(
                    "not an MVN segment (or a prop after a missing one); expected one of {}, Prop1 to Prop4 in order, or a finger segment such as {}",
                    BODY_SEGMENTS.join(", "),
                    FINGER_SEGMENTS[0]
                ),
            })?;
            if segments.iter().any(|s: &SegmentPose| s.id == id) {
                return Err(MvnError::Segment {
                    name: name.to_string(),
                    message: "given twice; expected each segment once".into(),
                });
            }
            let finite = pose.position.iter().chain(pose.rotation.matrix().iter());
            if !finite.into_iter().all(|v| v.is_finite()) {
                return Err(MvnError::Segment {
                    name: name.to_string(),
                    message: "a position or rotation that is not a finite number".into(),
                });
            }
            segments.push(SegmentPose::from_world(id, pose));
        }
        segments.sort_by_key(|s| s.id);
        Ok(MvnPose {
            kind: PoseType::Quaternion,
            sample_counter,
            time_code_ms,
            character_id,
            counts: Some(SegmentCounts {
                body: 23,
                props,
                fingers: fingers.unwrap_or(0),
            }),
            segments,
        })
    }

    /// `T8` and the four segments of arm `side`, or the first one missing.
    fn arm_segments(&self, side: Side) -> Result<[WorldPose; 5], MvnError> {
        let [c, u, f, h] = arm_names(side);
        let mut out = [WorldPose {
            position: Vector3::zeros(),
            rotation: Rotation3::identity(),
        }; 5];
        for (slot, name) in out.iter_mut().zip(["T8", c, u, f, h]) {
            *slot = self.named(name).ok_or_else(|| MvnError::Segment {
                name: name.to_string(),
                message: format!(
                    "not in this frame (sample {}); the {} arm's pose needs T8 (ID 5) and {c}, {u}, {f}, {h}",
                    self.sample_counter,
                    side.as_str()
                ),
            })?;
        }
        Ok(out)
    }

    /// Arm `side` in this frame as the importer's [`ArmPose`]: points relative to `T8` in its
    /// body axes (x forward, y left, z up), metres; turns from the null pose in body axes.
    pub fn arm_pose(&self, side: Side) -> Result<ArmPose, MvnError> {
        let [t8, clavicle, upper, fore, hand] = self.arm_segments(side)?;
        let to_body = t8.rotation.inverse();
        let at = |p: &Vector3<f64>| to_body * (p - t8.position);
        let turn = |r: &Rotation3<f64>| to_body * r;
        let forearm_at_rest = fore.rotation.inverse() * (hand.position - fore.position);
        let wrist = at(&hand.position);
        Ok(ArmPose {
            clavicle: at(&clavicle.position),
            shoulder: at(&upper.position),
            elbow: at(&fore.position),
            wrist,
            hand_tip: wrist + turn(&hand.rotation) * forearm_at_rest,
            upper_arm_turn: turn(&upper.rotation),
            hand_turn: turn(&hand.rotation),
        })
    }

    /// Arm `side` in the null pose (T-pose, every orientation the identity) with this person's
    /// segment lengths, read off this frame: the importer's rest [`ArmPose`], the calibration
    /// of the twists.
    pub fn rest_arm_pose(&self, side: Side) -> Result<ArmPose, MvnError> {
        let [t8, clavicle, upper, fore, hand] = self.arm_segments(side)?;
        let offset = |parent: &WorldPose, child: &WorldPose| {
            parent.rotation.inverse() * (child.position - parent.position)
        };
        let c = offset(&t8, &clavicle);
        let s = c + offset(&clavicle, &upper);
        let e = s + offset(&upper, &fore);
        let w = e + offset(&fore, &hand);
        Ok(ArmPose {
            clavicle: c,
            shoulder: s,
            elbow: e,
            wrist: w,
            hand_tip: w + (w - e),
            upper_arm_turn: Rotation3::identity(),
            hand_turn: Rotation3::identity(),
        })
    }
}
