//! The per-frame safety rule between a model's prediction and a robot: plain functions, no
//! network, so that tests drive it frame by frame.
//!
//! For each robot, each human frame:
//!
//! 1. **Trust.** The prediction's standard deviation σ (the model's standardised units) is
//!    compared with the robot's trust threshold τ (`sgplvm_core`'s `trust` module: the 99th
//!    percentile over the training frames, each predicted with its group of training frames
//!    held out). σ ≤ τ: the prediction is the target, and the *last trusted target*. σ > τ (or
//!    σ not a number): the frame is not trusted: the robot **holds** the command it was last
//!    sent, and from the next untrusted frame on **moves towards the last trusted target** at
//!    [`GateOptions::return_speed`] of each joint's velocity limit, until a frame is trusted
//!    again. (The last trusted target is where the robot was going when the model was last
//!    sure: when the velocity limits had it lagging behind a fast motion, it completes that
//!    motion slowly instead of stopping half-way; otherwise it stays where it holds.) Before
//!    any frame was trusted nothing is sent ([`Reason::Waiting`]).
//! 2. **Limits.** Whatever the target, the command sent is within each joint's velocity limit
//!    of the previous command sent (over the seconds between the two sends, on the node's
//!    clock: the stale hold is a command sent too, and the human frames' stamps play no part)
//!    and within its position limits ([`sgplvm_robots::limits::CommandLimits`]); every joint
//!    moved is counted.
//! 3. **Stale input.** No human frame for [`GateOptions::timeout_s`]: the robot holds its last
//!    command (sent again, and timed as sent), and the status says so, until frames come again
//!    (then it follows from where it is, within its velocity limits: no jump).
//!
//! [`Decision`] says what happened and why, for the status the node publishes.

use sgplvm_robots::limits::{Clamped, CommandLimits};

/// The rule's parameters.
#[derive(Debug, Clone, PartialEq)]
pub struct GateOptions {
    /// Predictions less certain than this (standardised standard deviation) are not trusted;
    /// `None`: the model's trust threshold.
    pub threshold: Option<f64>,
    /// The threshold is multiplied by this (1: the model's 99th percentile as it is).
    pub threshold_scale: f64,
    /// Fraction of each joint's velocity limit at which an untrusted robot moves towards its
    /// last trusted target.
    pub return_speed: f64,
    /// Seconds without a human frame after which the input is stale.
    pub timeout_s: f64,
}

impl Default for GateOptions {
    fn default() -> Self {
        GateOptions {
            threshold: None,
            threshold_scale: 1.0,
            return_speed: 0.25,
            timeout_s: 0.1,
        }
    }
}

/// Why the robot did what it did this frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Reason {
    /// Following a trusted prediction.
    Following,
    /// The prediction was not trusted: holding the last command.
    Holding,
    /// Still not trusted: moving back towards the last trusted command.
    Returning,
    /// No human frame for longer than the timeout: holding.
    Stale,
    /// No frame has been trusted yet: nothing is sent.
    Waiting,
}

impl Reason {
    /// A short word for the status.
    pub fn as_str(self) -> &'static str {
        match self {
            Reason::Following => "following",
            Reason::Holding => "holding",
            Reason::Returning => "moving to the last trusted target",
            Reason::Stale => "stale input",
            Reason::Waiting => "waiting for a trusted frame",
        }
    }
}

/// One frame's outcome for one robot.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Decision {
    /// What the robot does ([`Reason::Waiting`]: no command to send).
    pub reason: Reason,
    /// The prediction's standard deviation (standardised), `NaN` for a stale step.
    pub sd: f64,
    /// What the limits moved.
    pub clamped: Clamped,
    /// Whether the reason differs from the previous frame's (worth a status message).
    pub changed: bool,
}

/// Counts since the start, for the status.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct GateCounts {
    /// Frames seen.
    pub frames: usize,
    /// Frames not trusted.
    pub untrusted: usize,
    /// Commands the position limits moved.
    pub position_clamped: usize,
    /// Commands the velocity limits slowed.
    pub velocity_clamped: usize,
    /// Times the input went stale.
    pub stale: usize,
}

/// The rule's state for one robot.
#[derive(Debug, Clone)]
pub struct Gate {
    limits: CommandLimits,
    threshold: f64,
    return_speed: f64,
    /// The command last sent and when it was sent (seconds on the node's clock).
    last_sent: Option<(Vec<f64>, f64)>,
    /// The last trusted prediction, within the position limits.
    last_trusted: Option<Vec<f64>>,
    reason: Option<Reason>,
    counts: GateCounts,
    /// The joints the limits moved in the last command.
    clamped_joints: Vec<usize>,
}

impl Gate {
    /// A gate for a robot with `limits`, trusting predictions up to `threshold` (standardised
    /// standard deviation, already scaled), moving back at `return_speed` of the velocity
    /// limits.
    pub fn new(limits: CommandLimits, threshold: f64, return_speed: f64) -> Gate {
        Gate {
            limits,
            threshold,
            return_speed,
            last_sent: None,
            last_trusted: None,
            reason: None,
            counts: GateCounts::default(),
            clamped_joints: Vec::new(),
        }
    }

    /// The trust threshold in use.
    pub fn threshold(&self) -> f64 {
        self.threshold
    }

    /// The limits in use.
    pub fn limits(&self) -> &CommandLimits {
        &self.limits
    }

    /// Counts since the start.
    pub fn counts(&self) -> GateCounts {
        self.counts
    }

    /// The joints (command order) the limits moved in the last command.
    pub fn clamped_joints(&self) -> &[usize] {
        &self.clamped_joints
    }

    /// The command last sent.
    pub fn last_sent(&self) -> Option<&[f64]> {
        self.last_sent.as_ref().map(|(q, _)| q.as_slice())
    }

    fn decide(&mut self, reason: Reason, sd: f64, clamped: Clamped) -> Decision {
        let changed = self.reason != Some(reason);
        self.reason = Some(reason);
        if clamped.position > 0 {
            self.counts.position_clamped += 1;
        }
        if clamped.velocity > 0 {
            self.counts.velocity_clamped += 1;
        }
        Decision {
            reason,
            sd,
            clamped,
            changed,
        }
    }

    /// One human frame, its command to be sent at `now` seconds on the node's clock (the
    /// clock of every command this gate sends: the velocity limits hold over the time between
    /// two sends): the model predicted `prediction` with standard deviation `sd`; the command
    /// to send is written to `command` (untouched, and nothing to send, when the decision is
    /// [`Reason::Waiting`]).
    pub fn step(&mut self, now: f64, prediction: &[f64], sd: f64, command: &mut [f64]) -> Decision {
        self.counts.frames += 1;
        let trusted = sd.is_finite() && sd <= self.threshold;
        if !trusted {
            self.counts.untrusted += 1;
        }
        let previous = self.last_sent.clone();
        let reason = match (trusted, self.reason) {
            (true, _) => Reason::Following,
            (false, _) if previous.is_none() => {
                return self.decide(Reason::Waiting, sd, Clamped::default());
            }
            (false, Some(Reason::Holding | Reason::Returning)) => Reason::Returning,
            (false, _) => Reason::Holding,
        };
        match (reason, &previous) {
            (Reason::Holding, Some((q, _))) => command.copy_from_slice(q),
            (Reason::Returning, Some((q, t))) => {
                // Towards the last trusted target at the return speed.
                let dt = (now - t).max(0.0);
                let target = self.last_trusted.as_deref().unwrap_or(q);
                for (k, c) in command.iter_mut().enumerate() {
                    let step = self.return_speed * self.limits.velocity()[k] * dt;
                    *c = q[k] + (target[k] - q[k]).clamp(-step, step);
                }
            }
            _ => {
                command.copy_from_slice(prediction);
                let mut target = prediction.to_vec();
                self.limits.apply(&mut target, None);
                self.last_trusted = Some(target);
            }
        }
        let wanted = command.to_vec();
        let clamped = self.limits.apply(
            command,
            previous.as_ref().map(|(q, t)| (q.as_slice(), now - t)),
        );
        self.clamped_joints.clear();
        self.clamped_joints
            .extend((0..command.len()).filter(|&k| command[k] != wanted[k]));
        self.last_sent = Some((command.to_vec(), now));
        self.decide(reason, sd, clamped)
    }

    /// No frame came for longer than the timeout: hold. The command to repeat, if any, is
    /// written to `command`, to be sent at `now` seconds on the node's clock: the next command
    /// moves within the velocity limits over the time since this one.
    pub fn stale(&mut self, now: f64, command: &mut [f64]) -> Option<Decision> {
        let (q, t) = self.last_sent.as_mut()?;
        command.copy_from_slice(q);
        *t = t.max(now);
        if self.reason != Some(Reason::Stale) {
            self.counts.stale += 1;
        }
        Some(self.decide(Reason::Stale, f64::NAN, Clamped::default()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use sgplvm_robots::Robot;

    fn gate() -> Gate {
        let robot = Robot::builtin("coman").unwrap();
        let joints: Vec<String> = robot.joint_names()[..2].to_vec(); // LShSag, LShLat (4 rad/s)
        Gate::new(
            CommandLimits::for_joints(&robot, &joints).unwrap(),
            0.5,
            0.25,
        )
    }

    #[test]
    fn trusted_frames_follow_within_the_velocity_limit() {
        let mut g = gate();
        let mut c = [0.0; 2];
        let d = g.step(0.0, &[0.1, 0.2], 0.1, &mut c);
        assert_eq!((d.reason, c), (Reason::Following, [0.1, 0.2]));
        // 25 ms later a jump of 1 rad: at most 0.1 rad (4 rad/s).
        let d = g.step(0.025, &[1.1, 0.2], 0.1, &mut c);
        assert!((c[0] - 0.2).abs() < 1e-12 && d.clamped.velocity == 1);
        assert_eq!(g.clamped_joints(), &[0]);
        // Beyond LShLat's upper limit (2.094): held at it, once the speed allows.
        let mut t = 0.025;
        for _ in 0..40 {
            t += 0.025;
            g.step(t, &[0.2, 3.0], 0.1, &mut c);
        }
        assert_eq!(c[1], 2.094);
        assert!(g.counts().position_clamped > 0);
    }

    #[test]
    fn untrusted_frames_hold_then_return_to_the_last_trusted_command() {
        let mut g = gate();
        let mut c = [0.0; 2];
        g.step(0.0, &[0.0, 0.0], 0.1, &mut c);
        g.step(0.025, &[0.05, 0.0], 0.1, &mut c);
        // A trusted frame that the velocity limit cuts short, then distrust.
        g.step(0.05, &[0.5, 0.0], 0.2, &mut c); // sent [0.15, 0], trusted
        assert!((c[0] - 0.15).abs() < 1e-12);
        let d = g.step(0.075, &[2.0, 1.0], 0.9, &mut c);
        assert_eq!(d.reason, Reason::Holding);
        assert!(
            (c[0] - 0.15).abs() < 1e-12 && c[1] == 0.0,
            "holds what it sent: {c:?}"
        );
        assert!(d.changed);
        // The last trusted target is [0.5, 0]: the robot moves on towards it at a quarter of
        // 4 rad/s, 0.025 rad in 25 ms.
        let d = g.step(0.1, &[2.0, 1.0], 0.9, &mut c);
        assert_eq!(d.reason, Reason::Returning);
        assert!((c[0] - 0.175).abs() < 1e-12 && c[1] == 0.0, "{c:?}");
        assert_eq!(g.counts().untrusted, 2);
        // Trust again: follows, from where it is, within the velocity limit.
        let d = g.step(0.125, &[1.0, 0.0], 0.1, &mut c);
        assert_eq!(d.reason, Reason::Following);
        assert!((c[0] - 0.275).abs() < 1e-12);
    }

    #[test]
    fn returning_moves_back_at_the_return_speed() {
        let mut g = gate();
        let mut c = [0.0; 2];
        g.step(0.0, &[0.0, 0.0], 0.1, &mut c); // trusted target 0
                                               // The robot sits elsewhere (as if the velocity limit had it lagging).
        g.last_sent = Some((vec![0.4, 0.0], 1.0));
        g.step(1.0, &[9.0, 9.0], 2.0, &mut c); // holding at [0.4, 0]
        assert!((c[0] - 0.4).abs() < 1e-12);
        let d = g.step(1.1, &[9.0, 9.0], 2.0, &mut c); // 0.1 s at 0.25 × 4 rad/s = 0.1 rad
        assert_eq!(d.reason, Reason::Returning);
        assert!((c[0] - 0.3).abs() < 1e-12, "{c:?}");
    }

    #[test]
    fn stale_input_holds_and_is_counted_once() {
        let mut g = gate();
        let mut c = [0.0; 2];
        assert!(
            g.stale(0.0, &mut c).is_none(),
            "nothing sent yet: nothing to hold"
        );
        g.step(0.0, &[0.3, 0.1], 0.1, &mut c);
        let d = g.stale(0.1, &mut c).unwrap();
        assert_eq!((d.reason, c), (Reason::Stale, [0.3, 0.1]));
        assert!(d.changed);
        assert!(!g.stale(0.2, &mut c).unwrap().changed);
        assert_eq!(g.counts().stale, 1);
        // Frames again: follows within the velocity limit from the held command.
        let d = g.step(2.0, &[0.4, 0.1], 0.1, &mut c);
        assert_eq!(d.reason, Reason::Following);
        assert!(d.changed);
    }

    #[test]
    fn nothing_is_sent_before_a_frame_is_trusted() {
        let mut g = gate();
        let mut c = [7.0; 2];
        let d = g.step(0.0, &[1.0, 1.0], 0.9, &mut c);
        assert_eq!((d.reason, c), (Reason::Waiting, [7.0, 7.0]));
        assert!(g.last_sent().is_none());
        let d = g.step(0.025, &[0.1, 0.2], 0.1, &mut c);
        assert_eq!((d.reason, c), (Reason::Following, [0.1, 0.2]));
        assert_eq!(g.counts().untrusted, 1);
    }

    #[test]
    fn a_nan_standard_deviation_is_not_trusted() {
        let mut g = gate();
        let mut c = [0.0; 2];
        g.step(0.0, &[0.0, 0.0], 0.1, &mut c);
        assert_eq!(
            g.step(0.025, &[0.1, 0.1], f64::NAN, &mut c).reason,
            Reason::Holding
        );
    }

    #[test]
    fn after_silence_the_first_command_moves_within_the_velocity_limit_of_the_hold() {
        // Issue 44: the input stops, the node sends the hold at the timeout (0.1 s), frames
        // come back 30 ms after the hold with a pose 1 rad away. The robot received the hold
        // 30 ms before: 4 rad/s allow 0.12 rad, not the 0.52 rad of the 0.13 s since the last
        // frame's command.
        let mut g = gate();
        let mut c = [0.0; 2];
        g.step(0.0, &[0.0, 0.0], 0.1, &mut c);
        g.stale(0.1, &mut c).unwrap();
        let d = g.step(0.13, &[1.0, 0.0], 0.1, &mut c);
        assert_eq!(d.reason, Reason::Following);
        assert!((c[0] - 4.0 * 0.03).abs() < 1e-12, "{c:?}");
        assert_eq!(d.clamped.velocity, 1);
        // The 400 ms pause of the issue: the hold at 0.1 s, the next frame at 0.4 s.
        let mut g = gate();
        g.step(0.0, &[0.0, 0.0], 0.1, &mut c);
        g.stale(0.1, &mut c).unwrap();
        g.step(0.4, &[2.0, 0.0], 0.1, &mut c);
        assert!((c[0] - 4.0 * 0.3).abs() < 1e-12, "{c:?}");
    }

    #[test]
    fn a_stale_hold_never_moves_the_clock_back() {
        let mut g = gate();
        let mut c = [0.0; 2];
        g.step(1.0, &[0.0, 0.0], 0.1, &mut c);
        g.stale(0.5, &mut c).unwrap(); // an earlier time: the command's own time is kept
        g.step(1.01, &[1.0, 0.0], 0.1, &mut c);
        assert!((c[0] - 0.04).abs() < 1e-12, "{c:?}");
    }
}
