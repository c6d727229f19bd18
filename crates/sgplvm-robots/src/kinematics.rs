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

use nalgebra::{
    Isometry3, Matrix3, Matrix6, Matrix6xX, Translation3, Unit, UnitQuaternion, Vector3, Vector6,
};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

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

/// Ordered movable joints from a base link to a tip link.
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
    /// The chain of movable joints from link `base` down to link `tip`.
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
            acc *= joint.origin;
            if let Some(qi) = joint.q_index {
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

/// What inverse kinematics should reach: a tip position, or a full tip pose (base frame).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum IkTarget {
    /// Tip origin at this point; orientation free.
    Position(Vector3<f64>),
    /// Tip frame equal to this pose.
    Pose(Isometry3<f64>),
}

/// Settings of [`Chain::inverse_kinematics`].
#[derive(Debug, Clone, PartialEq)]
pub struct IkOptions {
    /// Iterations per attempt (the first attempt from `q0`, then each restart).
    pub max_iters: usize,
    /// Converged when the residual (metres; for poses the weighted 6-vector norm) is below this.
    pub tolerance: f64,
    /// Initial damping λ of `Δq = Jᵀ (J Jᵀ + λ² I)⁻¹ e`; adapted per iteration.
    pub damping: f64,
    /// Largest change of any joint in one iteration (rad or m).
    pub max_step: f64,
    /// Metres per radian of orientation error for pose targets.
    pub orientation_weight: f64,
    /// Attempts from seeded random configurations within limits after a failed first attempt.
    pub restarts: usize,
    /// Seed of the restarts' configurations (deterministic).
    pub seed: u64,
}

impl Default for IkOptions {
    fn default() -> Self {
        IkOptions {
            max_iters: 100,
            tolerance: 1e-9,
            damping: 1e-2,
            max_step: 0.5,
            orientation_weight: 0.2,
            restarts: 8,
            seed: 0,
        }
    }
}

/// Result of [`Chain::inverse_kinematics`]; the best configuration found even when not converged.
#[derive(Debug, Clone, PartialEq)]
pub struct IkSolution {
    /// Joint values, within limits.
    pub q: Vec<f64>,
    /// Whether the residual fell below the tolerance.
    pub converged: bool,
    /// Remaining error: position distance in metres, or for poses
    /// `sqrt(|Δp|² + (w·|Δθ|)²)` with `w = orientation_weight`.
    pub residual: f64,
    /// Position error in metres.
    pub position_error: f64,
    /// Orientation error in radians (0 for position targets).
    pub orientation_error: f64,
    /// Iterations used over all attempts.
    pub iterations: usize,
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

    /// Damped least-squares inverse kinematics within the joint limits.
    ///
    /// Starts from `q0` (clamped into the limits; missing values are 0), iterates
    /// `Δq = Jᵀ (J Jᵀ + λ² I)⁻¹ e` with λ adapted Levenberg–Marquardt style (a step that does
    /// not reduce the error is rejected and λ grows), drops from each step the joints that sit
    /// at a limit and would be pushed beyond it, and clamps. If the first attempt does not
    /// converge, it tries again from `opts.restarts` seeded random configurations and returns
    /// the best result. An unreachable target gives `converged == false` and the residual left.
    pub fn inverse_kinematics(&self, target: &IkTarget, q0: &[f64], opts: &IkOptions) -> IkSolution {
        let n = self.dof();
        let mut start: Vec<f64> = (0..n)
            .map(|i| clamp(q0.get(i).copied().unwrap_or(0.0), self.limits[i]))
            .collect();
        let mut best: Option<IkSolution> = None;
        let mut total_iters = 0;
        let mut rng = ChaCha8Rng::seed_from_u64(opts.seed);
        for attempt in 0..=opts.restarts {
            if attempt > 0 {
                for (v, &(lo, hi)) in start.iter_mut().zip(&self.limits) {
                    let (lo, hi) = (lo.max(-std::f64::consts::PI), hi.min(std::f64::consts::PI));
                    *v = if hi > lo { rng.random_range(lo..=hi) } else { lo };
                }
            }
            let mut sol = self.dls(target, &start, opts);
            total_iters += sol.iterations;
            sol.iterations = total_iters;
            let better = best.as_ref().is_none_or(|b| sol.residual < b.residual);
            if better {
                best = Some(sol);
            }
            if best.as_ref().is_some_and(|b| b.converged) {
                break;
            }
        }
        let mut best = best.unwrap_or_else(|| IkSolution {
            q: start.clone(),
            converged: false,
            residual: f64::INFINITY,
            position_error: f64::INFINITY,
            orientation_error: f64::INFINITY,
            iterations: 0,
        });
        best.iterations = total_iters;
        best
    }

    /// Error vector (target − current), 6 entries (orientation rows weighted; zero for
    /// position targets) and the unweighted position and orientation errors.
    fn error(&self, target: &IkTarget, tip: &Isometry3<f64>, w: f64) -> (Vector6<f64>, f64, f64) {
        match target {
            IkTarget::Position(p) => {
                let d = p - tip.translation.vector;
                (Vector6::new(d.x, d.y, d.z, 0.0, 0.0, 0.0), d.norm(), 0.0)
            }
            IkTarget::Pose(t) => {
                let d = t.translation.vector - tip.translation.vector;
                let r = (t.rotation * tip.rotation.inverse()).scaled_axis();
                (
                    Vector6::new(d.x, d.y, d.z, w * r.x, w * r.y, w * r.z),
                    d.norm(),
                    r.norm(),
                )
            }
        }
    }

    fn dls(&self, target: &IkTarget, q0: &[f64], opts: &IkOptions) -> IkSolution {
        let n = self.dof();
        let pose_target = matches!(target, IkTarget::Pose(_));
        let w = opts.orientation_weight;
        let mut q = q0.to_vec();
        let mut f = self.frames(&q);
        let (mut e, mut pe, mut oe) = self.error(target, &f.tip, w);
        let mut err = e.norm();
        let mut lambda = opts.damping.max(1e-12);
        let mut cols: Vec<Vector6<f64>> = vec![Vector6::zeros(); n];
        let mut free = vec![true; n];
        let mut dq = vec![0.0; n];
        let mut trial = vec![0.0; n];
        let mut tf = self.frames(&q);
        let mut iters = 0;
        while iters < opts.max_iters && err > opts.tolerance {
            iters += 1;
            for (i, c) in cols.iter_mut().enumerate() {
                let mut col = self.column(&f, i);
                if pose_target {
                    col[3] *= w;
                    col[4] *= w;
                    col[5] *= w;
                } else {
                    col[3] = 0.0;
                    col[4] = 0.0;
                    col[5] = 0.0;
                }
                *c = col;
            }
            free.iter_mut().for_each(|x| *x = true);
            // Active set: a joint at a limit that the step pushes outward is frozen, then re-solve.
            for _pass in 0..=n {
                solve_step(&cols, &free, &e, lambda, pose_target, &mut dq);
                let mut changed = false;
                for i in 0..n {
                    let (lo, hi) = self.limits[i];
                    if free[i]
                        && ((q[i] <= lo && dq[i] < 0.0) || (q[i] >= hi && dq[i] > 0.0))
                    {
                        free[i] = false;
                        changed = true;
                    }
                }
                if !changed {
                    break;
                }
            }
            let biggest = dq.iter().fold(0.0_f64, |m, d| m.max(d.abs()));
            let scale = if biggest > opts.max_step {
                opts.max_step / biggest
            } else {
                1.0
            };
            for i in 0..n {
                trial[i] = clamp(q[i] + scale * dq[i], self.limits[i]);
            }
            self.frames_into(&trial, &mut tf);
            let (te, tpe, toe) = self.error(target, &tf.tip, w);
            let terr = te.norm();
            if terr < err {
                std::mem::swap(&mut q, &mut trial);
                std::mem::swap(&mut f, &mut tf);
                e = te;
                pe = tpe;
                oe = toe;
                err = terr;
                lambda = (lambda * 0.3).max(1e-9);
            } else {
                lambda *= 5.0;
                if lambda > 1e4 {
                    break; // stuck in a local minimum or at the limits
                }
            }
        }
        IkSolution {
            q,
            converged: err <= opts.tolerance,
            residual: err,
            position_error: pe,
            orientation_error: oe,
            iterations: iters,
        }
    }
}

fn clamp(v: f64, (lo, hi): (f64, f64)) -> f64 {
    if lo <= hi {
        v.clamp(lo, hi)
    } else {
        v
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

/// `dq = Jfᵀ (Jf Jfᵀ + λ² I)⁻¹ e` over the free columns (3×3 system for position targets).
fn solve_step(
    cols: &[Vector6<f64>],
    free: &[bool],
    e: &Vector6<f64>,
    lambda: f64,
    pose: bool,
    dq: &mut [f64],
) {
    let l2 = lambda * lambda;
    if pose {
        let mut a = Matrix6::identity() * l2;
        for (c, _) in cols.iter().zip(free).filter(|(_, &f)| f) {
            a += c * c.transpose();
        }
        let y = a.cholesky().map(|ch| ch.solve(e)).unwrap_or_else(Vector6::zeros);
        for ((d, c), &f) in dq.iter_mut().zip(cols).zip(free) {
            *d = if f { c.dot(&y) } else { 0.0 };
        }
    } else {
        let mut a = Matrix3::identity() * l2;
        for (c, _) in cols.iter().zip(free).filter(|(_, &f)| f) {
            let v = c.fixed_rows::<3>(0);
            a += v * v.transpose();
        }
        let e3 = e.fixed_rows::<3>(0).into_owned();
        let y = a.cholesky().map(|ch| ch.solve(&e3)).unwrap_or_else(Vector3::zeros);
        for ((d, c), &f) in dq.iter_mut().zip(cols).zip(free) {
            *d = if f { c.fixed_rows::<3>(0).dot(&y) } else { 0.0 };
        }
    }
}
