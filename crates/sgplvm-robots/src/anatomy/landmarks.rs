//! Each arm's landmarks as points fixed on the robot's links: the shoulder centre, the elbow's
//! centre on the bone line, the wrist centre and the hand point, which whole-arm retargeting
//! measures the arm's bone lines between.

use nalgebra::Vector3;

use super::AnatomyArm;
use crate::kinematics::tasks::LinkPoint;
use crate::urdf::Robot;

impl AnatomyArm {
    /// The shoulder point in the chain's base frame at the arm's joint values `q`.
    pub fn shoulder_at(&self, q: &[f64]) -> Vector3<f64> {
        if self.shoulder_after == 0 {
            self.shoulder_local
        } else {
            (self.chain.joint_frames(q)[self.shoulder_after]
                * nalgebra::Point3::from(self.shoulder_local))
            .coords
        }
    }

    /// The elbow's centre on the arm's bone line, in the elbow joint's frame (before its
    /// motion): the point of the elbow's axis midway, along that axis, between the shoulder
    /// centre and the wrist centre. A URDF may place the elbow joint's origin anywhere on its
    /// axis (at the side of the arm, say); this point lies in the plane the shoulder, elbow
    /// and wrist centres bend in, so that shoulder → elbow → wrist are the upper arm's and the
    /// forearm's bone lines. Read at the neutral posture (the axial places do not change as the
    /// elbow bends).
    pub fn elbow_centre_local(&self) -> Vector3<f64> {
        if self.chain.is_prismatic(self.elbow) {
            return Vector3::zeros();
        }
        let q = &self.neutral;
        let frames = self.chain.joint_frames(q);
        let Some(elbow) = frames.get(self.elbow) else {
            return Vector3::zeros();
        };
        let wrist = match frames.get(self.wrist_after) {
            Some(f) => (f * nalgebra::Point3::from(self.wrist_local)).coords,
            // On the last link: the chain ends at the hand point.
            None => self.chain.forward(q).translation.vector,
        };
        let axis = self.chain.joint_axes(q)[self.elbow];
        let at = elbow.translation.vector;
        let shoulder = self.shoulder_at(q);
        let along = 0.5 * ((shoulder - at).dot(&axis) + (wrist - at).dot(&axis));
        elbow.rotation.inverse() * (axis * along)
    }

    /// The upper arm's and the forearm's lengths on the bone line (shoulder centre → elbow
    /// centre → wrist centre) at the neutral posture, metres.
    pub fn bone_lengths(&self) -> (f64, f64) {
        let q = &self.neutral;
        let frames = self.chain.joint_frames(q);
        let point = |k: usize, local: Vector3<f64>| match frames.get(k) {
            Some(f) => (f * nalgebra::Point3::from(local)).coords,
            None => self.chain.forward(q).translation.vector,
        };
        let shoulder = self.shoulder_at(q);
        let elbow = point(self.elbow, self.elbow_centre_local());
        let wrist = point(self.wrist_after, self.wrist_local);
        ((elbow - shoulder).norm(), (wrist - elbow).norm())
    }

    /// The arm's landmarks (shoulder, elbow centre, wrist centre, hand) as points fixed on the
    /// robot's links, for tasks evaluated on the whole robot.
    pub fn landmarks(&self, robot: &Robot) -> ArmLandmarks {
        let on_joint = |k: usize, local: Vector3<f64>| -> LinkPoint {
            // A joint's frame before its motion is its parent link's frame times its origin.
            match self.chain.robot_indices().get(k).map(|&i| robot.movable[i]) {
                Some(j) => {
                    let joint = &robot.joints[j];
                    LinkPoint {
                        link: joint.parent,
                        local: (joint.origin * nalgebra::Point3::from(local)).coords,
                    }
                }
                None => LinkPoint {
                    link: robot.root,
                    local,
                },
            }
        };
        let base = robot
            .link_index
            .get(self.chain.base())
            .copied()
            .unwrap_or(robot.root);
        let tip = robot
            .link_index
            .get(self.chain.tip())
            .copied()
            .unwrap_or(robot.root);
        let shoulder = if self.shoulder_after == 0 {
            LinkPoint {
                link: base,
                local: self.shoulder_local,
            }
        } else {
            on_joint(self.shoulder_after, self.shoulder_local)
        };
        ArmLandmarks {
            shoulder,
            elbow: on_joint(self.elbow, self.elbow_centre_local()),
            wrist: if self.wrist_after < self.chain.dof() {
                on_joint(self.wrist_after, self.wrist_local)
            } else {
                LinkPoint {
                    link: tip,
                    local: self.wrist_local,
                }
            },
            hand: LinkPoint {
                link: tip,
                local: self.hand_local,
            },
        }
    }

    /// The hand's position in the torso link's frame for the arm's joint values `q` (chain
    /// order).
    pub fn hand_in_torso(&self, q: &[f64]) -> Vector3<f64> {
        (self.base_in_torso * self.chain.forward(q))
            .translation
            .vector
    }
}

/// An arm's landmarks as points fixed on the robot's links.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ArmLandmarks {
    /// The shoulder centre.
    pub shoulder: LinkPoint,
    /// The elbow's centre on the bone line ([`AnatomyArm::elbow_centre_local`]).
    pub elbow: LinkPoint,
    /// The wrist centre.
    pub wrist: LinkPoint,
    /// The hand (the hand link's origin).
    pub hand: LinkPoint,
}
