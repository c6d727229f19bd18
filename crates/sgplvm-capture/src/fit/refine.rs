//! The fit where a joint limit holds the arm: the clavicle's and the shoulder's angles and the
//! elbow's flexion moved, within their limits, to the least squares of the elbow's and the
//! wrist's distances to the scaled capture and of the elbow angle's difference.
//!
//! What the fit returns is that optimum, not wherever an iteration happens to stop. The same
//! motion in metres or in centimetres, from a file or from a stream, differs by round-off, and
//! an iteration that stops on the cost's relative improvement (it stopped at 1e-6) stops at
//! different places for each: a Kinect capture in metres and in centimetres came out up to
//! 6.1e-4 rad apart where the optimum lies in a long, flat valley (shoulders abducted 100–112°).
//! So the descent, from the clamped closed form, takes Newton's steps on the exact Hessian
//! where it is positive definite and they lower the cost (quadratic convergence near the
//! optimum, however flat the valley), else Levenberg–Marquardt's; and it stops when Newton's
//! step moves no free angle by more than [`STEP_TOLERANCE`] radians (whatever the capture's
//! units: the residuals are the model's), or no step moves the angles at all.
//!
//! That optimum must be one, and near the capture. Where the arm is overhead at the abduction
//! limit with the elbow nearly straight, positions hardly tell the upper arm's twist: turning
//! it (with the clavicle and the shoulder's other angles making up) moves elbow and wrist by
//! a fraction of a millimetre over half a radian, and the converged descent went to one of
//! two far optima from frame to frame (CMU 13_26 at 11.6 s: rotation 0.53 rad and pronation
//! 0.88 rad away, three new jumps of 0.5 rad or more). So the least squares has a prior too:
//! each of the six angles' distance from the start (the clamped closed form, which carries the
//! capture's own segment orientations, and so its twist), weighted by [`PRIOR`] times the
//! arm's length. The rule for the weight: a radian from the start costs as much as a miss of
//! 0.3 % of the arm (about 2 mm), the least a capture's joint centres are known to. A change
//! of the angles that moves elbow and wrist by less than that per radian, positions do not
//! tell, and the prior holds it near the start; one that moves them by ten times more (elbow
//! bent, away from the gimbal point) is shifted by at most 1 % of the refinement's move (the
//! prior's weight over the positions' curvature, 1/100). Measured against the descent without
//! it on four captures (CMU 13_26, two MocapBank files, a Kinect v1 recording), where the
//! optimum stayed on its branch the prior added at most 0.04 mm to the elbow's and wrist's
//! miss (0.24 mm on the Kinect's), and with the elbow bent 40° or more it moved the angles by a
//! median 1–4 % of the fit's own error (its miss over the arm's length). The prior is in the
//! model's units, as the residuals are, and its Hessian (the weight on the diagonal) only makes
//! the valley better posed: the convergence and its tolerance are unchanged.

use nalgebra::{Matrix6, SMatrix, SVector, Vector3};

use super::{clavicle_rotation, rx, ry, rz, ArmTarget, HumanArms};

/// The descent has converged where Newton's step moves no free angle by more than this
/// (radians): the same capture in other units or with its values off by round-off then gives
/// the same angles to within 1e-9 rad.
const STEP_TOLERANCE: f64 = 1e-12;

/// Largest Newton step (radians, every angle) taken without its lowering the cost: within it
/// the quadratic model holds to far below the cost's round-off, which in a flat valley hides
/// what such a step gains.
const NEWTON_STEPS: f64 = 1e-6;

/// How near its limit (radians) a step may leave an angle before it is put on it.
const AT_LIMIT: f64 = 1e-10;

/// Most damping of Levenberg–Marquardt's step (relative to the Hessian's entries, about 0.1):
/// a step damped further moves the angles by less than the cost's round-off can tell.
const MAX_DAMPING: f64 = 1e12;

/// Most iterations of the descent. From the clamped closed form it most often takes 3 to 10;
/// where the arm lies near the shoulder's gimbal point (abduction 90°) and a line of poses
/// fits as well, a hundred or more.
const MAX_ITERATIONS: usize = 200;

/// The prior's weight: each refined angle's distance from the start (radians) enters the
/// least squares times this fraction of the arm's length, so that a radian from the start
/// costs as much as a miss of 0.3 % of the arm (about 2 mm), the least a capture's joint
/// centres are known to (module docs).
const PRIOR: f64 = 3e-3;

/// The residuals: the elbow's and the wrist's distances to the scaled capture (metres, model
/// torso frame), the elbow angle's difference (radians, weighted by the arm's length) and the
/// six angles' distances from the start (weighted by [`PRIOR`] times the arm's length).
type Residuals = SVector<f64, 13>;

/// The residuals' derivatives by the six angles refined (clavicle 2, shoulder 3, elbow 1).
type Jacobian = SMatrix<f64, 13, 6>;

impl HumanArms {
    /// The residuals at the first six angles of `q` and their exact derivatives: each angle
    /// turns the points below it about its axis (in the torso frame) through its joint.
    fn residuals(
        &self,
        goal: (Vector3<f64>, Vector3<f64>),
        elbow_angle: f64,
        start: &[f64; 9],
        q: &[f64; 9],
    ) -> (Residuals, Jacobian, Matrix6<f64>) {
        let (elbow, wrist) = self.elbow_wrist_left(q);
        let turn = rx(q[0]);
        let rc = clavicle_rotation(q[0], q[1]);
        let flex = rc * ry(-q[2]);
        let abducted = flex * rx(q[3]);
        let upper = abducted * rz(-q[4]);
        let shoulder = self.sc + rc * Vector3::new(0.0, self.clavicle, 0.0);
        // Axis and pivot of each angle, in the torso frame.
        let joints = [
            (Vector3::x(), self.sc),
            (-(turn * Vector3::z()), self.sc),
            (-(rc * Vector3::y()), shoulder),
            (flex * Vector3::x(), shoulder),
            (-(abducted * Vector3::z()), shoulder),
            (-(upper * Vector3::y()), elbow),
        ];
        let weight = self.upper_arm + self.forearm;
        let (de, dw) = (elbow - goal.0, wrist - goal.1);
        let angle = weight * (q[5] - elbow_angle);
        let prior = PRIOR * weight;
        let mut residuals = Residuals::zeros();
        residuals
            .fixed_rows_mut::<7>(0)
            .copy_from_slice(&[de.x, de.y, de.z, dw.x, dw.y, dw.z, angle]);
        let mut jacobian = Jacobian::zeros();
        for k in 0..6 {
            residuals[7 + k] = prior * (q[k] - start[k]);
            jacobian[(7 + k, k)] = prior;
        }
        for (k, (axis, pivot)) in joints.iter().enumerate() {
            if k < 5 {
                let e = axis.cross(&(elbow - pivot));
                jacobian.fixed_view_mut::<3, 1>(0, k).copy_from(&e);
            }
            let w = axis.cross(&(wrist - pivot));
            jacobian.fixed_view_mut::<3, 1>(3, k).copy_from(&w);
        }
        jacobian[(6, 5)] = weight;
        // Half the cost's Hessian: JᵀJ and the residuals times their second derivatives (the
        // prior's are none),
        // ∂²P/∂q_j∂q_k = a_j × (a_k × (P − p_k)) for angle j at or above angle k.
        let mut hessian = jacobian.transpose() * jacobian;
        for k in 0..6 {
            let (axis_k, pivot_k) = joints[k];
            for (j, (axis_j, _)) in joints.iter().enumerate().take(k + 1) {
                let mut second = dw.dot(&axis_j.cross(&axis_k.cross(&(wrist - pivot_k))));
                if k < 5 {
                    second += de.dot(&axis_j.cross(&axis_k.cross(&(elbow - pivot_k))));
                }
                hessian[(j, k)] += second;
                if j != k {
                    hessian[(k, j)] += second;
                }
            }
        }
        (residuals, jacobian, hessian)
    }

    /// Moves the clavicle and shoulder angles and the elbow flexion of `q`, within `lim`, to
    /// the least squares of the elbow's and the wrist's distances to the scaled capture and the
    /// elbow angle's difference (weighted by the arm's length), started from the clamped closed
    /// form (module docs). (The clavicle may then leave the capture's: raising the shoulder
    /// girdle is how a person reaches beyond the arm's range.)
    pub(super) fn refine_at_limits(
        &self,
        t: &ArmTarget,
        lim: &[(f64, f64); 9],
        elbow_angle: f64,
        q: &mut [f64; 9],
    ) {
        let points = self.target_points(t);
        let goal = (points.elbow, points.wrist);
        let start = *q;
        let at = |q: &[f64; 9]| {
            let (r, jac, hessian) = self.residuals(goal, elbow_angle, &start, q);
            (
                r.norm_squared(),
                jac.transpose() * r,
                jac.transpose() * jac,
                hessian,
            )
        };
        let (mut cost, mut gradient, mut gauss_newton, mut hessian) = at(q);
        let mut lambda = 1e-3;
        for _ in 0..MAX_ITERATIONS {
            // An angle at a limit that the descent would push beyond stays there: the others
            // move as if it were fixed.
            let pushed_out = |k: usize, towards: f64| {
                let (lo, hi) = lim[k];
                (q[k] <= lo && towards < 0.0) || (q[k] >= hi && towards > 0.0)
            };
            let free: [bool; 6] = std::array::from_fn(|k| !pushed_out(k, -gradient[k]));
            // The step of `matrix` (damped) over the free angles; an angle at a limit that the
            // step itself would take beyond it (the angles move together) is fixed too.
            let step_of = |matrix: &Matrix6<f64>, damping: f64| {
                let mut free = free;
                loop {
                    let mut m = *matrix + Matrix6::identity() * damping;
                    let mut g = gradient;
                    for k in (0..6).filter(|&k| !free[k]) {
                        m.row_mut(k).fill(0.0);
                        m.column_mut(k).fill(0.0);
                        m[(k, k)] = 1.0;
                        g[k] = 0.0;
                    }
                    let step = m.cholesky()?.solve(&(-g));
                    let beyond: Vec<usize> = (0..6)
                        .filter(|&k| free[k] && pushed_out(k, step[k]))
                        .collect();
                    if beyond.is_empty() {
                        return Some(step);
                    }
                    for k in beyond {
                        free[k] = false;
                    }
                }
            };
            // Where the Hessian is positive definite, Newton's step: taken where it lowers the
            // cost, and where it is so small that the cost's round-off could not tell
            // ([`NEWTON_STEPS`]); near the optimum it converges quadratically.
            if let Some(step) = step_of(&hessian, 0.0) {
                let trial = within(q, &step, lim);
                if step.amax() <= STEP_TOLERANCE || trial == *q {
                    return;
                }
                let next = at(&trial);
                if next.0 < cost || step.amax() <= NEWTON_STEPS {
                    *q = trial;
                    (cost, gradient, gauss_newton, hessian) = next;
                    continue;
                }
            }
            // Further away, Gauss–Newton's step, damped until it lowers the cost
            // (Levenberg–Marquardt).
            loop {
                let trial = match step_of(&gauss_newton, lambda) {
                    Some(step) => within(q, &step, lim),
                    None => *q,
                };
                if trial == *q {
                    // No step moves an angle: a stationary point, to round-off.
                    return;
                }
                let next = at(&trial);
                if next.0 < cost {
                    *q = trial;
                    (cost, gradient, gauss_newton, hessian) = next;
                    lambda = (lambda * 0.3).max(1e-12);
                    break;
                }
                lambda *= 10.0;
                if lambda > MAX_DAMPING {
                    return;
                }
            }
        }
    }
}

/// `q` moved by `step` (the six angles refined) as far as the limits `lim` let it go along it:
/// the step shortened to where the first angle meets its limit, which it is then set to.
fn within(q: &[f64; 9], step: &SVector<f64, 6>, lim: &[(f64, f64); 9]) -> [f64; 9] {
    let mut fraction: f64 = 1.0;
    let mut stop = None;
    for k in 0..6 {
        let (lo, hi) = lim[k];
        let room = if step[k] > 0.0 { hi - q[k] } else { lo - q[k] };
        if step[k] != 0.0 && room / step[k] < fraction {
            fraction = (room / step[k]).max(0.0);
            stop = Some(k);
        }
    }
    let mut moved = *q;
    for k in 0..6 {
        let (lo, hi) = lim[k];
        let v = (q[k] + fraction * step[k]).clamp(lo, hi);
        // An angle left a hair's breadth from its limit is on it: the next step can then hold
        // it there, where from just inside it the step would be cut to nothing.
        moved[k] = if v - lo <= AT_LIMIT {
            lo
        } else if hi - v <= AT_LIMIT {
            hi
        } else {
            v
        };
    }
    if let Some(k) = stop {
        moved[k] = if step[k] > 0.0 { lim[k].1 } else { lim[k].0 };
    }
    moved
}

#[cfg(test)]
mod tests {
    use super::*;
    use sgplvm_robots::Robot;

    #[test]
    fn the_jacobian_and_the_hessian_are_the_derivatives() {
        let h = HumanArms::new(&Robot::builtin("human").unwrap()).unwrap();
        let goal = (Vector3::new(0.1, 0.3, 0.0), Vector3::new(0.3, 0.25, 0.1));
        let q = [0.2, -0.1, 0.7, 1.9, -0.4, 1.1, 0.0, 0.0, 0.0];
        let start = [0.3, -0.2, 0.5, 1.7, -0.1, 1.3, 0.0, 0.0, 0.0];
        let (_, jac, hessian) = h.residuals(goal, 0.9, &start, &q);
        // The cost's half-gradient Jᵀr, whose derivative is the half-Hessian.
        let gradient = |q: &[f64; 9]| {
            let (r, j, _) = h.residuals(goal, 0.9, &start, q);
            j.transpose() * r
        };
        for k in 0..6 {
            let (mut up, mut down) = (q, q);
            up[k] += 1e-6;
            down[k] -= 1e-6;
            let residual = |q: &[f64; 9]| h.residuals(goal, 0.9, &start, q).0;
            let numeric = (residual(&up) - residual(&down)) / 2e-6;
            let off = (numeric - jac.column(k)).amax();
            assert!(off < 1e-8, "Jacobian, angle {k}: {off}");
            let numeric = (gradient(&up) - gradient(&down)) / 2e-6;
            let off = (numeric - hessian.column(k)).amax();
            assert!(off < 1e-8, "Hessian, angle {k}: {off}");
        }
    }
}
