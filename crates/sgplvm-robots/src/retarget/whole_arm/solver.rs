//! The whole-arm solver of one robot ([`ArmSolver`]): set up once (the posture gauge measured
//! from the robot's reference posture, the collision model, the joints it moves, the robot's
//! posture for the person's neutral), then each frame followed from that posture along the
//! frame's path from the person's neutral to its pose ([`FrameSolver`]), within the joint
//! limits, each elbow on its bending side, and out of self-collision.

use nalgebra::{UnitQuaternion, Vector3};

use super::{ArmPosture, PersonGauge, PostureGauge, WholeArmOptions};
use crate::anatomy::Anatomy;
use crate::kinematics::collision::{CollisionModel, Proximity};
use crate::kinematics::frames::RobotFrames;
use crate::kinematics::limits::{collision_limit, position_limits};
use crate::kinematics::qp::{Solved, Step};
use crate::kinematics::tasks::{Task, TaskContext};

/// One robot's whole-arm solver, set up once: the posture gauge (its orientations measured
/// from the robot's reference posture), the collision model, the joints it moves and the fixed
/// posture for the person's neutral. [`ArmSolver::solve`] gives a frame's posture from its path
/// alone.
pub(in crate::retarget) struct ArmSolver {
    anatomy: Anatomy,
    pub(super) gauge: PostureGauge,
    pub(super) model: CollisionModel,
    /// The arm joints' configuration indices and their movable-joint indices.
    pub(super) q_index: Vec<usize>,
    active: Vec<usize>,
    /// The whole configuration at hold, and the arm joints' values there.
    pub(super) hold: Vec<f64>,
    neutral: Vec<f64>,
    /// The posture every frame's path starts from: the person's neutral, solved from the
    /// neutral posture and the fixed starts (whole configuration).
    start: Vec<f64>,
    /// The fixed starts (whole configurations), and whether frames are followed along their
    /// paths rather than solved from them ([`ArmSolver::choose`]).
    seeds: Vec<Vec<f64>>,
    follows: bool,
    elbows: Vec<ElbowSide>,
    options: WholeArmOptions,
}

impl ArmSolver {
    /// The solver of `anatomy`'s arms for `person` (turns measured from their reference
    /// posture, [`super::reference_configuration`]); every frame's path starts at the posture
    /// for the person's neutral, solved once from the robot's neutral posture and the fixed
    /// starts `seeds` (whole configurations); and whether this robot follows paths at all is
    /// decided on the person's key postures ([`ArmSolver::choose`]).
    pub(in crate::retarget) fn new(
        anatomy: &Anatomy,
        person: &PersonGauge,
        seeds: &[Vec<f64>],
        options: &WholeArmOptions,
    ) -> ArmSolver {
        let (reference, neutral_target) = person.person();
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
            start: hold.clone(),
            seeds: seeds.to_vec(),
            follows: true,
            q_index,
            active,
            hold,
            options: options.clone(),
        };
        let turns = solver
            .frame()
            .reference_hands(reference, &solver.hold, seeds);
        (solver.gauge.neutral_hands, solver.gauge.neutral_uppers) = turns;
        let mut start = solver.hold.clone();
        solver
            .frame()
            .solve_from_starts(&mut start, neutral_target, seeds);
        solver.start = solver.hanging_way(start, neutral_target, person.probes());
        solver.choose(person.probes());
        solver
    }

    /// The posture the paths start from: `first` (the neutral's best fit), or another posture
    /// that fits the person's neutral about as well (a shoulder turned half round, converged)
    /// from which the person's key postures are followed better by more than [`START_GAIN`]
    /// (their tasks' total error, the posture pull left out). An arm that hangs two ways (a Motoman SDA5F's
    /// shoulder with S at −90° or +90°) starts the way from which a forward raise stays
    /// within its limits. A property of the robot and the probes, never of the data.
    fn hanging_way(
        &self,
        first: Vec<f64>,
        neutral: &[ArmPosture; 2],
        probes: &[Vec<[ArmPosture; 2]>],
    ) -> Vec<f64> {
        let frame = self.frame();
        let fit = |q: &[f64], target: &[ArmPosture; 2]| {
            let mut tasks = frame.tasks(target);
            tasks.retain(|(t, _)| !matches!(t, Task::Posture { .. }));
            frame.cost(q, &tasks)
        };
        let followed = |start: &[f64]| -> f64 {
            probes
                .iter()
                .filter_map(|path| {
                    let mut q = start.to_vec();
                    frame.follow(&mut q, path);
                    Some(fit(&q, path.last()?))
                })
                .sum()
        };
        let neutral_fit = fit(&first, neutral);
        let mut best = (followed(&first), first);
        // Each shoulder turned half round: the first joint by ±π, the second negated, the third
        // by ±π (either way round) — the same upper arm for a shoulder whose first and third
        // axes meet in line, and a start on its other way of hanging for others.
        let limits = self.anatomy.robot().joint_limits();
        let pi = std::f64::consts::PI;
        for arm in self.anatomy.arms() {
            let joints = arm.chain.robot_indices();
            if arm.elbow < 3 || (0..3).any(|k| arm.chain.is_prismatic(k)) {
                continue;
            }
            let (a, b, c) = (joints[0], joints[1], joints[2]);
            for (turn_a, turn_c) in [(pi, pi), (pi, -pi), (-pi, pi), (-pi, -pi)] {
                let mut q = best.1.clone();
                (q[a], q[b], q[c]) = (q[a] + turn_a, -q[b], q[c] + turn_c);
                let within = [a, b, c].iter().all(|&i| {
                    let (lo, hi) = limits[i];
                    lo > hi || (lo <= q[i] && q[i] <= hi)
                });
                if !within {
                    continue;
                }
                frame.converge(&mut q, &frame.tasks(neutral));
                let hangs = fit(&q, neutral) <= neutral_fit * 1.25 + START_TIE;
                if hangs {
                    let probe_fit = followed(&q);
                    if probe_fit < best.0 * (1.0 - START_GAIN) {
                        best = (probe_fit, q);
                    }
                }
            }
        }
        best.1
    }

    /// The frame solver over this robot.
    fn frame(&self) -> FrameSolver<'_> {
        FrameSolver {
            anatomy: &self.anatomy,
            gauge: &self.gauge,
            model: &self.model,
            active: &self.active,
            neutral: &self.neutral,
            elbows: &self.elbows,
            options: &self.options,
        }
    }

    /// The posture (whole configuration, into `q`) at the end of `path` (the frame's path from
    /// the person's neutral to its pose, [`super::PersonGauge::path`]), followed from the
    /// posture of the person's neutral; the Gauss–Newton steps taken and how many had an
    /// active limit.
    pub(in crate::retarget) fn solve(
        &self,
        path: &[[ArmPosture; 2]],
        q: &mut Vec<f64>,
    ) -> (usize, usize) {
        let Some(target) = path.last() else {
            return (0, 0);
        };
        if self.follows {
            q.clone_from(&self.start);
            self.frame().follow(q, path)
        } else {
            q.clone_from(&self.hold);
            self.frame().solve_from_starts(q, target, &self.seeds)
        }
    }

    /// Whether frames are followed along their paths (else solved from the fixed starts).
    pub(in crate::retarget) fn follows(&self) -> bool {
        self.follows
    }

    /// Decides, from the paths of fixed probe poses (the person's key postures), whether
    /// this robot follows each frame's path or solves it from the fixed starts: it follows
    /// unless following fits the probes worse by more than [`FOLLOW_TOLERANCE`] in total (a
    /// robot whose limits stop the posture carried from the neutral short of the pose, where
    /// another start reaches it). A property of the robot and the probes, never of the data:
    /// the posture stays a function of the pose.
    fn choose(&mut self, probes: &[Vec<[ArmPosture; 2]>]) {
        let frame = self.frame();
        let (mut followed, mut started) = (0.0, 0.0);
        for path in probes {
            let Some(target) = path.last() else { continue };
            let tasks = frame.tasks(target);
            let mut q = self.start.clone();
            frame.follow(&mut q, path);
            followed += frame.cost(&q, &tasks);
            let mut q = self.hold.clone();
            frame.solve_from_starts(&mut q, target, &self.seeds);
            started += frame.cost(&q, &tasks);
        }
        self.follows = followed <= FOLLOW_TOLERANCE * started + 1e-9;
    }

    /// The arm joints' configuration indices, in the order of the anatomy's arm joint names.
    pub(in crate::retarget) fn arm_indices(&self) -> &[usize] {
        &self.q_index
    }

    /// The whole configuration at hold.
    pub(in crate::retarget) fn hold(&self) -> &[f64] {
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
    /// Per arm, the elbow's place among the active joints and the side it bends to.
    elbows: &'a [ElbowSide],
    options: &'a WholeArmOptions,
}

/// How many of the fixed starts (the key postures) the person's neutral is also solved from
/// besides the robot's neutral posture: those whose objective is lowest at the start.
const SEED_STARTS: usize = 2;

/// Gauss–Newton steps at most per point of a frame's path before its last (the path only
/// chooses which of the postures that fit the pose the last point converges to).
const PATH_ITERATIONS: usize = 6;

/// How much worse (the tasks' total squared error, radians² and reach², the posture pull left
/// out) another posture may fit the person's neutral than the best one and still be a way the
/// arm hangs ([`ArmSolver::hanging_way`]): a quarter of the best one's error, and this (about
/// 2° in all).
const START_TIE: f64 = 1e-3;

/// How much better (a share of the total) the key postures must be followed from another way
/// of hanging before the paths start from it ([`ArmSolver::hanging_way`]).
const START_GAIN: f64 = 0.1;

/// How much worse (total objective over the probe poses) following may fit than the fixed
/// starts before a robot solves from the starts instead ([`ArmSolver::choose`]).
const FOLLOW_TOLERANCE: f64 = 1.5;

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
        seeds: &[Vec<f64>],
    ) -> (Vec<UnitQuaternion<f64>>, Vec<UnitQuaternion<f64>>) {
        let g = self.gauge;
        let r = g.body_to_root;
        let mut tasks = Vec::new();
        for (s, t) in g.followed(reference).enumerate() {
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
        // From the neutral posture and from every fixed start, the best fit kept (the first on
        // a tie within 0.1 %): from the neutral alone an elbow can stop at its limit, the
        // directions 30° off, and every orientation measured from there would pull against
        // the directions (PAL's single-arm TIAGo).
        let mut q = hold.to_vec();
        let mut best = f64::INFINITY;
        for start in std::iter::once(hold).chain(seeds.iter().map(Vec::as_slice)) {
            let mut x = start.to_vec();
            self.solve(&mut x, &tasks, false, self.options.max_iterations);
            let cost = self.cost(&x, &tasks);
            if cost < best * (1.0 - 1e-3) - 1e-9 {
                (q, best) = (x, cost);
            }
        }
        let frames = RobotFrames::new(self.anatomy.robot(), &g.ancestry, &q);
        // Where the limits keep the robot from the person's neutral directions, each segment's
        // orientation is turned by what its bone still misses: the reference is the robot's
        // segments as they would sit along the person's bones.
        let got = g.measure(self.anatomy, &q);
        let align = |from: &Vector3<f64>, to: &Vector3<f64>| {
            UnitQuaternion::rotation_between(&(r * from), &(r * to))
                .unwrap_or_else(UnitQuaternion::identity)
        };
        g.followed(reference)
            .zip(&got)
            .enumerate()
            .map(|(s, (want, got))| {
                (
                    align(&got.forearm, &want.forearm) * frames.link(g.hand_links[s]).rotation,
                    align(&got.upper_arm, &want.upper_arm) * frames.link(g.upper_links[s]).rotation,
                )
            })
            .unzip()
    }

    /// The tasks of a frame's target posture.
    fn tasks(&self, target: &[ArmPosture; 2]) -> Vec<(Task, f64)> {
        let g = self.gauge;
        let w = &self.options.weights;
        let mut tasks = Vec::new();
        for (s, t) in g.followed(target).enumerate() {
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

    /// The posture at the end of `path`, followed from `q` (the posture of the path's start):
    /// each point but the last a few steps, the last to convergence. A function of the frame's
    /// pose alone (its path is), and continuous in it where the path meets no fold of the
    /// robot's limits: a posture that fits the pose in two ways (a shoulder turned half round)
    /// is the one the person's motion out of their neutral leads to, not whichever fits a hair
    /// better. Written to `q`; returns the steps taken and how many had an active limit.
    fn follow(&self, q: &mut [f64], path: &[[ArmPosture; 2]]) -> (usize, usize) {
        let Some((last, before)) = path.split_last() else {
            return (0, 0);
        };
        let (mut steps, mut constrained) = (0, 0);
        for target in before {
            let (s, c) = self.solve(q, &self.tasks(target), false, PATH_ITERATIONS);
            steps += s;
            constrained += c;
        }
        let (s, c) = self.converge(q, &self.tasks(last));
        (steps + s, constrained + c)
    }

    /// The posture for `target` converged from the robot's neutral (`q` on entry) and from the
    /// [`SEED_STARTS`] fixed starts whose objective is lowest at the start, the lowest objective
    /// kept (the first start's on a tie within 0.1 %), into `q`; the steps taken and how many
    /// had an active limit.
    fn solve_from_starts(
        &self,
        q: &mut Vec<f64>,
        target: &[ArmPosture; 2],
        seeds: &[Vec<f64>],
    ) -> (usize, usize) {
        let tasks = self.tasks(target);
        let (mut steps, mut constrained) = (0, 0);
        let mut starts: Vec<(f64, &Vec<f64>)> =
            seeds.iter().map(|s| (self.cost(s, &tasks), s)).collect();
        starts.sort_by(|a, b| a.0.total_cmp(&b.0));
        let mut best: Option<(Vec<f64>, f64)> = None;
        let first = q.clone();
        for start in std::iter::once(&first).chain(starts.iter().take(SEED_STARTS).map(|s| s.1)) {
            let mut x = start.clone();
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
        let iterations = self.options.max_iterations;
        let (mut steps, mut constrained) = self.solve(q, tasks, false, iterations);
        if self.options.self_collision {
            let frames = RobotFrames::new(self.anatomy.robot(), &self.gauge.ancestry, q);
            let margin = self.options.margin_m;
            let within = |p: &Proximity| p.distance < self.model.margin_of(p.pair, margin);
            if self.model.proximities(&frames, margin).iter().any(within) {
                let (s, c) = self.solve(q, tasks, true, iterations);
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

    /// Converges `q` (the whole configuration) onto the tasks in at most `iterations` steps,
    /// with the self-collision limit when `collisions`; returns the steps taken and how many
    /// had an active limit.
    fn solve(
        &self,
        q: &mut [f64],
        tasks: &[(Task, f64)],
        collisions: bool,
        iterations: usize,
    ) -> (usize, usize) {
        let robot = self.anatomy.robot();
        let (mut steps, mut constrained) = (0, 0);
        // A trust region: a step is taken only if it lowers the objective (or keeps a collision
        // limit), else the region shrinks (plain Gauss–Newton oscillates where the tasks
        // conflict).
        let mut radius = self.options.step_bound;
        let mut cost = self.cost(q, tasks);
        let mut trial = q.to_vec();
        for _ in 0..iterations {
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
