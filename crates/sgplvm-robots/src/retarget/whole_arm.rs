//! Whole-arm retargeting ([`super::Match::Arms`]): the robot takes the person's arm posture by
//! differential IK, each frame solved to convergence as one QP per Gauss–Newton step over both
//! arms' joints ([`crate::kinematics::qp`]):
//!
//! ```text
//! min  Σ_arms  w_u ‖u − û‖² + w_f ‖f − f̂‖² + w_o ‖log(R̂_hand R_handᵀ)‖² + w_t ‖log(R̂_upper R_upperᵀ)‖²
//!              + w_h ‖(h − ĥ)/reach‖²  +  w_p ‖q − q_neutral‖²
//! s.t. joint position limits, each elbow on its bending side, every pair of the robot's own
//!      shapes that can meet ≥ margin
//! ```
//!
//! - `u`, `f`: the upper arm's and the forearm's directions on their **bone lines** — shoulder
//!   centre → elbow centre → wrist centre ([`crate::anatomy::AnatomyArm::elbow_centre_local`]),
//!   not the joints' origins, which a URDF may place anywhere on their axes — in the body frame.
//! - `R_hand`, `R_upper`: the hand's and the upper arm's orientations, each the person's turn
//!   from the person's neutral posture applied to the robot's **reference** posture: the one
//!   whose bone directions are the person's neutral ones (`FrameSolver::reference_hands`), so
//!   that directions and orientations ask one posture of the robot. The hand's orientation holds
//!   the forearm's roll and the wrist; the upper arm's holds its twist where the elbow is
//!   straight and the directions cannot tell it. So the twist follows from the person (what
//!   the capture measured of it, through the person's calibration), not from history.
//! - `h`: the hand relative to the shoulder in units of reach, a weak pull (bodies whose
//!   proportions differ from a person's cannot have both the directions and the place).
//! - the posture regulariser pulls towards the fixed neutral posture.
//!
//! Each frame is followed along its own path from the person's neutral to its pose (the
//! person's joint angles moved straight from their neutral values: `PersonGauge::path`),
//! starting from the robot's posture for the person's neutral, never from the previous frame:
//! the posture is a function of the person's pose, whatever came before it, and continuous in
//! it — where the pose fits the robot in two ways (a shoulder turned half round through its
//! limits), the one the person's own motion out of their neutral leads to. The command sent is
//! then the nearest safe one ([`crate::safety`]): out of self-collision, linearised at the
//! posture itself, and — only when asked for — within the velocity limits of the command
//! before (then, where they hold it back, the command depends on the path).

use nalgebra::{DMatrix, UnitQuaternion, Vector3};
use serde::{Deserialize, Serialize};

use crate::anatomy::{Anatomy, ArmLandmarks};
use crate::kinematics::frames::{Ancestry, RobotFrames};
use crate::models::Side;
use crate::safety::{SafetyOptions, SafetyStep};

mod report;
mod solver;

use report::Tally;
pub use report::{
    BoundHeld, JointJumps, LimitHeld, PairHeld, PostureReport, AT_BOUND_RAD, JUMP_RAD, STILL_RAD,
};
pub(in crate::retarget) use solver::ArmSolver;

/// The weights of the tasks (and of the posture regulariser).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Weights {
    /// The upper arm's direction (error in unit-vector length, about radians).
    pub upper_arm: f64,
    /// The forearm's direction.
    pub forearm: f64,
    /// The hand's position, its error as a fraction of the arm's reach.
    pub hand: f64,
    /// The hand's orientation (radians); 0: free.
    pub orientation: f64,
    /// The upper arm's orientation (radians), which holds its twist where the elbow is
    /// straight; 0: free.
    #[serde(default)]
    pub twist: f64,
    /// The pull towards the neutral posture (radians).
    pub posture: f64,
}

impl Default for Weights {
    fn default() -> Self {
        Weights {
            upper_arm: 1.0,
            forearm: 1.0,
            hand: 0.5,
            orientation: 1.0,
            twist: 1.0,
            posture: 0.01,
        }
    }
}

/// Settings of whole-arm retargeting.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct WholeArmOptions {
    /// The tasks' weights.
    pub weights: Weights,
    /// How far apart the robot's own shapes stay, metres.
    pub margin_m: f64,
    /// Keep the robot out of self-collision.
    pub self_collision: bool,
    /// Gauss–Newton steps per frame at most.
    pub max_iterations: usize,
    /// A frame has converged when no joint moves more than this in a step, radians.
    pub tolerance: f64,
    /// No joint moves more than this in one step, radians (the steps' trust region).
    pub step_bound: f64,
}

impl Default for WholeArmOptions {
    fn default() -> Self {
        WholeArmOptions {
            weights: Weights::default(),
            margin_m: 0.01,
            self_collision: true,
            max_iterations: 40,
            tolerance: 1e-3,
            step_bound: 0.4,
        }
    }
}

/// The person's arm posture in one frame, per arm, in the body frame: the upper arm's and the
/// forearm's unit directions, the hand relative to the shoulder in units of reach, and the
/// hand's turn from its neutral orientation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ArmPosture {
    /// Shoulder → elbow, unit.
    pub upper_arm: Vector3<f64>,
    /// Elbow → wrist centre, unit.
    pub forearm: Vector3<f64>,
    /// Hand relative to the shoulder, in reach.
    pub hand: Vector3<f64>,
    /// The hand's rotation from its neutral orientation.
    pub turn: UnitQuaternion<f64>,
    /// The upper arm's rotation from its neutral orientation.
    pub upper_turn: UnitQuaternion<f64>,
}

impl ArmPosture {
    /// The posture turned by `r` (a rotation of the body frame): directions and the hand's
    /// place turned, the segments' turns conjugated.
    fn turned(&self, r: &UnitQuaternion<f64>) -> ArmPosture {
        ArmPosture {
            upper_arm: r * self.upper_arm,
            forearm: r * self.forearm,
            hand: r * self.hand,
            turn: r * self.turn * r.inverse(),
            upper_turn: r * self.upper_turn * r.inverse(),
        }
    }
}

/// A body's arms as postures are measured on them: landmarks, and the rotation from the body
/// frame to the root frame. Per arm in [`Anatomy::arms`]' order (two, or one on a single-arm
/// robot; `sides` says whose).
pub(super) struct PostureGauge {
    sides: Vec<Side>,
    /// Per arm, the turn of the person's arm it takes ([`crate::anatomy::Mount`]), body frame.
    mounts: Vec<UnitQuaternion<f64>>,
    landmarks: Vec<ArmLandmarks>,
    body_to_root: UnitQuaternion<f64>,
    /// The fixed shoulder points hands are placed from, root frame.
    shoulders: Vec<Vector3<f64>>,
    reach: Vec<f64>,
    neutral_hands: Vec<UnitQuaternion<f64>>,
    hand_links: Vec<usize>,
    /// The upper arms' orientations at the neutral posture, and their links (the elbow's).
    neutral_uppers: Vec<UnitQuaternion<f64>>,
    upper_links: Vec<usize>,
    ancestry: Ancestry,
}

impl PostureGauge {
    /// The gauge of `anatomy`'s arms.
    pub(super) fn of(anatomy: &Anatomy) -> PostureGauge {
        PostureGauge::at(anatomy, anatomy.hold_configuration())
    }

    /// The gauge of `anatomy`'s arms whose turns are measured from configuration `reference`.
    pub(super) fn at(anatomy: &Anatomy, reference: &[f64]) -> PostureGauge {
        let robot = anatomy.robot();
        let ancestry = Ancestry::of(robot);
        let torso = anatomy.torso_in_root();
        let arms = anatomy.arms();
        let landmarks: Vec<ArmLandmarks> = arms.iter().map(|a| a.landmarks(robot)).collect();
        let neutral = RobotFrames::new(robot, &ancestry, reference);
        PostureGauge {
            sides: anatomy.sides(),
            mounts: arms
                .iter()
                .map(|a| anatomy.mount().rotation(a.side))
                .collect(),
            body_to_root: torso.rotation * anatomy.body_in_torso(),
            shoulders: arms
                .iter()
                .map(|a| (torso * nalgebra::Point3::from(a.shoulder)).coords)
                .collect(),
            reach: arms.iter().map(|a| a.reach).collect(),
            neutral_hands: landmarks
                .iter()
                .map(|m| neutral.link(m.hand.link).rotation)
                .collect(),
            hand_links: landmarks.iter().map(|m| m.hand.link).collect(),
            neutral_uppers: landmarks
                .iter()
                .map(|m| neutral.link(m.elbow.link).rotation)
                .collect(),
            upper_links: landmarks.iter().map(|m| m.elbow.link).collect(),
            landmarks,
            ancestry,
        }
    }

    /// The arm postures of configuration `q` of `anatomy`'s robot, per arm.
    pub(super) fn measure(&self, anatomy: &Anatomy, q: &[f64]) -> Vec<ArmPosture> {
        let frames = RobotFrames::new(anatomy.robot(), &self.ancestry, q);
        let to_body = self.body_to_root.inverse();
        (0..self.landmarks.len())
            .map(|s| {
                let m = &self.landmarks[s];
                let (sh, el, wr, ha) = (
                    m.shoulder.at(&frames),
                    m.elbow.at(&frames),
                    m.wrist.at(&frames),
                    m.hand.at(&frames),
                );
                let hand_rot = frames.link(self.hand_links[s]).rotation;
                let upper_rot = frames.link(self.upper_links[s]).rotation;
                ArmPosture {
                    upper_arm: to_body * (el - sh).normalize(),
                    forearm: to_body * (wr - el).normalize(),
                    hand: to_body * (ha - self.shoulders[s]) / self.reach[s],
                    turn: to_body
                        * (hand_rot * self.neutral_hands[s].inverse())
                        * self.body_to_root,
                    upper_turn: to_body
                        * (upper_rot * self.neutral_uppers[s].inverse())
                        * self.body_to_root,
                }
            })
            .collect()
    }

    /// The person's arm postures (left, right) that this gauge's arms follow, in its arms'
    /// order — both on a two-armed robot, the one of its side on a single-arm robot — turned
    /// by the body's mount.
    pub(super) fn followed<'a>(
        &'a self,
        person: &'a [ArmPosture; 2],
    ) -> impl Iterator<Item = ArmPosture> + 'a {
        self.sides
            .iter()
            .zip(&self.mounts)
            .map(move |(side, mount)| person[side.index()].turned(mount))
    }
}

/// How far apart two postures of one robot's arms are, on bone lines: what a learned
/// mapping's commands are judged by against the retargeted ones (`sgplvm evaluate`).
pub struct PostureDistance<'a> {
    anatomy: &'a Anatomy,
    gauge: PostureGauge,
}

/// The angles between two postures of one arm, degrees.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ArmAngles {
    /// Between the upper arms' directions (shoulder centre → elbow centre).
    pub upper_arm_deg: f64,
    /// Between the forearms' directions (elbow centre → wrist centre).
    pub forearm_deg: f64,
}

impl<'a> PostureDistance<'a> {
    /// The distance on `anatomy`'s arms.
    pub fn new(anatomy: &'a Anatomy) -> PostureDistance<'a> {
        PostureDistance {
            anatomy,
            gauge: PostureGauge::of(anatomy),
        }
    }

    /// Per arm ([`Anatomy::arms`]' order: left, right; one on a single-arm robot), the angles
    /// between configurations `a` and `b` (every movable joint of the URDF, in its order).
    pub fn between(&self, a: &[f64], b: &[f64]) -> Vec<ArmAngles> {
        let b = self.gauge.measure(self.anatomy, b);
        arm_angles(&self.gauge.measure(self.anatomy, a), b.into_iter())
    }
}

/// Per arm, the angles between the segments of arm postures `a` and the postures `b` they are
/// measured against.
fn arm_angles(a: &[ArmPosture], b: impl Iterator<Item = ArmPosture>) -> Vec<ArmAngles> {
    a.iter()
        .zip(b)
        .map(|(a, b)| ArmAngles {
            upper_arm_deg: a.upper_arm.angle(&b.upper_arm).to_degrees(),
            forearm_deg: a.forearm.angle(&b.forearm).to_degrees(),
        })
        .collect()
}

/// How far a robot's arms are from a person's, on bone lines: each segment's direction in the
/// robot's body frame against the person's in theirs, as retargeting's report measures its
/// result (`sgplvm evaluate` judges a learned mapping's commands and the retargeted ones by it,
/// side by side).
pub struct PersonDistance<'a> {
    robot: PostureDistance<'a>,
    human: Anatomy,
    human_gauge: PostureGauge,
}

impl<'a> PersonDistance<'a> {
    /// The distance between `anatomy`'s arms and the built-in human model's (the 18 joints
    /// demonstrations store the person in).
    pub fn new(anatomy: &'a Anatomy) -> Result<PersonDistance<'a>, super::RetargetError> {
        let model =
            crate::urdf::Robot::builtin("human").map_err(|source| super::RetargetError::Robot {
                body: "human".into(),
                source,
            })?;
        let human =
            Anatomy::of(model).map_err(|e| super::RetargetError::Invalid(format!("human: {e}")))?;
        Ok(PersonDistance {
            robot: PostureDistance::new(anatomy),
            human_gauge: PostureGauge::of(&human),
            human,
        })
    }

    /// Per arm of the robot ([`Anatomy::arms`]' order), the angles between the robot at
    /// configuration `q` (every movable joint of the URDF, in its order) and the person's arm
    /// of its side at `person` (the human model's joints).
    pub fn between(&self, q: &[f64], person: &[f64]) -> Vec<ArmAngles> {
        let person = two(self.human_gauge.measure(&self.human, person));
        let gauge = &self.robot.gauge;
        arm_angles(
            &gauge.measure(self.robot.anatomy, q),
            gauge.followed(&person),
        )
    }
}

/// The person's side of whole-arm retargeting: the human model, its arm postures measured with
/// turns from the person's reference posture ([`reference_configuration`]), and each frame's
/// path from the person's neutral to its pose.
pub(super) struct PersonGauge {
    human: Anatomy,
    gauge: PostureGauge,
    /// The arm postures of the person's reference posture and of their neutral.
    reference: [ArmPosture; 2],
    neutral: [ArmPosture; 2],
    /// The paths of the person's key postures: the fixed probes a robot's solver decides by
    /// whether it follows paths ([`ArmSolver::new`]).
    probes: Vec<Vec<[ArmPosture; 2]>>,
}

/// The person's two arm postures (left, right) of a measure of the human model, which has both.
fn two(postures: Vec<ArmPosture>) -> [ArmPosture; 2] {
    let mut arms = postures.into_iter();
    let mut next = || arms.next().expect("the human model has two arms");
    [next(), next()]
}

/// The largest change of any of the person's joints (radians) between two points of a frame's
/// path: small enough that the robot's posture follows from one point to the next.
const PATH_STEP: f64 = 0.25;

impl PersonGauge {
    /// The gauge of `human` (the human model's anatomy).
    pub(super) fn new(human: Anatomy) -> PersonGauge {
        let at = reference_configuration(&human);
        let gauge = PostureGauge::at(&human, &at);
        let reference = two(gauge.measure(&human, &at));
        let neutral = two(gauge.measure(&human, human.hold_configuration()));
        let mut person = PersonGauge {
            human,
            gauge,
            reference,
            neutral,
            probes: Vec::new(),
        };
        // The human's key postures (the generator's); none if they cannot be solved.
        let keys = crate::generator::solve_key_poses("human")
            .map(|k| k.postures)
            .unwrap_or_default();
        person.probes = keys
            .iter()
            .map(|q| {
                let mut path = Vec::new();
                person.path(q, &mut path);
                path
            })
            .collect();
        person
    }

    /// The paths of the person's key postures.
    pub(super) fn probes(&self) -> &[Vec<[ArmPosture; 2]>] {
        &self.probes
    }

    /// The human model's joint count.
    pub(super) fn joints(&self) -> usize {
        self.human.hold_configuration().len()
    }

    /// The arm postures of the person's reference posture and of their neutral, what a robot's
    /// solver is set up with ([`ArmSolver::new`]).
    pub(super) fn person(&self) -> (&[ArmPosture; 2], &[ArmPosture; 2]) {
        (&self.reference, &self.neutral)
    }

    /// The arm postures (left, right) of the human model's configuration `q`.
    pub(super) fn measure(&self, q: &[f64]) -> [ArmPosture; 2] {
        two(self.gauge.measure(&self.human, q))
    }

    /// The path of configuration `q` from the person's neutral, into `out`: the arm postures
    /// with every joint moved a share k/K of the way from its neutral value, k = 1 … K, K the
    /// fewest steps of at most [`PATH_STEP`]; the last is `q`'s.
    pub(super) fn path(&self, q: &[f64], out: &mut Vec<[ArmPosture; 2]>) {
        let hold = self.human.hold_configuration();
        let far = q
            .iter()
            .zip(hold)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        let steps = (far / PATH_STEP).ceil().max(1.0) as usize;
        out.clear();
        let mut at = hold.to_vec();
        for k in 1..=steps {
            let t = k as f64 / steps as f64;
            for ((a, &h), &v) in at.iter_mut().zip(hold).zip(q) {
                *a = h + t * (v - h);
            }
            out.push(self.measure(if k == steps { q } else { &at }));
        }
    }
}

/// One robot through every frame: the commands (frames × every joint of the URDF, held joints
/// at their hold values), each hand's miss per frame (metres, left and right) and the report.
/// `person` gives each frame's path ([`PersonGauge::path`] of `human`'s rows); the robot's
/// segment orientations are measured from the robot's posture with the person's reference
/// bone directions (`FrameSolver::reference_hands`), so that orientations and bone directions
/// ask one posture of the robot.
pub(super) fn run(
    anatomy: &Anatomy,
    person: &PersonGauge,
    human: &DMatrix<f64>,
    seeds: &[Vec<f64>],
    times_ns: &[i64],
    options: &WholeArmOptions,
    velocity_limits: bool,
) -> Result<(DMatrix<f64>, Vec<f64>, PostureReport), String> {
    let started = std::time::Instant::now();
    let robot = anatomy.robot();
    let solver = ArmSolver::new(anatomy, person, seeds, options);
    let (gauge, model, q_index, hold) =
        (&solver.gauge, &solver.model, &solver.q_index, &solver.hold);
    let mut safety = SafetyStep::new(
        anatomy,
        &anatomy.arm_joint_names(),
        SafetyOptions {
            margin_m: options.margin_m,
            velocity_limits,
            self_collision: options.self_collision,
            ..SafetyOptions::default()
        },
    )?;
    let mut ideal = hold.clone();
    let frames = human.nrows();
    let mut out = DMatrix::<f64>::from_fn(frames, hold.len(), |_, i| hold[i]);
    let mut tally = Tally {
        from_fixed_starts: !solver.follows(),
        ..Tally::default()
    };
    let mut sent = vec![0.0; q_index.len()];
    let position_limits = robot.joint_limits();
    let mut path = Vec::new();
    let mut last: Option<(Vec<f64>, Vec<f64>, f64)> = None;
    let start_seconds = started.elapsed().as_secs_f64();
    for f in 0..frames {
        let q_human: Vec<f64> = human.row(f).iter().copied().collect();
        person.path(&q_human, &mut path);
        let target = path.last().expect("a path ends at its frame");
        let (steps, constrained) = solver.solve(&path, &mut ideal);
        tally.steps += steps;
        tally.constrained += constrained;
        let asked: Vec<f64> = q_index.iter().map(|&i| ideal[i]).collect();
        // Seconds since the first frame: a capture's absolute clock (1.7e9 s) leaves a double
        // too few digits for a 25 ms step's velocity limit.
        let now = (times_ns[f] - times_ns[0]) as f64 * 1e-9;
        if let Some((h, a, t)) = &last {
            tally.jumps(q_index, (h, a, *t), (&q_human, &asked, now));
        }
        let before = (velocity_limits && f > 0)
            .then(|| (sent.clone(), (times_ns[f] - times_ns[f - 1]) as f64 * 1e-9));
        // Without velocity limits the safe command is a function of the pose alone: the
        // self-collision limit linearised at the asked posture, not at the command before,
        // and again at each result while it moves (a posture deep in a shape needs more than
        // one linearised step out).
        let outcome = if velocity_limits {
            safety.step(&asked, now, &mut sent)
        } else {
            let before_sent = sent.clone();
            let mut outcome = safety.step_from(&asked, None, now, &mut sent);
            // A posture the step leaves as asked, having found a step, keeps every pair its
            // margin apart (more than nothing): it would be left so again, and nothing overlaps.
            if outcome.changed || outcome.infeasible {
                for _ in 0..SAFE_PASSES {
                    let at = sent.clone();
                    if !safety.step_from(&at, None, now, &mut sent).changed {
                        break;
                    }
                }
                if f > 0 && safety.overlaps(&sent) {
                    // No safe posture found from the pose alone: the step from the command
                    // before, cut back until nothing overlaps (this frame then depends on the
                    // path).
                    tally.from_before += 1;
                    outcome = safety.step_from(&asked, Some((&before_sent, now)), now, &mut sent);
                }
            }
            outcome.changed = sent.iter().zip(&asked).any(|(o, a)| (o - a).abs() > 1e-9);
            outcome
        };
        if outcome.changed {
            // A joint held at its velocity limit, and no pair near, is a frame the velocity
            // limits held; else the robot's own shapes moved it (a frame stepped out of them
            // may end with no pair near, and then no joint at its velocity limit either).
            let by_velocity = tally.limits_held(
                (q_index, safety.velocity_limits()),
                (&asked, &sent),
                before,
                &outcome.near,
            );
            if velocity_limits && by_velocity && outcome.near.is_empty() {
                tally.velocity_limited += 1;
            } else {
                tally.collision_limited += 1;
            }
        }
        tally.bounds_held(&position_limits, q_index, &sent);
        let mut q = hold.clone();
        for (k, &i) in q_index.iter().enumerate() {
            q[i] = sent[k];
            out[(f, i)] = sent[k];
        }
        tally.judge(anatomy, gauge, model, &q, target, options.self_collision);
        last = Some((q_human, asked, now));
    }
    let arms = gauge.reach.len();
    let misses: Vec<f64> = tally
        .hand
        .iter()
        .enumerate()
        .map(|(k, h)| h * gauge.reach[k % arms])
        .collect();
    let mut report = tally.report(options, model, (robot, frames));
    report.start_seconds = start_seconds;
    report.frames_seconds = started.elapsed().as_secs_f64() - start_seconds;
    Ok((out, misses, report))
}

/// The elbows' flexion in the reference posture, radians: bent enough that the bone
/// directions tell the plane the elbow bends in (and so the upper arm's twist), on the person
/// and on the robot alike.
const REFERENCE_ELBOW: f64 = std::f64::consts::FRAC_PI_2;

/// The person's reference posture: the human model's neutral with both elbows bent
/// [`REFERENCE_ELBOW`] (the side each bends to), the posture a hand's and an upper arm's turn is
/// measured from.
pub(super) fn reference_configuration(human: &Anatomy) -> Vec<f64> {
    let mut q = human.hold_configuration().to_vec();
    let limits = human.robot().joint_limits();
    for arm in human.arms() {
        if let Some(&i) = arm.chain.robot_indices().get(arm.elbow) {
            let (lo, hi) = limits[i];
            q[i] = if hi >= -lo {
                REFERENCE_ELBOW.min(hi)
            } else {
                (-REFERENCE_ELBOW).max(lo)
            };
        }
    }
    q
}

/// Further linearised safety steps from the last one's result, at most, when velocity limits
/// are off (each only while the one before moved the command).
const SAFE_PASSES: usize = 4;
