//! Where a robot's arm sits on a person: the **mount**, a turn of the person's arm about the
//! body's forward axis before the robot takes it.
//!
//! A humanoid's arm hangs as a person's does, and takes the person's arm as it is (roll 0).
//! An arm standing on a table or low on a base cannot hang: its shoulder is at its base, and
//! a person's hanging arm would ask it to point down through its own base and the table
//! (Franka's Panda cannot point its upper arm more than 11° below the horizontal). Such an arm
//! takes the person's arm rolled out by [`TABLE_ROLL_DEG`] about the forward axis: the
//! person's hanging arm is the robot's arm reaching out to its side, their arm out to the side
//! its arm straight up, and their arm reaching forward its arm reaching forward — what a
//! person does in front of them, the robot does in front of it. (A pitch — the hanging arm
//! reaching forward, the arm raised forward pointing up — puts a table arm's shoulder
//! singularity, its upper arm along its first joint's vertical axis, on a person's most common
//! reach, and measured worse: docs/robots.md.) Every direction, orientation and hand position
//! the robot is asked for, and every error reported against the person, is the person's turned
//! by the mount.
//!
//! Which robots cannot hang is told from the kinematics alone, never from data: where no
//! posture within the joint limits brings the upper arm within [`HANG_MISS_DEG`] of a person's
//! hanging upper arm (the neutral key pose's direction), the arm is mounted as on a table.
//! (Universal Robots' arms can point down, through their table, and are not: rolled out, their
//! elbow, which bends only in the plane of their shoulder's lift, cannot follow a person's
//! forearm — measured worse, docs/robots.md — so `--mount-roll 90` is theirs to choose.) A
//! user sets it (`--mount-roll DEG`, `mount_roll_deg` in the description file; 0 turns it
//! off).

use nalgebra::{UnitQuaternion, Vector3};
use serde::Serialize;

use crate::models::Side;

/// The roll of an arm that cannot hang, degrees: the person's hanging arm reaches out to its
/// side, their arm out to the side points up, their forward reach stays forward.
pub const TABLE_ROLL_DEG: f64 = 90.0;

/// How far (degrees) an arm's upper arm may stay, at best within its joint limits, from a
/// person's hanging upper arm before the arm is taken to be one that cannot hang.
pub const HANG_MISS_DEG: f64 = 30.0;

/// Why a robot's arms are mounted as they are.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(rename_all = "snake_case", tag = "why")]
pub enum MountReason {
    /// The arms hang as a person's do: the person's arm as it is. Their upper arms come within
    /// `missed` degrees of a person's hanging upper arm.
    Hangs {
        /// The nearest the upper arms come, degrees.
        missed: f64,
    },
    /// Set by the user (`--mount-roll`, the description file).
    Given,
    /// An arm cannot hang: its upper arm stays `missed` degrees, at best, from a person's
    /// hanging upper arm, so the person's arms are rolled out ([`TABLE_ROLL_DEG`]).
    CannotHang {
        /// The nearest the upper arm comes, degrees.
        missed: f64,
    },
}

/// The turn of the person's arm before the robot takes it (module docs).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Mount {
    /// Degrees the person's arm is turned outward about the body's forward axis (mirrored
    /// between the sides: a hanging arm turns out to its side).
    pub roll_deg: f64,
    /// Why.
    #[serde(flatten)]
    pub reason: MountReason,
}

impl Default for Mount {
    fn default() -> Self {
        Mount {
            roll_deg: 0.0,
            reason: MountReason::Hangs { missed: 0.0 },
        }
    }
}

impl Mount {
    /// No mount: the arms hang, their upper arms within `missed` degrees of a person's hanging
    /// upper arm.
    pub fn hangs(missed: f64) -> Mount {
        Mount {
            roll_deg: 0.0,
            reason: MountReason::Hangs { missed },
        }
    }

    /// Whether `roll_deg` is a roll a user may set: finite, within ±180°.
    pub fn valid_roll(roll_deg: f64) -> bool {
        roll_deg.is_finite() && roll_deg.abs() <= 180.0
    }

    /// The mount a user set.
    pub fn given(roll_deg: f64) -> Mount {
        Mount {
            roll_deg,
            reason: MountReason::Given,
        }
    }

    /// The mount of an arm whose upper arm stays `missed` degrees from a hanging one.
    pub fn cannot_hang(missed: f64) -> Mount {
        Mount {
            roll_deg: TABLE_ROLL_DEG,
            reason: MountReason::CannotHang { missed },
        }
    }

    /// The rotation in the body frame (x forward, y left, z up) taking the person's arm of
    /// `side` to the robot's: about the forward axis, so that a positive roll turns a hanging
    /// arm out to its side (mirrored between the sides).
    pub fn rotation(&self, side: Side) -> UnitQuaternion<f64> {
        let outward = match side {
            Side::Left => 1.0,
            Side::Right => -1.0,
        };
        UnitQuaternion::from_axis_angle(&Vector3::x_axis(), outward * self.roll_deg.to_radians())
    }

    /// One line for a person: what the mount does and why.
    pub fn describe(&self) -> String {
        match self.reason {
            MountReason::Hangs { missed } => format!(
                "none: the arms hang as a person's do (the upper arm comes within {missed:.0}° of a hanging one; --mount-roll DEG turns the person's arm outward about the forward axis)"
            ),
            MountReason::Given if self.roll_deg == 0.0 => {
                "none (given): the person's arm as it is".into()
            }
            MountReason::Given => format!(
                "the person's arm turned {:.0}° outward about the body's forward axis (given)",
                self.roll_deg
            ),
            MountReason::CannotHang { missed } => format!(
                "the person's arm turned {:.0}° outward about the body's forward axis: the arm cannot hang (its upper arm stays {missed:.0}° from a hanging one within its limits), so the person's hanging arm is its arm reaching out to the side, their arm out to the side its arm up, their forward reach its forward reach (--mount-roll 0 turns this off)",
                self.roll_deg
            ),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_outward_roll_turns_a_hanging_arm_out_to_its_side_and_keeps_forward() {
        let m = Mount::given(90.0);
        let down = Vector3::new(0.0, 0.0, -1.0);
        let right = m.rotation(Side::Right);
        assert!((right * down - Vector3::new(0.0, -1.0, 0.0)).norm() < 1e-12);
        assert!((right * Vector3::new(0.0, -1.0, 0.0) - Vector3::z()).norm() < 1e-12);
        assert!((right * Vector3::x() - Vector3::x()).norm() < 1e-12);
        let left = m.rotation(Side::Left);
        assert!((left * down - Vector3::y()).norm() < 1e-12);
        assert!((left * Vector3::y() - Vector3::z()).norm() < 1e-12);
        assert_eq!(
            Mount::default().rotation(Side::Right),
            UnitQuaternion::identity()
        );
    }
}
