//! Whole-arm retargeting ([`super::Match::Arms`]): the robot takes the person's arm posture —
//! the upper arm's and the forearm's directions in the body frame, and the hand where the
//! person's is relative to the shoulder in units of reach — by differential IK, each frame
//! solved to convergence as one QP per Gauss–Newton step over both arms' joints
//! ([`crate::kinematics::qp`]):
//!
//! ```text
//! min  Σ_arms  w_u ‖u − û‖² + w_f ‖f − f̂‖² + w_h ‖(h − ĥ)/reach‖² [+ w_o ‖log(R̂ Rᵀ)‖²]
//!      + w_p ‖q − q_neutral‖²
//! s.t. joint position limits, every pair of the robot's own shapes that can meet ≥ margin
//! ```
//!
//! The posture regulariser pulls towards the fixed neutral posture, not the previous frame,
//! so the solution is a function of the person's pose (each frame starts from the previous
//! frame's solution only to converge faster). The command sent is then the nearest safe one
//! ([`crate::safety`]): within the velocity limits of the command before, and out of
//! self-collision.

use nalgebra::{DMatrix, UnitQuaternion, Vector3};
use serde::{Deserialize, Serialize};

use crate::anatomy::{Anatomy, ArmLandmarks};
use crate::kinematics::collision::CollisionModel;
use crate::kinematics::frames::{Ancestry, RobotFrames};
use crate::kinematics::limits::{collision_limit, position_limits};
use crate::kinematics::qp::{Solved, Step};
use crate::kinematics::tasks::{Task, TaskContext};
use crate::safety::{SafetyOptions, SafetyStep};
use crate::series::median;

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
    /// The pull towards the neutral posture (radians).
    pub posture: f64,
}

impl Default for Weights {
    fn default() -> Self {
        Weights {
            upper_arm: 1.0,
            forearm: 1.0,
            hand: 4.0,
            orientation: 0.0,
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
    ancestry: Ancestry,
}

impl PostureGauge {
    /// The gauge of `anatomy`'s arms.
    pub(super) fn of(anatomy: &Anatomy) -> PostureGauge {
        let robot = anatomy.robot();
        let ancestry = Ancestry::of(robot);
        let torso = anatomy.torso_in_root();
        let landmarks = [0, 1].map(|s| anatomy.arms()[s].landmarks(robot));
        let neutral = RobotFrames::new(robot, &ancestry, anatomy.hold_configuration());
        PostureGauge {
            body_to_root: torso.rotation * anatomy.body_in_torso(),
            shoulders: [0, 1]
                .map(|s| (torso * nalgebra::Point3::from(anatomy.arms()[s].shoulder)).coords),
            reach: [0, 1].map(|s| anatomy.arms()[s].reach),
            neutral_hands: [0, 1].map(|s| neutral.link(landmarks[s].hand.link).rotation),
            hand_links: [0, 1].map(|s| landmarks[s].hand.link),
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
            ArmPosture {
                upper_arm: to_body * (el - sh).normalize(),
                forearm: to_body * (wr - el).normalize(),
                hand: to_body * (ha - self.shoulders[s]) / self.reach[s],
                turn: to_body * (hand_rot * self.neutral_hands[s].inverse()) * self.body_to_root,
            }
        })
    }
}

/// How one robot followed, over every frame.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct PostureReport {
    /// Upper arm direction error, degrees: median and 90th percentile.
    pub upper_arm_deg: [f64; 2],
    /// Forearm direction error, degrees: median and 90th percentile.
    pub forearm_deg: [f64; 2],
    /// Hand position error as a fraction of reach: median and 90th percentile.
    pub hand_of_reach: [f64; 2],
    /// Share of hand targets within 5 % of the reach.
    pub hands_within_5pct: f64,
    /// Frames whose command the velocity limits held back.
    pub velocity_limited_frames: usize,
    /// Frames whose command the self-collision limit moved.
    pub collision_limited_frames: usize,
    /// Which velocity limits held the commands: per joint that was held at its limit (the
    /// command moved by the limit's whole step and not as far as asked), the joint, its limit
    /// (rad/s or m/s) and the frames; most frames first.
    #[serde(default)]
    pub velocity_limited_joints: Vec<LimitHeld>,
    /// Which pairs of links the self-collision limit kept apart: per pair of links (nearer than
    /// the margin and a millimetre before the command's step), the frames; most frames first.
    #[serde(default)]
    pub collision_limited_pairs: Vec<PairHeld>,
    /// Frames in self-collision as sent (shapes overlapping): 0 is the goal.
    pub colliding_frames: usize,
    /// The closest two shapes that can meet came over all frames as sent, metres; `None` when
    /// no pair ever came near enough to be measured (their bounding spheres stayed apart).
    pub closest_m: Option<f64>,
    /// The margin kept, metres.
    pub margin_m: f64,
    /// Pairs of shapes that can meet.
    pub pairs: usize,
    /// What could not be checked (collision meshes not found …).
    pub unchecked: Vec<String>,
    /// Gauss–Newton steps per frame, mean.
    pub steps_per_frame: f64,
    /// Share of steps in which a limit was active (the QP solver ran).
    pub constrained_steps: f64,
}

/// A joint whose velocity limit held the commands, and in how many frames.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LimitHeld {
    /// The joint's URDF name.
    pub joint: String,
    /// Its velocity limit (rad/s, or m/s for a prismatic joint).
    pub limit: f64,
    /// Whether the joint is prismatic (its limit in m/s).
    pub prismatic: bool,
    /// Frames in which it held the command.
    pub frames: usize,
}

/// A pair of links the self-collision limit kept apart, and in how many frames.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PairHeld {
    /// One link's URDF name.
    pub link_a: String,
    /// The other's.
    pub link_b: String,
    /// Frames in which the pair was limited.
    pub frames: usize,
    /// The nearest the pair came (before the step), metres.
    pub closest_m: f64,
}

/// One robot through every frame: the commands (frames × every joint of the URDF, held joints
/// at their hold values), each hand's miss per frame (metres, left and right) and the report.
pub(super) fn run(
    anatomy: &Anatomy,
    targets: &[[ArmPosture; 2]],
    times_ns: &[i64],
    options: &WholeArmOptions,
    velocity_limits: bool,
) -> Result<(DMatrix<f64>, Vec<f64>, PostureReport), String> {
    let robot = anatomy.robot();
    let gauge = PostureGauge::of(anatomy);
    let arm_names = anatomy.arm_joint_names();
    let q_index: Vec<usize> = arm_names
        .iter()
        .filter_map(|n| robot.joint_index(n))
        .collect();
    let active: Vec<usize> = q_index.iter().map(|&i| robot.movable[i]).collect();
    let model = anatomy.collision_model(&q_index, options.margin_m);
    let mut safety = SafetyStep::new(
        anatomy,
        &arm_names,
        SafetyOptions {
            margin_m: options.margin_m,
            velocity_limits,
            self_collision: options.self_collision,
            ..SafetyOptions::default()
        },
    )?;
    let hold = anatomy.hold_configuration().to_vec();
    let neutral: Vec<f64> = q_index.iter().map(|&i| hold[i]).collect();
    let mut ideal = hold.clone();
    let mut out = DMatrix::<f64>::from_fn(targets.len(), hold.len(), |_, i| hold[i]);
    let mut tally = Tally::default();
    let mut sent = vec![0.0; q_index.len()];
    for (f, target) in targets.iter().enumerate() {
        let solver = FrameSolver {
            anatomy,
            gauge: &gauge,
            model: &model,
            active: &active,
            neutral: &neutral,
            options,
        };
        let (steps, constrained) = solver.solve_frame(&mut ideal, target, &hold);
        tally.steps += steps;
        tally.constrained += constrained;
        let asked: Vec<f64> = q_index.iter().map(|&i| ideal[i]).collect();
        // Seconds since the first frame: a capture's absolute clock (1.7e9 s) leaves a double
        // too few digits for a 25 ms step's velocity limit.
        let now = (times_ns[f] - times_ns[0]) as f64 * 1e-9;
        let before = (f > 0).then(|| (sent.clone(), (times_ns[f] - times_ns[f - 1]) as f64 * 1e-9));
        let outcome = safety.step(&asked, now, &mut sent);
        if outcome.changed {
            if outcome.near.is_empty() {
                tally.velocity_limited += 1;
            } else {
                tally.collision_limited += 1;
            }
            tally.limits_held(robot, &q_index, (&asked, &sent), before, &outcome.near);
        }
        let mut q = hold.clone();
        for (k, &i) in q_index.iter().enumerate() {
            q[i] = sent[k];
            out[(f, i)] = sent[k];
        }
        tally.judge(anatomy, &gauge, &model, &q, target, options.self_collision);
    }
    let misses: Vec<f64> = tally
        .hand
        .iter()
        .enumerate()
        .map(|(k, h)| h * gauge.reach[k % 2])
        .collect();
    let report = tally.report(options, &model, (robot, targets.len()));
    Ok((out, misses, report))
}

/// One frame's solve.
struct FrameSolver<'a> {
    anatomy: &'a Anatomy,
    gauge: &'a PostureGauge,
    model: &'a CollisionModel,
    active: &'a [usize],
    neutral: &'a [f64],
    options: &'a WholeArmOptions,
}

impl FrameSolver<'_> {
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
        }
        tasks.push((
            Task::Posture {
                target: self.neutral.to_vec(),
            },
            w.posture,
        ));
        tasks
    }

    /// The frame's posture, a function of the target rather than of the path: converged from
    /// the neutral posture (`hold`), and from the previous frame's posture (`q`) — kept only
    /// where its objective is lower by more than 0.1 %, where the neutral start fell into a
    /// worse optimum. Returns the steps taken and how many had an active limit.
    fn solve_frame(
        &self,
        q: &mut Vec<f64>,
        target: &[ArmPosture; 2],
        hold: &[f64],
    ) -> (usize, usize) {
        let tasks = self.tasks(target);
        let mut cold = hold.to_vec();
        let (s1, c1) = self.converge(&mut cold, &tasks);
        let (s2, c2) = self.converge(q, &tasks);
        // The previous posture only where the neutral start found a worse optimum, not where
        // the two differ by what convergence leaves undecided.
        let (cost_cold, cost_warm) = (self.cost(&cold, &tasks), self.cost(q, &tasks));
        if cost_cold < cost_warm * (1.0 - 1e-3) - 1e-6 {
            *q = cold;
        }
        (s1 + s2, c1 + c2)
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

/// What the frames showed, gathered.
#[derive(Default)]
struct Tally {
    upper: Vec<f64>,
    forearm: Vec<f64>,
    hand: Vec<f64>,
    steps: usize,
    constrained: usize,
    velocity_limited: usize,
    collision_limited: usize,
    colliding: usize,
    closest: Option<f64>,
    /// Per joint (configuration index): frames its velocity limit held.
    joints_held: std::collections::BTreeMap<usize, usize>,
    /// Per pair of links: frames the self-collision limit kept them apart, and the closest.
    pairs_held: std::collections::BTreeMap<(String, String), (usize, f64)>,
}

impl Tally {
    /// Which limits held one frame's command: the joints that moved by their velocity limit's
    /// whole step over `dt` from the command `before` and fell short of what was asked, and
    /// the pairs of links the safety step found near.
    fn limits_held(
        &mut self,
        robot: &crate::urdf::Robot,
        q_index: &[usize],
        (asked, sent): (&[f64], &[f64]),
        before: Option<(Vec<f64>, f64)>,
        near: &[(String, String, f64)],
    ) {
        if let Some((last, dt)) = before {
            let limits = robot.velocity_limits();
            for (k, &i) in q_index.iter().enumerate() {
                let step = limits[i] * dt;
                let short = (asked[k] - sent[k]).abs() > 1e-9;
                if limits[i] > 0.0 && short && (sent[k] - last[k]).abs() >= step - 1e-9 {
                    *self.joints_held.entry(i).or_default() += 1;
                }
            }
        }
        for (a, b, d) in near {
            let key = if a <= b {
                (a.clone(), b.clone())
            } else {
                (b.clone(), a.clone())
            };
            let e = self.pairs_held.entry(key).or_insert((0, f64::INFINITY));
            e.0 += 1;
            e.1 = e.1.min(*d);
        }
    }

    /// One frame as sent, against its target.
    fn judge(
        &mut self,
        anatomy: &Anatomy,
        gauge: &PostureGauge,
        model: &CollisionModel,
        q: &[f64],
        target: &[ArmPosture; 2],
        collisions: bool,
    ) {
        let got = gauge.measure(anatomy, q);
        for (g, t) in got.iter().zip(target) {
            self.upper
                .push(g.upper_arm.angle(&t.upper_arm).to_degrees());
            self.forearm.push(g.forearm.angle(&t.forearm).to_degrees());
            self.hand.push((g.hand - t.hand).norm());
        }
        if collisions {
            let frames = RobotFrames::new(anatomy.robot(), &gauge.ancestry, q);
            let near = model.proximities(&frames, 0.05);
            if near.iter().any(|p| p.distance < 0.0) {
                self.colliding += 1;
            }
            if let Some(d) = near.iter().map(|p| p.distance).reduce(f64::min) {
                self.closest = Some(self.closest.map_or(d, |c| c.min(d)));
            }
        }
    }

    fn report(
        self,
        options: &WholeArmOptions,
        model: &CollisionModel,
        (robot, frames): (&crate::urdf::Robot, usize),
    ) -> PostureReport {
        let names = robot.joint_names();
        let limits = robot.velocity_limits();
        let mut velocity_limited_joints: Vec<LimitHeld> = self
            .joints_held
            .iter()
            .map(|(&i, &n)| LimitHeld {
                joint: names[i].clone(),
                limit: limits[i],
                prismatic: robot.joints[robot.movable[i]].kind == crate::urdf::JointKind::Prismatic,
                frames: n,
            })
            .collect();
        velocity_limited_joints.sort_by(|a, b| b.frames.cmp(&a.frames));
        let mut collision_limited_pairs: Vec<PairHeld> = self
            .pairs_held
            .iter()
            .map(|((a, b), &(n, d))| PairHeld {
                link_a: a.clone(),
                link_b: b.clone(),
                frames: n,
                closest_m: d,
            })
            .collect();
        collision_limited_pairs.sort_by(|a, b| b.frames.cmp(&a.frames));
        let quantiles = |v: &[f64]| -> [f64; 2] {
            let mut s = v.to_vec();
            s.sort_by(f64::total_cmp);
            let p90 = s
                .get(((s.len() as f64) * 0.9).floor() as usize)
                .or(s.last())
                .copied()
                .unwrap_or(0.0);
            [median(&mut s.clone()), p90]
        };
        PostureReport {
            upper_arm_deg: quantiles(&self.upper),
            forearm_deg: quantiles(&self.forearm),
            hand_of_reach: quantiles(&self.hand),
            hands_within_5pct: self.hand.iter().filter(|&&h| h <= 0.05).count() as f64
                / self.hand.len().max(1) as f64,
            velocity_limited_frames: self.velocity_limited,
            collision_limited_frames: self.collision_limited,
            velocity_limited_joints,
            collision_limited_pairs,
            colliding_frames: self.colliding,
            closest_m: self.closest,
            margin_m: options.margin_m,
            pairs: model.pairs().len(),
            unchecked: model.unchecked().to_vec(),
            steps_per_frame: self.steps as f64 / frames.max(1) as f64,
            constrained_steps: self.constrained as f64 / self.steps.max(1) as f64,
        }
    }
}
