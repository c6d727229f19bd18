//! The human model's 9 joint angles per arm from a captured arm pose, in closed form.
//!
//! The shipped human (`data/urdf/human.urdf`, left arm; the right mirrors it) chains
//!
//! ```text
//! clavicle  R_c = Rx(e) · Rz(−p)                 elevation e, protraction p;   shoulder at R_c (0, L_c, 0)
//! shoulder  R_s = Ry(−f) · Rx(a) · Rz(−r)        flexion f, abduction a, rotation r;  elbow at R_c R_s (0, 0, −L_u)
//! elbow     R_e = Ry(−g) · Rz(ψ)                 flexion g, pronation ψ;        wrist at … R_e (0, 0, −L_f)
//! wrist     R_w = Rx(−w) · Ry(−d)                flexion w, deviation d;        hand at … R_w (0, 0, −L_h)
//! ```
//!
//! and each group is solved in turn from the capture's segment directions, scaled to the
//! model's segment lengths and anchored at the model's sternoclavicular joint: the clavicle
//! angles point the clavicle, the shoulder angles point the upper arm at the captured elbow and
//! turn the elbow's hinge plane onto the captured forearm, the elbow flexion is the angle
//! between the segments, and pronation and the wrist angles turn the hand onto the captured
//! hand's orientation. Each group is solved from where the previous one actually put the
//! model (after clamping to joint limits), so a limit costs only what it must.
//!
//! Where Euler angles have two solutions the one within the limits and nearest the previous
//! frame wins, unless a limit holds it more than 3 cm from the capture and the other, held by
//! its own limits, brings elbow and wrist 3 cm nearer (the arm's direction before continuity);
//! at the shoulder's gimbal point (abduction ±90°) the flexion of the previous frame is kept.
//! Twists that positions cannot tell (shoulder rotation with a straight elbow, pronation) come
//! from the capture's segment orientations, calibrated on its rest pose: every channel at zero
//! is taken as no twist (a T- or A-pose with palms down, or arms hanging with palms facing the
//! body, as capture systems define it). Where the rest pose holds the upper
//! arm at the shoulder's gimbal point (a T-pose with flat clavicles; the line of bones that
//! is the zero pose of a rig whose bones lie along local x), "no twist" is undefined there:
//! the elbow's hinge, as the motion bends it, sets the upper arm's twist instead, and the
//! hand's follows it (its rest orientation relative to the upper arm's).

use nalgebra::{Matrix3, Rotation3, Vector3};

mod girdle;
mod shoulder;

pub use girdle::with_clavicle;

use crate::bvh::axis_rotation;
use sgplvm_robots::kinematics::Chain;
use sgplvm_robots::{Robot, RobotError, Side};
use shoulder::{choose_turn, shoulder_angles, BRANCH_POSITION_GAIN};

/// Angles of one arm in the model's order: elevation, protraction, flexion, abduction,
/// rotation, elbow flexion, pronation, wrist flexion, wrist deviation.
pub type ArmAngles = [f64; 9];

/// Names of the nine joint groups' angles, for messages.
pub const ANGLE_NAMES: [&str; 9] = [
    "C7Shoulder_elevation",
    "C7Shoulder_protraction",
    "Shoulder_flexion",
    "Shoulder_abduction",
    "Shoulder_rotation",
    "Elbow_flexion",
    "Elbow_pronation",
    "Wrist_flexion",
    "Wrist_deviation",
];

/// The shipped human's arm geometry and the chains that check a fit.
#[derive(Debug, Clone)]
pub struct HumanArms {
    /// Sternoclavicular joint of the left arm in the torso (`T8`) frame.
    sc: Vector3<f64>,
    clavicle: f64,
    upper_arm: f64,
    forearm: f64,
    /// Joint limits per side, in the model's order.
    limits: [[(f64, f64); 9]; 2],
    /// Chains from the torso to the elbow and to the wrist, per side (residual checks).
    elbow_chain: [Chain; 2],
    wrist_chain: [Chain; 2],
    /// The model's 18 joint names (left arm, then right).
    pub joint_names: Vec<String>,
}

/// Expected joint axes of the left arm (the right arm's are mirrored: `(x, −y, z)` negated).
const LEFT_AXES: [[f64; 3]; 9] = [
    [1.0, 0.0, 0.0],
    [0.0, 0.0, -1.0],
    [0.0, -1.0, 0.0],
    [1.0, 0.0, 0.0],
    [0.0, 0.0, -1.0],
    [0.0, -1.0, 0.0],
    [0.0, 0.0, 1.0],
    [-1.0, 0.0, 0.0],
    [0.0, -1.0, 0.0],
];

/// The left-arm convention's mirror `diag(1, −1, 1)`.
fn mirror() -> Matrix3<f64> {
    Matrix3::from_diagonal(&Vector3::new(1.0, -1.0, 1.0))
}

/// A vector of the right arm in the left arm's convention (and back).
pub(crate) fn mirror_vector(v: Vector3<f64>) -> Vector3<f64> {
    Vector3::new(v.x, -v.y, v.z)
}

/// A rotation of the right arm in the left arm's convention (and back).
pub(crate) fn mirror_rotation(r: &Rotation3<f64>) -> Rotation3<f64> {
    Rotation3::from_matrix_unchecked(mirror() * r.matrix() * mirror())
}

impl HumanArms {
    /// The geometry of `robot`, which must be the shipped human (or a body with the same
    /// joints, axes and segment directions).
    pub fn new(robot: &Robot) -> Result<HumanArms, RobotError> {
        let names = robot.joint_names();
        let bad = |message: String| RobotError::Invalid {
            file: format!("builtin:{}", robot.name()),
            element: "human arm".into(),
            message,
        };
        if names.len() != 18 {
            return Err(bad(format!(
                "{} joints, expected the human's 18",
                names.len()
            )));
        }
        let zero = vec![0.0; 18];
        let link = |l: &str| -> Result<Vector3<f64>, RobotError> {
            Ok(robot.forward_kinematics(&zero, l)?.translation.vector)
        };
        let mut limits = [[(0.0, 0.0); 9]; 2];
        let all_limits = robot.joint_limits();
        for (side, lim) in limits.iter_mut().enumerate() {
            lim.copy_from_slice(&all_limits[side * 9..side * 9 + 9]);
        }
        // Axes, as the closed form assumes them.
        for (k, name) in names.iter().enumerate() {
            let info = robot
                .joints()
                .iter()
                .find(|j| &j.name == name)
                .ok_or_else(|| bad(format!("joint `{name}` missing")))?;
            let axis = info.origin.rotation * info.axis.into_inner();
            let expect = Vector3::from(LEFT_AXES[k % 9]);
            let expect = if k < 9 {
                expect
            } else {
                -mirror_vector(expect)
            };
            if (axis - expect).norm() > 1e-9 {
                return Err(bad(format!(
                    "joint `{name}` turns about {axis:?}, the closed-form fit expects {expect:?}"
                )));
            }
        }
        let sc = link("left_clavicle_base")?;
        let shoulder = link("left_upper_arm_flex")?;
        let elbow = link("left_forearm_flex")?;
        let wrist = link("left_hand_flex")?;
        let torso = robot.root_link().to_string();
        let chain = |tip: &str| robot.chain(&torso, tip);
        Ok(HumanArms {
            sc,
            clavicle: (shoulder - sc).norm(),
            upper_arm: (elbow - shoulder).norm(),
            forearm: (wrist - elbow).norm(),
            limits,
            elbow_chain: [chain("left_forearm_flex")?, chain("right_forearm_flex")?],
            wrist_chain: [chain("left_hand_flex")?, chain("right_hand_flex")?],
            joint_names: names,
        })
    }

    /// Joint limits of arm `side`.
    pub fn limits(&self, side: Side) -> &[(f64, f64); 9] {
        &self.limits[crate::skeleton::side_index(side)]
    }

    /// Elbow and wrist of arm `side` at `angles` by the model's forward kinematics (torso
    /// frame): the check of a fit, independent of the closed form.
    pub fn elbow_and_wrist(&self, side: Side, angles: &ArmAngles) -> (Vector3<f64>, Vector3<f64>) {
        let i = crate::skeleton::side_index(side);
        let e = self.elbow_chain[i].forward(&angles[..self.elbow_chain[i].dof()]);
        let w = self.wrist_chain[i].forward(&angles[..self.wrist_chain[i].dof()]);
        (e.translation.vector, w.translation.vector)
    }
}

/// One captured arm pose as the fit takes it, in the left arm's convention (the right arm
/// mirrored), body axes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ArmTarget {
    /// Unit direction sternoclavicular joint → shoulder; `None` without a clavicle segment.
    pub clavicle: Option<Vector3<f64>>,
    /// Unit direction shoulder → elbow.
    pub upper_arm: Vector3<f64>,
    /// Unit direction elbow → wrist.
    pub forearm: Vector3<f64>,
    /// Orientation the upper arm's frame would have with no shoulder twist change since the
    /// rest pose (used for the twist where the elbow is straight).
    pub upper_arm_frame: Rotation3<f64>,
    /// Target orientation of the hand's frame.
    pub hand_frame: Rotation3<f64>,
}

/// Scaled target positions of one arm (left convention, torso frame), for residuals.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TargetPoints {
    /// The captured elbow, scaled to the model.
    pub elbow: Vector3<f64>,
    /// The captured wrist, scaled to the model.
    pub wrist: Vector3<f64>,
}

/// What one arm's fit gave.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ArmFit {
    /// The angles, within limits.
    pub angles: ArmAngles,
    /// Which angles were clamped to a limit.
    pub clamped: [bool; 9],
    /// The capture's elbow angle (between upper arm and forearm), radians.
    pub capture_elbow_angle: f64,
}

/// Unclamped solution at the rest pose: the upper arm's and the hand's orientation, the
/// calibration of the twists.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RestFrames {
    /// Model upper-arm frame at the capture's rest pose.
    pub upper_arm: Rotation3<f64>,
    /// Model hand frame at the capture's rest pose.
    pub hand: Rotation3<f64>,
}

fn rx(a: f64) -> Rotation3<f64> {
    axis_rotation(0, a)
}
fn ry(a: f64) -> Rotation3<f64> {
    axis_rotation(1, a)
}
fn rz(a: f64) -> Rotation3<f64> {
    axis_rotation(2, a)
}

/// Clavicle rotation `Rx(e) Rz(−p)`.
fn clavicle_rotation(e: f64, p: f64) -> Rotation3<f64> {
    rx(e) * rz(-p)
}

/// Shoulder rotation `Ry(−f) Rx(a) Rz(−r)`.
fn shoulder_rotation(f: f64, a: f64, r: f64) -> Rotation3<f64> {
    ry(-f) * rx(a) * rz(-r)
}

/// `(e, p)` pointing the clavicle (rest direction +y) along unit `d`.
fn clavicle_angles(d: &Vector3<f64>) -> (f64, f64) {
    (d.z.atan2(d.y), d.x.atan2(d.y.hypot(d.z)))
}

/// How near the shoulder's gimbal point (the sine of the angle, about 3°) a rest pose's upper
/// arm must lie for its twist to be untold ([`HumanArms::rest_twist_untold`]): there the
/// flexion, and with it the twist taken as none, swings by up to half a turn for a hundredth
/// of a degree. Rigs whose bones lie along local x have their arms within 1e-5 of it at rest;
/// the CMU files converted for Reallusion's Character Creator (every bone along local y, the
/// rest a line of bones up to 5.3° crooked) 0.093; the T-poses of the CMU, Mixamo and DAZ
/// files shipped or tested lie 0.15 (9°) and further. Within 0.12 (7°), a degree's error in
/// the rest directions turns the twist taken from them by ten or more.
pub const REST_GIMBAL: f64 = 0.12;

/// Gauss–Newton iterations of the refinement at a limit (it starts from the clamped closed
/// form, a few steps from its optimum).
const REFINE_ITERATIONS: usize = 30;

/// Clamps `v` into `lim`, recording whether it moved.
fn clamp_into(v: f64, lim: (f64, f64), clamped: &mut bool) -> f64 {
    let c = v.clamp(lim.0, lim.1);
    *clamped = c != v;
    c
}

impl HumanArms {
    /// Where the scaled capture puts the elbow and the wrist (left convention, torso frame).
    pub fn target_points(&self, t: &ArmTarget) -> TargetPoints {
        let clavicle = t.clavicle.unwrap_or_else(Vector3::y);
        let shoulder = self.sc + self.clavicle * clavicle;
        let elbow = shoulder + self.upper_arm * t.upper_arm;
        TargetPoints {
            elbow,
            wrist: elbow + self.forearm * t.forearm,
        }
    }

    /// Whether a rest pose with these directions (left convention, body axes) leaves the
    /// shoulder's twist untold: the elbow straight and the upper arm straight out to the side
    /// of the clavicle (within [`REST_GIMBAL`]), where flexion and rotation turn about one axis.
    pub fn rest_twist_untold(
        &self,
        clavicle: Option<Vector3<f64>>,
        upper_arm: Vector3<f64>,
        forearm: Vector3<f64>,
    ) -> bool {
        let (e, p) = clavicle.map(|d| clavicle_angles(&d)).unwrap_or((0.0, 0.0));
        let u = clavicle_rotation(e, p).inverse() * upper_arm;
        let bend = forearm - upper_arm * forearm.dot(&upper_arm);
        bend.norm() <= 0.05 && u.x.hypot(u.z) < REST_GIMBAL
    }

    /// The model frames at the capture's rest pose, with no twist: the calibration of
    /// [`ArmTarget::upper_arm_frame`] and [`ArmTarget::hand_frame`]. `hand` is the rest
    /// direction wrist → hand end; `hinge`, where the rest leaves the twist untold
    /// ([`HumanArms::rest_twist_untold`]), the direction a bent elbow takes the forearm in the
    /// upper arm's rest orientation, as the motion shows it.
    pub fn rest_frames(
        &self,
        clavicle: Option<Vector3<f64>>,
        upper_arm: Vector3<f64>,
        forearm: Vector3<f64>,
        hand: Vector3<f64>,
        hinge: Option<Vector3<f64>>,
    ) -> RestFrames {
        let (e, p) = clavicle.map(|d| clavicle_angles(&d)).unwrap_or((0.0, 0.0));
        let rc = clavicle_rotation(e, p);
        let u = rc.inverse() * upper_arm;
        let untold = u.x.hypot(u.z) < REST_GIMBAL;
        let a = u.y.clamp(-1.0, 1.0).asin();
        let bend = forearm - upper_arm * forearm.dot(&upper_arm);
        let upper = if bend.norm() > 0.05 {
            // A bent rest elbow fixes the twist by its hinge plane.
            hinge_frame(&upper_arm, &bend)
        } else if untold {
            // At the gimbal point (a T-pose with flat clavicles, or the line of bones an
            // x-bone rig's zero pose is) flexion is undefined and the sign of a zero would
            // pick 0 or 180°: the elbow's hinge as the motion bends it, else the arm reached by
            // abduction alone (palms down).
            match hinge {
                Some(h) => hinge_frame(&upper_arm, &h),
                None => rc * shoulder_rotation(0.0, a, 0.0),
            }
        } else {
            rc * shoulder_rotation(u.x.atan2(-u.z), a, 0.0)
        };
        let fu = upper.inverse() * forearm;
        let g = fu.x.atan2(-fu.z);
        let fore = upper * ry(-g);
        let d = fore.inverse() * hand;
        let dev = d.x.clamp(-1.0, 1.0).asin();
        let flex = (-d.y).atan2(-d.z);
        RestFrames {
            upper_arm: upper,
            hand: fore * rx(-flex) * ry(-dev),
        }
    }

    /// The angles of one arm (left convention; `side` chooses the limits) for `t`, given the
    /// previous frame's fit.
    pub fn fit(&self, side: Side, t: &ArmTarget, prev: Option<&ArmAngles>) -> ArmFit {
        let lim = self.limits(side);
        let mut q = [0.0; 9];
        let mut clamped = [false; 9];
        // Clavicle.
        if let Some(d) = t.clavicle {
            let (e, p) = clavicle_angles(&d);
            q[0] = clamp_into(e, lim[0], &mut clamped[0]);
            q[1] = clamp_into(p, lim[1], &mut clamped[1]);
        }
        let rc = clavicle_rotation(q[0], q[1]);
        // The upper arm along the captured one, the hinge plane through the captured forearm:
        // the segment directions (and so the elbow angle) are the capture's, and a clamped
        // clavicle only shifts the arm.
        let (u, w) = (t.upper_arm, t.forearm);
        let bend = w - u * w.dot(&u);
        // Where the elbow is (almost) straight the hinge plane is the captured upper arm's.
        let reference = t.upper_arm_frame * Vector3::x();
        let reference = reference - u * reference.dot(&u);
        let plane = bend
            + 0.01
                * reference
                    .try_normalize(1e-12)
                    .unwrap_or_else(Vector3::zeros);
        let upper = hinge_frame(&u, &plane);
        let m = rc.inverse() * upper;
        let prev3 = prev.map(|p| [p[2], p[3], p[4]]);
        let capture_elbow_angle = u.dot(&w).clamp(-1.0, 1.0).acos();
        let goal = self.target_points(t);
        let mut best: Option<([f64; 9], [bool; 9], f64)> = None;
        for s in shoulder_angles(m.matrix(), prev3, &lim[2..5]) {
            let (mut qs, mut held) = (q, clamped);
            for k in 0..3 {
                qs[2 + k] = clamp_into(s[k], lim[2 + k], &mut held[2 + k]);
            }
            let upper = rc * shoulder_rotation(qs[2], qs[3], qs[4]);
            // Elbow flexion: the forearm's angle in the hinge plane.
            let wu = upper.inverse() * w;
            qs[5] = clamp_into(wu.x.atan2(-wu.z), lim[5], &mut held[5]);
            // Within the limits the capture's directions are met exactly; where a limit held
            // the arm (a clamped clavicle shifts the shoulder), elbow and wrist are brought as
            // near the capture as the limits let the shoulder and elbow go.
            let miss = if held[..6].iter().any(|c| *c) {
                self.refine_at_limits(t, lim, capture_elbow_angle, &mut qs);
                let (e, wr) = self.elbow_wrist_left(&qs);
                (e - goal.elbow).norm().max((wr - goal.wrist).norm())
            } else {
                0.0
            };
            if best.is_none_or(|b| miss < b.2 - BRANCH_POSITION_GAIN) {
                best = Some((qs, held, miss));
            }
            if miss <= BRANCH_POSITION_GAIN {
                break;
            }
        }
        if let Some((qs, held, _)) = best {
            (q, clamped) = (qs, held);
        }
        let rc = clavicle_rotation(q[0], q[1]);
        let upper = rc * shoulder_rotation(q[2], q[3], q[4]);
        // Pronation and wrist: Rz(ψ) Rx(−w) Ry(−d) = (upper Ry(−g))ᵀ hand.
        let fore = upper * ry(-q[5]);
        let n = fore.inverse() * t.hand_frame;
        let n = n.matrix();
        let beta = n[(2, 1)].clamp(-1.0, 1.0).asin();
        let gamma = (-n[(2, 0)]).atan2(n[(2, 2)]);
        let psi = (-n[(0, 1)]).atan2(n[(1, 1)]);
        let prev_psi = prev.map(|p| p[6]).unwrap_or(0.0);
        q[6] = clamp_into(choose_turn(psi, prev_psi, lim[6]), lim[6], &mut clamped[6]);
        q[7] = clamp_into(-beta, lim[7], &mut clamped[7]);
        q[8] = clamp_into(-gamma, lim[8], &mut clamped[8]);
        ArmFit {
            angles: q,
            clamped,
            capture_elbow_angle,
        }
    }

    /// Elbow and wrist (left convention, torso frame) at the first six angles of `q`.
    fn elbow_wrist_left(&self, q: &[f64; 9]) -> (Vector3<f64>, Vector3<f64>) {
        let rc = clavicle_rotation(q[0], q[1]);
        let upper = rc * shoulder_rotation(q[2], q[3], q[4]);
        let elbow = self.sc
            + rc * Vector3::new(0.0, self.clavicle, 0.0)
            + upper * Vector3::new(0.0, 0.0, -self.upper_arm);
        let wrist = elbow + upper * ry(-q[5]) * Vector3::new(0.0, 0.0, -self.forearm);
        (elbow, wrist)
    }

    /// Moves the clavicle and shoulder angles and the elbow flexion of `q`, within `lim`, to
    /// the least squares of the elbow's and the wrist's distances to the scaled capture and the
    /// elbow angle's difference (weighted by the arm's length): a damped Gauss–Newton on
    /// the six angles, started from the clamped closed form. (The clavicle may then leave the
    /// capture's: raising the shoulder girdle is how a person reaches beyond the arm's range.)
    fn refine_at_limits(
        &self,
        t: &ArmTarget,
        lim: &[(f64, f64); 9],
        elbow_angle: f64,
        q: &mut [f64; 9],
    ) {
        let goal = self.target_points(t);
        let residual = |q: &[f64; 9]| -> [f64; 7] {
            let (e, w) = self.elbow_wrist_left(q);
            let (de, dw) = (e - goal.elbow, w - goal.wrist);
            [
                de.x,
                de.y,
                de.z,
                dw.x,
                dw.y,
                dw.z,
                (self.upper_arm + self.forearm) * (q[5] - elbow_angle),
            ]
        };
        let cost = |r: &[f64; 7]| r.iter().map(|v| v * v).sum::<f64>();
        let mut r = residual(q);
        let mut c = cost(&r);
        let mut lambda = 1e-3;
        for _ in 0..REFINE_ITERATIONS {
            // Numerical Jacobian (7 × 6) by forward differences.
            let mut jac = nalgebra::SMatrix::<f64, 7, 6>::zeros();
            for k in 0..6 {
                let mut qh = *q;
                qh[k] += 1e-7;
                let rh = residual(&qh);
                for i in 0..7 {
                    jac[(i, k)] = (rh[i] - r[i]) / 1e-7;
                }
            }
            let rv = nalgebra::SVector::<f64, 7>::from_column_slice(&r);
            let mut jtj = jac.transpose() * jac;
            let mut jtr = jac.transpose() * rv;
            // An angle at a limit that the descent would push beyond stays there (its row and
            // column out of the system): the others then converge as if it were fixed.
            for k in 0..6 {
                let (lo, hi) = lim[k];
                if (q[k] <= lo && jtr[k] > 0.0) || (q[k] >= hi && jtr[k] < 0.0) {
                    jtj.row_mut(k).fill(0.0);
                    jtj.column_mut(k).fill(0.0);
                    jtj[(k, k)] = 1.0;
                    jtr[k] = 0.0;
                }
            }
            let mut improved = false;
            while lambda < 1e6 {
                let a = jtj + nalgebra::Matrix6::identity() * lambda;
                let Some(step) = a.cholesky().map(|ch| ch.solve(&(-jtr))) else {
                    break;
                };
                let mut trial = *q;
                for k in 0..6 {
                    trial[k] = (q[k] + step[k]).clamp(lim[k].0, lim[k].1);
                }
                let rt = residual(&trial);
                let ct = cost(&rt);
                if ct < c {
                    *q = trial;
                    r = rt;
                    improved = c - ct > 1e-6 * c.max(1e-12);
                    c = ct;
                    lambda = (lambda * 0.3).max(1e-9);
                    break;
                }
                lambda *= 10.0;
            }
            if !improved {
                break;
            }
        }
    }
}

/// The upper-arm frame whose −z is `u` and whose x points along `plane`'s part across `u`
/// (the side the elbow bends to).
fn hinge_frame(u: &Vector3<f64>, plane: &Vector3<f64>) -> Rotation3<f64> {
    let z = -u;
    let x = (plane - u * plane.dot(u))
        .try_normalize(1e-12)
        .unwrap_or_else(|| any_perpendicular(u));
    let y = z.cross(&x);
    Rotation3::from_matrix_unchecked(Matrix3::from_columns(&[x, y, z]))
}

/// Some unit vector perpendicular to unit `u`.
fn any_perpendicular(u: &Vector3<f64>) -> Vector3<f64> {
    let other = if u.x.abs() < 0.9 {
        Vector3::x()
    } else {
        Vector3::y()
    };
    (other - u * other.dot(u)).normalize()
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn human() -> (Robot, HumanArms) {
        let r = Robot::builtin("human").unwrap();
        let h = HumanArms::new(&r).unwrap();
        (r, h)
    }

    /// The model's own FK turned into a target: directions and frames of the segments.
    fn target_from_model(robot: &Robot, side: Side, q: &[f64; 9]) -> ArmTarget {
        let mut full = vec![0.0; 18];
        let off = if side == Side::Left { 0 } else { 9 };
        full[off..off + 9].copy_from_slice(q);
        let s = side.as_str();
        let pose = |l: &str| {
            robot
                .forward_kinematics(&full, &format!("{s}_{l}"))
                .unwrap()
        };
        let sc = pose("clavicle_base").translation.vector;
        let sh = pose("upper_arm_flex").translation.vector;
        let el = pose("forearm_flex").translation.vector;
        let wr = pose("hand_flex").translation.vector;
        let upper = pose("upper_arm").rotation.to_rotation_matrix();
        let hand = pose("hand").rotation.to_rotation_matrix();
        let m = |v: Vector3<f64>| {
            if side == Side::Left {
                v
            } else {
                mirror_vector(v)
            }
        };
        let mr = |r: Rotation3<f64>| {
            if side == Side::Left {
                r
            } else {
                mirror_rotation(&r)
            }
        };
        ArmTarget {
            clavicle: Some(m((sh - sc).normalize())),
            upper_arm: m((el - sh).normalize()),
            forearm: m((wr - el).normalize()),
            upper_arm_frame: mr(upper),
            hand_frame: mr(hand),
        }
    }

    #[test]
    fn recovers_random_poses_within_limits_on_both_arms() {
        let (robot, h) = human();
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        for side in [Side::Left, Side::Right] {
            let lim = *h.limits(side);
            for _ in 0..500 {
                let mut q = [0.0; 9];
                for k in 0..9 {
                    // Keep clear of the limits and of a straight elbow (twist then comes
                    // from the frame, tested below).
                    let (lo, hi) = lim[k];
                    let (lo, hi) = if k == 5 {
                        (0.3, hi - 0.05)
                    } else {
                        (lo + 0.05, hi - 0.05)
                    };
                    q[k] = rng.random_range(lo..hi);
                }
                let t = target_from_model(&robot, side, &q);
                let fit = h.fit(side, &t, Some(&q));
                let (e, w) = h.elbow_and_wrist(side, &fit.angles);
                let mut full = vec![0.0; 18];
                let off = if side == Side::Left { 0 } else { 9 };
                full[off..off + 9].copy_from_slice(&q);
                let s = side.as_str();
                let e0 = robot
                    .forward_kinematics(&full, &format!("{s}_forearm_flex"))
                    .unwrap()
                    .translation
                    .vector;
                let w0 = robot
                    .forward_kinematics(&full, &format!("{s}_hand_flex"))
                    .unwrap()
                    .translation
                    .vector;
                assert!(
                    (e - e0).norm() < 1e-9 && (w - w0).norm() < 1e-9,
                    "{side:?} {q:?} → {:?}",
                    fit.angles
                );
                for (k, (a, b)) in fit.angles.iter().zip(&q).enumerate() {
                    assert!((a - b).abs() < 1e-7, "{side:?} angle {k}: {a} vs {b}");
                }
            }
        }
    }

    #[test]
    fn twist_with_a_straight_elbow_comes_from_the_frame() {
        let (robot, h) = human();
        let q = [0.1, 0.05, 0.4, 0.3, 0.7, 0.0, 0.2, 0.1, 0.05];
        let t = target_from_model(&robot, Side::Left, &q);
        let fit = h.fit(Side::Left, &t, None);
        for (k, (a, b)) in fit.angles.iter().zip(&q).enumerate() {
            assert!((a - b).abs() < 2e-2, "angle {k}: {a} vs {b}");
        }
    }

    #[test]
    fn a_limit_on_the_other_euler_branch_does_not_give_up_the_arm_s_direction() {
        // FAIR's zombie take: an arm held forward, its twist beyond the shoulder rotation's
        // limit. The previous frame on the other Euler branch kept the fit there, clamped at
        // the flexion's lower limit: the upper arm 52° off. The branch that keeps the arm's
        // direction (only the twist clamped) is taken.
        let (robot, h) = human();
        let q = [0.0, 0.0, 1.8, -0.17, 1.8, 0.05, 0.0, 0.0, 0.0];
        let t = target_from_model(&robot, Side::Left, &q);
        let mut prev = q;
        prev[2..5].copy_from_slice(&[-1.047, 3.1, -1.22]);
        let fit = h.fit(Side::Left, &t, Some(&prev));
        let (e, w) = h.elbow_and_wrist(Side::Left, &fit.angles);
        let p = h.target_points(&t);
        assert!(
            (e - p.elbow).norm() + (w - p.wrist).norm() < 0.01,
            "{:?}",
            fit.angles
        );
        assert!((fit.angles[2] - 1.8).abs() < 0.02, "{:?}", fit.angles);
        assert!(
            fit.clamped[4],
            "the rotation is held at its limit: {:?}",
            fit.angles
        );
    }

    #[test]
    fn gimbal_point_keeps_the_previous_flexion() {
        let (robot, h) = human();
        // Abduction 90°: flexion and rotation turn about the same axis.
        let q = [
            0.0,
            0.0,
            0.3,
            std::f64::consts::FRAC_PI_2,
            0.2,
            1.0,
            0.0,
            0.0,
            0.0,
        ];
        let t = target_from_model(&robot, Side::Left, &q);
        let fit = h.fit(Side::Left, &t, Some(&q));
        let (e, w) = h.elbow_and_wrist(Side::Left, &fit.angles);
        let p = h.target_points(&t);
        assert!((e - p.elbow).norm() < 1e-6 && (w - p.wrist).norm() < 1e-6);
        assert!((fit.angles[2] - 0.3).abs() < 1e-6, "{:?}", fit.angles);
    }

    #[test]
    fn beyond_a_limit_the_angle_is_clamped_and_said() {
        let (robot, h) = human();
        // The capture turns the forearm 1 rad further about the upper arm than the shoulder's
        // rotation limit (90°) allows from 1.5 rad: an angle stops at a limit, flagged, and the
        // clavicle and shoulder make up what they can.
        let q = [0.0, 0.0, 0.5, 0.2, 1.5, 0.8, 0.0, 0.0, 0.0];
        let mut t = target_from_model(&robot, Side::Left, &q);
        let turn = Rotation3::from_axis_angle(&nalgebra::Unit::new_normalize(t.upper_arm), 1.0);
        t.forearm = turn * t.forearm;
        t.upper_arm_frame = turn * t.upper_arm_frame;
        t.hand_frame = turn * t.hand_frame;
        let fit = h.fit(Side::Left, &t, Some(&q));
        let lim = h.limits(Side::Left);
        assert!(fit.clamped[2..5].iter().any(|c| *c), "{:?}", fit.angles);
        assert!(fit
            .angles
            .iter()
            .zip(lim)
            .all(|(a, (lo, hi))| lo <= a && a <= hi));
        assert!(
            (2..5).any(|k| fit.angles[k] == lim[k].0 || fit.angles[k] == lim[k].1),
            "{:?}",
            fit.angles
        );
        let (e, w) = h.elbow_and_wrist(Side::Left, &fit.angles);
        let p = h.target_points(&t);
        let plain_clamp_miss = 0.05; // rotation stopped at 90° without the refinement
        assert!((w - p.wrist).norm() + (e - p.elbow).norm() < plain_clamp_miss);
    }
}
