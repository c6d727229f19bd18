//! Tasks of differential IK: each an error `e` (what is wanted minus what is) and its Jacobian
//! `J` with respect to the active joints, so that a step `Δq` changes the error by about
//! `−J Δq`; [`super::qp::Step::add_task`] weighs them into the step's objective.
//!
//! - [`Task::Direction`]: the unit vector from one point of the robot to another (an upper
//!   arm, a forearm) along a target direction: `u = (b − a)/‖b − a‖`, `e = û − u`,
//!   `J = (I − u uᵀ)(J_b − J_a)/‖b − a‖`.
//! - [`Task::Position`]: a point at a target: `e = p̂ − p`, `J = J_p`.
//! - [`Task::Orientation`]: a link's frame at a target rotation: `e = log(R̂ Rᵀ)` (axis ×
//!   angle, root frame), `J` the link's angular Jacobian.
//! - [`Task::Posture`]: the active joints towards a posture: `e = q̂ − q`, `J = I`.

use nalgebra::{DMatrix, DVector, Point3, UnitQuaternion, Vector3};

use super::frames::{Ancestry, RobotFrames};
use crate::urdf::Robot;

/// A point fixed on a link: the link (index into [`Robot::link_names`]) and the point in its
/// frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LinkPoint {
    /// The link.
    pub link: usize,
    /// The point in the link's frame.
    pub local: Vector3<f64>,
}

impl LinkPoint {
    /// The point in the root frame at `frames`.
    pub fn at(&self, frames: &RobotFrames) -> Vector3<f64> {
        (frames.link(self.link) * Point3::from(self.local)).coords
    }
}

/// One task (module docs).
#[derive(Debug, Clone, PartialEq)]
pub enum Task {
    /// From point `from` to point `to` along the unit direction `target` (root frame).
    Direction {
        /// Where the segment starts.
        from: LinkPoint,
        /// Where it ends.
        to: LinkPoint,
        /// The wanted unit direction.
        target: Vector3<f64>,
    },
    /// Point `point` at `target` (root frame), the error divided by `scale` (e.g. the arm's
    /// reach, so that it weighs as a fraction of it).
    Position {
        /// The point.
        point: LinkPoint,
        /// Where it should be.
        target: Vector3<f64>,
        /// The length the error is measured in.
        scale: f64,
    },
    /// Link `link`'s rotation at `target` (root frame).
    Orientation {
        /// The link.
        link: usize,
        /// The wanted rotation.
        target: UnitQuaternion<f64>,
    },
    /// The active joints towards `target` (one value per active joint).
    Posture {
        /// The wanted values.
        target: Vec<f64>,
    },
}

/// What a task is evaluated with: the robot, its ancestry, its frames at the current
/// configuration, that configuration and the active joints (indices into [`Robot::joints`]).
pub struct TaskContext<'a> {
    /// The robot.
    pub robot: &'a Robot,
    /// Its links' ancestry.
    pub ancestry: &'a Ancestry,
    /// Its frames at `q`.
    pub frames: &'a RobotFrames,
    /// The configuration (URDF order).
    pub q: &'a [f64],
    /// The joints the step moves.
    pub active: &'a [usize],
}

impl TaskContext<'_> {
    fn point_jacobian(&self, p: &LinkPoint, at: &Vector3<f64>) -> DMatrix<f64> {
        let j = self
            .frames
            .point_jacobian(self.robot, self.ancestry, p.link, at, self.active);
        DMatrix::from_column_slice(3, self.active.len(), j.as_slice())
    }

    /// The active joints' current values.
    pub fn active_values(&self) -> Vec<f64> {
        self.active
            .iter()
            .map(|&j| {
                self.robot.joints[j]
                    .q_index
                    .map_or(0.0, |i| self.q.get(i).copied().unwrap_or(0.0))
            })
            .collect()
    }
}

impl Task {
    /// The task's error alone at `ctx` (what [`Task::linearize`] gives without the Jacobian).
    pub fn error(&self, ctx: &TaskContext<'_>) -> DVector<f64> {
        match self {
            Task::Direction { from, to, target } => {
                let d = to.at(ctx.frames) - from.at(ctx.frames);
                let u = d / d.norm().max(1e-9);
                DVector::from_column_slice((target - u).as_slice())
            }
            Task::Position {
                point,
                target,
                scale,
            } => DVector::from_column_slice(
                ((target - point.at(ctx.frames)) / scale.max(1e-9)).as_slice(),
            ),
            Task::Orientation { link, target } => {
                let r = ctx.frames.link(*link).rotation;
                DVector::from_column_slice((target * r.inverse()).scaled_axis().as_slice())
            }
            Task::Posture { target } => DVector::from_iterator(
                target.len(),
                target.iter().zip(ctx.active_values()).map(|(t, v)| t - v),
            ),
        }
    }

    /// The task's error and Jacobian at `ctx`.
    pub fn linearize(&self, ctx: &TaskContext<'_>) -> (DVector<f64>, DMatrix<f64>) {
        match self {
            Task::Direction { from, to, target } => {
                let (a, b) = (from.at(ctx.frames), to.at(ctx.frames));
                let d = b - a;
                let len = d.norm().max(1e-9);
                let u = d / len;
                let project = nalgebra::Matrix3::identity() - u * u.transpose();
                let jd = ctx.point_jacobian(to, &b) - ctx.point_jacobian(from, &a);
                let jac = DMatrix::from_fn(3, 3, |r, c| project[(r, c)] / len) * jd;
                (DVector::from_column_slice((target - u).as_slice()), jac)
            }
            Task::Position {
                point,
                target,
                scale,
            } => {
                let p = point.at(ctx.frames);
                let s = scale.max(1e-9);
                (
                    DVector::from_column_slice(((target - p) / s).as_slice()),
                    ctx.point_jacobian(point, &p) / s,
                )
            }
            Task::Orientation { link, target } => {
                let r = ctx.frames.link(*link).rotation;
                let e = (target * r.inverse()).scaled_axis();
                let j = ctx
                    .frames
                    .angular_jacobian(ctx.robot, ctx.ancestry, *link, ctx.active);
                (
                    DVector::from_column_slice(e.as_slice()),
                    DMatrix::from_column_slice(3, ctx.active.len(), j.as_slice()),
                )
            }
            Task::Posture { target } => {
                let q = ctx.active_values();
                let e: Vec<f64> = target.iter().zip(&q).map(|(t, v)| t - v).collect();
                (
                    DVector::from_vec(e),
                    DMatrix::identity(ctx.active.len(), ctx.active.len()),
                )
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every task's Jacobian against central differences of its error (`e(q + h δ) ≈ e − J h δ`).
    #[test]
    fn each_task_s_jacobian_equals_finite_differences() {
        let robot = Robot::builtin("coman").unwrap();
        let ancestry = Ancestry::of(&robot);
        let active: Vec<usize> = robot.movable[..7].to_vec();
        let link = |n: &str| robot.link_index[n];
        let elbow = robot.joints[robot.movable[3]].parent;
        let tasks = [
            Task::Direction {
                from: LinkPoint {
                    link: link("left_shoulder"),
                    local: Vector3::zeros(),
                },
                to: LinkPoint {
                    link: elbow,
                    local: Vector3::new(0.015, 0.0, -0.1),
                },
                target: Vector3::new(0.3, 0.2, -0.9).normalize(),
            },
            Task::Position {
                point: LinkPoint {
                    link: link("left_hand"),
                    local: Vector3::new(0.0, 0.01, 0.0),
                },
                target: Vector3::new(0.2, 0.2, -0.1),
                scale: 0.45,
            },
            Task::Posture {
                target: vec![0.1; 7],
            },
        ];
        let q: Vec<f64> = (0..14).map(|i| 0.2 + 0.1 * (i as f64).cos()).collect();
        // The log map's derivative is the angular Jacobian where the error is 0.
        let hand_now = robot.forward_kinematics(&q, "left_hand").unwrap().rotation;
        let tasks: Vec<Task> = tasks
            .into_iter()
            .chain(std::iter::once(Task::Orientation {
                link: link("left_hand"),
                target: hand_now,
            }))
            .collect();
        let eval = |q: &[f64], t: &Task| {
            let frames = RobotFrames::new(&robot, &ancestry, q);
            let ctx = TaskContext {
                robot: &robot,
                ancestry: &ancestry,
                frames: &frames,
                q,
                active: &active,
            };
            t.linearize(&ctx)
        };
        for t in &tasks {
            let (_, jac) = eval(&q, t);
            for (c, &j) in active.iter().enumerate() {
                let i = robot.joints[j].q_index.unwrap();
                let h = 1e-6;
                let (mut a, mut b) = (q.clone(), q.clone());
                a[i] += h;
                b[i] -= h;
                let fd = (eval(&a, t).0 - eval(&b, t).0) / (2.0 * h);
                // The error falls as the task's Jacobian says: de/dq = −J.
                let diff = (fd + jac.column(c)).norm();
                assert!(diff < 1e-6, "{t:?}: joint {i}: {diff}");
            }
        }
    }
}
