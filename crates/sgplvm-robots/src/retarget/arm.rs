//! One arm of one robot through every frame: warm-started IK within the velocity limits, and,
//! where the arm's configuration cannot follow, the choice between holding on and changing
//! configuration, judged by looking ahead (retargeting is offline: the future frames are
//! known).

use nalgebra::Vector3;

use crate::{Chain, IkOptions, IkTarget};

/// How the arm's redundancy (seven joints for a hand's three coordinates) is resolved.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
pub enum Redundancy {
    /// Each frame's configuration continues the previous one (warm-started IK, pulled towards
    /// the middle of the joints' ranges), changing configuration only where looking ahead says
    /// it pays: the hands follow closely, but the same hand position can come with different
    /// postures depending on the path taken to it.
    #[default]
    Continuous,
    /// Each frame's configuration is the IK solution from the neutral posture, pulled towards
    /// it: a function of the hand targets alone, as the generator's key postures are. The arm
    /// moves to it as fast as its velocity limits allow; where that solution moves faster (or
    /// jumps between nearby targets) the hand lags while the arm follows.
    Canonical,
}

/// How one hand target came out.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Outcome {
    /// Within the tolerance.
    Reached,
    /// Within reach from where the arm was, but its joints' speed held the hand back.
    SpeedLimited,
    /// Within reach only from another configuration of the arm (held on, or on the way there).
    OtherConfiguration,
    /// Beyond reach within the joint limits.
    Unreachable,
}

/// Frames of one arm: configuration, hand miss and outcome per frame.
pub(super) struct ArmFrames {
    pub q: Vec<Vec<f64>>,
    pub miss: Vec<f64>,
    pub outcome: Vec<Outcome>,
}

/// Everything one arm's run needs.
pub(super) struct ArmRun<'a> {
    pub chain: &'a Chain,
    /// Velocity limit per joint, rad/s (0: none).
    pub velocity: &'a [f64],
    /// Where the null space pulls: the middle of each joint's range.
    pub rest: &'a [f64],
    /// Natural configurations of the arm: starts of the search for another configuration.
    pub key_postures: &'a [Vec<f64>],
    /// The first frame's start.
    pub neutral: &'a [f64],
    /// The IK target per frame.
    pub targets: Vec<IkTarget>,
    /// Frame times, ns.
    pub times_ns: &'a [i64],
    /// Whether joints keep their velocity limits between frames.
    pub velocity_limits: bool,
    /// Hand distance counted as reached, metres.
    pub tolerance: f64,
}

/// How far ahead a choice to change configuration looks, seconds.
const LOOK_AHEAD_S: f64 = 2.0;
/// After choosing to hold on, the frames before that choice is made again.
const HOLD_FRAMES: usize = 8;

impl ArmRun<'_> {
    /// Warm IK settings: a few iterations from the previous frame, a pull to mid-range.
    fn warm(&self, bounds: Option<Vec<(f64, f64)>>) -> IkOptions {
        IkOptions {
            max_iters: 50,
            tolerance: 1e-5,
            restarts: 0,
            posture_gain: 0.5,
            rest: Some(self.rest.to_vec()),
            posture_iters: 3,
            bounds,
            ..IkOptions::default()
        }
    }

    /// The canonical configuration for frame `f`: IK from the neutral posture, pulled to it
    /// in the null space, so a function of the target alone.
    fn canonical(&self, f: usize) -> Vec<f64> {
        let canon = IkOptions {
            max_iters: 200,
            tolerance: 1e-5,
            restarts: 8,
            posture_gain: 0.5,
            rest: Some(self.neutral.to_vec()),
            posture_iters: 20,
            ..IkOptions::default()
        };
        self.chain
            .inverse_kinematics(&self.targets[f], self.neutral, &canon)
            .q
    }

    /// Where the hand should be in frame `f`.
    fn hand_goal(&self, f: usize) -> Vector3<f64> {
        match self.targets[f] {
            IkTarget::Position(p) | IkTarget::PositionAndJoint { tip: p, .. } => p,
            IkTarget::Pose(t) => t.translation.vector,
        }
    }

    /// The hand's distance to its goal of frame `f` at `q`.
    pub fn miss(&self, f: usize, q: &[f64]) -> f64 {
        (self.chain.forward(q).translation.vector - self.hand_goal(f)).norm()
    }

    /// Per-joint bounds for frame `f` coming from `prev` at the velocity limits.
    fn bounds(&self, f: usize, prev: &[f64]) -> Option<Vec<(f64, f64)>> {
        if !self.velocity_limits || f == 0 {
            return None;
        }
        let dt = (self.times_ns[f] - self.times_ns[f - 1]) as f64 * 1e-9;
        Some(
            prev.iter()
                .zip(self.velocity)
                .map(|(&q, &v)| {
                    if v > 0.0 {
                        (q - v * dt, q + v * dt)
                    } else {
                        (f64::NEG_INFINITY, f64::INFINITY)
                    }
                })
                .collect(),
        )
    }

    /// The warm IK step of frame `f` from `prev`.
    fn warm_step(&self, f: usize, prev: &[f64]) -> Vec<f64> {
        let opts = self.warm(self.bounds(f, prev));
        self.chain
            .inverse_kinematics(&self.targets[f], prev, &opts)
            .q
    }

    /// One step of frame `f` from `prev` along the straight line to `goal`, as far as the
    /// velocity limits allow.
    fn toward(&self, f: usize, prev: &[f64], goal: &[f64]) -> Vec<f64> {
        let factor = match self.bounds(f, prev) {
            Some(b) => goal
                .iter()
                .zip(prev)
                .zip(&b)
                .map(|((&g, &from), &(lo, hi))| {
                    let step = g - from;
                    let room = if step > 0.0 { hi - from } else { from - lo };
                    if step.abs() > room {
                        room / step.abs()
                    } else {
                        1.0
                    }
                })
                .fold(1.0_f64, f64::min),
            None => 1.0,
        };
        goal.iter()
            .zip(prev)
            .map(|(&g, &from)| from + factor * (g - from))
            .collect()
    }

    /// Seconds the arm needs from `from` to `to` at its velocity limits.
    fn time_between(&self, from: &[f64], to: &[f64]) -> f64 {
        from.iter()
            .zip(to)
            .zip(self.velocity)
            .map(|((a, b), &v)| if v > 0.0 { (a - b).abs() / v } else { 0.0 })
            .fold(0.0, f64::max)
    }

    /// A configuration reaching frame `f`'s target, the one `prev` gets to soonest: from the
    /// key postures, else from random starts; `None` if nothing reaches it.
    fn other_configuration(&self, f: usize, prev: &[f64]) -> Option<Vec<f64>> {
        let seeded = IkOptions {
            max_iters: 200,
            tolerance: 1e-5,
            restarts: 0,
            ..IkOptions::default()
        };
        let best = self
            .key_postures
            .iter()
            .map(|seed| {
                self.chain
                    .inverse_kinematics(&self.targets[f], seed, &seeded)
                    .q
            })
            .filter(|q| self.miss(f, q) <= self.tolerance)
            .min_by(|a, b| {
                self.time_between(prev, a)
                    .total_cmp(&self.time_between(prev, b))
            });
        best.or_else(|| {
            let search = IkOptions {
                restarts: 24,
                posture_gain: 0.5,
                rest: Some(self.neutral.to_vec()),
                ..seeded
            };
            Some(
                self.chain
                    .inverse_kinematics(&self.targets[f], prev, &search)
                    .q,
            )
            .filter(|q| self.miss(f, q) <= self.tolerance)
        })
    }

    /// The summed hand misses over the frames from `f` on (up to the look-ahead) of holding on
    /// (`goal` = `None`: warm steps only) or of changing to `goal` first.
    fn look_ahead(&self, f: usize, prev: &[f64], goal: Option<&[f64]>) -> f64 {
        let n = self.targets.len();
        let dt = if f > 0 {
            (self.times_ns[f] - self.times_ns[f - 1]) as f64 * 1e-9
        } else {
            0.025
        };
        let horizon = ((LOOK_AHEAD_S / dt.max(1e-3)).ceil() as usize).max(1);
        let mut q = prev.to_vec();
        let mut goal = goal.map(<[f64]>::to_vec);
        let mut total = 0.0;
        for k in f..(f + horizon).min(n) {
            q = match &goal {
                Some(g) => {
                    let next = self.toward(k, &q, g);
                    if next.iter().zip(g).all(|(a, b)| (a - b).abs() < 1e-12) {
                        goal = None;
                    }
                    next
                }
                None => self.warm_step(k, &q),
            };
            total += self.miss(k, &q);
        }
        total
    }

    /// Every frame, the redundancy resolved as `redundancy` says.
    pub fn run(&self, redundancy: Redundancy) -> ArmFrames {
        match redundancy {
            Redundancy::Canonical => self.run_canonical(),
            Redundancy::Continuous => self.run_continuous(),
        }
    }

    /// Every frame: the canonical configuration, reached as fast as the velocity limits allow.
    fn run_canonical(&self) -> ArmFrames {
        let n = self.targets.len();
        let mut out = ArmFrames {
            q: Vec::with_capacity(n),
            miss: Vec::with_capacity(n),
            outcome: Vec::with_capacity(n),
        };
        let mut prev: Vec<f64> = self.neutral.to_vec();
        for f in 0..n {
            let goal = self.canonical(f);
            let q = if f == 0 {
                goal.clone()
            } else {
                self.toward(f, &prev, &goal)
            };
            let miss = self.miss(f, &q);
            let outcome = if miss <= self.tolerance {
                Outcome::Reached
            } else if self.miss(f, &goal) <= self.tolerance
                || self.other_configuration(f, &prev).is_some()
            {
                Outcome::SpeedLimited
            } else {
                Outcome::Unreachable
            };
            out.outcome.push(outcome);
            out.miss.push(miss);
            out.q.push(q.clone());
            prev = q;
        }
        out
    }

    /// Every frame: warm IK from the previous frame, changing configuration where looking ahead
    /// says it pays.
    fn run_continuous(&self) -> ArmFrames {
        let n = self.targets.len();
        let mut out = ArmFrames {
            q: Vec::with_capacity(n),
            miss: Vec::with_capacity(n),
            outcome: Vec::with_capacity(n),
        };
        let mut prev: Vec<f64> = self.neutral.to_vec();
        let mut changing_to: Option<Vec<f64>> = None;
        let mut hold_until = 0usize;
        for f in 0..n {
            if let Some(goal) = &changing_to {
                let q = self.toward(f, &prev, goal);
                if q.iter().zip(goal).all(|(a, b)| (a - b).abs() < 1e-12) {
                    changing_to = None;
                }
                let miss = self.miss(f, &q);
                out.outcome.push(if miss <= self.tolerance {
                    Outcome::Reached
                } else {
                    Outcome::OtherConfiguration
                });
                out.miss.push(miss);
                out.q.push(q.clone());
                prev = q;
                continue;
            }
            let mut q = if f == 0 {
                // The first frame: any configuration near the neutral posture.
                let first = IkOptions {
                    restarts: 24,
                    ..self.warm(None)
                };
                self.chain
                    .inverse_kinematics(&self.targets[0], self.neutral, &first)
                    .q
            } else {
                self.warm_step(f, &prev)
            };
            let mut miss = self.miss(f, &q);
            let outcome = if miss <= self.tolerance {
                Outcome::Reached
            } else if f > 0
                && self.velocity_limits
                && self.miss(
                    f,
                    &self
                        .chain
                        .inverse_kinematics(&self.targets[f], &prev, &self.warm(None))
                        .q,
                ) <= self.tolerance
            {
                Outcome::SpeedLimited
            } else {
                match self.other_configuration(f, &prev) {
                    None => Outcome::Unreachable,
                    Some(goal) => {
                        if f >= hold_until && f > 0 {
                            let hold = self.look_ahead(f, &prev, None);
                            let change = self.look_ahead(f, &prev, Some(&goal));
                            if change < hold {
                                q = self.toward(f, &prev, &goal);
                                miss = self.miss(f, &q);
                                changing_to = Some(goal);
                            } else {
                                hold_until = f + HOLD_FRAMES;
                            }
                        }
                        if miss <= self.tolerance {
                            Outcome::Reached
                        } else {
                            Outcome::OtherConfiguration
                        }
                    }
                }
            };
            out.outcome.push(outcome);
            out.miss.push(miss);
            out.q.push(q.clone());
            prev = q;
        }
        out
    }
}
