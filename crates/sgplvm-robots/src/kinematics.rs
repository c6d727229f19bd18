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
    /// Gain of the secondary task that pulls the joints towards `rest` in the null space of
    /// the target (per iteration, fraction of the gap); 0 (the default) disables it. Keeps
    /// redundant arms (the 9-joint human) in natural postures and consecutive solutions close
    /// to each other, at the price of more iterations (try 0.5).
    pub posture_gain: f64,
    /// Preferred configuration of the posture task; `None` means the start `q0`.
    pub rest: Option<Vec<f64>>,
    /// With a posture task: after convergence, up to this many null-space steps towards `rest`
    /// (each re-converged to the tolerance; a step that cannot be is undone).
    pub posture_iters: usize,
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
            posture_gain: 0.0,
            rest: None,
            posture_iters: 20,
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
    /// `Δq = z + Jᵀ (J Jᵀ + λ² I)⁻¹ (e − J z)` with λ adapted Levenberg–Marquardt style (a step
    /// that does not reduce the error is rejected and λ grows) and `z = posture_gain · (rest − q)`
    /// a pull towards a preferred posture in the task's null space, drops from each step the joints that sit
    /// at a limit and would be pushed beyond it, and clamps. If the first attempt does not
    /// converge, it tries again from `opts.restarts` seeded random configurations and returns
    /// the best result. An unreachable target gives `converged == false` and the residual left.
    pub fn inverse_kinematics(
        &self,
        target: &IkTarget,
        q0: &[f64],
        opts: &IkOptions,
    ) -> IkSolution {
        let n = self.dof();
        let mut start: Vec<f64> = (0..n)
            .map(|i| clamp(q0.get(i).copied().unwrap_or(0.0), self.limits[i]))
            .collect();
        let rest: Vec<f64> = match &opts.rest {
            Some(r) => (0..n)
                .map(|i| clamp(r.get(i).copied().unwrap_or(0.0), self.limits[i]))
                .collect(),
            None => start.clone(),
        };
        let mut best: Option<IkSolution> = None;
        let mut total_iters = 0;
        let mut rng = ChaCha8Rng::seed_from_u64(opts.seed);
        for attempt in 0..=opts.restarts {
            if attempt > 0 {
                for (v, &(lo, hi)) in start.iter_mut().zip(&self.limits) {
                    let (lo, hi) = (lo.max(-std::f64::consts::PI), hi.min(std::f64::consts::PI));
                    *v = if hi > lo {
                        rng.random_range(lo..=hi)
                    } else {
                        lo
                    };
                }
            }
            let mut sol = self.dls(target, &start, &rest, opts);
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
        if opts.posture_gain > 0.0 {
            if let Some(b) = best.as_mut().filter(|b| b.converged) {
                total_iters += self.posture_polish(target, b, &rest, opts);
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

    /// Null-space steps towards `rest` from a converged solution, each re-converged by plain
    /// DLS; stops when the steps become tiny or one cannot be re-converged. Returns iterations.
    fn posture_polish(
        &self,
        target: &IkTarget,
        sol: &mut IkSolution,
        rest: &[f64],
        opts: &IkOptions,
    ) -> usize {
        let n = self.dof();
        let plain = IkOptions {
            posture_gain: 0.0,
            max_iters: 10,
            restarts: 0,
            rest: None,
            ..opts.clone()
        };
        let w = opts.orientation_weight;
        let pose_target = matches!(target, IkTarget::Pose(_));
        let free = vec![true; n];
        let mut z = vec![0.0; n];
        let mut dq = vec![0.0; n];
        let mut trial = vec![0.0; n];
        let mut iters = 0;
        let distance = |q: &[f64]| -> f64 {
            q.iter()
                .zip(rest)
                .map(|(a, b)| (a - b) * (a - b))
                .sum::<f64>()
        };
        for _ in 0..opts.posture_iters {
            let f = self.frames(&sol.q);
            let (e, _, _) = self.error(target, &f.tip, w);
            let cols: Vec<Vector6<f64>> = (0..n)
                .map(|i| {
                    let mut c = self.column(&f, i);
                    for k in 3..6 {
                        c[k] = if pose_target { c[k] * w } else { 0.0 };
                    }
                    c
                })
                .collect();
            let mut biggest: f64 = 0.0;
            for i in 0..n {
                z[i] = opts.posture_gain * (rest[i] - sol.q[i]);
                biggest = biggest.max(z[i].abs());
            }
            if biggest < 1e-7 {
                break;
            }
            solve_step(&cols, &free, &e, &z, 1e-6, pose_target, &mut dq);
            for i in 0..n {
                trial[i] = clamp(sol.q[i] + dq[i], self.limits[i]);
            }
            let c = self.dls(target, &trial, rest, &plain);
            iters += 1 + c.iterations;
            if !c.converged || distance(&c.q) >= distance(&sol.q) {
                break;
            }
            sol.q = c.q;
            sol.residual = c.residual;
            sol.position_error = c.position_error;
            sol.orientation_error = c.orientation_error;
        }
        iters
    }

    fn dls(&self, target: &IkTarget, q0: &[f64], rest: &[f64], opts: &IkOptions) -> IkSolution {
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
        let mut z = vec![0.0; n];
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
            // First with the posture term, then (if that step is rejected) without it.
            let mut accepted = false;
            for with_posture in [opts.posture_gain > 0.0 && err > 1e-6, false] {
                free.iter_mut().for_each(|x| *x = true);
                // Active set: a joint at a limit that the step pushes outward is frozen.
                for _pass in 0..=n {
                    for i in 0..n {
                        z[i] = if with_posture && free[i] {
                            opts.posture_gain * (rest[i] - q[i])
                        } else {
                            0.0
                        };
                    }
                    solve_step(&cols, &free, &e, &z, lambda, pose_target, &mut dq);
                    let mut changed = false;
                    for i in 0..n {
                        let (lo, hi) = self.limits[i];
                        if free[i] && ((q[i] <= lo && dq[i] < 0.0) || (q[i] >= hi && dq[i] > 0.0)) {
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
                    accepted = true;
                    break;
                }
                if opts.posture_gain <= 0.0 {
                    break;
                }
            }
            if accepted {
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

/// `dq = z + Jfᵀ (Jf Jfᵀ + λ² I)⁻¹ (e − Jf z)` over the free columns: the damped least-squares
/// step towards `e` plus the secondary motion `z` projected onto the (damped) null space of the
/// task. The system is 3×3 for position targets and 6×6 for poses.
fn solve_step(
    cols: &[Vector6<f64>],
    free: &[bool],
    e: &Vector6<f64>,
    z: &[f64],
    lambda: f64,
    pose: bool,
    dq: &mut [f64],
) {
    let l2 = lambda * lambda;
    let mut rhs = *e;
    for ((c, &f), &zi) in cols.iter().zip(free).zip(z) {
        if f && zi != 0.0 {
            rhs -= c * zi;
        }
    }
    if pose {
        let mut a = Matrix6::identity() * l2;
        for (c, _) in cols.iter().zip(free).filter(|(_, &f)| f) {
            a += c * c.transpose();
        }
        let y = a
            .cholesky()
            .map(|ch| ch.solve(&rhs))
            .unwrap_or_else(Vector6::zeros);
        for (((d, c), &f), &zi) in dq.iter_mut().zip(cols).zip(free).zip(z) {
            *d = if f { zi + c.dot(&y) } else { 0.0 };
        }
    } else {
        let mut a = Matrix3::identity() * l2;
        for (c, _) in cols.iter().zip(free).filter(|(_, &f)| f) {
            let v = c.fixed_rows::<3>(0);
            a += v * v.transpose();
        }
        let r3 = rhs.fixed_rows::<3>(0).into_owned();
        let y = a
            .cholesky()
            .map(|ch| ch.solve(&r3))
            .unwrap_or_else(Vector3::zeros);
        for (((d, c), &f), &zi) in dq.iter_mut().zip(cols).zip(free).zip(z) {
            *d = if f {
                zi + c.fixed_rows::<3>(0).dot(&y)
            } else {
                0.0
            };
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Matrix3, Rotation3};
    use std::f64::consts::FRAC_PI_2;

    const PLANAR: &str = r#"<robot name="planar">
      <link name="base"/><link name="l1"/><link name="l2"/><link name="tip"/>
      <joint name="j1" type="revolute"><parent link="base"/><child link="l1"/>
        <axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
      <joint name="j2" type="revolute"><origin xyz="1 0 0"/><parent link="l1"/><child link="l2"/>
        <axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
      <joint name="t" type="fixed"><origin xyz="0.5 0 0"/><parent link="l2"/><child link="tip"/></joint>
    </robot>"#;

    fn planar() -> Chain {
        Robot::from_urdf_str(PLANAR, "planar.urdf")
            .unwrap()
            .chain("base", "tip")
            .unwrap()
    }

    #[test]
    fn planar_two_link_fk_matches_the_formula() {
        let c = planar();
        assert_eq!(c.dof(), 2);
        for &(a, b) in &[(0.0, 0.0), (0.3, -1.1), (2.5, 1.7), (-1.0, 2.9)] {
            let p = c.forward(&[a, b]);
            let want = Vector3::new(
                a.cos() + 0.5 * (a + b).cos(),
                a.sin() + 0.5 * (a + b).sin(),
                0.0,
            );
            assert!((p.translation.vector - want).norm() < 1e-15, "{a} {b}");
            let want_rot = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), a + b);
            assert!(p.rotation.angle_to(&want_rot) < 1e-12);
        }
    }

    #[test]
    fn rpy_origins_and_prismatic_joints_match_hand_computed_poses() {
        let xml = r#"<robot name="r">
          <link name="base"/><link name="a"/><link name="tip"/>
          <joint name="turn" type="fixed"><origin xyz="0 0 1" rpy="0.3 -0.4 1.2"/>
            <parent link="base"/><child link="a"/></joint>
          <joint name="slide" type="prismatic"><origin xyz="0.1 0 0" rpy="0 0 1.5707963267948966"/>
            <parent link="a"/><child link="tip"/><axis xyz="1 0 0"/>
            <limit lower="0" upper="1" effort="1" velocity="1"/></joint>
        </robot>"#;
        let r = Robot::from_urdf_str(xml, "r.urdf").unwrap();
        let (roll, pitch, yaw) = (0.3_f64, -0.4_f64, 1.2_f64);
        let rx = Matrix3::new(
            1.0,
            0.0,
            0.0,
            0.0,
            roll.cos(),
            -roll.sin(),
            0.0,
            roll.sin(),
            roll.cos(),
        );
        let ry = Matrix3::new(
            pitch.cos(),
            0.0,
            pitch.sin(),
            0.0,
            1.0,
            0.0,
            -pitch.sin(),
            0.0,
            pitch.cos(),
        );
        let rz = Matrix3::new(
            yaw.cos(),
            -yaw.sin(),
            0.0,
            yaw.sin(),
            yaw.cos(),
            0.0,
            0.0,
            0.0,
            1.0,
        );
        let ra = rz * ry * rx; // URDF: R = Rz(yaw) Ry(pitch) Rx(roll)
        let d = 0.7;
        let p = r.forward_kinematics(&[d], "tip").unwrap();
        // tip = (0,0,1) + Ra (0.1, 0, 0) + Ra Rz(π/2) (d, 0, 0) = ... + Ra (0.1, d, 0)
        let want = Vector3::new(0.0, 0.0, 1.0) + ra * Vector3::new(0.1, d, 0.0);
        assert!((p.translation.vector - want).norm() < 1e-15);
        let rot = Rotation3::from_matrix_unchecked(
            ra * Rotation3::from_axis_angle(&Vector3::z_axis(), FRAC_PI_2).into_inner(),
        );
        assert!((p.rotation.to_rotation_matrix().into_inner() - rot.into_inner()).norm() < 1e-15);
    }

    fn fd_check(c: &Chain, q: &[f64]) -> f64 {
        let j = c.jacobian(q);
        let h = 1e-6;
        let mut worst: f64 = 0.0;
        for i in 0..c.dof() {
            let mut qp = q.to_vec();
            let mut qm = q.to_vec();
            qp[i] += h;
            qm[i] -= h;
            let (tp, tm) = (c.forward(&qp), c.forward(&qm));
            let lin = (tp.translation.vector - tm.translation.vector) / (2.0 * h);
            let ang = (tp.rotation * tm.rotation.inverse()).scaled_axis() / (2.0 * h);
            for k in 0..3 {
                worst = worst.max((j[(k, i)] - lin[k]).abs());
                worst = worst.max((j[(3 + k, i)] - ang[k]).abs());
            }
        }
        worst
    }

    #[test]
    fn jacobian_matches_finite_differences() {
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        for name in Robot::builtin_names() {
            let r = Robot::builtin(name).unwrap();
            for arm in r.arms().unwrap() {
                for _ in 0..5 {
                    let q: Vec<f64> = arm
                        .chain
                        .limits()
                        .iter()
                        .map(|&(lo, hi)| rng.random_range(lo..=hi))
                        .collect();
                    let err = fd_check(&arm.chain, &q);
                    assert!(err < 1e-8, "{name}: {err}");
                }
            }
        }
        // Prismatic joints: the Panda's finger.
        let panda = Robot::from_urdf_file(
            &std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("tests/fixtures/franka_panda.urdf"),
        )
        .unwrap();
        let c = panda.chain("panda_link0", "panda_leftfinger").unwrap();
        assert_eq!(c.dof(), 8);
        let err = fd_check(&c, &[0.1, -0.3, 0.2, -1.5, 0.4, 1.2, -0.5, 0.02]);
        assert!(err < 1e-8, "{err}");
    }

    #[test]
    fn ik_round_trips_reachable_targets_on_every_arm() {
        let mut rng = ChaCha8Rng::seed_from_u64(2);
        let opts = IkOptions::default();
        for name in Robot::builtin_names() {
            let r = Robot::builtin(name).unwrap();
            let neutral = r.neutral_configuration();
            for arm in r.arms().unwrap() {
                let q0 = arm.chain.extract(&neutral).unwrap();
                let mut worst: f64 = 0.0;
                for _ in 0..20 {
                    let q: Vec<f64> = arm
                        .chain
                        .limits()
                        .iter()
                        .map(|&(lo, hi)| rng.random_range(lo..=hi))
                        .collect();
                    let p = arm.chain.forward(&q).translation.vector;
                    let sol = arm
                        .chain
                        .inverse_kinematics(&IkTarget::Position(p), &q0, &opts);
                    assert!(sol.converged, "{name} {:?}: {sol:?}", arm.side);
                    let back = arm.chain.forward(&sol.q).translation.vector;
                    worst = worst.max((back - p).norm());
                    for (v, &(lo, hi)) in sol.q.iter().zip(arm.chain.limits()) {
                        assert!(*v >= lo && *v <= hi, "{name}: {v} outside [{lo}, {hi}]");
                    }
                    assert!((sol.residual - (back - p).norm()).abs() < 1e-15);
                }
                assert!(worst < 1e-6, "{name}: {worst}");
            }
        }
    }

    #[test]
    fn ik_reaches_full_poses() {
        let r = Robot::builtin("centauro").unwrap();
        let [arm, _] = r.arms().unwrap();
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let q0 = arm.chain.extract(&r.neutral_configuration()).unwrap();
        for _ in 0..10 {
            let q: Vec<f64> = arm
                .chain
                .limits()
                .iter()
                .map(|&(lo, hi)| rng.random_range(lo..=hi))
                .collect();
            let t = arm.chain.forward(&q);
            let sol = arm
                .chain
                .inverse_kinematics(&IkTarget::Pose(t), &q0, &IkOptions::default());
            assert!(sol.converged, "{sol:?}");
            let back = arm.chain.forward(&sol.q);
            assert!((back.translation.vector - t.translation.vector).norm() < 1e-6);
            assert!((back.rotation * t.rotation.inverse()).angle() < 1e-6);
        }
    }

    #[test]
    fn unreachable_targets_report_non_convergence_and_the_gap() {
        let c = planar();
        let sol = c.inverse_kinematics(
            &IkTarget::Position(Vector3::new(3.0, 0.0, 0.0)),
            &[0.4, 0.4],
            &IkOptions::default(),
        );
        assert!(!sol.converged);
        // Best is the arm stretched towards the target: 1.5 m reach, 1.5 m short.
        assert!((sol.residual - 1.5).abs() < 1e-6, "{sol:?}");
        assert!(sol.iterations > 0);
        // Out of the plane: the z offset cannot be removed.
        let sol = c.inverse_kinematics(
            &IkTarget::Position(Vector3::new(1.0, 0.5, 0.2)),
            &[0.0, 0.0],
            &IkOptions::default(),
        );
        assert!(!sol.converged);
        assert!((sol.residual - 0.2).abs() < 1e-6, "{sol:?}");
        assert_eq!(sol.position_error, sol.residual);
        // A real arm and a point 3 m away: out of reach.
        let r = Robot::builtin("coman").unwrap();
        let [arm, _] = r.arms().unwrap();
        let far = IkTarget::Position(Vector3::new(0.0, 3.0, 0.0));
        let sol = arm
            .chain
            .inverse_kinematics(&far, &[0.0; 7], &IkOptions::default());
        assert!(!sol.converged && sol.residual > 2.0, "{sol:?}");
    }

    #[test]
    fn batch_equals_single_and_lengths_are_checked() {
        let c = planar();
        let qs = [0.1, 0.2, -0.5, 1.0, 2.0, -2.0, 9.9];
        let poses = c.forward_batch(&qs);
        assert_eq!(poses.len(), 3);
        for (k, p) in poses.iter().enumerate() {
            assert_eq!(*p, c.forward(&qs[2 * k..2 * k + 2]));
        }
        assert!(c.try_forward(&[0.1]).is_err());
        assert!(c.try_jacobian(&[0.1, 0.2, 0.3]).is_err());
        assert_eq!(c.forward(&[0.1]), c.forward(&[0.1, 0.0]));
        let r = Robot::from_urdf_str(PLANAR, "planar.urdf").unwrap();
        let batch = r.forward_kinematics_batch(&qs[..6], "tip").unwrap();
        assert_eq!(batch, poses);
        assert!(r.forward_kinematics_batch(&qs, "tip").is_err());
        assert!(r.forward_kinematics(&[0.0], "tip").is_err());
    }

    #[test]
    fn chain_errors_name_the_links() {
        let r = Robot::from_urdf_str(PLANAR, "planar.urdf").unwrap();
        let e = r.chain("tip", "base").unwrap_err().to_string();
        assert_eq!(e, "robot \"planar\": link \"base\" is not a descendant of link \"tip\", so they do not bound a chain");
        let e = r.chain("base", "hand").unwrap_err().to_string();
        assert_eq!(e, "robot \"planar\": no link named \"hand\"");
        let c = r.chain("l1", "tip").unwrap();
        assert_eq!(c.joint_names(), &["j2".to_string()]);
        assert_eq!(c.robot_indices(), &[1]);
        let empty = r.chain("l2", "tip").unwrap();
        assert_eq!(empty.dof(), 0);
        assert_eq!(
            empty.forward(&[]).translation.vector,
            Vector3::new(0.5, 0.0, 0.0)
        );
        assert!(empty.forward_batch(&[]).is_empty());
    }

    #[test]
    fn posture_task_keeps_redundant_arms_near_rest_and_still_converges() {
        let r = Robot::builtin("human").unwrap();
        let [arm, _] = r.arms().unwrap();
        let zero = vec![0.0; 9];
        let s = r
            .forward_kinematics(&[0.0; 18], &arm.shoulder_link)
            .unwrap()
            .translation
            .vector;
        let dist = |q: &[f64]| q.iter().map(|v| v * v).sum::<f64>().sqrt();
        for offset in [
            Vector3::new(0.25, 0.0, -0.10),
            Vector3::new(0.3, 0.2, 0.1),
            Vector3::new(0.4, -0.1, -0.3),
        ] {
            let target = IkTarget::Position(s + offset);
            let plain = arm
                .chain
                .inverse_kinematics(&target, &zero, &IkOptions::default());
            let opts = IkOptions {
                posture_gain: 0.5,
                ..IkOptions::default()
            };
            let natural = arm.chain.inverse_kinematics(&target, &zero, &opts);
            assert!(plain.converged && natural.converged, "{natural:?}");
            let back = arm.chain.forward(&natural.q).translation.vector;
            assert!((back - (s + offset)).norm() < 1e-6);
            assert!(
                dist(&natural.q) < dist(&plain.q),
                "{} vs {}",
                dist(&natural.q),
                dist(&plain.q)
            );
        }
    }

    #[test]
    fn public_types_are_send_and_sync() {
        fn check<T: Send + Sync>() {}
        check::<Robot>();
        check::<Chain>();
        check::<IkSolution>();
    }
}
