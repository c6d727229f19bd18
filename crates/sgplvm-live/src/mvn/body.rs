//! A frame as the capture importer sees a skeleton: named segment world poses (what a BVH
//! importer computes for each joint), and each arm as the importer's per-frame
//! [`ArmPose`], in the torso's body axes, through the capture crate's [`ArmSegments`] (its
//! module says how MVN's segment frames map onto the importer's: `T8`'s frame is the body
//! axes, every segment the identity in the null pose).

use std::collections::BTreeMap;

use nalgebra::{Quaternion, UnitQuaternion, Vector3};
pub use sgplvm_capture::WorldPose;
use sgplvm_capture::{ArmPose, ArmSegments};
use sgplvm_robots::Side;

use super::datagram::{MvnPose, PoseType, SegmentCounts, SegmentPose};
use super::segments::{segment_id, segment_name, BODY_SEGMENTS, FINGER_SEGMENTS, PROP_SEGMENTS};
use super::MvnError;

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
    pub fn arm_segments(&self, side: Side) -> Result<ArmSegments, MvnError> {
        let [c, u, f, h] = arm_names(side);
        let named = |name: &str| {
            self.named(name).ok_or_else(|| MvnError::Segment {
                name: name.to_string(),
                message: format!(
                    "not in this frame (sample {}); the {} arm's pose needs T8 (ID 5) and {c}, {u}, {f}, {h}",
                    self.sample_counter,
                    side.as_str()
                ),
            })
        };
        Ok(ArmSegments {
            torso: named("T8")?,
            clavicle: named(c)?,
            upper_arm: named(u)?,
            forearm: named(f)?,
            hand: named(h)?,
        })
    }

    /// Arm `side` in this frame as the importer's [`ArmPose`] ([`ArmSegments::arm_pose`]).
    pub fn arm_pose(&self, side: Side) -> Result<ArmPose, MvnError> {
        Ok(self.arm_segments(side)?.arm_pose())
    }

    /// Arm `side` in the null pose with this person's segment lengths, read off this frame
    /// ([`ArmSegments::rest_arm_pose`]).
    pub fn rest_arm_pose(&self, side: Side) -> Result<ArmPose, MvnError> {
        Ok(self.arm_segments(side)?.rest_arm_pose())
    }
}
