//! Damped least-squares inverse kinematics on a [`Chain`], within its joint limits, with an
//! optional posture task in the null space and seeded random restarts.

use nalgebra::{Isometry3, Matrix3, Matrix6, Vector3, Vector6};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::{Chain, Frames};

/// What inverse kinematics should reach: a tip position, or a full tip pose (base frame).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum IkTarget {
    /// Tip origin at this point; orientation free.
    Position(Vector3<f64>),
    /// Tip frame equal to this pose.
    Pose(Isometry3<f64>),
    /// Tip origin at `tip` first; then, in the null space of that task, the origin of chain
    /// joint `joint` (e.g. the elbow) as near `point` as the tip allows.
    PositionAndJoint {
        /// Where the tip goes.
        tip: Vector3<f64>,
        /// Index of the chain joint whose origin follows `point` (its origin moves with the
        /// joints before it).
        joint: usize,
        /// Where that joint's origin should be.
        point: Vector3<f64>,
    },
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
    /// With a posture task (or a [`IkTarget::PositionAndJoint`] target): after convergence, up
    /// to this many null-space steps towards `rest` (or the joint's point), each re-converged
    /// to the tolerance; a step that cannot be is undone.
    pub posture_iters: usize,
    /// Bounds per joint narrower than the chain's limits, e.g. how far each joint can move in
    /// one control period at its velocity limit; intersected with the limits. `None`: the
    /// limits alone.
    pub bounds: Option<Vec<(f64, f64)>>,
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
            bounds: None,
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

impl Chain {
    /// Damped least-squares inverse kinematics within the joint limits.
    ///
    /// Starts from `q0` (clamped into the limits; missing values are 0), iterates
    /// `Δq = z + Jᵀ (J Jᵀ + λ² I)⁻¹ (e − J z)` with λ adapted Levenberg–Marquardt style (a step
    /// that does not reduce the error is rejected and λ grows) and `z = posture_gain · (rest − q)`
    /// a pull towards a preferred posture in the task's null space, drops from each step the joints that sit
    /// at a limit and would be pushed beyond it, and clamps. If the first attempt does not
    /// converge, it tries again from `opts.restarts` seeded random configurations and returns
    /// the best result. An unreachable target gives `converged == false` and the residual left.
    ///
    /// With [`IkOptions::bounds`] the joints also stay within those bounds. With an
    /// [`IkTarget::PositionAndJoint`] target the tip's position is solved first, then null-space
    /// steps bring the joint's origin towards its point (the posture task is not used then).
    pub fn inverse_kinematics(
        &self,
        target: &IkTarget,
        q0: &[f64],
        opts: &IkOptions,
    ) -> IkSolution {
        if let Some(bounds) = &opts.bounds {
            let mut narrowed = self.clone();
            for (l, b) in narrowed.limits.iter_mut().zip(bounds) {
                let (lo, hi) = (l.0.max(b.0), l.1.min(b.1));
                // Bounds outside the limits leave the nearest limit.
                *l = if lo <= hi {
                    (lo, hi)
                } else if b.1 < l.0 {
                    (l.0, l.0)
                } else {
                    (l.1, l.1)
                };
            }
            let plain = IkOptions {
                bounds: None,
                ..opts.clone()
            };
            return narrowed.inverse_kinematics(target, q0, &plain);
        }
        if let IkTarget::PositionAndJoint { tip, joint, point } = target {
            let primary = IkTarget::Position(*tip);
            let plain = IkOptions {
                posture_gain: 0.0,
                rest: None,
                ..opts.clone()
            };
            let mut sol = self.inverse_kinematics(&primary, q0, &plain);
            if sol.converged && *joint < self.dof() {
                sol.iterations += self.null_space_polish(
                    &primary,
                    &mut sol,
                    opts,
                    &Secondary::Point {
                        joint: *joint,
                        point: *point,
                    },
                );
            }
            return sol;
        }
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
                total_iters += self.null_space_polish(target, b, opts, &Secondary::Posture(&rest));
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
            IkTarget::Position(p) | IkTarget::PositionAndJoint { tip: p, .. } => {
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

    /// Null-space steps of a secondary task from a converged solution (towards the posture
    /// `rest`, or bringing a joint's origin to a point), each re-converged by plain DLS; stops
    /// when the steps become tiny, one cannot be re-converged or the secondary objective stops
    /// improving. Returns iterations.
    fn null_space_polish(
        &self,
        target: &IkTarget,
        sol: &mut IkSolution,
        opts: &IkOptions,
        secondary: &Secondary<'_>,
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
        let gain = match secondary {
            Secondary::Posture(_) => opts.posture_gain,
            Secondary::Point { .. } => 1.0,
        };
        let rest_for_dls: Vec<f64> = match secondary {
            Secondary::Posture(rest) => rest.to_vec(),
            Secondary::Point { .. } => sol.q.clone(),
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
            secondary.velocity(self, &f, &sol.q, gain, &mut z);
            if z.iter().fold(0.0_f64, |m, v| m.max(v.abs())) < 1e-7 {
                break;
            }
            solve_step(&cols, &free, &e, &z, 1e-6, pose_target, &mut dq);
            for i in 0..n {
                trial[i] = clamp(sol.q[i] + dq[i], self.limits[i]);
            }
            let c = self.dls(target, &trial, &rest_for_dls, &plain);
            iters += 1 + c.iterations;
            if !c.converged || secondary.objective(self, &c.q) >= secondary.objective(self, &sol.q)
            {
                break;
            }
            sol.q = c.q;
            sol.residual = c.residual;
            sol.position_error = c.position_error;
            sol.orientation_error = c.orientation_error;
        }
        iters
    }

    /// The Jacobian columns of the task at frames `f`: orientation rows weighted by `w` for a
    /// pose target, zeroed for a position target.
    fn task_columns(&self, f: &Frames, pose_target: bool, w: f64, cols: &mut [Vector6<f64>]) {
        for (i, c) in cols.iter_mut().enumerate() {
            let mut col = self.column(f, i);
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
    }

    /// The damped least-squares step `dq` of [`solve_step`] with an active set: a joint at a
    /// limit that the step pushes outward is frozen and the step solved again, until no joint
    /// changes. With `posture = Some((gain, rest))` free joints are also pulled towards `rest`.
    fn limited_step(
        &self,
        step: &StepInput,
        posture: Option<(f64, &[f64])>,
        free: &mut [bool],
        z: &mut [f64],
        dq: &mut [f64],
    ) {
        let n = free.len();
        let q = step.q;
        free.iter_mut().for_each(|x| *x = true);
        for _pass in 0..=n {
            for i in 0..n {
                z[i] = match posture {
                    Some((gain, rest)) if free[i] => gain * (rest[i] - q[i]),
                    _ => 0.0,
                };
            }
            solve_step(
                step.cols,
                free,
                step.e,
                z,
                step.lambda,
                step.pose_target,
                dq,
            );
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
            self.task_columns(&f, pose_target, w, &mut cols);
            // First with the posture term, then (if that step is rejected) without it.
            let mut accepted = false;
            for with_posture in [opts.posture_gain > 0.0 && err > 1e-6, false] {
                let posture = with_posture.then_some((opts.posture_gain, rest));
                let step = StepInput {
                    cols: &cols,
                    e: &e,
                    q: &q,
                    lambda,
                    pose_target,
                };
                self.limited_step(&step, posture, &mut free, &mut z, &mut dq);
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

/// A task solved in the null space of the main target after it has converged.
enum Secondary<'a> {
    /// Towards a preferred configuration.
    Posture(&'a [f64]),
    /// The origin of chain joint `joint` towards `point`.
    Point { joint: usize, point: Vector3<f64> },
}

impl Secondary<'_> {
    /// The joint velocity that serves the task at `q` (frames `f`), scaled by `gain`.
    fn velocity(&self, chain: &Chain, f: &Frames, q: &[f64], gain: f64, z: &mut [f64]) {
        match self {
            Secondary::Posture(rest) => {
                for ((zi, r), qi) in z.iter_mut().zip(rest.iter()).zip(q) {
                    *zi = gain * (r - qi);
                }
            }
            Secondary::Point { joint, point } => {
                // Task priority: z = gain · (Jp N)ᵀ ((Jp N)(Jp N)ᵀ + μ² I)⁻¹ (point − p), with N
                // the projector onto the tip's null space and Jp the point's Jacobian (the
                // joints before `joint` move it): the point's least-squares step among the
                // motions that leave the tip where it is.
                let n = q.len();
                let p = f.origins[*joint];
                let e = point - p;
                let jp = nalgebra::DMatrix::from_fn(3, n, |r, i| {
                    if i >= *joint {
                        0.0
                    } else if chain.segments[i].prismatic {
                        f.axes[i][r]
                    } else {
                        f.axes[i].cross(&(p - f.origins[i]))[r]
                    }
                });
                let jt = nalgebra::DMatrix::from_fn(3, n, |r, i| chain.column(f, i)[r]);
                let jjt = &jt * jt.transpose() + nalgebra::DMatrix::identity(3, 3) * 1e-8;
                let projector = match jjt.cholesky() {
                    Some(ch) => nalgebra::DMatrix::identity(n, n) - jt.transpose() * ch.solve(&jt),
                    None => nalgebra::DMatrix::identity(n, n),
                };
                let a = jp * &projector;
                let aat = &a * a.transpose() + nalgebra::DMatrix::identity(3, 3) * 1e-6;
                let ev = nalgebra::DVector::from_column_slice(e.as_slice());
                let y = aat
                    .cholesky()
                    .map(|ch| ch.solve(&ev))
                    .unwrap_or_else(|| nalgebra::DVector::zeros(3));
                let zv = a.transpose() * y;
                for (zi, v) in z.iter_mut().zip(zv.iter()) {
                    *zi = gain * v;
                }
            }
        }
    }

    /// How far the task is from done at `q` (smaller is better).
    fn objective(&self, chain: &Chain, q: &[f64]) -> f64 {
        match self {
            Secondary::Posture(rest) => q
                .iter()
                .zip(rest.iter())
                .map(|(a, b)| (a - b) * (a - b))
                .sum(),
            Secondary::Point { joint, point } => {
                (chain.frames(q).origins[*joint] - point).norm_squared()
            }
        }
    }
}

/// What one damped least-squares step is taken from.
struct StepInput<'a> {
    /// Task Jacobian columns.
    cols: &'a [Vector6<f64>],
    /// Task error.
    e: &'a Vector6<f64>,
    /// Current configuration.
    q: &'a [f64],
    /// Damping.
    lambda: f64,
    /// Whether the task has orientation rows.
    pose_target: bool,
}

fn clamp(v: f64, (lo, hi): (f64, f64)) -> f64 {
    if lo <= hi {
        v.clamp(lo, hi)
    } else {
        v
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
