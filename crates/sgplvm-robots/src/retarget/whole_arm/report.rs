//! What whole-arm retargeting tells of a robot's run: the report (directions, orientations,
//! hands, the limits that held — velocity, position, self-collision — and for how many frames)
//! and the tally it is gathered in.

use serde::{Deserialize, Serialize};

use super::{ArmPosture, PostureGauge, WholeArmOptions};
use crate::anatomy::Anatomy;
use crate::kinematics::collision::CollisionModel;
use crate::kinematics::frames::RobotFrames;
use crate::series::median;

/// How one robot followed, over every frame.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct PostureReport {
    /// Frames retargeted.
    #[serde(default)]
    pub frames: usize,
    /// Upper arm direction error, degrees: median and 90th percentile.
    pub upper_arm_deg: [f64; 2],
    /// Forearm direction error, degrees: median and 90th percentile.
    pub forearm_deg: [f64; 2],
    /// Hand position error as a fraction of reach: median and 90th percentile.
    pub hand_of_reach: [f64; 2],
    /// The hand's orientation error (from the person's turn on the reference posture),
    /// degrees: median and 90th percentile.
    #[serde(default)]
    pub hand_orientation_deg: [f64; 2],
    /// The upper arm's orientation error (its twist included), degrees: median and 90th
    /// percentile.
    #[serde(default)]
    pub upper_arm_orientation_deg: [f64; 2],
    /// Share of hand targets within 5 % of the reach.
    pub hands_within_5pct: f64,
    /// Frames whose command the velocity limits held back.
    pub velocity_limited_frames: usize,
    /// Frames whose command the self-collision limit moved.
    pub collision_limited_frames: usize,
    /// Frames whose safe command could not be found from the pose alone (the asked posture too
    /// deep in a shape) and was stepped from the command before: the only frames whose command
    /// depends on the path when velocity limits are off.
    #[serde(default)]
    pub stepped_from_before_frames: usize,
    /// Whether each frame was solved from the fixed starts (the best fit kept) rather than
    /// followed along its path from the person's neutral: for a robot whose limits stop the
    /// followed posture short of the person's key postures (the posture is then a function of
    /// the pose, but may change branch between near poses).
    #[serde(default)]
    pub from_fixed_starts: bool,
    /// Which velocity limits held the commands: per joint that was held at its limit (the
    /// command moved by the limit's whole step and not as far as asked), the joint, its limit
    /// (rad/s or m/s) and the frames; most frames first.
    #[serde(default)]
    pub velocity_limited_joints: Vec<LimitHeld>,
    /// Which position limits the commands sat on: per joint and bound that held the command
    /// (within [`AT_BOUND_RAD`]) in some frame, the joint, the bound and the frames; most frames
    /// first. Where a robot's range is narrower than a person's (an arm that cannot be raised
    /// above its shoulder), this says which joint and how often: the directions' error there is
    /// the robot's reach, not the retargeting.
    #[serde(default)]
    pub position_limited_joints: Vec<BoundHeld>,
    /// Which pairs of links the self-collision limit kept apart: per pair of links (nearer than
    /// the margin and a millimetre before the command's step), the frames; most frames first.
    #[serde(default)]
    pub collision_limited_pairs: Vec<PairHeld>,
    /// Frames whose asked posture jumped: a joint turned more than [`JUMP_RAD`] from the frame
    /// before (under half a second earlier) while no joint of the person moved
    /// [`STILL_RAD`] — the posture changing branch (where two of the robot's joint axes line
    /// up, or at a fold of its limits; docs/robots.md). A live robot takes such a jump within its velocity limits; a learned
    /// model sees it as noise.
    #[serde(default)]
    pub jump_frames: usize,
    /// Per joint that jumped, the frames; most frames first.
    #[serde(default)]
    pub jumping_joints: Vec<JointJumps>,
    /// Frames in self-collision as sent (shapes overlapping): 0 is the goal.
    pub colliding_frames: usize,
    /// The closest two shapes that can meet came over all frames as sent, metres; `None` when
    /// no pair ever came near enough to be measured (their bounding spheres stayed apart).
    pub closest_m: Option<f64>,
    /// The margin kept, metres.
    pub margin_m: f64,
    /// Pairs of shapes that can meet.
    pub pairs: usize,
    /// Pairs of shapes left unchecked because the joint limits keep them apart (proven when the
    /// model was made: [`crate::kinematics::collision::CollisionModel::kept_apart_by_limits`]).
    pub pairs_kept_apart: usize,
    /// What could not be checked (collision meshes not found …).
    pub unchecked: Vec<String>,
    /// Gauss–Newton steps per frame, mean.
    pub steps_per_frame: f64,
    /// Share of steps in which a limit was active (the QP solver ran).
    pub constrained_steps: f64,
    /// Seconds the robot's start took before the first frame: its collision model (meshes'
    /// hulls and convex parts, the proofs that limits keep pairs apart) and its solver. A fact
    /// of the run, not of the data: never written, so that the same input gives the same file.
    #[serde(skip)]
    pub start_seconds: f64,
    /// Seconds the frames took after the start: frames over this is the rate a live stream
    /// is followed at (not written either).
    #[serde(skip)]
    pub frames_seconds: f64,
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

/// A joint that sat on one of its position limits, and in how many frames.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BoundHeld {
    /// The joint's URDF name.
    pub joint: String,
    /// Whether the bound is the upper one (else the lower).
    pub upper: bool,
    /// The bound, rad (m for a prismatic joint).
    pub bound: f64,
    /// Frames whose command sat on it.
    pub frames: usize,
}

/// How near a command's joint must be to a position limit to sit on it, rad (or m).
pub const AT_BOUND_RAD: f64 = 1e-4;

/// A joint whose asked posture jumped ([`PostureReport::jump_frames`]), and in how many frames.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct JointJumps {
    /// The joint's URDF name.
    pub joint: String,
    /// Frames in which it jumped.
    pub frames: usize,
}

/// A jump of a robot joint between consecutive frames, radians ([`PostureReport::jump_frames`]).
pub const JUMP_RAD: f64 = 1.0;

/// The most any joint of the person may move between the two frames of a jump, radians.
pub const STILL_RAD: f64 = 0.3;

/// Frames further apart than this (seconds) are no consecutive frames of one motion.
const CONSECUTIVE_S: f64 = 0.5;

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

/// What the frames showed, gathered.
#[derive(Default)]
pub(super) struct Tally {
    /// Whether frames were solved from the fixed starts ([`PostureReport::from_fixed_starts`]).
    pub(super) from_fixed_starts: bool,
    pub(super) upper: Vec<f64>,
    pub(super) forearm: Vec<f64>,
    pub(super) hand: Vec<f64>,
    pub(super) hand_turn: Vec<f64>,
    pub(super) upper_turn: Vec<f64>,
    pub(super) steps: usize,
    pub(super) constrained: usize,
    pub(super) velocity_limited: usize,
    pub(super) collision_limited: usize,
    pub(super) from_before: usize,
    pub(super) colliding: usize,
    pub(super) closest: Option<f64>,
    /// Per joint (configuration index): frames its velocity limit held, and the limit.
    pub(super) joints_held: std::collections::BTreeMap<usize, (usize, f64)>,
    /// Per joint (configuration index) and bound (upper or not): frames the command sat on it.
    pub(super) bounds_held: std::collections::BTreeMap<(usize, bool), usize>,
    /// Per pair of links: frames the self-collision limit kept them apart, and the closest.
    pub(super) pairs_held: std::collections::BTreeMap<(String, String), (usize, f64)>,
    /// Frames whose asked posture jumped, and per joint (configuration index) the frames.
    pub(super) jumps: usize,
    pub(super) joints_jumped: std::collections::BTreeMap<usize, usize>,
}

impl Tally {
    /// Which limits held one frame's command: the joints that moved by their velocity limit's
    /// whole step over `dt` from the command `before` and fell short of what was asked, and
    /// the pairs of links the safety step found near; whether any joint was held by its
    /// velocity limit.
    pub(super) fn limits_held(
        &mut self,
        (q_index, velocity): (&[usize], &[f64]),
        (asked, sent): (&[f64], &[f64]),
        before: Option<(Vec<f64>, f64)>,
        near: &[(String, String, f64)],
    ) -> bool {
        let mut by_velocity = false;
        if let Some((last, dt)) = before {
            for (k, (&i, &limit)) in q_index.iter().zip(velocity).enumerate() {
                let step = limit * dt;
                let short = (asked[k] - sent[k]).abs() > 1e-9;
                if short && (sent[k] - last[k]).abs() >= step - 1e-9 {
                    self.joints_held.entry(i).or_insert((0, limit)).0 += 1;
                    by_velocity = true;
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
        by_velocity
    }

    /// The position limits one frame's command `sent` (configuration indices `q_index`) sits
    /// on; `limits` are every joint's (lower, upper).
    pub(super) fn bounds_held(&mut self, limits: &[(f64, f64)], q_index: &[usize], sent: &[f64]) {
        for (&i, &q) in q_index.iter().zip(sent) {
            let (lo, hi) = limits[i];
            for (upper, bound) in [(false, lo), (true, hi)] {
                if bound.is_finite() && (q - bound).abs() <= AT_BOUND_RAD {
                    *self.bounds_held.entry((i, upper)).or_default() += 1;
                }
            }
        }
    }

    /// Whether the asked posture jumped between two consecutive frames ([`JUMP_RAD`]): `before`
    /// and `now` the person's joints, the arm joints asked (configuration indices `q_index`)
    /// and the frame's time, seconds.
    pub(super) fn jumps(
        &mut self,
        q_index: &[usize],
        before: (&[f64], &[f64], f64),
        now: (&[f64], &[f64], f64),
    ) {
        let moved = |a: &[f64], b: &[f64]| {
            a.iter()
                .zip(b)
                .map(|(x, y)| (x - y).abs())
                .fold(0.0, f64::max)
        };
        if now.2 - before.2 > CONSECUTIVE_S || moved(before.0, now.0) >= STILL_RAD {
            return;
        }
        let mut jumped = false;
        for (k, (a, b)) in before.1.iter().zip(now.1).enumerate() {
            if (a - b).abs() > JUMP_RAD {
                jumped = true;
                *self.joints_jumped.entry(q_index[k]).or_default() += 1;
            }
        }
        self.jumps += usize::from(jumped);
    }

    /// One frame as sent, against its target.
    pub(super) fn judge(
        &mut self,
        anatomy: &Anatomy,
        gauge: &PostureGauge,
        model: &CollisionModel,
        q: &[f64],
        target: &[ArmPosture; 2],
        collisions: bool,
    ) {
        let got = gauge.measure(anatomy, q);
        for (g, t) in got.iter().zip(gauge.followed(target)) {
            self.upper
                .push(g.upper_arm.angle(&t.upper_arm).to_degrees());
            self.forearm.push(g.forearm.angle(&t.forearm).to_degrees());
            self.hand.push((g.hand - t.hand).norm());
            self.hand_turn
                .push((g.turn * t.turn.inverse()).angle().to_degrees());
            self.upper_turn
                .push((g.upper_turn * t.upper_turn.inverse()).angle().to_degrees());
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

    pub(super) fn report(
        self,
        options: &WholeArmOptions,
        model: &CollisionModel,
        (robot, frames): (&crate::urdf::Robot, usize),
    ) -> PostureReport {
        let names = robot.joint_names();
        let mut velocity_limited_joints: Vec<LimitHeld> = self
            .joints_held
            .iter()
            .map(|(&i, &(n, limit))| LimitHeld {
                joint: names[i].clone(),
                limit,
                prismatic: robot.joints[robot.movable[i]].kind == crate::urdf::JointKind::Prismatic,
                frames: n,
            })
            .collect();
        velocity_limited_joints.sort_by_key(|j| std::cmp::Reverse(j.frames));
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
        collision_limited_pairs.sort_by_key(|p| std::cmp::Reverse(p.frames));
        let bounds = robot.joint_limits();
        let mut position_limited_joints: Vec<BoundHeld> = self
            .bounds_held
            .iter()
            .map(|(&(i, upper), &n)| BoundHeld {
                joint: names[i].clone(),
                upper,
                bound: if upper { bounds[i].1 } else { bounds[i].0 },
                frames: n,
            })
            .collect();
        position_limited_joints.sort_by_key(|j| std::cmp::Reverse(j.frames));
        let mut jumping_joints: Vec<JointJumps> = self
            .joints_jumped
            .iter()
            .map(|(&i, &n)| JointJumps {
                joint: names[i].clone(),
                frames: n,
            })
            .collect();
        jumping_joints.sort_by_key(|j| std::cmp::Reverse(j.frames));
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
            frames,
            upper_arm_deg: quantiles(&self.upper),
            forearm_deg: quantiles(&self.forearm),
            hand_of_reach: quantiles(&self.hand),
            hand_orientation_deg: quantiles(&self.hand_turn),
            upper_arm_orientation_deg: quantiles(&self.upper_turn),
            hands_within_5pct: self.hand.iter().filter(|&&h| h <= 0.05).count() as f64
                / self.hand.len().max(1) as f64,
            velocity_limited_frames: self.velocity_limited,
            collision_limited_frames: self.collision_limited,
            stepped_from_before_frames: self.from_before,
            from_fixed_starts: self.from_fixed_starts,
            velocity_limited_joints,
            position_limited_joints,
            collision_limited_pairs,
            jump_frames: self.jumps,
            jumping_joints,
            colliding_frames: self.colliding,
            closest_m: self.closest,
            margin_m: options.margin_m,
            pairs: model.pairs().len(),
            pairs_kept_apart: model.kept_apart_by_limits(),
            unchecked: model.unchecked().to_vec(),
            steps_per_frame: self.steps as f64 / frames.max(1) as f64,
            constrained_steps: self.constrained as f64 / self.steps.max(1) as f64,
            start_seconds: 0.0,
            frames_seconds: 0.0,
        }
    }
}
