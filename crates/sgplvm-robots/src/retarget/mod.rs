//! Robot joint commands paired with a human's frames by inverse kinematics: the robot side of
//! demonstrations recorded from a person alone.
//!
//! Each frame, each hand of the human model (forward kinematics of the recorded angles) is
//! taken relative to its shoulder frame, in units of the human's arm length, and the robot's
//! hand is sent to the same place relative to its own shoulder in units of its own arm length,
//! as the generator places its key poses. Damped least-squares IK ([`crate::Chain`]) solves
//! each arm, warm-started from the previous frame so that motion stays continuous, with a
//! null-space pull towards the robot's neutral posture, within the joint limits and, between
//! frames, within the joint velocity limits. What [`Match`] asks for besides the hands:
//!
//! - [`Match::Hands`]: hand positions only. The robot's redundancy goes to its neutral posture.
//! - [`Match::HandsAndElbows`]: the elbow, too, follows the human's (scaled the same way) as far
//!   as the hand allows: the arm's swivel copies the person's.
//! - [`Match::Poses`]: the hand's orientation follows the human's (its rotation from the zero
//!   pose, copied): six constraints on seven joints, so fewer targets are within reach.
//!
//! A hand target that misses by more than [`RetargetOptions::reach_tolerance_m`] is tried again
//! without the velocity limit: if that reaches it from where the arm is, only the joints' speed
//! held the hand back (counted as velocity-limited; the arm follows as fast as it can). Else
//! the key postures and random starts tell whether any configuration reaches it: if one does,
//! the target is reachable only from another configuration (counted apart; the arm steps
//! towards that configuration only where the step brings the hand nearer, for on the way the
//! hand would swing far off); if none does, it is out of reach (counted as unreachable, the
//! closest configuration within the limits kept). [`ReachReport`] gives the counts per robot
//! with the residuals of the targets reached.
//!
//! [`split`] then cuts the frames into blocks and chooses the train/test split.

mod arm;
pub mod split;

use nalgebra::{DMatrix, Isometry3, Vector3};
use serde::{Deserialize, Serialize};

use crate::dataset::{BodyData, Dataset};
use crate::generator::{solve_key_poses_for, NEUTRAL};
use crate::models::Arm;
use crate::series::median;
use crate::{IkTarget, Robot, RobotError};
pub use arm::Redundancy;
use arm::{ArmRun, Outcome};

/// What the robot's arm matches besides the hand's position.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub enum Match {
    /// Hand positions only (the default).
    #[default]
    Hands,
    /// Hand positions, and the elbows as near the human's as the hands allow.
    HandsAndElbows,
    /// Hand positions and orientations.
    Poses,
}

impl Match {
    /// The command-line name: `hands`, `hands+elbows` or `poses`.
    pub fn name(self) -> &'static str {
        match self {
            Match::Hands => "hands",
            Match::HandsAndElbows => "hands+elbows",
            Match::Poses => "poses",
        }
    }

    /// Parses a command-line name.
    pub fn parse(s: &str) -> Option<Match> {
        [Match::Hands, Match::HandsAndElbows, Match::Poses]
            .into_iter()
            .find(|m| m.name() == s)
    }
}

/// How to retarget.
#[derive(Debug, Clone, PartialEq)]
pub struct RetargetOptions {
    /// What to match besides hand positions.
    pub mode: Match,
    /// How the arms' redundancy is resolved.
    pub redundancy: Redundancy,
    /// Keep every joint within its URDF velocity limit between frames.
    pub velocity_limits: bool,
    /// A hand this close to its target (metres) has reached it.
    pub reach_tolerance_m: f64,
}

impl Default for RetargetOptions {
    fn default() -> Self {
        Self {
            mode: Match::Hands,
            redundancy: Redundancy::Continuous,
            velocity_limits: true,
            reach_tolerance_m: 0.005,
        }
    }
}

/// Errors of retargeting.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum RetargetError {
    /// A body model could not be used.
    #[error("{body}: {source}")]
    Robot {
        /// The robot or the human.
        body: String,
        /// Why.
        source: RobotError,
    },
    /// A body lacks the arm convention's links.
    #[error("{body} has no left/right arm (links left_shoulder, left_hand, right_shoulder and right_hand expected)")]
    NoArms {
        /// The body.
        body: String,
    },
    /// The human's joints do not match the human model's.
    #[error(
        "the demonstrations' human joints are not the human model's: {}",
        crate::names::difference(expected, found, "joint")
    )]
    HumanJoints {
        /// What the file holds.
        found: Vec<String>,
        /// What the model has.
        expected: Vec<String>,
    },
    /// Bad options or data.
    #[error("{0}")]
    Invalid(String),
}

/// How well one robot's hands followed their targets.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ReachReport {
    /// The robot.
    pub robot: String,
    /// What was matched.
    pub mode: Match,
    /// Hand targets (two per frame).
    pub targets: usize,
    /// Median distance of a hand to its target, over the reachable targets, metres.
    pub median_m: f64,
    /// Largest distance over the reachable targets that the velocity limits did not hold back,
    /// metres (the IK converges to 10 µm where it reaches; a target it leaves beyond the
    /// tolerance counts as velocity-limited or unreachable).
    pub worst_m: f64,
    /// Targets the robot cannot reach within its joint limits from any start tried.
    pub unreachable: usize,
    /// Largest miss of an unreachable target, metres (0 if none).
    pub unreachable_worst_m: f64,
    /// Reachable targets missed by more than the tolerance because a joint was at its velocity
    /// limit (the arm was on its way).
    pub velocity_limited: usize,
    /// Largest miss of a velocity-limited target, metres (0 if none).
    pub velocity_limited_worst_m: f64,
    /// Targets reachable only from another configuration of the arm (its joints would have to
    /// pass through poses that swing the hand away): the arm stayed at its closest point.
    pub other_configuration: usize,
    /// Largest miss of such a target, metres (0 if none).
    pub other_configuration_worst_m: f64,
    /// With [`Match::HandsAndElbows`]: median distance of the elbows to theirs, metres.
    pub elbow_median_m: Option<f64>,
    /// With [`Match::Poses`]: median orientation error of the hands, radians.
    pub orientation_median_rad: Option<f64>,
}

/// One robot's retargeted commands.
#[derive(Debug, Clone, PartialEq)]
pub struct Retargeted {
    /// The robot's commands (frames × joints), named after the robot.
    pub body: BodyData,
    /// How well the hands followed.
    pub report: ReachReport,
}

/// The human side: where the model's hands, elbows and hand frames are, relative to the fixed
/// shoulder frames, in units of arm length.
struct HumanArms {
    arms: [Arm; 2],
    shoulders: [Vector3<f64>; 2],
    /// Chain joint of the elbow per arm.
    elbows: [usize; 2],
    /// Hand frame orientation at the zero configuration, per arm.
    zero_hands: [nalgebra::UnitQuaternion<f64>; 2],
}

/// One arm's targets in one frame, relative to the shoulder in units of arm length.
#[derive(Debug, Clone, Copy)]
struct Relative {
    hand: Vector3<f64>,
    elbow: Vector3<f64>,
    /// The hand frame's rotation from its zero-pose orientation (torso frame).
    turn: nalgebra::UnitQuaternion<f64>,
}

/// The chain joint most in the middle of the arm at the zero configuration (farthest from both
/// the shoulder and the hand): the elbow.
fn elbow_joint(arm: &Arm, shoulder: &Vector3<f64>) -> usize {
    let zero = vec![0.0; arm.chain.dof()];
    let origins = arm.chain.joint_origins(&zero);
    let hand = arm.chain.forward(&zero).translation.vector;
    (0..origins.len())
        .max_by(|&a, &b| {
            let score = |i: usize| {
                (origins[i] - shoulder)
                    .norm()
                    .min((origins[i] - hand).norm())
            };
            score(a).total_cmp(&score(b))
        })
        .unwrap_or(0)
}

/// The fixed shoulder frames' positions at the zero configuration.
fn shoulder_points(
    robot: &Robot,
    arms: &[Arm; 2],
    body: &str,
) -> Result<[Vector3<f64>; 2], RetargetError> {
    let zero = vec![0.0; robot.dof()];
    let at = |arm: &Arm| {
        robot
            .forward_kinematics(&zero, &arm.shoulder_link)
            .map(|p| p.translation.vector)
            .map_err(|source| RetargetError::Robot {
                body: body.to_string(),
                source,
            })
    };
    Ok([at(&arms[0])?, at(&arms[1])?])
}

/// Both arms of a body with what relative targets are measured from: their shoulder points,
/// elbow joints and hand rotations at the zero configuration.
struct ArmGeometry {
    arms: [Arm; 2],
    shoulders: [Vector3<f64>; 2],
    elbows: [usize; 2],
    zero_hands: [nalgebra::UnitQuaternion<f64>; 2],
}

impl ArmGeometry {
    /// The arms of `body` (called `name` in errors).
    fn of(body: &Robot, name: &str) -> Result<Self, RetargetError> {
        let arms = body.arms().ok_or_else(|| RetargetError::NoArms {
            body: name.to_string(),
        })?;
        let shoulders = shoulder_points(body, &arms, name)?;
        let elbows = [0, 1].map(|s| elbow_joint(&arms[s], &shoulders[s]));
        let zero_hands = [0, 1].map(|s| {
            let chain = &arms[s].chain;
            chain.forward(&vec![0.0; chain.dof()]).rotation
        });
        Ok(Self {
            arms,
            shoulders,
            elbows,
            zero_hands,
        })
    }
}

impl HumanArms {
    fn new(human: &Robot) -> Result<Self, RetargetError> {
        let ArmGeometry {
            arms,
            shoulders,
            elbows,
            zero_hands,
        } = ArmGeometry::of(human, "human")?;
        Ok(Self {
            arms,
            shoulders,
            elbows,
            zero_hands,
        })
    }

    /// Both arms' relative targets for one frame of the model's joint angles.
    fn relative(&self, q: &[f64]) -> [Relative; 2] {
        [0, 1].map(|s| {
            let arm = &self.arms[s];
            let qa: Vec<f64> = arm.chain.robot_indices().iter().map(|&i| q[i]).collect();
            let tip = arm.chain.forward(&qa);
            let elbow = arm.chain.joint_origins(&qa)[self.elbows[s]];
            Relative {
                hand: (tip.translation.vector - self.shoulders[s]) / arm.length,
                elbow: (elbow - self.shoulders[s]) / arm.length,
                turn: tip.rotation * self.zero_hands[s].inverse(),
            }
        })
    }
}

/// A robot prepared for retargeting.
struct RobotArms {
    name: String,
    robot: Robot,
    arms: [Arm; 2],
    shoulders: [Vector3<f64>; 2],
    elbows: [usize; 2],
    zero_hands: [nalgebra::UnitQuaternion<f64>; 2],
    /// Neutral posture per arm (the generator's neutral key pose): start and posture pull.
    neutral: [Vec<f64>; 2],
    /// The middle of every joint's range per arm: where the warm IK's null space pulls, away
    /// from the limits a continuing motion would otherwise get stuck at.
    rest: [Vec<f64>; 2],
    /// Every key posture per arm: starts when the arm must change configuration.
    key_postures: [Vec<Vec<f64>>; 2],
    /// Velocity limit per arm joint, rad/s (0: none).
    velocity: [Vec<f64>; 2],
}

impl RobotArms {
    fn new(name: &str, robot: Robot) -> Result<Self, RetargetError> {
        let ArmGeometry {
            arms,
            shoulders,
            elbows,
            zero_hands,
        } = ArmGeometry::of(&robot, name)?;
        let poses = solve_key_poses_for(&robot, name)
            .map_err(|e| RetargetError::Invalid(format!("{name}: {e}")))?;
        let all_velocity = robot.velocity_limits();
        let pick = |arm: &Arm, v: &[f64]| -> Vec<f64> {
            arm.chain.robot_indices().iter().map(|&i| v[i]).collect()
        };
        let neutral = [
            pick(&arms[0], &poses.postures[NEUTRAL]),
            pick(&arms[1], &poses.postures[NEUTRAL]),
        ];
        let key_postures =
            [0, 1].map(|s| poses.postures.iter().map(|p| pick(&arms[s], p)).collect());
        let rest = [0, 1].map(|s| {
            arms[s]
                .chain
                .limits()
                .iter()
                .map(|&(lo, hi)| {
                    if lo.is_finite() && hi.is_finite() {
                        0.5 * (lo + hi)
                    } else {
                        0.0
                    }
                })
                .collect()
        });
        let velocity = [pick(&arms[0], &all_velocity), pick(&arms[1], &all_velocity)];
        Ok(Self {
            name: name.to_string(),
            robot,
            arms,
            shoulders,
            elbows,
            zero_hands,
            neutral,
            key_postures,
            rest,
            velocity,
        })
    }

    /// The IK target of arm `s` for the human's relative target `r`.
    fn target(&self, s: usize, r: &Relative, mode: Match) -> IkTarget {
        let scale = self.arms[s].length;
        let hand = self.shoulders[s] + scale * r.hand;
        match mode {
            Match::Hands => IkTarget::Position(hand),
            Match::HandsAndElbows => IkTarget::PositionAndJoint {
                tip: hand,
                joint: self.elbows[s],
                point: self.shoulders[s] + scale * r.elbow,
            },
            Match::Poses => IkTarget::Pose(Isometry3::from_parts(
                hand.into(),
                r.turn * self.zero_hands[s],
            )),
        }
    }
}

/// Retargets the human of `dataset` (the human model's 18 joints) onto each robot of `robots`
/// (name and model), frame by frame.
pub fn retarget(
    dataset: &Dataset,
    robots: &[(String, Robot)],
    options: &RetargetOptions,
) -> Result<Vec<Retargeted>, RetargetError> {
    let human_model = Robot::builtin("human").map_err(|source| RetargetError::Robot {
        body: "human".into(),
        source,
    })?;
    let expected = human_model.joint_names();
    if dataset.human.joint_names != expected {
        return Err(RetargetError::HumanJoints {
            found: dataset.human.joint_names.clone(),
            expected,
        });
    }
    if !(options.reach_tolerance_m.is_finite() && options.reach_tolerance_m > 0.0) {
        return Err(RetargetError::Invalid(format!(
            "reach tolerance {} m; expected a positive distance",
            options.reach_tolerance_m
        )));
    }
    let human = HumanArms::new(&human_model)?;
    let n = dataset.len();
    let targets: Vec<[Relative; 2]> = (0..n)
        .map(|f| {
            let q: Vec<f64> = dataset.human.positions.row(f).iter().copied().collect();
            human.relative(&q)
        })
        .collect();
    robots
        .iter()
        .map(|(name, robot)| {
            let arms = RobotArms::new(name, robot.clone())?;
            Ok(retarget_robot(&arms, &targets, &dataset.times_ns, options))
        })
        .collect()
}

/// One robot, every frame.
fn retarget_robot(
    r: &RobotArms,
    targets: &[[Relative; 2]],
    times_ns: &[i64],
    options: &RetargetOptions,
) -> Retargeted {
    let n = targets.len();
    let mut positions = DMatrix::<f64>::zeros(n, r.robot.dof());
    let mut reached = Vec::with_capacity(2 * n);
    let mut counts = [0usize; 3];
    let mut worst = [0.0_f64; 3];
    let mut elbow_misses = Vec::new();
    let mut orientation_misses = Vec::new();
    for s in 0..2 {
        let arm = &r.arms[s];
        let run = ArmRun {
            chain: &arm.chain,
            velocity: &r.velocity[s],
            rest: &r.rest[s],
            key_postures: &r.key_postures[s],
            neutral: &r.neutral[s],
            targets: targets
                .iter()
                .map(|t| r.target(s, &t[s], options.mode))
                .collect(),
            times_ns,
            velocity_limits: options.velocity_limits,
            tolerance: options.reach_tolerance_m,
        };
        let frames = run.run(options.redundancy);
        for f in 0..n {
            let q = &frames.q[f];
            let kind = match frames.outcome[f] {
                Outcome::Reached => {
                    reached.push(frames.miss[f]);
                    None
                }
                Outcome::SpeedLimited => Some(0),
                Outcome::OtherConfiguration => Some(1),
                Outcome::Unreachable => Some(2),
            };
            if let Some(k) = kind {
                counts[k] += 1;
                worst[k] = worst[k].max(frames.miss[f]);
            }
            match run.targets[f] {
                IkTarget::PositionAndJoint { joint, point, .. } => {
                    elbow_misses.push((arm.chain.joint_origins(q)[joint] - point).norm());
                }
                IkTarget::Pose(t) => {
                    let tip = arm.chain.forward(q);
                    orientation_misses.push((t.rotation * tip.rotation.inverse()).angle());
                }
                IkTarget::Position(_) => {}
            }
            for (k, &i) in arm.chain.robot_indices().iter().enumerate() {
                positions[(f, i)] = q[k];
            }
        }
    }
    let report = ReachReport {
        robot: r.name.clone(),
        mode: options.mode,
        targets: 2 * n,
        worst_m: reached.iter().copied().fold(0.0, f64::max),
        median_m: median(&mut reached),
        velocity_limited: counts[0],
        velocity_limited_worst_m: worst[0],
        other_configuration: counts[1],
        other_configuration_worst_m: worst[1],
        unreachable: counts[2],
        unreachable_worst_m: worst[2],
        elbow_median_m: (options.mode == Match::HandsAndElbows).then(|| median(&mut elbow_misses)),
        orientation_median_rad: (options.mode == Match::Poses)
            .then(|| median(&mut orientation_misses)),
    };
    Retargeted {
        body: BodyData {
            name: r.name.clone(),
            topic: format!("/{}/joint_command", r.name),
            joint_names: r.robot.joint_names(),
            positions,
        },
        report,
    }
}

#[cfg(test)]
mod tests;
