//! The older retargeting modes ([`super::Match::Hands`], `HandsElbows`, `Poses`): each robot's
//! hands placed on the person's (relative to the shoulder, in units of reach) by damped least
//! squares, each frame continuing the last, and the tally of how the targets were met.

use super::*;

/// A robot prepared for retargeting.
pub(super) struct RobotArms<'a> {
    name: String,
    anatomy: &'a Anatomy,
    frames: ArmFrames,
    /// The middle of every joint's range per arm: where the warm IK's null space pulls, away
    /// from the limits a continuing motion would otherwise get stuck at.
    rest: Vec<Vec<f64>>,
    /// Every key posture per arm (the generator's key poses at this robot's reach): starts
    /// when the arm must change configuration.
    key_postures: Vec<Vec<Vec<f64>>>,
    /// Velocity limit per arm joint, rad/s (0: none).
    velocity: Vec<Vec<f64>>,
}

impl<'a> RobotArms<'a> {
    pub(super) fn new(name: &str, anatomy: &'a Anatomy) -> Self {
        let frames = ArmFrames::of(anatomy);
        let all_velocity = anatomy.robot().velocity_limits();
        let arms = anatomy.arms();
        let velocity = arms
            .iter()
            .map(|a| {
                a.chain
                    .robot_indices()
                    .iter()
                    .map(|&i| all_velocity[i])
                    .collect()
            })
            .collect();
        let rest = arms
            .iter()
            .map(|a| a.chain.mid_range(&vec![0.0; a.chain.dof()]))
            .collect();
        let mut robot = Self {
            name: name.to_string(),
            anatomy,
            frames,
            rest,
            key_postures: Vec::new(),
            velocity,
        };
        robot.key_postures = (0..arms.len())
            .map(|s| robot.solve_key_postures(s))
            .collect();
        robot
    }

    /// The neutral posture of arm `s`.
    fn neutral(&self, s: usize) -> &[f64] {
        &self.anatomy.arms()[s].neutral
    }

    /// Arm `s`'s configuration for each of the generator's key poses ([`key_postures`]).
    fn solve_key_postures(&self, s: usize) -> Vec<Vec<f64>> {
        key_postures(self.anatomy, &self.frames, s)
    }

    /// A point of arm `s` given relative to the shoulder in units of reach (body frame), in
    /// the chain's base frame.
    pub(super) fn place(&self, s: usize, rel: &Vector3<f64>) -> Vector3<f64> {
        let f = &self.frames;
        f.shoulders[s] + f.reach[s] * (f.body_in_base[s] * rel)
    }

    /// The IK target of arm `s` for the human's relative target `r`.
    fn target(&self, s: usize, r: &Relative, mode: Match) -> IkTarget {
        let hand = self.place(s, &r.hand);
        match mode {
            Match::Hands | Match::Arms => IkTarget::Position(hand),
            Match::HandsAndElbows => IkTarget::PositionAndJoint {
                tip: hand,
                joint: self.frames.elbows[s],
                point: self.place(s, &r.elbow),
            },
            Match::Poses => {
                let f = &self.frames;
                let turn = f.body_in_base[s] * r.turn * f.body_in_base[s].inverse();
                IkTarget::Pose(Isometry3::from_parts(
                    hand.into(),
                    turn * f.neutral_hands[s],
                ))
            }
        }
    }
}

/// One robot, every frame; `targets` are the person's arms (left, right) per frame, each of
/// the robot's arms following the person's arm of its side.
pub(super) fn retarget_robot(
    r: &RobotArms,
    targets: &[[Relative; 2]],
    times_ns: &[i64],
    options: &RetargetOptions,
) -> Retargeted {
    let n = targets.len();
    let anatomy = r.anatomy;
    // Every joint of every frame: the arms' as solved, the rest at their hold values.
    let hold = anatomy.hold_configuration();
    let mut full = DMatrix::<f64>::from_fn(n, hold.len(), |_, i| hold[i]);
    let mut runs = Vec::with_capacity(2);
    for (s, arm) in anatomy.arms().iter().enumerate() {
        let run = ArmRun {
            chain: &arm.chain,
            velocity: &r.velocity[s],
            rest: &r.rest[s],
            key_postures: &r.key_postures[s],
            neutral: r.neutral(s),
            targets: targets
                .iter()
                .map(|t| r.target(s, &t[arm.side.index()], options.mode))
                .collect(),
            times_ns,
            velocity_limits: options.velocity_limits,
            tolerance: options.reach_tolerance_m,
        };
        let frames = run.run(options.redundancy);
        for f in 0..n {
            for (k, &i) in arm.chain.robot_indices().iter().enumerate() {
                full[(f, i)] = frames.q[f][k];
            }
        }
        runs.push((run, frames));
    }
    let mut tally = Tally::default();
    for (s, (run, frames)) in runs.iter().enumerate() {
        let chain = &anatomy.arms()[s].chain;
        for f in 0..n {
            // Judged on the command as written, not on the arm's own solution.
            let row: Vec<f64> = full.row(f).iter().copied().collect();
            let q = chain.extract(&row).unwrap_or_default();
            let miss = run.miss(f, &q);
            tally.add(frames.outcome[f], miss, options.reach_tolerance_m);
            match run.targets[f] {
                IkTarget::PositionAndJoint { joint, point, .. } => {
                    tally
                        .elbow_misses
                        .push((chain.joint_origins(&q)[joint] - point).norm());
                }
                IkTarget::Pose(t) => {
                    let tip = chain.forward(&q);
                    tally
                        .orientation_misses
                        .push((t.rotation * tip.rotation.inverse()).angle());
                }
                IkTarget::Position(_) => {}
            }
        }
    }
    let command: Vec<usize> = anatomy
        .command_joint_names()
        .iter()
        .filter_map(|name| anatomy.robot().joint_index(name))
        .collect();
    let positions = DMatrix::from_fn(n, command.len(), |f, c| full[(f, command[c])]);
    Retargeted {
        body: BodyData {
            name: r.name.clone(),
            topic: format!("/{}/joint_command", r.name),
            joint_names: anatomy.command_joint_names(),
            positions,
        },
        report: tally.report(&r.name, options.mode, anatomy.arms().len() * n),
    }
}

/// The counts of a reach report as targets are judged.
#[derive(Default)]
pub(super) struct Tally {
    reached: Vec<f64>,
    counts: [usize; 3],
    worst: [f64; 3],
    elbow_misses: Vec<f64>,
    orientation_misses: Vec<f64>,
}

impl Tally {
    /// One hand target: reached only when the hand is within `tolerance`, whatever the
    /// arm's run said; a miss the run called reached counts as out of reach.
    pub(super) fn add(&mut self, outcome: Outcome, miss: f64, tolerance: f64) {
        let kind = match outcome {
            _ if miss <= tolerance => {
                self.reached.push(miss);
                return;
            }
            Outcome::SpeedLimited => 0,
            Outcome::OtherConfiguration => 1,
            Outcome::Unreachable | Outcome::Reached => 2,
        };
        self.counts[kind] += 1;
        self.worst[kind] = self.worst[kind].max(miss);
    }

    pub(super) fn report(mut self, robot: &str, mode: Match, targets: usize) -> ReachReport {
        ReachReport {
            robot: robot.to_string(),
            mode,
            targets,
            reached: self.reached.len(),
            worst_m: (!self.reached.is_empty())
                .then(|| self.reached.iter().copied().fold(0.0, f64::max)),
            median_m: (!self.reached.is_empty()).then(|| median(&mut self.reached)),
            velocity_limited: self.counts[0],
            velocity_limited_worst_m: self.worst[0],
            other_configuration: self.counts[1],
            other_configuration_worst_m: self.worst[1],
            unreachable: self.counts[2],
            unreachable_worst_m: self.worst[2],
            elbow_median_m: (mode == Match::HandsAndElbows).then(|| median(&mut self.elbow_misses)),
            orientation_median_rad: (mode == Match::Poses)
                .then(|| median(&mut self.orientation_misses)),
            compromised: 0,
            posture: None,
        }
    }
}
