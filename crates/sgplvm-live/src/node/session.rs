//! The node's loop, one wake-up at a time: wait for the input (or the next stale deadline, or
//! the next status tick), take every waiting message and use only the newest for every robot,
//! hold when the input goes stale, and publish the status when it changed or is due.

use std::time::{Duration, Instant};

use ros2_client::dds::rustdds::mio1::{Events, Interest, Poll, Token};
use ros2_client::dds::{Publisher, Subscription};

use super::dds::dds;
use super::drive::{Driven, LatentSlot};
use super::mvn_input::MvnInput;
use super::status::publish_status;
use super::step::{command, publish, show, By, Sent};
use super::tf_input::TfInput;
use super::{Latency, RobotSummary, TeleopOptions, TeleopSummary};
use crate::msgs::{DiagnosticArray, JointState, Time};
use crate::LiveError;
use sgplvm_core::AnyModel;

/// Everything the loop keeps from one wake-up to the next.
///
/// The fields are dropped in their order here, which is the order in which `teleop` dropped
/// them when they were its local variables.
pub(super) struct Session<'a> {
    options: &'a TeleopOptions,
    events: Events,
    poll: Poll,
    view: Option<crate::view::LiveView>,
    slots: Vec<LatentSlot>,
    /// The current frame's reconstruction error and novelty under each distinct model
    /// (`slots`' order).
    known: Vec<[f64; 2]>,
    driven: Vec<Driven>,
    status: Publisher<DiagnosticArray>,
    /// The JointState topic, when it is the input.
    input: Option<Subscription<JointState>>,
    /// The MVN stream, when the human comes from a suit.
    mvn: Option<MvnInput>,
    /// The TF frames, when the human comes from a skeleton's transforms.
    tf: Option<TfInput>,
    /// The models' human joint names.
    human: Vec<String>,
    start: Instant,
    summary: TeleopSummary,
    warned: Vec<String>,
    latencies: Vec<f64>,
    /// The human frame in the models' joint order.
    h: Vec<f64>,
    /// The names of the last message and where each model joint is among them.
    layout: (Vec<String>, Vec<usize>),
    last_input: Option<Instant>,
    last_stamp: Option<i64>,
    period_s: f64,
    stale: bool,
    next_status: Instant,
    timeout: Duration,
    status_period: Duration,
    status_due: bool,
}

/// What the loop starts from: the input, the status publisher, the robots and their models,
/// the live view.
pub(super) struct Parts {
    pub(super) human: Vec<String>,
    pub(super) mvn: Option<MvnInput>,
    pub(super) tf: Option<TfInput>,
    pub(super) input: Option<Subscription<JointState>>,
    pub(super) status: Publisher<DiagnosticArray>,
    pub(super) driven: Vec<Driven>,
    pub(super) slots: Vec<LatentSlot>,
    pub(super) view: Option<crate::view::LiveView>,
}

impl<'a> Session<'a> {
    /// The loop's state before its first wake-up, the input registered with the poll.
    pub(super) fn new(options: &'a TeleopOptions, parts: Parts) -> Result<Self, LiveError> {
        let Parts {
            human,
            mut mvn,
            mut tf,
            mut input,
            status,
            driven,
            slots,
            view,
        } = parts;
        let poll = Poll::new().map_err(|e| dds(e.to_string()))?;
        if let Some(i) = input.as_mut() {
            poll.registry()
                .register(i, Token(0), Interest::READABLE)
                .map_err(|e| dds(e.to_string()))?;
        }
        if let Some(m) = mvn.as_mut() {
            poll.registry()
                .register(&mut m.receiver, Token(1), Interest::READABLE)
                .map_err(|e| dds(e.to_string()))?;
        }
        if let Some(t) = tf.as_mut() {
            poll.registry()
                .register(&mut t.dynamic, Token(2), Interest::READABLE)
                .map_err(|e| dds(e.to_string()))?;
            poll.registry()
                .register(&mut t.statics, Token(3), Interest::READABLE)
                .map_err(|e| dds(e.to_string()))?;
        }
        let events = Events::with_capacity(8);
        let start = Instant::now();
        let h = vec![0.0; human.len()];
        Ok(Session {
            options,
            events,
            poll,
            view,
            known: vec![[f64::NAN; 2]; slots.len()],
            slots,
            driven,
            status,
            input,
            mvn,
            tf,
            human,
            start,
            summary: TeleopSummary::default(),
            warned: Vec::new(),
            latencies: Vec::new(),
            h,
            layout: (Vec::new(), Vec::new()),
            last_input: None,
            last_stamp: None,
            period_s: 0.025,
            stale: false,
            next_status: Instant::now(),
            timeout: Duration::from_secs_f64(options.gate.timeout_s.max(1e-3)),
            status_period: Duration::from_secs_f64(options.status_period_s.max(0.01)),
            status_due: true,
        })
    }

    /// Input frames used so far.
    pub(super) fn frames(&self) -> usize {
        self.summary.frames
    }

    /// How long since the last input frame, once one came.
    pub(super) fn since_input(&self) -> Option<std::time::Duration> {
        let heard = [
            self.last_input,
            self.tf.as_ref().and_then(|t| t.heard),
            self.mvn.as_ref().and_then(|m| m.heard),
        ];
        heard.into_iter().flatten().max().map(|t| t.elapsed())
    }

    /// The stream's calibration under way, if its person is being calibrated (no frame
    /// commanded until it is done).
    pub(super) fn calibrating(&self) -> Option<String> {
        let tf = self.tf.as_ref().and_then(|t| t.calibrating());
        let mvn = self.mvn.as_ref().and_then(|m| m.calibrating());
        tf.or(mvn).map(str::to_string)
    }

    /// One wake-up: wait, use the newest message, check for stale input, publish the status
    /// if due.
    pub(super) fn step(&mut self, log: &mut dyn FnMut(&str)) -> Result<(), LiveError> {
        self.wait()?;
        if let Some((msg, received)) = self.newest(log) {
            self.use_message(&msg, received, log)?;
        }
        if let Some(m) = self.mvn.as_mut() {
            let received = Instant::now();
            let used = m.newest(&mut self.h, log);
            self.status_due |= m.report(log);
            if used {
                // The suit's frames carry no ROS stamp: the node's clock stamps them.
                let now = std::time::SystemTime::now()
                    .duration_since(std::time::UNIX_EPOCH)
                    .map_or(0, |d| i64::try_from(d.as_nanos()).unwrap_or(i64::MAX));
                self.follow(Time::from_ns(now), received, log)?;
            }
        }
        if let Some(t) = self.tf.as_mut() {
            let received = Instant::now();
            if let Some(stamp) = t.newest(&mut self.h, log) {
                self.follow(stamp, received, log)?;
            }
        }
        self.check_stale(log)?;
        if self.status_due || Instant::now() >= self.next_status {
            let input = self.input_values();
            publish_status(
                &self.status,
                &self.driven,
                &self.summary,
                self.stale,
                &input,
                log,
            )?;
            self.status_due = false;
            self.next_status = Instant::now() + self.status_period;
        }
        Ok(())
    }

    /// The input's own values for the status (the MVN stream's sender, refusals, units; the
    /// person's calibration of an MVN or TF stream).
    fn input_values(&self) -> Vec<(String, String)> {
        let mut values = self
            .mvn
            .as_ref()
            .map(MvnInput::status_values)
            .unwrap_or_default();
        if let Some(t) = &self.tf {
            values.push(("calibration".into(), t.calibration_status()));
        }
        values
    }

    /// Waits for the input, the next stale deadline or the next status tick.
    fn wait(&mut self) -> Result<(), LiveError> {
        let now = Instant::now();
        let mut wait = self.next_status.saturating_duration_since(now);
        if let (Some(t), false) = (self.last_input, self.stale) {
            wait = wait.min((t + self.timeout).saturating_duration_since(now));
        }
        // A signal (Ctrl-C, SIGTERM) interrupts the wait: the loop then sees the stop flag.
        match self
            .poll
            .poll(&mut self.events, Some(wait.min(Duration::from_millis(100))))
        {
            Err(e) if e.kind() != std::io::ErrorKind::Interrupted => {
                return Err(dds(e.to_string()))
            }
            _ => {}
        }
        Ok(())
    }

    /// The newest waiting message (by stamp) and when it was taken; the others are counted as
    /// superseded, one that cannot be decoded as malformed.
    fn newest(&mut self, log: &mut dyn FnMut(&str)) -> Option<(JointState, Instant)> {
        let mut newest: Option<(JointState, Instant)> = None;
        let input = self.input.as_ref()?;
        loop {
            match input.take() {
                Ok(Some((msg, _info))) => {
                    // The newest by stamp (a later one on a tie): of a pair that arrived
                    // swapped, the older is not the one followed.
                    let stamp = msg.header.stamp.to_ns();
                    match &newest {
                        Some((n, _)) if n.header.stamp.to_ns() > stamp => {
                            self.summary.superseded += 1;
                            continue;
                        }
                        Some(_) => self.summary.superseded += 1,
                        None => {}
                    }
                    newest = Some((msg, Instant::now()));
                }
                Ok(None) => break,
                Err(e) => {
                    *self.summary.dropped.entry("malformed".into()).or_default() += 1;
                    warn_once(
                        &mut self.warned,
                        "malformed",
                        &format!(
                            "a message on {} could not be decoded ({e:?}): dropped",
                            self.options.input_topic
                        ),
                        log,
                    );
                    break;
                }
            }
        }
        newest
    }

    /// Uses a message for every robot, or counts and reports why it is dropped.
    fn use_message(
        &mut self,
        msg: &JointState,
        received: Instant,
        log: &mut dyn FnMut(&str),
    ) -> Result<(), LiveError> {
        let stamp = msg.header.stamp.to_ns();
        if let Some(last) = self.last_stamp {
            // An older pose than the one followed, arriving after it (reordered, or a burst's
            // straggler): following it would move the robot back. Further back than the
            // window, the publisher's clock is taken to have started again.
            if stamp < last && last - stamp <= REORDER_WINDOW_NS {
                *self
                    .summary
                    .dropped
                    .entry("out of order".into())
                    .or_default() += 1;
                warn_once(
                    &mut self.warned,
                    "out of order",
                    &format!(
                        "a message on {} stamped {:.3} s before the one followed: dropped (counted; this is said once)",
                        self.options.input_topic,
                        (last - stamp) as f64 * 1e-9
                    ),
                    log,
                );
                return Ok(());
            }
        }
        match human_frame(msg, &self.human, &mut self.layout, &mut self.h) {
            Err(kind) => {
                *self.summary.dropped.entry(kind.0.to_string()).or_default() += 1;
                warn_once(
                    &mut self.warned,
                    kind.0,
                    &format!("{}: dropped (counted; this is said once)", kind.1),
                    log,
                );
                Ok(())
            }
            Ok(()) => self.follow(msg.header.stamp, received, log),
        }
    }

    /// The human frame in `h` (stamped `stamp`, taken at `received`) through every robot's
    /// model and safety rule, then to the live view.
    fn follow(
        &mut self,
        stamp: Time,
        received: Instant,
        log: &mut dyn FnMut(&str),
    ) -> Result<(), LiveError> {
        if let Some(prev) = self.last_stamp {
            let dt = (stamp.to_ns() - prev) as f64 * 1e-9;
            if dt > 0.0 && dt < 1.0 {
                self.period_s = dt;
            }
        }
        self.last_stamp = Some(stamp.to_ns());
        for (slot, known) in self.slots.iter_mut().zip(&mut self.known) {
            slot.take(&self.h);
            // Not a number (the robots hold) when the pose cannot be reconstructed.
            *known = match slot.model.as_ref() {
                AnyModel::Single(m) => {
                    slot.ok = m.latent_frame(&slot.h, &mut slot.x).is_ok();
                    match slot.ok {
                        true => [
                            m.reconstruction_error(&slot.h, &slot.x).unwrap_or(f64::NAN),
                            m.novelty(&slot.h).unwrap_or(f64::NAN),
                        ],
                        false => [f64::NAN; 2],
                    }
                }
                AnyModel::Parts(m) => {
                    let known = m.known_frame(&slot.h, &mut slot.x);
                    slot.ok = known.is_ok();
                    known.unwrap_or([f64::NAN; 2])
                }
            };
        }
        for r in &mut self.driven {
            let by = match r.model_slot {
                Some(k) => By::Model(&self.slots[k], self.known[k]),
                None => By::Retargeting(&self.h),
            };
            let sent = Sent {
                stamp,
                period_s: self.period_s,
                start: self.start,
            };
            let changed = command(r, by, self.options, sent, log)?;
            self.status_due |= changed;
        }
        self.latencies.push(received.elapsed().as_secs_f64() * 1e6);
        if let Some(v) = self.view.as_mut() {
            // The first robot's latent point (a per-part model's parts side by side; an empty
            // one where the robot is retargeted, no model).
            let latent = match self.driven[0].model_slot.map(|k| &self.slots[k]) {
                Some(l) => l.ok.then_some(&l.x[..]),
                None => Some(&[][..]),
            };
            show(v, &self.driven, &self.h, latent, stamp.to_ns(), log);
        }
        self.summary.frames += 1;
        self.last_input = Some(received);
        if self.stale {
            self.stale = false;
            self.status_due = true;
        }
        Ok(())
    }

    /// Stale input: hold and report.
    fn check_stale(&mut self, log: &mut dyn FnMut(&str)) -> Result<(), LiveError> {
        if let (Some(t), false) = (self.last_input, self.stale) {
            if t.elapsed() > self.timeout {
                self.stale = true;
                self.status_due = true;
                let source = match (self.options.mvn, &self.options.tf) {
                    (Some(a), _) => format!("the MVN stream (udp://{a})"),
                    (None, Some(_)) => "/tf".to_string(),
                    (None, None) => self.options.input_topic.clone(),
                };
                log(&format!(
                    "stale input: no human frame on {source} for {:.0} ms: holding",
                    self.timeout.as_secs_f64() * 1e3
                ));
                for r in &mut self.driven {
                    // The hold is a command sent now: the next one moves within the velocity
                    // limits over the time since its send ended.
                    let now_s = self.start.elapsed().as_secs_f64();
                    if let Some(d) = r.gate.stale(now_s, &mut r.command) {
                        let stamp = Time::from_ns(self.last_stamp.unwrap_or(0));
                        publish(r, self.options, stamp, self.period_s, self.start)?;
                        r.last = Some(d);
                    }
                }
            }
        }
        Ok(())
    }

    /// The last status and what the run did.
    pub(super) fn finish(mut self, log: &mut dyn FnMut(&str)) -> Result<TeleopSummary, LiveError> {
        let input = self.input_values();
        publish_status(
            &self.status,
            &self.driven,
            &self.summary,
            self.stale,
            &input,
            log,
        )?;
        self.summary.latency = Latency::of(std::mem::take(&mut self.latencies));
        self.summary.mvn = self.mvn.as_ref().map(MvnInput::summary);
        self.summary.tf = self.tf.as_ref().map(TfInput::summary);
        for r in &self.driven {
            let c = r.gate.counts();
            self.summary.robots.insert(
                r.drive.robot.clone(),
                RobotSummary {
                    untrusted: c.untrusted,
                    position_clamped: c.position_clamped,
                    velocity_clamped: c.velocity_clamped,
                    stale: c.stale,
                    collision_limited: c.collision_limited,
                    threshold: r.gate.threshold(),
                    reconstruction_threshold: r.gate.thresholds().reconstruction,
                    novelty_threshold: r.gate.thresholds().novelty,
                },
            );
        }
        Ok(self.summary)
    }
}

/// How far back a JointState stamp may go behind the last one followed and be dropped as out
/// of order, nanoseconds; further back, the publisher's clock started again (its frames are
/// followed).
const REORDER_WINDOW_NS: i64 = 1_000_000_000;

/// Logs `text` the first time `kind` happens.
fn warn_once(warned: &mut Vec<String>, kind: &str, text: &str, log: &mut dyn FnMut(&str)) {
    if !warned.iter().any(|k| k == kind) {
        warned.push(kind.to_string());
        log(&format!("warning: {text}"));
    }
}

/// The model's human joints of `msg` into `h`, or why the message is dropped (kind, text).
fn human_frame(
    msg: &JointState,
    human: &[String],
    layout: &mut (Vec<String>, Vec<usize>),
    h: &mut [f64],
) -> Result<(), (&'static str, String)> {
    if msg.position.len() != msg.name.len() {
        return Err((
            "malformed",
            format!(
                "a message with {} names and {} positions",
                msg.name.len(),
                msg.position.len()
            ),
        ));
    }
    if layout.0 != msg.name {
        if let Some(unknown) = msg.name.iter().find(|n| !human.contains(n)) {
            return Err(("unknown names", format!("a message with the unknown joint `{unknown}` (the model takes the human model's {} joints)", human.len())));
        }
        let mut at = Vec::with_capacity(human.len());
        for j in human {
            match msg.name.iter().position(|n| n == j) {
                Some(k) => at.push(k),
                None => {
                    return Err((
                        "missing joints",
                        format!("a message missing the joint `{j}`"),
                    ))
                }
            }
        }
        *layout = (msg.name.clone(), at);
    }
    for (v, &k) in h.iter_mut().zip(&layout.1) {
        *v = msg.position[k];
    }
    if let Some(k) = h.iter().position(|v| !v.is_finite()) {
        return Err(("NaN", format!("a message with {} for `{}`", h[k], human[k])));
    }
    Ok(())
}
