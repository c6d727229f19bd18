//! The per-frame safety rule between a model's prediction and a robot: plain functions, no
//! network, so that tests drive it frame by frame.
//!
//! For each robot, each human frame:
//!
//! 1. **Trust.** Three signals say whether the model knows the frame (`sgplvm_core`'s
//!    `reconstruction`, `novelty` and `trust` modules), each with a threshold computed from
//!    the training frames:
//!    - the *reconstruction error* e: how far the human pose is from the model's own
//!      reconstruction of it (h → x → ĥ), against its threshold τₑ (the larger of the 99th
//!      percentile of the held-out frames' errors and the mean pose's held-out error). It sees
//!      an input far from every training pose, which a far input's latent point (near the
//!      origin, inside the data) hides from σ.
//!    - the *novelty* n: the distance to the nearest training pose, each joint in units of its
//!      spread, against τₙ (within which 1 % of poses drawn at random within the human's
//!      joint limits fall). It sees a pose no one in the training data made where a model that
//!      keeps little of the human reconstructs every pose about equally badly. With e it gates
//!      by default ([`Signals::Known`]: either beyond its threshold holds the robot).
//!    - the robot prediction's *standard deviation* σ (standardised), against the trust
//!      threshold τ (the 99th percentile over the held-out frames). It is larger on any motion
//!      the training did not repeat, and holding on it stops a robot on a third of the shipped
//!      test motions; it gates when asked ([`Signals::Sd`], [`Signals::Both`]).
//!
//!    Within the thresholds of the gating signals: the prediction is the target, and the *last
//!    trusted target*. Beyond one (or a signal not a number, whichever gates): the frame is not
//!    trusted: the robot **holds** the command it was last sent, and from the next untrusted
//!    frame on **moves towards the last trusted target** at [`GateOptions::return_speed`] of
//!    each joint's velocity limit, until a frame is trusted again. (The last trusted target is
//!    where the robot was going when the model was last sure: when the velocity limits had it
//!    lagging behind a fast motion, it completes that motion slowly instead of stopping
//!    half-way; otherwise it stays where it holds.) Before any frame was trusted nothing is
//!    sent ([`Reason::Waiting`]).
//! 2. **Limits.** Whatever the target, the command sent is within each joint's velocity limit
//!    of the previous command sent, whatever sent that one (a frame, the hold, the return, the
//!    stale hold; the human frames' stamps play no part), and within its position limits
//!    ([`sgplvm_robots::limits::CommandLimits`]); every joint moved is counted. The time the
//!    limit allows is from the moment the previous command's send *ended* ([`Gate::sent`]: the
//!    node's clock read after the middleware took it) to the moment this one is computed
//!    (`now`, read before): at most the time between the two leaving the node, however long
//!    a send or the computation took. On a robot's receipt clock the interval differs from
//!    that by the two commands' difference in delivery time.
//! 3. **Stale input.** No human frame for [`GateOptions::timeout_s`]: the robot holds its last
//!    command (sent again, and timed as sent), and the status says so, until frames come again
//!    (then it follows from where it is, within its velocity limits: no jump).
//!
//! [`Decision`] says what happened and why, for the status the node publishes.

use sgplvm_core::AnyModel;
use sgplvm_robots::limits::{Clamped, CommandLimits};
use sgplvm_robots::safety::SafetyStep;

/// Which signals gate (hold the robot when beyond their thresholds).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Signals {
    /// The reconstruction error of the human frame or its novelty: a pose the model does not
    /// know (the default).
    #[default]
    Known,
    /// The reconstruction error of the human frame.
    Reconstruction,
    /// The human frame's distance to the nearest training pose.
    Novelty,
    /// The robot prediction's standard deviation.
    Sd,
    /// The standard deviation or the reconstruction error.
    Both,
}

impl Signals {
    /// Whether the reconstruction error gates.
    pub fn reconstruction(self) -> bool {
        matches!(
            self,
            Signals::Reconstruction | Signals::Both | Signals::Known
        )
    }

    /// Whether the standard deviation gates.
    pub fn sd(self) -> bool {
        matches!(self, Signals::Sd | Signals::Both)
    }

    /// Whether the novelty gates.
    pub fn novelty(self) -> bool {
        matches!(self, Signals::Novelty | Signals::Known)
    }

    /// The gating signals' names, for a status.
    pub fn names(self) -> &'static str {
        match self {
            Signals::Known => "reconstruction, novelty",
            Signals::Reconstruction => "reconstruction",
            Signals::Novelty => "novelty",
            Signals::Sd => "sd",
            Signals::Both => "reconstruction, sd",
        }
    }
}

/// The rule's parameters.
#[derive(Debug, Clone, PartialEq)]
pub struct GateOptions {
    /// Which signals gate.
    pub signals: Signals,
    /// Predictions less certain than this (standardised standard deviation) are not trusted;
    /// `None`: the model's trust threshold.
    pub threshold: Option<f64>,
    /// The threshold is multiplied by this (1: the model's 99th percentile as it is).
    pub threshold_scale: f64,
    /// Human frames whose reconstruction error is above this are not trusted; `None`: the
    /// model's reconstruction threshold.
    pub reconstruction_threshold: Option<f64>,
    /// The reconstruction threshold is multiplied by this.
    pub reconstruction_scale: f64,
    /// Human frames farther than this from every training pose are not trusted; `None`: the
    /// model's novelty threshold.
    pub novelty_threshold: Option<f64>,
    /// The novelty threshold is multiplied by this.
    pub novelty_scale: f64,
    /// Fraction of each joint's velocity limit at which an untrusted robot moves towards its
    /// last trusted target.
    pub return_speed: f64,
    /// Seconds without a human frame after which the input is stale.
    pub timeout_s: f64,
    /// How far apart the robot's own collision shapes stay, metres; `None`: no self-collision
    /// limit.
    pub collision_margin_m: Option<f64>,
}

impl Default for GateOptions {
    fn default() -> Self {
        GateOptions {
            signals: Signals::default(),
            threshold: None,
            threshold_scale: 1.0,
            reconstruction_threshold: None,
            reconstruction_scale: 1.0,
            novelty_threshold: None,
            novelty_scale: 1.0,
            return_speed: 0.25,
            timeout_s: 0.1,
            collision_margin_m: Some(0.01),
        }
    }
}

/// The thresholds a robot's gate compares its signals with (already scaled), and which gate.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Thresholds {
    /// Which signals gate.
    pub signals: Signals,
    /// The trust threshold (standardised standard deviation).
    pub sd: f64,
    /// The reconstruction threshold (the human space's standardised units).
    pub reconstruction: f64,
    /// The novelty threshold (RMS over the human's joints of each joint's spreads).
    pub novelty: f64,
}

impl Thresholds {
    /// The thresholds for `robot` of `model` under `options`: the given ones, else the
    /// model's, each times its scale. A per-part model's signals are ratios to its parts' own
    /// thresholds: its thresholds are 1 (times the scales; a given one is a ratio too).
    pub fn of(
        model: &AnyModel,
        robot: &str,
        options: &GateOptions,
    ) -> Result<Thresholds, crate::LiveError> {
        let config = |e: sgplvm_core::Error| crate::LiveError::Config(format!("{robot}: {e}"));
        let own = match model {
            AnyModel::Single(m) => [
                m.trust_threshold(robot).map_err(config)?,
                m.reconstruction_threshold().map_err(config)?,
                m.novelty_threshold().map_err(config)?,
            ],
            AnyModel::Parts(_) => [1.0; 3],
        };
        let sd = options.threshold.unwrap_or(own[0]);
        let reconstruction = options.reconstruction_threshold.unwrap_or(own[1]);
        let novelty = options.novelty_threshold.unwrap_or(own[2]);
        Ok(Thresholds {
            signals: options.signals,
            sd: sd * options.threshold_scale,
            reconstruction: reconstruction * options.reconstruction_scale,
            novelty: novelty * options.novelty_scale,
        })
    }

    /// Whether a frame with these signals is trusted: every gating signal within its
    /// threshold, and no signal not a number (a failed prediction or reconstruction).
    pub fn trusts(&self, frame: Frame) -> bool {
        let Beyond {
            sd,
            reconstruction,
            novelty,
        } = self.beyond(frame);
        !(sd || reconstruction || novelty)
    }

    /// Which signals of `frame` hold the robot: those that gate and are beyond their
    /// thresholds, and those that are not a number.
    pub fn beyond(&self, frame: Frame) -> Beyond {
        let past = |v: f64, gates: bool, t: f64| !v.is_finite() || (gates && v > t);
        Beyond {
            sd: past(frame.sd, self.signals.sd(), self.sd),
            reconstruction: past(
                frame.reconstruction,
                self.signals.reconstruction(),
                self.reconstruction,
            ),
            novelty: past(frame.novelty, self.signals.novelty(), self.novelty),
        }
    }
}

/// Which of a frame's signals hold the robot ([`Thresholds::beyond`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Beyond {
    /// The standard deviation.
    pub sd: bool,
    /// The reconstruction error.
    pub reconstruction: bool,
    /// The novelty.
    pub novelty: bool,
}

impl std::fmt::Display for Thresholds {
    /// `reconstruction threshold 0.2259 (holds), novelty threshold 0.9653 (holds), trust
    /// threshold 0.0964 (reported)`.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let role = |gates: bool| if gates { "holds" } else { "reported" };
        write!(
            f,
            "reconstruction threshold {:.4} ({}), novelty threshold {:.4} ({}), trust threshold {:.4} ({})",
            self.reconstruction,
            role(self.signals.reconstruction()),
            self.novelty,
            role(self.signals.novelty()),
            self.sd,
            role(self.signals.sd())
        )
    }
}

/// One frame's signals for one robot.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Frame {
    /// The robot prediction's standard deviation (standardised).
    pub sd: f64,
    /// The human frame's reconstruction error (the human space's standardised units).
    pub reconstruction: f64,
    /// The human frame's distance to the nearest training pose.
    pub novelty: f64,
}

impl Frame {
    /// No frame (a stale step): every signal not a number.
    pub const NONE: Frame = Frame {
        sd: f64::NAN,
        reconstruction: f64::NAN,
        novelty: f64::NAN,
    };
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
    /// The frame's signals ([`Frame::NONE`] for a stale step).
    pub frame: Frame,
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
    /// Commands the self-collision limit moved (two of the robot's shapes within the margin).
    pub collision_limited: usize,
}

/// The rule's state for one robot.
#[derive(Debug, Clone)]
pub struct Gate {
    limits: CommandLimits,
    thresholds: Thresholds,
    return_speed: f64,
    /// The command last sent and when it was sent (seconds on the node's clock).
    last_sent: Option<(Vec<f64>, f64)>,
    /// The last trusted prediction, within the position limits.
    last_trusted: Option<Vec<f64>>,
    reason: Option<Reason>,
    counts: GateCounts,
    /// The joints the limits moved in the last command.
    clamped_joints: Vec<usize>,
    /// The nearest safe command (self-collision with a margin), where the robot's collision
    /// shapes are known.
    safety: Option<Box<SafetyStep>>,
    /// The pair of links the last command kept apart, and their distance (metres).
    near: Option<(String, String, f64)>,
}

impl Gate {
    /// A gate for a robot with `limits`, trusting frames within `thresholds`, moving back at
    /// `return_speed` of the velocity limits.
    pub fn new(limits: CommandLimits, thresholds: Thresholds, return_speed: f64) -> Gate {
        Gate {
            limits,
            thresholds,
            return_speed,
            last_sent: None,
            last_trusted: None,
            reason: None,
            counts: GateCounts::default(),
            clamped_joints: Vec::new(),
            safety: None,
            near: None,
        }
    }

    /// The gate with the self-collision limit of `safety` (over the same joints, in the same
    /// order): every command is then the nearest one keeping the robot's own shapes apart.
    pub fn with_safety(mut self, safety: SafetyStep) -> Gate {
        self.safety = Some(Box::new(safety));
        self
    }

    /// The pair of links the self-collision limit kept apart in the last command, and their
    /// distance (metres).
    pub fn near(&self) -> Option<&(String, String, f64)> {
        self.near.as_ref()
    }

    /// The trust threshold (standardised standard deviation; it gates if
    /// [`Thresholds::signals`] says so).
    pub fn threshold(&self) -> f64 {
        self.thresholds.sd
    }

    /// The thresholds in use.
    pub fn thresholds(&self) -> &Thresholds {
        &self.thresholds
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

    fn decide(&mut self, reason: Reason, frame: Frame, clamped: Clamped) -> Decision {
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
            frame,
            clamped,
            changed,
        }
    }

    /// One human frame, its command computed at `now` seconds on the node's clock (read before
    /// the step; the clock of every command this gate sends: the velocity limits hold over the
    /// time since the last command's send ended, [`Gate::sent`]): the model predicted
    /// `prediction`, with the signals `frame`; the command to send is written to `command`
    /// (untouched, and nothing to send, when the decision is [`Reason::Waiting`]).
    pub fn step(
        &mut self,
        now: f64,
        prediction: &[f64],
        frame: Frame,
        command: &mut [f64],
    ) -> Decision {
        self.counts.frames += 1;
        let trusted = self.thresholds.trusts(frame);
        if !trusted {
            self.counts.untrusted += 1;
        }
        let previous = self.last_sent.clone();
        let reason = match (trusted, self.reason) {
            (true, _) => Reason::Following,
            (false, _) if previous.is_none() => {
                return self.decide(Reason::Waiting, frame, Clamped::default());
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
        self.keep_apart(command, previous.as_ref(), now);
        if let Some((q, t)) = &previous {
            // The self-collision step solves within the same bounds, to its solver's tolerance:
            // the velocity bound is made exact again (a move of at most that tolerance).
            within_velocity(command, q, self.limits.velocity(), now - t);
        }
        self.clamped_joints.clear();
        self.clamped_joints
            .extend((0..command.len()).filter(|&k| command[k] != wanted[k]));
        self.last_sent = Some((command.to_vec(), now));
        self.decide(reason, frame, clamped)
    }

    /// The self-collision limit on a command already within the position and velocity limits.
    fn keep_apart(&mut self, command: &mut [f64], previous: Option<&(Vec<f64>, f64)>, now: f64) {
        let Some(safety) = self.safety.as_mut() else {
            return;
        };
        let asked = command.to_vec();
        let outcome = safety.step_from(
            &asked,
            previous.map(|(q, t)| (q.as_slice(), *t)),
            now,
            command,
        );
        self.near = outcome.near.into_iter().min_by(|a, b| a.2.total_cmp(&b.2));
        if self.near.is_some() && outcome.changed {
            self.counts.collision_limited += 1;
        }
    }

    /// The command of the last [`Gate::step`] or [`Gate::stale`] was sent, and its send ended
    /// at `at` seconds on the node's clock (read after the middleware took the message): the
    /// next command's velocity limits count from then, so that a send that took long (a
    /// middleware busy, the node descheduled) shortens the next step rather than lengthens it.
    /// Never moves the time back.
    pub fn sent(&mut self, at: f64) {
        if let Some((_, t)) = self.last_sent.as_mut() {
            *t = t.max(at);
        }
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
        Some(self.decide(Reason::Stale, Frame::NONE, Clamped::default()))
    }
}

/// Each joint of `command` within `velocity · dt` of `from` (a clamp).
fn within_velocity(command: &mut [f64], from: &[f64], velocity: &[f64], dt: f64) {
    for ((c, &f), &v) in command.iter_mut().zip(from).zip(velocity) {
        let step = v * dt.max(0.0);
        *c = c.clamp(f - step, f + step);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use sgplvm_robots::Robot;

    /// A gate on COMAN's LShSag and LShLat (4 rad/s each) gated by `signals`: σ ≤ 0.5,
    /// e ≤ 0.2 and n ≤ 1 are trusted.
    fn gate_on(signals: Signals) -> Gate {
        let robot = Robot::builtin("coman").unwrap();
        let joints: Vec<String> = robot.joint_names()[..2].to_vec(); // LShSag, LShLat (4 rad/s)
        let thresholds = Thresholds {
            signals,
            sd: 0.5,
            reconstruction: 0.2,
            novelty: 1.0,
        };
        Gate::new(
            CommandLimits::for_joints(&robot, &joints).unwrap(),
            thresholds,
            0.25,
        )
    }

    /// The gate of the tests of the standard deviation's rule.
    fn gate() -> Gate {
        gate_on(Signals::Sd)
    }

    /// A frame of standard deviation `sd` whose pose the model reconstructs well and knows.
    fn sd(sd: f64) -> Frame {
        Frame {
            sd,
            reconstruction: 0.01,
            novelty: 0.1,
        }
    }

    #[test]
    fn trusted_frames_follow_within_the_velocity_limit() {
        let mut g = gate();
        let mut c = [0.0; 2];
        let d = g.step(0.0, &[0.1, 0.2], sd(0.1), &mut c);
        assert_eq!((d.reason, c), (Reason::Following, [0.1, 0.2]));
        // 25 ms later a jump of 1 rad: at most 0.1 rad (4 rad/s).
        let d = g.step(0.025, &[1.1, 0.2], sd(0.1), &mut c);
        assert!((c[0] - 0.2).abs() < 1e-12 && d.clamped.velocity == 1);
        assert_eq!(g.clamped_joints(), &[0]);
        // Beyond LShLat's upper limit (2.094): held at it, once the speed allows.
        let mut t = 0.025;
        for _ in 0..40 {
            t += 0.025;
            g.step(t, &[0.2, 3.0], sd(0.1), &mut c);
        }
        assert_eq!(c[1], 2.094);
        assert!(g.counts().position_clamped > 0);
    }

    #[test]
    fn untrusted_frames_hold_then_return_to_the_last_trusted_command() {
        let mut g = gate();
        let mut c = [0.0; 2];
        g.step(0.0, &[0.0, 0.0], sd(0.1), &mut c);
        g.step(0.025, &[0.05, 0.0], sd(0.1), &mut c);
        // A trusted frame that the velocity limit cuts short, then distrust.
        g.step(0.05, &[0.5, 0.0], sd(0.2), &mut c); // sent [0.15, 0], trusted
        assert!((c[0] - 0.15).abs() < 1e-12);
        let d = g.step(0.075, &[2.0, 1.0], sd(0.9), &mut c);
        assert_eq!(d.reason, Reason::Holding);
        assert!(
            (c[0] - 0.15).abs() < 1e-12 && c[1] == 0.0,
            "holds what it sent: {c:?}"
        );
        assert!(d.changed);
        // The last trusted target is [0.5, 0]: the robot moves on towards it at a quarter of
        // 4 rad/s, 0.025 rad in 25 ms.
        let d = g.step(0.1, &[2.0, 1.0], sd(0.9), &mut c);
        assert_eq!(d.reason, Reason::Returning);
        assert!((c[0] - 0.175).abs() < 1e-12 && c[1] == 0.0, "{c:?}");
        assert_eq!(g.counts().untrusted, 2);
        // Trust again: follows, from where it is, within the velocity limit.
        let d = g.step(0.125, &[1.0, 0.0], sd(0.1), &mut c);
        assert_eq!(d.reason, Reason::Following);
        assert!((c[0] - 0.275).abs() < 1e-12);
    }

    #[test]
    fn returning_moves_back_at_the_return_speed() {
        let mut g = gate();
        let mut c = [0.0; 2];
        g.step(0.0, &[0.0, 0.0], sd(0.1), &mut c); // trusted target 0
                                                   // The robot sits elsewhere (as if the velocity limit had it lagging).
        g.last_sent = Some((vec![0.4, 0.0], 1.0));
        g.step(1.0, &[9.0, 9.0], sd(2.0), &mut c); // holding at [0.4, 0]
        assert!((c[0] - 0.4).abs() < 1e-12);
        let d = g.step(1.1, &[9.0, 9.0], sd(2.0), &mut c); // 0.1 s at 0.25 × 4 rad/s = 0.1 rad
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
        g.step(0.0, &[0.3, 0.1], sd(0.1), &mut c);
        let d = g.stale(0.1, &mut c).unwrap();
        assert_eq!((d.reason, c), (Reason::Stale, [0.3, 0.1]));
        assert!(d.changed);
        assert!(!g.stale(0.2, &mut c).unwrap().changed);
        assert_eq!(g.counts().stale, 1);
        // Frames again: follows within the velocity limit from the held command.
        let d = g.step(2.0, &[0.4, 0.1], sd(0.1), &mut c);
        assert_eq!(d.reason, Reason::Following);
        assert!(d.changed);
    }

    #[test]
    fn nothing_is_sent_before_a_frame_is_trusted() {
        let mut g = gate();
        let mut c = [7.0; 2];
        let d = g.step(0.0, &[1.0, 1.0], sd(0.9), &mut c);
        assert_eq!((d.reason, c), (Reason::Waiting, [7.0, 7.0]));
        assert!(g.last_sent().is_none());
        let d = g.step(0.025, &[0.1, 0.2], sd(0.1), &mut c);
        assert_eq!((d.reason, c), (Reason::Following, [0.1, 0.2]));
        assert_eq!(g.counts().untrusted, 1);
    }

    #[test]
    fn a_nan_standard_deviation_is_not_trusted() {
        let mut g = gate();
        let mut c = [0.0; 2];
        g.step(0.0, &[0.0, 0.0], sd(0.1), &mut c);
        assert_eq!(
            g.step(0.025, &[0.1, 0.1], sd(f64::NAN), &mut c).reason,
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
        g.step(0.0, &[0.0, 0.0], sd(0.1), &mut c);
        g.stale(0.1, &mut c).unwrap();
        let d = g.step(0.13, &[1.0, 0.0], sd(0.1), &mut c);
        assert_eq!(d.reason, Reason::Following);
        assert!((c[0] - 4.0 * 0.03).abs() < 1e-12, "{c:?}");
        assert_eq!(d.clamped.velocity, 1);
        // The 400 ms pause of the issue: the hold at 0.1 s, the next frame at 0.4 s.
        let mut g = gate();
        g.step(0.0, &[0.0, 0.0], sd(0.1), &mut c);
        g.stale(0.1, &mut c).unwrap();
        g.step(0.4, &[2.0, 0.0], sd(0.1), &mut c);
        assert!((c[0] - 4.0 * 0.3).abs() < 1e-12, "{c:?}");
    }

    #[test]
    fn the_limit_counts_from_the_end_of_the_last_send_whatever_sent_it() {
        // Issue 50: a send that ends late (the middleware busy, the node descheduled) moves
        // the next command's allowance with it: 10 ms after the end of the send, 0.04 rad.
        let mut g = gate();
        let mut c = [0.0; 2];
        g.step(0.0, &[0.0, 0.0], sd(0.1), &mut c);
        g.sent(0.3);
        g.step(0.31, &[1.0, 0.0], sd(0.1), &mut c);
        assert!((c[0] - 0.04).abs() < 1e-12, "{c:?}");
        // The stale hold, the gate's hold and its return alike.
        g.stale(0.4, &mut c).unwrap();
        g.sent(0.5);
        g.step(0.51, &[1.0, 0.0], sd(0.1), &mut c);
        assert!((c[0] - 0.08).abs() < 1e-12, "{c:?}");
        g.step(0.52, &[1.0, 0.0], sd(0.9), &mut c); // holding
        g.sent(0.6);
        let d = g.step(0.61, &[1.0, 0.0], sd(0.9), &mut c); // returning at a quarter
        assert_eq!(d.reason, Reason::Returning);
        assert!((c[0] - 0.09).abs() < 1e-12, "{c:?}");
        // Never back: a send said to end before the step's own time changes nothing.
        g.sent(0.0);
        g.step(0.62, &[1.0, 0.0], sd(0.1), &mut c);
        assert!((c[0] - 0.13).abs() < 1e-12, "{c:?}");
    }

    #[test]
    fn a_stale_hold_never_moves_the_clock_back() {
        let mut g = gate();
        let mut c = [0.0; 2];
        g.step(1.0, &[0.0, 0.0], sd(0.1), &mut c);
        g.stale(0.5, &mut c).unwrap(); // an earlier time: the command's own time is kept
        g.step(1.01, &[1.0, 0.0], sd(0.1), &mut c);
        assert!((c[0] - 0.04).abs() < 1e-12, "{c:?}");
    }

    #[test]
    fn a_pose_the_model_does_not_know_holds_by_default_and_each_signal_as_asked() {
        assert_eq!(GateOptions::default().signals, Signals::Known);
        let frame = |sd, reconstruction, novelty| Frame {
            sd,
            reconstruction,
            novelty,
        };
        let beyond = |sd, reconstruction, novelty| Beyond {
            sd,
            reconstruction,
            novelty,
        };
        let mut c = [0.0; 2];
        // The default: a large σ is followed; a large e holds, and so does a large n.
        for (f, why) in [
            (frame(0.1, 0.3, 0.5), beyond(false, true, false)),
            (frame(0.1, 0.1, 1.5), beyond(false, false, true)),
        ] {
            let mut g = gate_on(Signals::Known);
            assert_eq!(
                g.step(0.0, &[0.1, 0.0], frame(0.9, 0.1, 0.5), &mut c)
                    .reason,
                Reason::Following
            );
            let d = g.step(0.025, &[0.2, 0.0], f, &mut c);
            assert_eq!((d.reason, c[0]), (Reason::Holding, 0.1));
            assert_eq!(g.thresholds().beyond(d.frame), why);
        }
        // Each alone: only its own signal holds.
        let cases = [
            (
                Signals::Reconstruction,
                frame(0.9, 0.1, 1.5),
                frame(0.1, 0.3, 0.5),
            ),
            (Signals::Novelty, frame(0.9, 0.3, 0.5), frame(0.1, 0.1, 1.5)),
            (Signals::Sd, frame(0.1, 0.3, 1.5), frame(0.9, 0.1, 0.5)),
        ];
        for (signals, followed, held) in cases {
            let mut g = gate_on(signals);
            assert_eq!(
                g.step(0.0, &[0.1, 0.0], followed, &mut c).reason,
                Reason::Following,
                "{signals:?}"
            );
            let d = g.step(0.025, &[0.2, 0.0], held, &mut c);
            assert_eq!(d.reason, Reason::Holding, "{signals:?}");
        }
        // Both: σ or e.
        let mut g = gate_on(Signals::Both);
        g.step(0.0, &[0.1, 0.0], frame(0.1, 0.1, 1.5), &mut c);
        let d = g.step(0.025, &[0.2, 0.0], frame(0.9, 0.3, 0.5), &mut c);
        assert_eq!(g.thresholds().beyond(d.frame), beyond(true, true, false));
        // A signal that is not a number holds, whether it gates or not.
        for signals in [Signals::Sd, Signals::Reconstruction, Signals::Known] {
            for nan in [frame(0.1, f64::NAN, 0.5), frame(0.1, 0.1, f64::NAN)] {
                let mut g = gate_on(signals);
                g.step(0.0, &[0.1, 0.0], frame(0.1, 0.1, 0.5), &mut c);
                let d = g.step(0.025, &[0.2, 0.0], nan, &mut c);
                assert_eq!(d.reason, Reason::Holding, "{signals:?} {nan:?}");
            }
        }
        // At the thresholds: trusted.
        let t = gate_on(Signals::Known).thresholds;
        assert!(t.trusts(frame(9.0, 0.2, 1.0)));
        assert!(!t.trusts(frame(0.1, 0.2 + 1e-12, 1.0)) && !t.trusts(frame(0.1, 0.2, 1.0 + 1e-12)));
    }

    #[test]
    fn thresholds_are_the_models_or_the_given_ones_times_their_scales() {
        use sgplvm_core::{Mat, ModelConfig, SharedGplvm, TrainOptions};
        let n = 30;
        let h = Mat::from_fn(n, 4, |i, j| ((i as f64) * 0.2 + j as f64).sin());
        let r = Mat::from_fn(n, 3, |i, j| ((i as f64) * 0.2 + 0.5 * j as f64).cos());
        let config = ModelConfig::default().with_latent_dim(2);
        let train = TrainOptions::default().with_max_iters(5);
        let spaces = [("human", h.as_ref()), ("robot", r.as_ref())];
        let single = SharedGplvm::fit(&config, &spaces, "human", &train, None).unwrap();
        let m = &single;
        let (sd, e, n) = (
            m.trust_threshold("robot").unwrap(),
            m.reconstruction_threshold().unwrap(),
            m.novelty_threshold().unwrap(),
        );
        let m = AnyModel::Single(single.clone());
        let t = Thresholds::of(&m, "robot", &GateOptions::default()).unwrap();
        assert_eq!(
            (t.signals, t.sd, t.reconstruction, t.novelty),
            (Signals::Known, sd, e, n)
        );
        let options = GateOptions {
            signals: Signals::Both,
            threshold_scale: 2.0,
            reconstruction_scale: 3.0,
            novelty_scale: 4.0,
            ..GateOptions::default()
        };
        let t = Thresholds::of(&m, "robot", &options).unwrap();
        assert_eq!(
            (t.sd, t.reconstruction, t.novelty),
            (2.0 * sd, 3.0 * e, 4.0 * n)
        );
        let options = GateOptions {
            threshold: Some(0.7),
            reconstruction_threshold: Some(0.05),
            reconstruction_scale: 2.0,
            novelty_threshold: Some(0.3),
            ..GateOptions::default()
        };
        let t = Thresholds::of(&m, "robot", &options).unwrap();
        assert_eq!((t.sd, t.reconstruction, t.novelty), (0.7, 0.1, 0.3));
        let err = Thresholds::of(&m, "nao", &GateOptions::default())
            .unwrap_err()
            .to_string();
        assert!(err.contains("nao"), "{err}");
        // A latent space per part: its signals are ratios to each part's own thresholds, so
        // its thresholds are 1 (times the scales); a part beyond its own is beyond 1.
        use sgplvm_core::{PartSpec, PartsConfig, PartsGplvm};
        let parts = vec![
            PartSpec::new("a", [("human", vec![0, 1]), ("robot", vec![0])]),
            PartSpec::new("b", [("human", vec![2, 3]), ("robot", vec![1, 2])]),
        ];
        let p = PartsGplvm::fit(
            &PartsConfig::new(config, parts),
            &spaces,
            "human",
            &train,
            None,
            None,
        )
        .unwrap();
        let b = p.part("b").unwrap();
        let model = AnyModel::Parts(p.clone());
        let options = GateOptions {
            novelty_scale: 2.0,
            ..GateOptions::default()
        };
        let t = Thresholds::of(&model, "robot", &options).unwrap();
        assert_eq!((t.sd, t.reconstruction, t.novelty), (1.0, 1.0, 2.0));
        // Part b's human columns 3 rad off: its novelty is beyond its threshold, a's is not.
        let far: Vec<f64> = (0..4)
            .map(|j| h[(7, j)] + if j >= 2 { 3.0 } else { 0.0 })
            .collect();
        let mut x = vec![0.0; p.latent_dim()];
        let [e, n] = p.known_frame(&far, &mut x).unwrap();
        let own = b.novelty(&far[2..]).unwrap() / b.novelty_threshold().unwrap();
        assert!(n > 1.0 && (n - own).abs() < 1e-12, "{n} {own}");
        assert!(e.is_finite());
        let (mut mean, mut sd) = ([0.0; 3], [0.0; 3]);
        let ratio = p
            .predict_latent_sd(&x, "robot", &mut mean, &mut sd)
            .unwrap();
        let mut want = [0.0; 3];
        p.predict_frame(&far, "robot", &mut want).unwrap();
        assert!(
            mean.iter().zip(want).all(|(a, b)| (a - b).abs() < 1e-12),
            "{mean:?} {want:?}"
        );
        assert!(ratio.is_finite() && sd.iter().all(|s| s.is_finite() && *s > 0.0));
        assert!(p.known_frame(&far[..3], &mut x).is_err());
    }
}
