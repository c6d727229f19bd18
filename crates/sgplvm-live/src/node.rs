//! `sgplvm teleop`'s ROS 2 participant: the human's `sensor_msgs/msg/JointState` in, each
//! robot's command out, through the model and the safety rule ([`crate::gate`]), with a
//! `diagnostic_msgs/msg/DiagnosticArray` status.
//!
//! One thread: a mio poll waits for the input subscription (or the next stale deadline, or the
//! next status tick); every waiting message is taken and only the newest is used (the input is
//! a stream of poses; a late one is worth nothing).

use std::collections::BTreeMap;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use ros2_client::dds::rustdds::mio1::{Events, Interest, Poll, Token};
use ros2_client::dds::{Context, ContextOptions, Node, Publisher, Subscription};
use ros2_client::qos::{Durability, History, WhenFull};
use ros2_client::{MessageTypeName, Name, NodeName, NodeOptions, QosProfile};
use serde::Serialize;
use sgplvm_core::SharedGplvm;
use sgplvm_robots::limits::CommandLimits;
use sgplvm_robots::Robot;

use crate::commands::{Command, CommandForm};
use crate::gate::{Decision, Gate, GateOptions, Reason};
use crate::msgs::{
    types, DiagnosticArray, DiagnosticStatus, Header, JointState, KeyValue, Time, OK, STALE, WARN,
};
use crate::LiveError;

/// One robot the node drives, with the model that predicts for it and its URDF (limits).
#[derive(Clone)]
pub struct Drive {
    /// The robot's name: a robot space of `model`.
    pub robot: String,
    /// The model.
    pub model: Arc<SharedGplvm>,
    /// The robot's body (for its joint limits).
    pub body: Robot,
}

/// Quality of service of one side of the node.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Reliability {
    /// Best effort, keep last 1 (ROS 2's sensor-data profile).
    BestEffort,
    /// Reliable, keep last 10.
    Reliable,
}

/// How the node runs.
#[derive(Debug, Clone)]
pub struct TeleopOptions {
    /// DDS domain (ROS 2's `ROS_DOMAIN_ID`).
    pub domain_id: u16,
    /// The human's JointState topic.
    pub input_topic: String,
    /// QoS of the input (default: the sensor-data profile).
    pub input_qos: Reliability,
    /// The command's message.
    pub form: CommandForm,
    /// Command topic; `{robot}` is replaced by the robot's name. `None`: the form's default.
    pub command_topic: Option<String>,
    /// QoS of the commands (default: reliable).
    pub command_qos: Reliability,
    /// For `forward`: the controller's joint order (default: the URDF's order of the model's
    /// joints).
    pub joint_order: Option<Vec<String>>,
    /// The safety rule's parameters.
    pub gate: GateOptions,
    /// The status topic.
    pub status_topic: String,
    /// Stop after this many input frames (tests, benchmarks).
    pub max_frames: Option<usize>,
    /// Seconds between status messages when nothing changes.
    pub status_period_s: f64,
    /// Serve the live view (Foxglove WebSocket) on this address.
    pub view: Option<std::net::SocketAddr>,
}

impl Default for TeleopOptions {
    fn default() -> Self {
        TeleopOptions {
            domain_id: 0,
            input_topic: "/human/joint_states".into(),
            input_qos: Reliability::BestEffort,
            form: CommandForm::JointState,
            command_topic: None,
            command_qos: Reliability::Reliable,
            joint_order: None,
            gate: GateOptions::default(),
            status_topic: "/sgplvm/status".into(),
            max_frames: None,
            status_period_s: 1.0,
            view: None,
        }
    }
}

/// Per-frame receive-to-publish times, microseconds.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct Latency {
    /// Frames measured.
    pub frames: usize,
    /// Median.
    pub p50_us: f64,
    /// 99th percentile.
    pub p99_us: f64,
    /// Largest.
    pub max_us: f64,
}

impl Latency {
    fn of(mut v: Vec<f64>) -> Latency {
        if v.is_empty() {
            return Latency::default();
        }
        v.sort_by(|a, b| a.total_cmp(b));
        let at = |p: f64| v[((p * v.len() as f64).ceil() as usize).clamp(1, v.len()) - 1];
        Latency {
            frames: v.len(),
            p50_us: at(0.5),
            p99_us: at(0.99),
            max_us: v[v.len() - 1],
        }
    }
}

/// What a run did.
#[derive(Debug, Clone, Default, Serialize)]
pub struct TeleopSummary {
    /// Input frames used.
    pub frames: usize,
    /// Input messages dropped, by kind (`NaN`, `missing joints`, `unknown names`, `malformed`).
    pub dropped: BTreeMap<String, usize>,
    /// Messages taken but superseded by a newer one before they were used.
    pub superseded: usize,
    /// Receive-to-publish time per frame (all robots' commands published).
    pub latency: Latency,
    /// Per robot: the rule's counts.
    pub robots: BTreeMap<String, RobotSummary>,
}

/// One robot's counts.
#[derive(Debug, Clone, Default, Serialize)]
pub struct RobotSummary {
    /// Frames not trusted.
    pub untrusted: usize,
    /// Commands the position limits moved.
    pub position_clamped: usize,
    /// Commands the velocity limits slowed.
    pub velocity_clamped: usize,
    /// Times the input went stale.
    pub stale: usize,
    /// The trust threshold used (standardised standard deviation).
    pub threshold: f64,
}

/// A publisher of one command form.
enum CommandPublisher {
    JointState(Publisher<JointState>),
    Forward(Publisher<crate::msgs::Float64MultiArray>),
    Trajectory(Publisher<crate::msgs::JointTrajectory>),
    Xbot(Publisher<crate::msgs::XbotJointCommand>),
}

impl CommandPublisher {
    fn publish(&self, c: Command, topic: &str) -> Result<(), LiveError> {
        let fail = |e: String| LiveError::Publish {
            topic: topic.to_string(),
            message: e,
        };
        match (self, c) {
            (CommandPublisher::JointState(p), Command::JointState(m)) => {
                p.publish(m).map_err(|e| fail(format!("{e:?}")))
            }
            (CommandPublisher::Forward(p), Command::Forward(m)) => {
                p.publish(m).map_err(|e| fail(format!("{e:?}")))
            }
            (CommandPublisher::Trajectory(p), Command::Trajectory(m)) => {
                p.publish(m).map_err(|e| fail(format!("{e:?}")))
            }
            (CommandPublisher::Xbot(p), Command::Xbot(m)) => {
                p.publish(m).map_err(|e| fail(format!("{e:?}")))
            }
            _ => Err(fail("a command of another form".into())),
        }
    }
}

/// The QoS profile of `r`.
pub(crate) fn qos(r: Reliability) -> QosProfile {
    match r {
        Reliability::BestEffort => QosProfile::subscription_default()
            .reliability_best_effort()
            .durability(Durability::Volatile)
            .history(History::KeepLast { depth: 1 }),
        Reliability::Reliable => QosProfile::publisher_default()
            .reliability_reliable(WhenFull::DEFAULT)
            .durability(Durability::Volatile)
            .history(History::KeepLast { depth: 10 }),
    }
}

/// A ROS 2 name from an absolute or relative topic name.
pub(crate) fn topic_name(topic: &str) -> Result<Name, LiveError> {
    let t = topic.trim_start_matches('/');
    let (ns, base) = match t.rsplit_once('/') {
        Some((ns, base)) => (format!("/{ns}"), base),
        None => ("/".to_string(), t),
    };
    Name::new(&ns, base).map_err(|e| LiveError::Name {
        name: topic.to_string(),
        message: format!("{e:?}"),
    })
}

/// A ROS 2 node with the given name.
pub(crate) fn new_node(domain_id: u16, name: &str) -> Result<Node, LiveError> {
    let dds = |e: String| LiveError::Dds { message: e };
    let context = Context::with_options(ContextOptions::new().domain_id(domain_id))
        .map_err(|e| dds(format!("{e:?}")))?;
    let node_name = NodeName::new("/", name).map_err(|e| dds(format!("{e:?}")))?;
    context
        .new_node(node_name, NodeOptions::new().enable_rosout(false))
        .map_err(|e| dds(format!("{e:?}")))
}

/// One robot as the node drives it.
struct Driven {
    drive: Drive,
    /// The model's joint names for the robot (its output columns).
    joints: Vec<String>,
    /// Positions of the model's joints in the sent order.
    order: Vec<usize>,
    /// The names in the sent order.
    sent_names: Vec<String>,
    gate: Gate,
    publisher: CommandPublisher,
    topic: String,
    mean: Vec<f64>,
    sd: Vec<f64>,
    command: Vec<f64>,
    sent: Vec<f64>,
    last: Option<Decision>,
    /// Which of the distinct models (their latent points per frame) drives this robot.
    model_slot: usize,
}

/// A distinct model among the robots' and its latent point of the current frame (computed once
/// per frame for all the robots it drives).
struct LatentSlot {
    model: std::sync::Arc<SharedGplvm>,
    x: Vec<f64>,
    ok: bool,
}

/// The human's joint names of the models (all must agree).
fn human_joints(drives: &[Drive]) -> Result<Vec<String>, LiveError> {
    let names = |m: &SharedGplvm| -> Vec<String> {
        let input = m.input_name().to_string();
        m.column_names(&input)
            .map(<[String]>::to_vec)
            .unwrap_or_else(|| {
                (0..m.space_dim(&input).unwrap_or(0))
                    .map(|j| format!("{input}_{j}"))
                    .collect()
            })
    };
    let first = drives
        .first()
        .ok_or_else(|| LiveError::Config("no robot to drive".into()))?;
    let h = names(&first.model);
    for d in &drives[1..] {
        if names(&d.model) != h {
            return Err(LiveError::Config(format!(
                "the models for {} and {} take different human joints",
                first.robot, d.robot
            )));
        }
    }
    Ok(h)
}

/// Runs the node until `stop` is set (or `max_frames` input frames were used); `log` receives
/// one line per warning and state change.
pub fn teleop(
    drives: Vec<Drive>,
    options: &TeleopOptions,
    stop: &AtomicBool,
    log: &mut dyn FnMut(&str),
) -> Result<TeleopSummary, LiveError> {
    let human = human_joints(&drives)?;
    let mut node = new_node(options.domain_id, "sgplvm_teleop")?;
    let dds = |e: String| LiveError::Dds { message: e };
    let type_of = |(pkg, name): (&str, &str)| MessageTypeName::new(pkg, name);
    let input_topic = node
        .create_topic(
            &topic_name(&options.input_topic)?,
            type_of(types::JOINT_STATE),
            &qos(options.input_qos),
        )
        .map_err(|e| dds(format!("{e:?}")))?;
    let mut input: Subscription<JointState> = node
        .create_subscription(&input_topic, Some(qos(options.input_qos)))
        .map_err(|e| dds(format!("{e:?}")))?;
    let status_topic = node
        .create_topic(
            &topic_name(&options.status_topic)?,
            type_of(types::DIAGNOSTIC_ARRAY),
            &qos(Reliability::Reliable),
        )
        .map_err(|e| dds(format!("{e:?}")))?;
    let status: Publisher<DiagnosticArray> = node
        .create_publisher(&status_topic, None)
        .map_err(|e| dds(format!("{e:?}")))?;
    let shared = drives.len() > 1;
    let mut driven = Vec::with_capacity(drives.len());
    let mut slots: Vec<LatentSlot> = Vec::new();
    for drive in drives {
        let model = &drive.model;
        let model_slot = match slots
            .iter()
            .position(|s| std::sync::Arc::ptr_eq(&s.model, model))
        {
            Some(k) => k,
            None => {
                slots.push(LatentSlot {
                    model: model.clone(),
                    x: vec![0.0; model.latent_points().ncols()],
                    ok: false,
                });
                slots.len() - 1
            }
        };
        if !model.output_names().contains(&drive.robot.as_str()) {
            return Err(LiveError::Config(format!(
                "the model does not know robot `{}`; it predicts for {:?}",
                drive.robot,
                model.output_names()
            )));
        }
        let joints: Vec<String> = model
            .column_names(&drive.robot)
            .map(<[String]>::to_vec)
            .ok_or_else(|| {
                LiveError::Config(format!("the model names no joints for `{}`", drive.robot))
            })?;
        let sent_names = match (options.form, &options.joint_order) {
            (CommandForm::Forward, Some(order)) => order.clone(),
            (CommandForm::Forward, None) => drive
                .body
                .joint_names()
                .into_iter()
                .filter(|n| joints.contains(n))
                .collect(),
            _ => joints.clone(),
        };
        let order: Vec<usize> = sent_names
            .iter()
            .map(|n| {
                joints.iter().position(|j| j == n).ok_or_else(|| {
                    LiveError::Config(format!(
                        "--joints names `{n}`, which is not a joint of `{}`'s model: {joints:?}",
                        drive.robot
                    ))
                })
            })
            .collect::<Result<_, _>>()?;
        if order.len() != joints.len() {
            return Err(LiveError::Config(format!(
                "`{}`: the command names {} joints, the model predicts {}",
                drive.robot,
                order.len(),
                joints.len()
            )));
        }
        let limits = CommandLimits::for_joints(&drive.body, &joints)
            .map_err(|e| LiveError::Config(e.to_string()))?;
        let threshold = match options.gate.threshold {
            Some(t) => t,
            None => model
                .trust_threshold(&drive.robot)
                .map_err(|e| LiveError::Config(e.to_string()))?,
        } * options.gate.threshold_scale;
        let topic = match &options.command_topic {
            Some(t) => t.replace("{robot}", &drive.robot),
            None => options.form.default_topic(&drive.robot, shared),
        };
        let t = node
            .create_topic(
                &topic_name(&topic)?,
                type_of(options.form.type_name()),
                &qos(options.command_qos),
            )
            .map_err(|e| dds(format!("{e:?}")))?;
        let q = Some(qos(options.command_qos));
        let publisher = match options.form {
            CommandForm::JointState => CommandPublisher::JointState(
                node.create_publisher(&t, q)
                    .map_err(|e| dds(format!("{e:?}")))?,
            ),
            CommandForm::Forward => CommandPublisher::Forward(
                node.create_publisher(&t, q)
                    .map_err(|e| dds(format!("{e:?}")))?,
            ),
            CommandForm::Trajectory => CommandPublisher::Trajectory(
                node.create_publisher(&t, q)
                    .map_err(|e| dds(format!("{e:?}")))?,
            ),
            CommandForm::Xbot => CommandPublisher::Xbot(
                node.create_publisher(&t, q)
                    .map_err(|e| dds(format!("{e:?}")))?,
            ),
        };
        let d = joints.len();
        log(&format!(
            "{}: {} joints as {} on {topic}; trust threshold {threshold:.4}",
            drive.robot,
            d,
            options.form.name()
        ));
        driven.push(Driven {
            gate: Gate::new(limits, threshold, options.gate.return_speed),
            drive,
            joints,
            order,
            sent_names,
            publisher,
            topic,
            mean: vec![0.0; d],
            sd: vec![0.0; d],
            command: vec![0.0; d],
            sent: vec![0.0; d],
            last: None,
            model_slot,
        });
    }
    let mut view = match options.view {
        Some(addr) => {
            let robots = driven
                .iter()
                .map(|r| crate::view::ViewRobot {
                    name: r.drive.robot.clone(),
                    body: r.drive.body.clone(),
                    joints: r.joints.clone(),
                })
                .collect();
            let q = driven[0].drive.model.latent_points().ncols();
            let v = crate::view::LiveView::start(addr, human.clone(), robots, q)?;
            log(&format!(
                "live view: Foxglove WebSocket on ws://{}:{}",
                addr.ip(),
                v.port()
            ));
            Some(v)
        }
        None => None,
    };
    let mut poll = Poll::new().map_err(|e| dds(e.to_string()))?;
    poll.registry()
        .register(&mut input, Token(0), Interest::READABLE)
        .map_err(|e| dds(e.to_string()))?;
    let mut events = Events::with_capacity(8);
    let start = Instant::now();
    let mut summary = TeleopSummary::default();
    let mut warned: Vec<String> = Vec::new();
    let mut latencies: Vec<f64> = Vec::new();
    let mut h = vec![0.0; human.len()];
    // The names of the last message and where each model joint is among them.
    let mut layout: (Vec<String>, Vec<usize>) = (Vec::new(), Vec::new());
    let mut last_input: Option<Instant> = None;
    let mut last_stamp: Option<i64> = None;
    let mut period_s = 0.025;
    let mut stale = false;
    let mut next_status = Instant::now();
    let timeout = Duration::from_secs_f64(options.gate.timeout_s.max(1e-3));
    let status_period = Duration::from_secs_f64(options.status_period_s.max(0.01));
    let mut status_due = true;
    while !stop.load(Ordering::Relaxed) && options.max_frames.is_none_or(|m| summary.frames < m) {
        let now = Instant::now();
        let mut wait = next_status.saturating_duration_since(now);
        if let (Some(t), false) = (last_input, stale) {
            wait = wait.min((t + timeout).saturating_duration_since(now));
        }
        // A signal (Ctrl-C, SIGTERM) interrupts the wait: the loop then sees the stop flag.
        match poll.poll(&mut events, Some(wait.min(Duration::from_millis(100)))) {
            Err(e) if e.kind() != std::io::ErrorKind::Interrupted => {
                return Err(dds(e.to_string()))
            }
            _ => {}
        }
        // The newest waiting message.
        let mut newest: Option<(JointState, Instant)> = None;
        loop {
            match input.take() {
                Ok(Some((msg, _info))) => {
                    if newest.is_some() {
                        summary.superseded += 1;
                    }
                    newest = Some((msg, Instant::now()));
                }
                Ok(None) => break,
                Err(e) => {
                    *summary.dropped.entry("malformed".into()).or_default() += 1;
                    warn_once(
                        &mut warned,
                        "malformed",
                        &format!(
                            "a message on {} could not be decoded ({e:?}): dropped",
                            options.input_topic
                        ),
                        log,
                    );
                    break;
                }
            }
        }
        if let Some((msg, received)) = newest {
            match human_frame(&msg, &human, &mut layout, &mut h) {
                Err(kind) => {
                    *summary.dropped.entry(kind.0.to_string()).or_default() += 1;
                    warn_once(
                        &mut warned,
                        kind.0,
                        &format!("{}: dropped (counted; this is said once)", kind.1),
                        log,
                    );
                }
                Ok(()) => {
                    let stamp = msg.header.stamp;
                    if let Some(prev) = last_stamp {
                        let dt = (stamp.to_ns() - prev) as f64 * 1e-9;
                        if dt > 0.0 && dt < 1.0 {
                            period_s = dt;
                        }
                    }
                    last_stamp = Some(stamp.to_ns());
                    let now_s = received.duration_since(start).as_secs_f64();
                    for slot in &mut slots {
                        slot.ok = slot.model.latent_frame(&h, &mut slot.x).is_ok();
                    }
                    for r in &mut driven {
                        // A prediction that fails (not a number) is not trusted: the robot holds.
                        let slot = &slots[r.model_slot];
                        let sd = match slot.ok {
                            true => slot
                                .model
                                .predict_latent_sd(&slot.x, &r.drive.robot, &mut r.mean, &mut r.sd)
                                .unwrap_or(f64::NAN),
                            false => f64::NAN,
                        };
                        let decision = r.gate.step(now_s, &r.mean, sd, &mut r.command);
                        if decision.reason != Reason::Waiting {
                            for (k, &j) in r.order.iter().enumerate() {
                                r.sent[k] = r.command[j];
                            }
                            let c = Command::build(
                                options.form,
                                &r.sent_names,
                                &r.sent,
                                stamp,
                                period_s,
                            );
                            r.publisher.publish(c, &r.topic)?;
                        }
                        if decision.changed {
                            status_due = true;
                            log(&format!(
                                "{}: {} (sd {:.4}, threshold {:.4})",
                                r.drive.robot,
                                decision.reason.as_str(),
                                sd,
                                r.gate.threshold()
                            ));
                        }
                        r.last = Some(decision);
                    }
                    latencies.push(received.elapsed().as_secs_f64() * 1e6);
                    if let Some(v) = view.as_mut() {
                        let latent = &slots[driven[0].model_slot];
                        show(
                            v,
                            &driven,
                            &h,
                            latent.ok.then_some(&latent.x[..]),
                            stamp.to_ns(),
                            log,
                        );
                    }
                    summary.frames += 1;
                    last_input = Some(received);
                    if stale {
                        stale = false;
                        status_due = true;
                    }
                }
            }
        }
        // Stale input: hold and report.
        if let (Some(t), false) = (last_input, stale) {
            if t.elapsed() > timeout {
                stale = true;
                status_due = true;
                log(&format!(
                    "stale input: no human frame on {} for {:.0} ms: holding",
                    options.input_topic,
                    timeout.as_secs_f64() * 1e3
                ));
                for r in &mut driven {
                    if let Some(d) = r.gate.stale(&mut r.command) {
                        for (k, &j) in r.order.iter().enumerate() {
                            r.sent[k] = r.command[j];
                        }
                        let stamp = Time::from_ns(last_stamp.unwrap_or(0));
                        r.publisher.publish(
                            Command::build(options.form, &r.sent_names, &r.sent, stamp, period_s),
                            &r.topic,
                        )?;
                        r.last = Some(d);
                    }
                }
            }
        }
        if status_due || Instant::now() >= next_status {
            publish_status(&status, &driven, &summary, stale, log)?;
            status_due = false;
            next_status = Instant::now() + status_period;
        }
    }
    publish_status(&status, &driven, &summary, stale, log)?;
    summary.latency = Latency::of(latencies);
    for r in &driven {
        let c = r.gate.counts();
        summary.robots.insert(
            r.drive.robot.clone(),
            RobotSummary {
                untrusted: c.untrusted,
                position_clamped: c.position_clamped,
                velocity_clamped: c.velocity_clamped,
                stale: c.stale,
                threshold: r.gate.threshold(),
            },
        );
    }
    Ok(summary)
}

/// Sends one frame to the live view (after the commands: it is not on their path); a failure
/// is logged, the node goes on.
fn show(
    view: &mut crate::view::LiveView,
    driven: &[Driven],
    h: &[f64],
    latent: Option<&[f64]>,
    time_ns: i64,
    log: &mut dyn FnMut(&str),
) {
    let state = |d: Option<Decision>| match d.map(|d| d.reason) {
        Some(Reason::Following) | None => 0.0,
        Some(Reason::Holding) => 1.0,
        Some(Reason::Returning) => 2.0,
        Some(Reason::Stale) => 3.0,
        Some(Reason::Waiting) => 4.0,
    };
    let robots: Vec<(&[f64], &[f64], [f64; 3])> = driven
        .iter()
        .map(|r| {
            (
                r.command.as_slice(),
                r.sd.as_slice(),
                [
                    r.last.map(|d| d.sd).unwrap_or(f64::NAN),
                    r.gate.threshold(),
                    state(r.last),
                ],
            )
        })
        .collect();
    let sent = match latent {
        Some(x) => view.frame(time_ns, h, &robots, x),
        None => Err(LiveError::View(
            "the frame's latent point is not a number".into(),
        )),
    };
    if let Err(e) = sent {
        log(&format!("warning: {e}"));
    }
}

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

/// Publishes the status: one entry per robot and one for the input.
fn publish_status(
    status: &Publisher<DiagnosticArray>,
    driven: &[Driven],
    summary: &TeleopSummary,
    stale: bool,
    log: &mut dyn FnMut(&str),
) -> Result<(), LiveError> {
    let kv = |k: &str, v: String| KeyValue {
        key: k.into(),
        value: v,
    };
    let mut entries = Vec::with_capacity(driven.len() + 1);
    for r in driven {
        let c = r.gate.counts();
        let (level, message) = match r.last.map(|d| d.reason) {
            None => (OK, "waiting for the first human frame".to_string()),
            Some(Reason::Following) => (OK, "following".to_string()),
            Some(Reason::Stale) => (STALE, "stale input: holding the last command".to_string()),
            Some(reason) => {
                let sd = r.last.map(|d| d.sd).unwrap_or(f64::NAN);
                // The joints the model is least sure of.
                let mut by_sd: Vec<usize> = (0..r.sd.len()).collect();
                by_sd.sort_by(|&a, &b| r.sd[b].total_cmp(&r.sd[a]));
                let worst: Vec<String> = by_sd
                    .iter()
                    .take(3)
                    .map(|&k| format!("{} ({:.3} rad)", r.joints[k], r.sd[k]))
                    .collect();
                (
                    WARN,
                    format!(
                        "{}: prediction sd {sd:.4} above the trust threshold {:.4}; least certain joints: {}",
                        reason.as_str(),
                        r.gate.threshold(),
                        worst.join(", ")
                    ),
                )
            }
        };
        let limited: Vec<String> = match r.last {
            Some(d) if !d.clamped.is_none() => r
                .gate
                .clamped_joints()
                .iter()
                .map(|&k| r.joints[k].clone())
                .collect(),
            _ => Vec::new(),
        };
        entries.push(DiagnosticStatus {
            level,
            name: format!("sgplvm/{}", r.drive.robot),
            message: if limited.is_empty() {
                message
            } else {
                format!("{message}; held within its limits: {}", limited.join(", "))
            },
            hardware_id: r.drive.robot.clone(),
            values: vec![
                kv(
                    "reason",
                    r.last
                        .map(|d| d.reason.as_str())
                        .unwrap_or("waiting")
                        .to_string(),
                ),
                kv(
                    "sd",
                    r.last.map(|d| format!("{:.6}", d.sd)).unwrap_or_default(),
                ),
                kv("threshold", format!("{:.6}", r.gate.threshold())),
                kv("frames", c.frames.to_string()),
                kv("untrusted", c.untrusted.to_string()),
                kv("position_clamped", c.position_clamped.to_string()),
                kv("velocity_clamped", c.velocity_clamped.to_string()),
                kv("stale", c.stale.to_string()),
            ],
        });
    }
    let dropped: usize = summary.dropped.values().sum();
    entries.push(DiagnosticStatus {
        level: if stale {
            STALE
        } else if dropped > 0 {
            WARN
        } else {
            OK
        },
        name: "sgplvm/input".into(),
        message: if stale {
            "stale: no human frame within the timeout".into()
        } else if dropped > 0 {
            format!("{dropped} input message(s) dropped")
        } else {
            "receiving".into()
        },
        hardware_id: "human".into(),
        values: std::iter::once(kv("frames", summary.frames.to_string()))
            .chain(
                summary
                    .dropped
                    .iter()
                    .map(|(k, v)| kv(&format!("dropped: {k}"), v.to_string())),
            )
            .collect(),
    });
    let msg = DiagnosticArray {
        header: Header {
            stamp: Time::from_ns(
                std::time::SystemTime::now()
                    .duration_since(std::time::UNIX_EPOCH)
                    .map(|d| d.as_nanos() as i64)
                    .unwrap_or(0),
            ),
            frame_id: String::new(),
        },
        status: entries,
    };
    if let Err(e) = status.publish(msg) {
        log(&format!(
            "warning: the status could not be published: {e:?}"
        ));
    }
    Ok(())
}
