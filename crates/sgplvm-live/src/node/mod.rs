//! `sgplvm teleop`'s ROS 2 participant: the human's `sensor_msgs/msg/JointState` in, each
//! robot's command out, through the model and the safety rule ([`crate::gate`]), with a
//! `diagnostic_msgs/msg/DiagnosticArray` status.
//!
//! One thread: a mio poll waits for the input subscription (or the next stale deadline, or the
//! next status tick); every waiting message is taken and only the newest is used (the input is
//! a stream of poses; a late one is worth nothing).

//!
//! The module's parts: `dds` (QoS, names, the participant, the command publishers), `drive`
//! (each robot checked against its model, with its safety rule and publisher), `session` (the
//! loop, one wake-up at a time) and `status` (the `DiagnosticArray`).

mod dds;
mod drive;
mod mvn_input;
mod session;
mod status;
mod step;
mod tf_input;

use std::collections::BTreeMap;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

use ros2_client::dds::{Node, Publisher, Subscription};
use serde::Serialize;
use sgplvm_core::AnyModel;
use sgplvm_robots::Anatomy;

use crate::commands::CommandForm;
use crate::gate::GateOptions;
use crate::msgs::{types, DiagnosticArray, JointState};
use crate::LiveError;
use dds::{dds, type_of};
pub(crate) use dds::{new_node, new_node_on, qos, topic_name};
use drive::{drive_all, human_joints, start_view};
use session::{Parts, Session};

/// One robot the node drives, with the model that predicts for it and its URDF (limits).
#[derive(Clone)]
pub struct Drive {
    /// The robot's name: a robot space of `model`.
    pub robot: String,
    /// The model; `None`: the robot is driven by whole-arm retargeting of each frame (the
    /// human model's joints in, no model, nothing gated by trust; the velocity limits and the
    /// self-collision limit as for a model's robot). A latent space per body part drives it
    /// too: its gate's signals are then each part's over that part's thresholds.
    pub model: Option<Arc<AnyModel>>,
    /// The robot's anatomy: its URDF (joint limits, the live view), the joints its commands
    /// name and the hold values of those the model does not predict.
    pub anatomy: Anatomy,
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
    /// The addresses of the network interfaces DDS uses for multicast and announces in
    /// discovery (`--dds-interface`); every interface when empty.
    pub dds_interfaces: Vec<std::net::IpAddr>,
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
    /// For `forward`: the controller's joint order, a permutation of the robot's command joints
    /// (default: the URDF's order of the command joints).
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
    /// Take the human from an Xsens MVN stream on this UDP address (each frame fitted as
    /// `sgplvm import` fits a file's) instead of the JointState topic.
    pub mvn: Option<std::net::SocketAddr>,
    /// Whose MVN datagrams drive the robots (`--mvn-from`; default: the first sender's,
    /// locked).
    pub mvn_from: crate::mvn::Senders,
    /// Take the human from a skeleton's TF frames on `/tf` and `/tf_static` (each complete set
    /// fitted as `sgplvm import` fits a file's frame) instead of the JointState topic.
    pub tf: Option<TfInputOptions>,
    /// How the person of a stream (MVN, TF) is calibrated: the calibrations offered (the
    /// models' training data's, or the user's file) and how long to watch the motion.
    pub calibration: sgplvm_capture::StreamCalibrationOptions,
    /// Whether each model takes the person's clavicles aligned to its people
    /// ([`sgplvm_capture::girdle::GirdleAlignment`]: each arm's mean clavicle angles over the
    /// frames so far moved to the model's people's, the shoulder turned to keep the arm's pose),
    /// as `predict` and `evaluate` give them by default.
    pub align_girdle: bool,
}

/// How the TF input finds the arms.
#[derive(Debug, Clone, Default)]
pub struct TfInputOptions {
    /// The arms' frames named explicitly (as `sgplvm import --map`); `None`: by the importer's
    /// naming schemes.
    pub map: Option<sgplvm_capture::ArmMap>,
}

impl Default for TeleopOptions {
    fn default() -> Self {
        TeleopOptions {
            domain_id: 0,
            dds_interfaces: Vec::new(),
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
            mvn: None,
            mvn_from: crate::mvn::Senders::First,
            tf: None,
            calibration: sgplvm_capture::StreamCalibrationOptions::default(),
            align_girdle: true,
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
    /// With an MVN input: its datagrams, frames and the fit's residuals.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub mvn: Option<mvn_input::MvnSummary>,
    /// With a TF input: its messages, frame sets (used, superseded, incomplete) and the fit's
    /// residuals.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub tf: Option<tf_input::TfSummary>,
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
    /// Commands the self-collision limit moved.
    pub collision_limited: usize,
    /// The trust threshold used (standardised standard deviation).
    pub threshold: f64,
    /// The reconstruction threshold used (radians, RMS over the human's joints).
    pub reconstruction_threshold: f64,
    /// The novelty threshold used (RMS over the human's joints of each joint's spreads).
    pub novelty_threshold: f64,
}

/// Runs the node until `stop` is set (or `max_frames` input frames were used, or its input
/// stopped for 5 s short of them); `log` receives
/// one line per warning and state change.
pub fn teleop(
    drives: Vec<Drive>,
    options: &TeleopOptions,
    stop: &AtomicBool,
    log: &mut dyn FnMut(&str),
) -> Result<TeleopSummary, LiveError> {
    let human = human_joints(&drives)?;
    let mut node = new_node_on(options.domain_id, "sgplvm_teleop", &options.dds_interfaces)?;
    if !options.dds_interfaces.is_empty() {
        let ips: Vec<String> = options
            .dds_interfaces
            .iter()
            .map(|ip| ip.to_string())
            .collect();
        log(&format!(
            "DDS: domain {}, multicast and discovery on the interface(s) of {} only",
            options.domain_id,
            ips.join(", ")
        ));
    }
    let status = status_publisher(&mut node, options)?;
    let (driven, slots) = drive_all(&mut node, drives, options, log)?;
    // The JointState topic is the input only when no other is named: a publisher on it must
    // not drive the robots alongside a suit or a skeleton. Subscribed once every robot is ready
    // (its collision model made): a sender that waits to be matched sends nothing that is lost.
    let input = match (options.mvn, &options.tf) {
        (None, None) => Some(subscribe_input(&mut node, options)?),
        _ => None,
    };
    let view = start_view(options, &driven, &human, log)?;
    let mvn = options
        .mvn
        .map(|addr| {
            let m = mvn_input::MvnInput::bind(
                addr,
                options.mvn_from,
                &human,
                options.calibration.clone(),
            )?;
            if let Ok(a) = m.receiver.local_addr() {
                log(&format!(
                    "input: Xsens MVN stream on udp://{a}, pose datagrams from {}",
                    match options.mvn_from {
                        crate::mvn::Senders::First =>
                            "the first sender's host only (locked; --mvn-from names one)"
                                .to_string(),
                        named => named.to_string(),
                    }
                ));
            }
            Ok::<_, LiveError>(m)
        })
        .transpose()?;
    if options.mvn.is_some() && options.tf.is_some() {
        return Err(LiveError::Config(
            "one human input at a time: MVN or TF, not both".into(),
        ));
    }
    let tf = options
        .tf
        .as_ref()
        .map(|t| {
            log("input: TF frames on /tf and /tf_static");
            tf_input::TfInput::subscribe(
                &mut node,
                &human,
                t.map.clone(),
                options.calibration.clone(),
            )
        })
        .transpose()?;
    let parts = Parts {
        human,
        mvn,
        tf,
        input,
        status,
        driven,
        slots,
        view,
    };
    let mut session = Session::new(options, parts)?;
    while !stop.load(Ordering::Relaxed) && options.max_frames.is_none_or(|m| session.frames() < m) {
        session.step(log)?;
        // A run of a bounded number of frames ends when its input has ended short of them (a
        // sender that started before the node listened, a recording shorter than asked):
        // not held forever.
        if let (Some(m), Some(idle)) = (options.max_frames, session.since_input()) {
            if idle > BOUNDED_RUN_IDLE {
                let calibrating = session.calibrating().map_or(String::new(), |c| {
                    format!(" (it ended while {c}; --calibration FILE or --calibration-seconds 0 commands from the first frame)")
                });
                log(&format!(
                    "stopping after {} of the {m} frames asked: no input for {:.0} s{calibrating}",
                    session.frames(),
                    idle.as_secs_f64()
                ));
                break;
            }
        }
    }
    session.finish(log)
}

/// How long a run with `max_frames` waits for more input once its input has stopped.
const BOUNDED_RUN_IDLE: std::time::Duration = std::time::Duration::from_secs(5);

/// The subscription to the human's JointState topic.
fn subscribe_input(
    node: &mut Node,
    options: &TeleopOptions,
) -> Result<Subscription<JointState>, LiveError> {
    let input_topic = node
        .create_topic(
            &topic_name(&options.input_topic)?,
            type_of(types::JOINT_STATE),
            &qos(options.input_qos),
        )
        .map_err(|e| dds(format!("{e:?}")))?;
    node.create_subscription(&input_topic, Some(qos(options.input_qos)))
        .map_err(|e| dds(format!("{e:?}")))
}

/// The publisher of the status topic.
fn status_publisher(
    node: &mut Node,
    options: &TeleopOptions,
) -> Result<Publisher<DiagnosticArray>, LiveError> {
    let status_topic = node
        .create_topic(
            &topic_name(&options.status_topic)?,
            type_of(types::DIAGNOSTIC_ARRAY),
            &qos(Reliability::Reliable),
        )
        .map_err(|e| dds(format!("{e:?}")))?;
    node.create_publisher(&status_topic, None)
        .map_err(|e| dds(format!("{e:?}")))
}
