//! Serial chains cut out of a [`Robot`]: forward kinematics, the geometric Jacobian and damped
//! least-squares inverse kinematics with joint limits.
//!
//! # Example
//! ```
//! use sgplvm_robots::{IkOptions, IkTarget, Robot};
//! let robot = Robot::builtin("coman")?;
//! let arm = robot.chain("DWYTorso", "left_hand")?;
//! let q = vec![-0.5, 0.3, 0.2, -1.0, 0.1, 0.2, 0.1];
//! let target = arm.forward(&q).translation.vector;
//! let sol = arm.inverse_kinematics(&IkTarget::Position(target), &vec![0.0; 7], &IkOptions::default());
//! assert!(sol.converged && sol.residual < 1e-6);
//! # Ok::<(), sgplvm_robots::RobotError>(())
//! ```
//!
//! `mod.rs` cuts the chain out of the robot and computes its forward kinematics and Jacobian;
//! `ik.rs` solves inverse kinematics on it.

pub(crate) mod adjacency;
mod apart;
mod bounds;
pub mod collision;
mod contact;
pub mod frames;
mod hull;
mod ik;
pub mod limits;
pub mod qp;
pub mod tasks;

pub use apart::ApartProofs;
pub use ik::{IkOptions, IkSolution, IkTarget};

use nalgebra::{Isometry3, Matrix6xX, Translation3, Unit, UnitQuaternion, Vector3, Vector6};

use crate::error::{RobotError, RobotResult};
use crate::urdf::{JointKind, Robot};

/// One movable joint of a chain, with the rigid transform that precedes it.
#[derive(Debug, Clone)]
struct Segment {
    /// From the previous joint's moving frame (or the base) to this joint's frame.
    pre: Isometry3<f64>,
    axis: Unit<Vector3<f64>>,
    prismatic: bool,
}

/// Ordered joints that can move, from a base link to a tip link.
#[derive(Debug, Clone)]
pub struct Chain {
    base: String,
    tip: String,
    joint_names: Vec<String>,
    limits: Vec<(f64, f64)>,
    robot_indices: Vec<usize>,
    segments: Vec<Segment>,
    /// From the last joint's moving frame (or the base) to the tip link.
    tail: Isometry3<f64>,
}

impl Robot {
    /// The chain of joints that can move ([`crate::urdf::JointInfo::can_move`]) from link
    /// `base` down to link `tip`; a joint with one value allowed is held at it.
    ///
    /// Fails if either link is unknown or `tip` is not below `base` in the tree.
    pub fn chain(&self, base: &str, tip: &str) -> RobotResult<Chain> {
        let base_id = self.link_id(base)?;
        let tip_id = self.link_id(tip)?;
        let mut joints = Vec::new();
        let mut cur = tip_id;
        while cur != base_id {
            match self.parent_joint[cur] {
                Some(j) => {
                    joints.push(j);
                    cur = self.joints[j].parent;
                }
                None => {
                    return Err(RobotError::NotAChain {
                        robot: self.name.clone(),
                        base: base.to_string(),
                        tip: tip.to_string(),
                    })
                }
            }
        }
        joints.reverse();
        let mut segments = Vec::new();
        let mut names = Vec::new();
        let mut limits = Vec::new();
        let mut robot_indices = Vec::new();
        let mut acc = Isometry3::identity();
        for j in joints {
            let joint = &self.joints[j];
            // A joint that cannot move (fixed, or one value allowed) is part of the segment,
            // at that value.
            let Some(qi) = joint.q_index.filter(|_| joint.can_move()) else {
                acc *= joint.transform(joint.limits.0);
                continue;
            };
            acc *= joint.origin;
            segments.push(Segment {
                pre: acc,
                axis: joint.axis,
                prismatic: joint.kind == JointKind::Prismatic,
            });
            names.push(joint.name.clone());
            limits.push(joint.limits);
            robot_indices.push(qi);
            acc = Isometry3::identity();
        }
        Ok(Chain {
            base: base.to_string(),
            tip: tip.to_string(),
            joint_names: names,
            limits,
            robot_indices,
            segments,
            tail: acc,
        })
    }
}

/// Scratch state of one FK pass: joint origins and axes in the base frame, and the tip pose.
struct Frames {
    origins: Vec<Vector3<f64>>,
    axes: Vec<Vector3<f64>>,
    tip: Isometry3<f64>,
}

impl Chain {
    /// Name of the base link.
    pub fn base(&self) -> &str {
        &self.base
    }

    /// Name of the tip link.
    pub fn tip(&self) -> &str {
        &self.tip
    }

    /// Movable joints from base to tip.
    pub fn joint_names(&self) -> &[String] {
        &self.joint_names
    }

    /// `(lower, upper)` per joint, base to tip.
    pub fn limits(&self) -> &[(f64, f64)] {
        &self.limits
    }

    /// The middle of each joint's range, base to tip; `otherwise[k]` for a joint whose range is
    /// unbounded on either side.
    pub fn mid_range(&self, otherwise: &[f64]) -> Vec<f64> {
        self.limits
            .iter()
            .zip(otherwise)
            .map(|(&(lo, hi), &other)| {
                if lo.is_finite() && hi.is_finite() {
                    0.5 * (lo + hi)
                } else {
                    other
                }
            })
            .collect()
    }

    /// Number of movable joints.
    pub fn dof(&self) -> usize {
        self.segments.len()
    }

    /// Positions of this chain's joints in the robot's configuration vector.
    pub fn robot_indices(&self) -> &[usize] {
        &self.robot_indices
    }

    /// Gathers this chain's joint values out of a full robot configuration.
    pub fn extract(&self, robot_q: &[f64]) -> RobotResult<Vec<f64>> {
        self.robot_indices
            .iter()
            .map(|&i| {
                robot_q.get(i).copied().ok_or(RobotError::WrongDof {
                    what: format!("Chain::extract ({} → {})", self.base, self.tip),
                    expected: i + 1,
                    got: robot_q.len(),
                })
            })
            .collect()
    }

    /// The chain ending at `point` (in the tip link's frame) instead of the tip link's origin:
    /// the hand of an arm whose last link carries the forearm and the hand beyond its joint.
    pub fn with_tip_point(mut self, point: Vector3<f64>) -> Chain {
        self.tail *= nalgebra::Translation3::from(point);
        self
    }

    /// Tip pose in the base frame.
    ///
    /// `q` holds one value per joint; missing values count as 0 and extra ones are ignored
    /// (use [`Chain::try_forward`] to have the length checked).
    pub fn forward(&self, q: &[f64]) -> Isometry3<f64> {
        let mut t = Isometry3::identity();
        for (i, s) in self.segments.iter().enumerate() {
            let v = q.get(i).copied().unwrap_or(0.0);
            t *= s.pre;
            t *= motion(s, v);
        }
        t * self.tail
    }

    /// Origins of the chain's joints in the base frame at `q`, in chain order (missing `q`
    /// values count as 0): where an elbow or a wrist is.
    pub fn joint_origins(&self, q: &[f64]) -> Vec<Vector3<f64>> {
        self.frames(q).origins
    }

    /// Each joint's frame in the base frame at `q`, before its own motion (its origin is the
    /// joint's origin), in chain order (missing `q` values count as 0).
    pub fn joint_frames(&self, q: &[f64]) -> Vec<Isometry3<f64>> {
        let mut t = Isometry3::identity();
        let mut out = Vec::with_capacity(self.dof());
        for (i, s) in self.segments.iter().enumerate() {
            t *= s.pre;
            out.push(t);
            t *= motion(s, q.get(i).copied().unwrap_or(0.0));
        }
        out
    }

    /// Each joint's unit axis in the base frame at `q`, in chain order.
    pub fn joint_axes(&self, q: &[f64]) -> Vec<Vector3<f64>> {
        self.frames(q).axes
    }

    /// Whether chain joint `i` slides (prismatic) rather than turns.
    pub fn is_prismatic(&self, i: usize) -> bool {
        self.segments.get(i).is_some_and(|s| s.prismatic)
    }

    /// [`Chain::forward`] that rejects a `q` of the wrong length.
    pub fn try_forward(&self, q: &[f64]) -> RobotResult<Isometry3<f64>> {
        self.check(q, "Chain::forward")?;
        Ok(self.forward(q))
    }

    /// Tip poses for many configurations, `qs` row-major `n × dof`; a trailing partial row is
    /// ignored, and a chain without joints gives no poses.
    pub fn forward_batch(&self, qs: &[f64]) -> Vec<Isometry3<f64>> {
        let dof = self.dof();
        if dof == 0 {
            return Vec::new();
        }
        qs.chunks_exact(dof).map(|q| self.forward(q)).collect()
    }

    /// Geometric Jacobian of the tip in the base frame: rows 0–2 linear velocity of the tip
    /// origin, rows 3–5 angular velocity; one column per joint. Missing `q` values count as 0.
    pub fn jacobian(&self, q: &[f64]) -> Matrix6xX<f64> {
        let f = self.frames(q);
        let mut j = Matrix6xX::zeros(self.dof());
        for i in 0..self.dof() {
            let col = self.column(&f, i);
            j.set_column(i, &col);
        }
        j
    }

    /// [`Chain::jacobian`] that rejects a `q` of the wrong length.
    pub fn try_jacobian(&self, q: &[f64]) -> RobotResult<Matrix6xX<f64>> {
        self.check(q, "Chain::jacobian")?;
        Ok(self.jacobian(q))
    }

    fn check(&self, q: &[f64], what: &str) -> RobotResult<()> {
        if q.len() != self.dof() {
            return Err(RobotError::WrongDof {
                what: format!("{what} ({} → {})", self.base, self.tip),
                expected: self.dof(),
                got: q.len(),
            });
        }
        Ok(())
    }

    fn frames(&self, q: &[f64]) -> Frames {
        let mut f = Frames {
            origins: Vec::with_capacity(self.dof()),
            axes: Vec::with_capacity(self.dof()),
            tip: Isometry3::identity(),
        };
        self.frames_into(q, &mut f);
        f
    }

    fn frames_into(&self, q: &[f64], f: &mut Frames) {
        f.origins.clear();
        f.axes.clear();
        let mut t = Isometry3::identity();
        for (i, s) in self.segments.iter().enumerate() {
            t *= s.pre;
            f.origins.push(t.translation.vector);
            f.axes.push(t.rotation * s.axis.into_inner());
            let v = q.get(i).copied().unwrap_or(0.0);
            t *= motion(s, v);
        }
        f.tip = t * self.tail;
    }

    fn column(&self, f: &Frames, i: usize) -> Vector6<f64> {
        let z = f.axes[i];
        if self.segments[i].prismatic {
            Vector6::new(z.x, z.y, z.z, 0.0, 0.0, 0.0)
        } else {
            let lin = z.cross(&(f.tip.translation.vector - f.origins[i]));
            Vector6::new(lin.x, lin.y, lin.z, z.x, z.y, z.z)
        }
    }
}

fn motion(s: &Segment, v: f64) -> Isometry3<f64> {
    if s.prismatic {
        Isometry3::from_parts(
            Translation3::from(s.axis.into_inner() * v),
            UnitQuaternion::identity(),
        )
    } else {
        Isometry3::from_parts(
            Translation3::identity(),
            UnitQuaternion::from_axis_angle(&s.axis, v),
        )
    }
}

#[cfg(test)]
mod tests;
