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
//! Each frame is solved from the neutral posture and from the fixed starts (the key postures)
//! that begin nearest it, never from the previous frame, and the lowest objective kept: the
//! posture is a function of the person's pose, whatever came before it. The command sent is
//! then the nearest safe one ([`crate::safety`]): out of self-collision, linearised at the
//! posture itself, and — only when asked for — within the velocity limits of the command
//! before (then, where they hold it back, the command depends on the path).

use nalgebra::{DMatrix, UnitQuaternion, Vector3};
use serde::{Deserialize, Serialize};

use crate::anatomy::{Anatomy, ArmLandmarks};
use crate::kinematics::collision::CollisionModel;
use crate::kinematics::frames::{Ancestry, RobotFrames};
use crate::kinematics::limits::{collision_limit, position_limits};
use crate::kinematics::qp::{Solved, Step};
use crate::kinematics::tasks::{Task, TaskContext};
use crate::safety::{SafetyOptions, SafetyStep};

mod report;

use report::Tally;
pub use report::{LimitHeld, PairHeld, PostureReport};

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

/// A body's arms as postures are measured on them: landmarks, and the rotation from the body
/// frame to the root frame.
pub(super) struct PostureGauge {
    landmarks: [ArmLandmarks; 2],
    body_to_root: UnitQuaternion<f64>,
    /// The fixed shoulder points hands are placed from, root frame.
    shoulders: [Vector3<f64>; 2],
    reach: [f64; 2],
    neutral_hands: [UnitQuaternion<f64>; 2],
    hand_links: [usize; 2],
    /// The upper arms' orientations at the neutral posture, and their links (the elbow's).
    neutral_uppers: [UnitQuaternion<f64>; 2],
    upper_links: [usize; 2],
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
        let landmarks = [0, 1].map(|s| anatomy.arms()[s].landmarks(robot));
        let neutral = RobotFrames::new(robot, &ancestry, reference);
        PostureGauge {
            body_to_root: torso.rotation * anatomy.body_in_torso(),
            shoulders: [0, 1]
                .map(|s| (torso * nalgebra::Point3::from(anatomy.arms()[s].shoulder)).coords),
            reach: [0, 1].map(|s| anatomy.arms()[s].reach),
            neutral_hands: [0, 1].map(|s| neutral.link(landmarks[s].hand.link).rotation),
            hand_links: [0, 1].map(|s| landmarks[s].hand.link),
            neutral_uppers: [0, 1].map(|s| neutral.link(landmarks[s].elbow.link).rotation),
            upper_links: [0, 1].map(|s| landmarks[s].elbow.link),
            landmarks,
            ancestry,
        }
    }

    /// The arm postures of configuration `q` of `anatomy`'s robot.
    pub(super) fn measure(&self, anatomy: &Anatomy, q: &[f64]) -> [ArmPosture; 2] {
        let frames = RobotFrames::new(anatomy.robot(), &self.ancestry, q);
        let to_body = self.body_to_root.inverse();
        [0, 1].map(|s| {
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
                turn: to_body * (hand_rot * self.neutral_hands[s].inverse()) * self.body_to_root,
                upper_turn: to_body
                    * (upper_rot * self.neutral_uppers[s].inverse())
                    * self.body_to_root,
            }
        })
    }
}

/// One robot through every frame: the commands (frames × every joint of the URDF, held joints
/// at their hold values), each hand's miss per frame (metres, left and right) and the report.
/// `reference` is the person's reference posture (the one their turns are measured from,
/// [`reference_configuration`]): the robot's segment orientations are measured from the
/// robot's posture with the person's bone directions there (`FrameSolver::reference_hands`),
/// so that orientations and bone directions ask one posture of the robot.
pub(super) fn run(
    anatomy: &Anatomy,
    targets: &[[ArmPosture; 2]],
    reference: &[ArmPosture; 2],
    seeds: &[Vec<f64>],
    times_ns: &[i64],
    options: &WholeArmOptions,
    velocity_limits: bool,
) -> Result<(DMatrix<f64>, Vec<f64>, PostureReport), String> {
    let robot = anatomy.robot();
    let solver = ArmSolver::new(anatomy, reference, seeds.to_vec(), options);
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
    let mut out = DMatrix::<f64>::from_fn(targets.len(), hold.len(), |_, i| hold[i]);
    let mut tally = Tally::default();
    let mut sent = vec![0.0; q_index.len()];
    for (f, target) in targets.iter().enumerate() {
        let (steps, constrained) = solver.solve(target, &mut ideal);
        tally.steps += steps;
        tally.constrained += constrained;
        let asked: Vec<f64> = q_index.iter().map(|&i| ideal[i]).collect();
        // Seconds since the first frame: a capture's absolute clock (1.7e9 s) leaves a double
        // too few digits for a 25 ms step's velocity limit.
        let now = (times_ns[f] - times_ns[0]) as f64 * 1e-9;
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
            for _ in 0..SAFE_PASSES {
                let at = sent.clone();
                if !safety.step_from(&at, None, now, &mut sent).changed {
                    break;
                }
            }
            if f > 0 && safety.overlaps(&sent) {
                // No safe posture found from the pose alone: the step from the command before,
                // cut back until nothing overlaps (this frame then depends on the path).
                tally.from_before += 1;
                outcome = safety.step_from(&asked, Some((&before_sent, now)), now, &mut sent);
            }
            outcome.changed = sent.iter().zip(&asked).any(|(o, a)| (o - a).abs() > 1e-9);
            outcome
        };
        if outcome.changed {
            if outcome.near.is_empty() {
                tally.velocity_limited += 1;
            } else {
                tally.collision_limited += 1;
            }
            tally.limits_held(robot, q_index, (&asked, &sent), before, &outcome.near);
        }
        let mut q = hold.clone();
        for (k, &i) in q_index.iter().enumerate() {
            q[i] = sent[k];
            out[(f, i)] = sent[k];
        }
        tally.judge(anatomy, gauge, model, &q, target, options.self_collision);
    }
    let misses: Vec<f64> = tally
        .hand
        .iter()
        .enumerate()
        .map(|(k, h)| h * gauge.reach[k % 2])
        .collect();
    let report = tally.report(options, model, (robot, targets.len()));
    Ok((out, misses, report))
}

/// One robot's whole-arm solver, set up once: the posture gauge (its orientations measured
/// from the robot's reference posture), the collision model, the joints it moves and the fixed
/// starts. [`ArmSolver::solve`] gives a frame's posture from its target alone.
pub(super) struct ArmSolver {
    anatomy: Anatomy,
    gauge: PostureGauge,
    model: CollisionModel,
    /// The arm joints' configuration indices and their movable-joint indices.
    q_index: Vec<usize>,
    active: Vec<usize>,
    /// The whole configuration at hold, and the arm joints' values there.
    hold: Vec<f64>,
    neutral: Vec<f64>,
    seeds: Vec<Vec<f64>>,
    elbows: Vec<ElbowSide>,
    options: WholeArmOptions,
}

impl ArmSolver {
    /// The solver of `anatomy`'s arms for a person whose turns are measured from `reference`
    /// ([`reference_configuration`]), with the fixed starts `seeds` (whole configurations).
    pub(super) fn new(
        anatomy: &Anatomy,
        reference: &[ArmPosture; 2],
        seeds: Vec<Vec<f64>>,
        options: &WholeArmOptions,
    ) -> ArmSolver {
        let robot = anatomy.robot();
        let q_index: Vec<usize> = anatomy
            .arm_joint_names()
            .iter()
            .filter_map(|n| robot.joint_index(n))
            .collect();
        let active: Vec<usize> = q_index.iter().map(|&i| robot.movable[i]).collect();
        let hold = anatomy.hold_configuration().to_vec();
        let mut solver = ArmSolver {
            anatomy: anatomy.clone(),
            gauge: PostureGauge::of(anatomy),
            model: anatomy.collision_model(&q_index, options.margin_m),
            neutral: q_index.iter().map(|&i| hold[i]).collect(),
            elbows: elbow_sides(anatomy, &active),
            q_index,
            active,
            hold,
            seeds,
            options: options.clone(),
        };
        let turns = solver.frame().reference_hands(reference, &solver.hold);
        (solver.gauge.neutral_hands, solver.gauge.neutral_uppers) = turns;
        solver
    }

    /// The frame solver over this robot.
    fn frame(&self) -> FrameSolver<'_> {
        FrameSolver {
            anatomy: &self.anatomy,
            gauge: &self.gauge,
            model: &self.model,
            active: &self.active,
            neutral: &self.neutral,
            seeds: &self.seeds,
            elbows: &self.elbows,
            options: &self.options,
        }
    }

    /// The posture (whole configuration, into `q`) for `target`, solved from the fixed starts
    /// alone; the Gauss–Newton steps taken and how many had an active limit.
    pub(super) fn solve(&self, target: &[ArmPosture; 2], q: &mut Vec<f64>) -> (usize, usize) {
        self.frame().solve_frame(q, target, &self.hold)
    }

    /// The arm joints' configuration indices, in the order of the anatomy's arm joint names.
    pub(super) fn arm_indices(&self) -> &[usize] {
        &self.q_index
    }

    /// The whole configuration at hold.
    pub(super) fn hold(&self) -> &[f64] {
        &self.hold
    }
}

/// One frame's solve.
struct FrameSolver<'a> {
    anatomy: &'a Anatomy,
    gauge: &'a PostureGauge,
    model: &'a CollisionModel,
    active: &'a [usize],
    neutral: &'a [f64],
    /// Fixed starts besides the neutral posture (whole configurations).
    seeds: &'a [Vec<f64>],
    /// Per arm, the elbow's place among the active joints and the side it bends to.
    elbows: &'a [ElbowSide],
    options: &'a WholeArmOptions,
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

/// How many of the fixed starts (the key postures) each frame is also solved from besides the
/// neutral posture: those whose objective is lowest at the start.
const SEED_STARTS: usize = 2;

/// Further linearised safety steps from the last one's result, at most, when velocity limits
/// are off (each only while the one before moved the command).
const SAFE_PASSES: usize = 4;

/// How far past straight (radians) an elbow is let bend the other way while retargeting.
const PAST_STRAIGHT: f64 = 0.02;

/// An elbow's bending side: the retargeting keeps it there (a person's elbow bends one way; a
/// robot's that can also bend a little the other way would otherwise take the same bone
/// directions with the upper arm turned half round and the elbow bent backwards, a second
/// posture of the same pose).
#[derive(Debug, Clone, Copy)]
struct ElbowSide {
    /// The elbow's index among the active joints.
    active: usize,
    /// Its range on its bending side (the side of the larger range), radians.
    range: (f64, f64),
}

/// The bending side of each arm's elbow of `anatomy` (`active`: the joints the solver moves).
fn elbow_sides(anatomy: &Anatomy, active: &[usize]) -> Vec<ElbowSide> {
    let robot = anatomy.robot();
    anatomy
        .arms()
        .iter()
        .filter_map(|arm| {
            let i = *arm.chain.robot_indices().get(arm.elbow)?;
            let j = robot.movable[i];
            let k = active.iter().position(|&a| a == j)?;
            let (lo, hi) = robot.joints[j].limits;
            if !(lo < 0.0 && hi > 0.0) || arm.chain.is_prismatic(arm.elbow) {
                return None;
            }
            let range = if -lo >= hi {
                (lo, hi.min(PAST_STRAIGHT))
            } else {
                (lo.max(-PAST_STRAIGHT), hi)
            };
            Some(ElbowSide { active: k, range })
        })
        .collect()
}

impl FrameSolver<'_> {
    /// The robot's hand orientations (root frame) at the posture whose bone directions are the
    /// person's neutral ones (`reference`), the rest of the arm pulled towards the neutral
    /// posture: where a hand's (and an upper arm's) turn from the person's neutral is measured
    /// from on the robot.
    fn reference_hands(
        &self,
        reference: &[ArmPosture; 2],
        hold: &[f64],
    ) -> ([UnitQuaternion<f64>; 2], [UnitQuaternion<f64>; 2]) {
        let g = self.gauge;
        let r = g.body_to_root;
        let mut tasks = Vec::new();
        for (s, t) in reference.iter().enumerate() {
            let m = &g.landmarks[s];
            tasks.push((
                Task::Direction {
                    from: m.shoulder,
                    to: m.elbow,
                    target: r * t.upper_arm,
                },
                1.0,
            ));
            tasks.push((
                Task::Direction {
                    from: m.elbow,
                    to: m.wrist,
                    target: r * t.forearm,
                },
                1.0,
            ));
        }
        tasks.push((
            Task::Posture {
                target: self.neutral.to_vec(),
            },
            self.options.weights.posture,
        ));
        let mut q = hold.to_vec();
        self.solve(&mut q, &tasks, false);
        let frames = RobotFrames::new(self.anatomy.robot(), &g.ancestry, &q);
        // Where the limits keep the robot from the person's neutral directions, each segment's
        // orientation is turned by what its bone still misses: the reference is the robot's
        // segments as they would sit along the person's bones.
        let got = g.measure(self.anatomy, &q);
        let align = |from: &Vector3<f64>, to: &Vector3<f64>| {
            UnitQuaternion::rotation_between(&(r * from), &(r * to))
                .unwrap_or_else(UnitQuaternion::identity)
        };
        (
            [0, 1].map(|s| {
                align(&got[s].forearm, &reference[s].forearm)
                    * frames.link(g.hand_links[s]).rotation
            }),
            [0, 1].map(|s| {
                align(&got[s].upper_arm, &reference[s].upper_arm)
                    * frames.link(g.upper_links[s]).rotation
            }),
        )
    }

    /// The tasks of a frame's target posture.
    fn tasks(&self, target: &[ArmPosture; 2]) -> Vec<(Task, f64)> {
        let g = self.gauge;
        let w = &self.options.weights;
        let mut tasks = Vec::new();
        for (s, t) in target.iter().enumerate() {
            let m = &g.landmarks[s];
            let r = g.body_to_root;
            tasks.push((
                Task::Direction {
                    from: m.shoulder,
                    to: m.elbow,
                    target: r * t.upper_arm,
                },
                w.upper_arm,
            ));
            tasks.push((
                Task::Direction {
                    from: m.elbow,
                    to: m.wrist,
                    target: r * t.forearm,
                },
                w.forearm,
            ));
            tasks.push((
                Task::Position {
                    point: m.hand,
                    target: g.shoulders[s] + g.reach[s] * (r * t.hand),
                    scale: g.reach[s],
                },
                w.hand,
            ));
            if w.orientation > 0.0 {
                tasks.push((
                    Task::Orientation {
                        link: g.hand_links[s],
                        target: (r * t.turn * r.inverse()) * g.neutral_hands[s],
                    },
                    w.orientation,
                ));
            }
            if w.twist > 0.0 {
                tasks.push((
                    Task::Orientation {
                        link: g.upper_links[s],
                        target: (r * t.upper_turn * r.inverse()) * g.neutral_uppers[s],
                    },
                    w.twist,
                ));
            }
        }
        tasks.push((
            Task::Posture {
                target: self.neutral.to_vec(),
            },
            w.posture,
        ));
        tasks
    }

    /// The frame's posture, a function of the target and never of the path: converged from the
    /// neutral posture and from the [`SEED_STARTS`] fixed starts whose objective is lowest at the
    /// start, the lowest objective kept (the first start's on a tie within 0.1 %). Written to
    /// `q`; returns the steps taken and how many had an active limit.
    fn solve_frame(
        &self,
        q: &mut Vec<f64>,
        target: &[ArmPosture; 2],
        hold: &[f64],
    ) -> (usize, usize) {
        let tasks = self.tasks(target);
        let mut starts: Vec<(f64, &Vec<f64>)> = self
            .seeds
            .iter()
            .map(|s| (self.cost(s, &tasks), s))
            .collect();
        starts.sort_by(|a, b| a.0.total_cmp(&b.0));
        let mut best: Option<(Vec<f64>, f64)> = None;
        let (mut steps, mut constrained) = (0, 0);
        for start in
            std::iter::once(hold).chain(starts.iter().take(SEED_STARTS).map(|s| s.1.as_slice()))
        {
            let mut x = start.to_vec();
            let (s, c) = self.converge(&mut x, &tasks);
            steps += s;
            constrained += c;
            let cost = self.cost(&x, &tasks);
            if best
                .as_ref()
                .is_none_or(|b| cost < b.1 * (1.0 - 1e-3) - 1e-6)
            {
                best = Some((x, cost));
            }
        }
        if let Some((x, _)) = best {
            *q = x;
        }
        (steps, constrained)
    }

    /// Converges `q` onto the tasks, the self-collision limit only where the tasks alone end
    /// with two shapes nearer than the margin (shapes are the costly part: meshes' hulls).
    fn converge(&self, q: &mut [f64], tasks: &[(Task, f64)]) -> (usize, usize) {
        let (mut steps, mut constrained) = self.solve(q, tasks, false);
        if self.options.self_collision {
            let frames = RobotFrames::new(self.anatomy.robot(), &self.gauge.ancestry, q);
            if !self
                .model
                .proximities(&frames, self.options.margin_m)
                .is_empty()
            {
                let (s, c) = self.solve(q, tasks, true);
                steps += s;
                constrained += c;
            }
        }
        (steps, constrained)
    }

    /// The objective at `q`: the tasks' weighted squared errors.
    fn cost(&self, q: &[f64], tasks: &[(Task, f64)]) -> f64 {
        let robot = self.anatomy.robot();
        let frames = RobotFrames::new(robot, &self.gauge.ancestry, q);
        let ctx = TaskContext {
            robot,
            ancestry: &self.gauge.ancestry,
            frames: &frames,
            q,
            active: self.active,
        };
        tasks
            .iter()
            .map(|(t, w)| w * t.error(&ctx).norm_squared())
            .sum()
    }

    /// Converges `q` (the whole configuration) onto the tasks, with the self-collision limit
    /// when `collisions`; returns the steps taken and how many had an active limit.
    fn solve(&self, q: &mut [f64], tasks: &[(Task, f64)], collisions: bool) -> (usize, usize) {
        let robot = self.anatomy.robot();
        let (mut steps, mut constrained) = (0, 0);
        // A trust region: a step is taken only if it lowers the objective (or keeps a collision
        // limit), else the region shrinks (plain Gauss–Newton oscillates where the tasks
        // conflict).
        let mut radius = self.options.step_bound;
        let mut cost = self.cost(q, tasks);
        let mut trial = q.to_vec();
        for _ in 0..self.options.max_iterations {
            let frames = RobotFrames::new(robot, &self.gauge.ancestry, q);
            let ctx = TaskContext {
                robot,
                ancestry: &self.gauge.ancestry,
                frames: &frames,
                q,
                active: self.active,
            };
            let mut step = Step::new(self.active.len(), 1e-8);
            for (task, weight) in tasks {
                let (e, j) = task.linearize(&ctx);
                step.add_task(&j, &e, *weight);
            }
            position_limits(&mut step, &ctx, Some(radius));
            let values = ctx.active_values();
            for e in self.elbows {
                let v = values[e.active];
                // From a start beyond the side (a seed), back towards it, never further out.
                step.bound(e.active, (e.range.0 - v).min(0.0), (e.range.1 - v).max(0.0));
            }
            // Near another shape the step keeps its distance: taken whatever it costs the
            // tasks (the objective does not see the collision limit).
            let near = collisions
                && !collision_limit(
                    &mut step,
                    &ctx,
                    self.model,
                    self.options.margin_m,
                    0.05,
                    0.5,
                )
                .is_empty();
            let Ok((delta, how)) = step.solve() else {
                // Limits that admit no step (shapes that cannot all be kept apart): the tasks
                // decide, and the command sent is kept safe.
                break;
            };
            steps += 1;
            constrained += usize::from(how == Solved::Constrained);
            trial.copy_from_slice(q);
            for (k, &j) in self.active.iter().enumerate() {
                if let Some(i) = robot.joints[j].q_index {
                    trial[i] += delta[k];
                }
            }
            let c = self.cost(&trial, tasks);
            if c <= cost || near {
                q.copy_from_slice(&trial);
                cost = c;
                radius = (radius * 2.0).min(self.options.step_bound);
                if delta.amax() < self.options.tolerance {
                    break;
                }
            } else {
                radius = 0.25 * delta.amax();
                if radius < self.options.tolerance {
                    break;
                }
            }
        }
        (steps, constrained)
    }
}
