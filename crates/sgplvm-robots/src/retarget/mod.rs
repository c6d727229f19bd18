//! Robot joint commands paired with a human's frames by inverse kinematics: the robot side of
//! demonstrations recorded from a person alone.
//!
//! Each frame, each hand of the human model (forward kinematics of the recorded angles) is
//! taken relative to its shoulder, in units of the human's reach, in its body frame, and the
//! robot's hand is sent to the same place relative to its own shoulder in units of its own
//! reach, in its own body frame, as the generator places its key poses. The robot is an
//! [`Anatomy`]: each arm moves its own joints only, every other joint (a waist, legs, a head,
//! grippers) stays at its hold value, and the commands name the anatomy's command joints. Damped least-squares IK ([`crate::Chain`]) solves
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
pub mod file;
mod hands;
pub mod live;
pub mod split;
pub mod whole_arm;

use nalgebra::{DMatrix, Isometry3, UnitQuaternion, Vector3};
use serde::{Deserialize, Serialize};

use crate::anatomy::Anatomy;
use crate::dataset::{BodyData, Dataset};
use crate::generator::KEY_POSES;
use crate::series::median;
use crate::{IkOptions, IkTarget, Robot, RobotError};
pub use arm::Redundancy;
use arm::{ArmRun, Outcome};
use hands::{retarget_robot, RobotArms, Tally};
pub use live::FrameRetargeter;

/// What the robot's arm matches.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub enum Match {
    /// The person's arm posture (the default): the upper arm's and forearm's directions and
    /// the hand's position, weighed, by differential IK with self-collision avoidance, a
    /// function of the pose ([`whole_arm`]).
    #[default]
    Arms,
    /// Hand positions only.
    Hands,
    /// Hand positions, and the elbows as near the human's as the hands allow.
    HandsAndElbows,
    /// Hand positions and orientations.
    Poses,
}

impl Match {
    /// The command-line name: `arms`, `hands`, `hands+elbows` or `poses`.
    pub fn name(self) -> &'static str {
        match self {
            Match::Arms => "arms",
            Match::Hands => "hands",
            Match::HandsAndElbows => "hands+elbows",
            Match::Poses => "poses",
        }
    }

    /// Parses a command-line name.
    pub fn parse(s: &str) -> Option<Match> {
        [
            Match::Arms,
            Match::Hands,
            Match::HandsAndElbows,
            Match::Poses,
        ]
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
    /// Keep every joint within its URDF velocity limit between frames (off by default: then
    /// every frame's posture is a function of its pose alone).
    pub velocity_limits: bool,
    /// A hand this close to its target (metres) has reached it.
    pub reach_tolerance_m: f64,
    /// Whole-arm retargeting's settings ([`Match::Arms`]).
    pub whole_arm: whole_arm::WholeArmOptions,
}

impl Default for RetargetOptions {
    fn default() -> Self {
        Self {
            mode: Match::Arms,
            redundancy: Redundancy::Continuous,
            velocity_limits: false,
            reach_tolerance_m: 0.005,
            whole_arm: whole_arm::WholeArmOptions::default(),
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
    /// Targets the hand reached: within the tolerance, measured on the commands as written.
    pub reached: usize,
    /// Median distance of a hand to its target over the targets reached, metres (`None` when
    /// none was).
    pub median_m: Option<f64>,
    /// Largest distance over the targets reached, metres (`None` when none was; a target left
    /// beyond the tolerance counts as velocity-limited, another configuration's or
    /// unreachable).
    pub worst_m: Option<f64>,
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
    /// With [`Match::Arms`]: hand targets the hand missed by more than the tolerance because
    /// the arm's posture was weighed against them.
    #[serde(default)]
    pub compromised: usize,
    /// With [`Match::Arms`]: how the arm postures followed, and the self-collisions.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub posture: Option<whole_arm::PostureReport>,
}

/// One robot's retargeted commands.
#[derive(Debug, Clone, PartialEq)]
pub struct Retargeted {
    /// The robot's commands (frames × joints), named after the robot.
    pub body: BodyData,
    /// How well the hands followed.
    pub report: ReachReport,
}

/// One body's arms as retargeting measures them: per arm ([`Anatomy::arms`]' order), the
/// rotation from the body frame (x forward, y left, z up) into the chain's base frame, the
/// shoulder point there, the reach, the elbow joint and the hand's orientation at the neutral
/// posture.
struct ArmFrames {
    body_in_base: Vec<UnitQuaternion<f64>>,
    shoulders: Vec<Vector3<f64>>,
    reach: Vec<f64>,
    elbows: Vec<usize>,
    neutral_hands: Vec<UnitQuaternion<f64>>,
}

impl ArmFrames {
    fn of(anatomy: &Anatomy) -> Self {
        let arms = anatomy.arms();
        Self {
            body_in_base: arms
                .iter()
                .map(|a| {
                    a.base_in_torso.rotation.inverse()
                        * anatomy.body_in_torso()
                        * anatomy.mount().rotation(a.side)
                })
                .collect(),
            // The shoulder where it is with the arm's joints at zero: a point fixed on the
            // torso, which the hands are placed from.
            shoulders: arms
                .iter()
                .map(|a| (a.base_in_torso.inverse() * nalgebra::Point3::from(a.shoulder)).coords)
                .collect(),
            reach: arms.iter().map(|a| a.reach).collect(),
            elbows: arms.iter().map(|a| a.elbow).collect(),
            neutral_hands: arms
                .iter()
                .map(|a| a.chain.forward(&a.neutral).rotation)
                .collect(),
        }
    }
}

/// The human side: where the model's hands and elbows are relative to its shoulders, in units
/// of its reach, in its body frame, and how its hands have turned from their neutral posture.
struct HumanArms {
    anatomy: Anatomy,
    frames: ArmFrames,
}

/// One arm's targets in one frame, relative to the shoulder in units of reach, in the body
/// frame.
#[derive(Debug, Clone, Copy)]
struct Relative {
    hand: Vector3<f64>,
    elbow: Vector3<f64>,
    /// The hand frame's rotation from its neutral orientation (body frame).
    turn: UnitQuaternion<f64>,
}

impl HumanArms {
    fn new(human: Robot) -> Result<Self, RetargetError> {
        let anatomy =
            Anatomy::of(human).map_err(|e| RetargetError::Invalid(format!("human: {e}")))?;
        let frames = ArmFrames::of(&anatomy);
        Ok(Self { anatomy, frames })
    }

    /// Both arms' relative targets (left, right) for one frame of the model's joint angles.
    fn relative(&self, q: &[f64]) -> [Relative; 2] {
        let f = &self.frames;
        [0, 1].map(|s| {
            let arm = &self.anatomy.arms()[s];
            let qa: Vec<f64> = arm.chain.robot_indices().iter().map(|&i| q[i]).collect();
            let tip = arm.chain.forward(&qa);
            let elbow = arm.chain.joint_origins(&qa)[f.elbows[s]];
            let to_body = f.body_in_base[s].inverse();
            Relative {
                hand: to_body * (tip.translation.vector - f.shoulders[s]) / f.reach[s],
                elbow: to_body * (elbow - f.shoulders[s]) / f.reach[s],
                turn: to_body * (tip.rotation * f.neutral_hands[s].inverse()) * f.body_in_base[s],
            }
        })
    }
}

/// Arm `s`'s ([`Anatomy::arms`]' order) configuration (chain order) for each of the generator's key poses (its hand
/// where the key pose puts it, relative to the shoulder in units of reach), from the neutral
/// posture and pulled towards it: a fixed set of postures across the arm's workspace.
fn key_postures(anatomy: &Anatomy, frames: &ArmFrames, s: usize) -> Vec<Vec<f64>> {
    let arm = &anatomy.arms()[s];
    let options = IkOptions {
        tolerance: 1e-6,
        max_iters: 200,
        restarts: 4,
        posture_gain: 0.5,
        rest: Some(arm.neutral.clone()),
        ..IkOptions::default()
    };
    KEY_POSES
        .iter()
        .map(|pose| {
            let rel = match arm.side {
                crate::models::Side::Left => pose.left,
                crate::models::Side::Right => pose.right,
            };
            let target = frames.shoulders[s]
                + frames.reach[s] * (frames.body_in_base[s] * Vector3::from(rel));
            arm.chain
                .inverse_kinematics(&IkTarget::Position(target), &arm.neutral, &options)
                .q
        })
        .collect()
}

/// The whole configurations of `anatomy`'s robot at each key pose ([`key_postures`] of its
/// arms, the other joints at their hold values): the fixed starts of whole-arm retargeting.
fn key_configurations(anatomy: &Anatomy) -> Vec<Vec<f64>> {
    let frames = ArmFrames::of(anatomy);
    let arms: Vec<Vec<Vec<f64>>> = (0..anatomy.arms().len())
        .map(|s| key_postures(anatomy, &frames, s))
        .collect();
    (0..KEY_POSES.len())
        .map(|k| {
            let mut q = anatomy.hold_configuration().to_vec();
            for (s, postures) in arms.iter().enumerate() {
                for (c, &i) in anatomy.arms()[s].chain.robot_indices().iter().enumerate() {
                    q[i] = postures[k][c];
                }
            }
            q
        })
        .collect()
}

/// Retargets the human of `dataset` (the human model's 18 joints) onto each robot of `robots`
/// (name and anatomy), frame by frame: each arm over its own joints, every other joint at its
/// hold value; the commands name the anatomy's command joints.
pub fn retarget(
    dataset: &Dataset,
    robots: &[(String, Anatomy)],
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
    let human = HumanArms::new(human_model)?;
    if options.mode == Match::Arms {
        let person = whole_arm::PersonGauge::new(human.anatomy);
        return robots
            .iter()
            .map(|(name, anatomy)| retarget_whole_arm(name, anatomy, &person, dataset, options))
            .collect();
    }
    let targets: Vec<[Relative; 2]> = (0..dataset.len())
        .map(|f| {
            let q: Vec<f64> = dataset.human.positions.row(f).iter().copied().collect();
            human.relative(&q)
        })
        .collect();
    Ok(robots
        .iter()
        .map(|(name, anatomy)| {
            let arms = RobotArms::new(name, anatomy);
            retarget_robot(&arms, &targets, &dataset.times_ns, options)
        })
        .collect())
}

/// One robot by whole-arm retargeting ([`Match::Arms`]).
fn retarget_whole_arm(
    name: &str,
    anatomy: &Anatomy,
    person: &whole_arm::PersonGauge,
    dataset: &Dataset,
    options: &RetargetOptions,
) -> Result<Retargeted, RetargetError> {
    let (full, misses, posture) = whole_arm::run(
        anatomy,
        person,
        &dataset.human.positions,
        &key_configurations(anatomy),
        &dataset.times_ns,
        &options.whole_arm,
        options.velocity_limits,
    )
    .map_err(|e| RetargetError::Invalid(format!("{name}: {e}")))?;
    let mut tally = Tally::default();
    for &miss in &misses {
        tally.add(Outcome::Reached, miss, options.reach_tolerance_m);
    }
    let mut report = tally.report(name, options.mode, misses.len());
    // A miss the posture weighed against is no target out of reach.
    report.compromised = report.unreachable;
    report.unreachable = 0;
    report.unreachable_worst_m = 0.0;
    report.posture = Some(posture);
    let command: Vec<usize> = anatomy
        .command_joint_names()
        .iter()
        .filter_map(|n| anatomy.robot().joint_index(n))
        .collect();
    let n = dataset.len();
    Ok(Retargeted {
        body: BodyData {
            name: name.to_string(),
            topic: format!("/{name}/joint_command"),
            joint_names: anatomy.command_joint_names(),
            positions: DMatrix::from_fn(n, command.len(), |f, c| full[(f, command[c])]),
        },
        report,
    })
}

#[cfg(test)]
mod tests;
