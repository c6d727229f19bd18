//! Key poses and their IK solutions: the sixteen bimanual hand targets ([`KEY_POSES`]) and,
//! per body, the joint configuration that reaches each of them within joint limits
//! ([`solve_key_poses`]). Each pose is solved from a posture seed (the body's neutral solution,
//! then its zero configuration) with a null-space pull towards that seed; a pose that no seed
//! reaches takes the closest configuration found and is reported ([`PoseReport`]).

use nalgebra::Vector3;

use super::GenerateError;
use crate::models::Arm;
use crate::{IkOptions, IkTarget, Robot, Side};

/// Index of the neutral pose in [`KEY_POSES`].
pub const NEUTRAL: usize = 0;

/// A key bimanual pose: hand targets relative to the shoulder joint centres, in units of arm
/// length, in the torso frame (x forward, y left, z up).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct KeyPose {
    /// Short name.
    pub name: &'static str,
    /// Left hand relative to the left shoulder.
    pub left: [f64; 3],
    /// Right hand relative to the right shoulder.
    pub right: [f64; 3],
}

const fn sym(name: &'static str, x: f64, y: f64, z: f64) -> KeyPose {
    KeyPose {
        name,
        left: [x, y, z],
        right: [x, -y, z],
    }
}

const fn asym(name: &'static str, left: [f64; 3], right: [f64; 3]) -> KeyPose {
    KeyPose { name, left, right }
}

/// The sixteen key poses; index [`NEUTRAL`] is the neutral pose (arms down, slightly forward).
pub const KEY_POSES: [KeyPose; 16] = [
    sym("neutral", 0.15, 0.05, -0.85),
    sym("forward", 0.85, 0.0, -0.15),
    sym("forward_high", 0.6, 0.05, 0.55),
    sym("lateral", 0.05, 0.85, -0.15),
    sym("overhead", 0.1, 0.1, 0.85),
    sym("hands_together", 0.6, -0.35, -0.2),
    sym("chest", 0.35, -0.15, -0.3),
    sym("forward_low", 0.55, 0.15, -0.6),
    sym("hug", 0.55, 0.55, -0.1),
    sym("v_up", 0.1, 0.55, 0.6),
    asym("left_forward", [0.85, 0.0, -0.15], [0.15, -0.05, -0.85]),
    asym("right_forward", [0.15, 0.05, -0.85], [0.85, 0.0, -0.15]),
    asym("left_up_right_side", [0.1, 0.1, 0.85], [0.05, -0.85, -0.15]),
    asym("right_up_left_side", [0.05, 0.85, -0.15], [0.1, -0.1, 0.85]),
    asym("left_across", [0.55, -0.55, -0.2], [0.15, -0.05, -0.85]),
    sym("box_low", 0.45, -0.1, -0.55),
];

/// Quintic Hermite blend s(τ) = 10τ³ − 15τ⁴ + 6τ⁵ on τ ∈ [0, 1] (clamped outside): s(0) = 0,
/// How well IK reached one hand target of one key pose.
#[derive(Debug, Clone, PartialEq)]
pub struct PoseReport {
    /// Key pose index.
    pub pose: usize,
    /// Which hand.
    pub side: Side,
    /// Whether IK converged onto the target.
    pub converged: bool,
    /// Distance from the hand to its target, metres.
    pub residual: f64,
}

/// A body's key postures.
#[derive(Debug, Clone, PartialEq)]
pub struct BodyPoses {
    /// Body name (`human`, `walkman`, ...).
    pub name: String,
    /// Joint names (columns).
    pub joint_names: Vec<String>,
    /// Joint limits, one per joint.
    pub limits: Vec<(f64, f64)>,
    /// One configuration per key pose.
    pub postures: Vec<Vec<f64>>,
    /// IK outcome per pose and hand.
    pub reports: Vec<PoseReport>,
}

impl BodyPoses {
    /// Reports of hands that did not reach their target (the closest configuration was used).
    pub fn unreached(&self) -> impl Iterator<Item = &PoseReport> {
        self.reports.iter().filter(|r| !r.converged)
    }
}

/// Gain of the IK posture task that keeps key postures close to the neutral one.
const POSTURE_GAIN: f64 = 0.5;

/// Solves every key pose for the built-in body `name` by position IK of each arm.
pub fn solve_key_poses(name: &str) -> Result<BodyPoses, GenerateError> {
    let robot_err = |source| GenerateError::Robot {
        body: name.to_string(),
        source,
    };
    let robot = Robot::builtin(name).map_err(robot_err)?;
    solve_key_poses_for(&robot, name)
}

/// [`solve_key_poses`] for any robot following the arm convention.
pub fn solve_key_poses_for(robot: &Robot, name: &str) -> Result<BodyPoses, GenerateError> {
    let arms = robot.arms().ok_or_else(|| GenerateError::NoArms {
        body: name.to_string(),
    })?;
    let zero = robot.neutral_configuration();
    let limits = robot.joint_limits();
    let mut postures = vec![zero.clone(); KEY_POSES.len()];
    let mut reports = Vec::new();
    for arm in &arms {
        let shoulder = robot
            .forward_kinematics(&zero, &arm.shoulder_link)
            .map_err(|source| GenerateError::Robot {
                body: name.to_string(),
                source,
            })?
            .translation
            .vector;
        let idx = arm.chain.robot_indices().to_vec();
        let arm_zero: Vec<f64> = idx.iter().map(|&i| zero[i]).collect();
        let mut neutral_q: Option<Vec<f64>> = None;
        // Solve the neutral pose first: it seeds the others, so postures stay alike.
        let order = std::iter::once(NEUTRAL).chain((0..KEY_POSES.len()).filter(|&p| p != NEUTRAL));
        for p in order {
            let rel = match arm.side {
                Side::Left => KEY_POSES[p].left,
                Side::Right => KEY_POSES[p].right,
            };
            let target = shoulder + arm.length * Vector3::new(rel[0], rel[1], rel[2]);
            let Candidate {
                converged,
                residual,
                q,
                ..
            } = solve_pose(arm, target, neutral_q.as_deref(), &arm_zero);
            for (k, &i) in idx.iter().enumerate() {
                postures[p][i] = q[k].clamp(limits[i].0, limits[i].1);
            }
            if p == NEUTRAL {
                neutral_q = Some(q);
            }
            reports.push(PoseReport {
                pose: p,
                side: arm.side,
                converged,
                residual,
            });
        }
    }
    reports.sort_by_key(|r| (r.pose, r.side == Side::Right));
    Ok(BodyPoses {
        name: name.to_string(),
        joint_names: robot.joint_names(),
        limits,
        postures,
        reports,
    })
}

/// The best IK solution of `arm` for a hand `target`: seeded from the neutral solution (once
/// known) and the arm's zero configuration, with a posture task towards the anchor (the
/// neutral solution, else the zero configuration); random restarts only if no seed converges.
fn solve_pose(
    arm: &Arm,
    target: Vector3<f64>,
    neutral_q: Option<&[f64]>,
    arm_zero: &[f64],
) -> Candidate {
    let seeded = IkOptions {
        restarts: 0,
        tolerance: 1e-6,
        max_iters: 200,
        ..IkOptions::default()
    };
    let fallback = IkOptions {
        tolerance: 1e-6,
        max_iters: 200,
        restarts: 16,
        ..IkOptions::default()
    };
    let mut seeds: Vec<&[f64]> = Vec::new();
    if let Some(n) = neutral_q {
        seeds.push(n);
    }
    seeds.push(arm_zero);
    let anchor: &[f64] = neutral_q.unwrap_or(arm_zero);
    // A null-space posture task pulls every solution towards the anchor (the neutral
    // posture; the hanging arm for the neutral pose itself): natural, continuous postures.
    let with_posture = IkOptions {
        posture_gain: POSTURE_GAIN,
        rest: Some(anchor.to_vec()),
        ..seeded
    };
    let target = IkTarget::Position(target);
    let first = arm
        .chain
        .inverse_kinematics(&target, seeds[0], &with_posture);
    let mut best = Candidate::new(first, anchor);
    for seed in &seeds[1..] {
        let sol = arm.chain.inverse_kinematics(&target, seed, &with_posture);
        best.keep_better(sol, anchor);
    }
    if !best.converged {
        let sol = arm.chain.inverse_kinematics(&target, anchor, &fallback);
        best.keep_better(sol, anchor);
    }
    best
}

/// An IK outcome considered for a key pose.
struct Candidate {
    converged: bool,
    /// Squared distance to the anchor posture (the neutral solution).
    dist: f64,
    residual: f64,
    q: Vec<f64>,
}

impl Candidate {
    /// `sol` with its squared distance to `anchor`.
    fn new(sol: crate::IkSolution, anchor: &[f64]) -> Self {
        let dist: f64 = sol
            .q
            .iter()
            .zip(anchor)
            .map(|(a, b)| (a - b) * (a - b))
            .sum();
        Self {
            converged: sol.converged,
            dist,
            residual: sol.residual,
            q: sol.q,
        }
    }

    /// Keeps the better of `self` and `sol`: converged beats not converged; among converged
    /// ones the closer to `anchor` wins (posture continuity); otherwise the smaller residual.
    fn keep_better(&mut self, sol: crate::IkSolution, anchor: &[f64]) {
        let other = Candidate::new(sol, anchor);
        let better = match (other.converged, self.converged) {
            (true, false) => true,
            (false, true) => false,
            (true, true) => other.dist < self.dist,
            (false, false) => other.residual < self.residual,
        };
        if better {
            *self = other;
        }
    }
}
