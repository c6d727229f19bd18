//! `sgplvm teleop`: the trained model as a ROS 2 node driving one or several robots live
//! (`sgplvm replay`, a recorded human published for it, is in `replay.rs`).

use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

use anyhow::{anyhow, bail, Context, Result};
use clap::{Args, ValueEnum};
use sgplvm::provenance::other_robot;
use sgplvm::{AnyModel, Predictor};
use sgplvm_live::gate::Signals;
use sgplvm_live::{CommandForm, Drive, GateOptions, Reliability, TeleopOptions};

use super::args::{load_any_model, JsonArg};
use super::args::{Girdle, GirdleArg};
use super::body::BodyArgs;
use super::calibration::CalibrationArgs;

#[derive(Args)]
pub struct TeleopArgs {
    /// A trained model (repeat for a family of transferred models, one per --robot, in order;
    /// one multi-robot model drives all of its robots).
    #[arg(long, required_unless_present = "retarget")]
    model: Vec<PathBuf>,
    /// Drive the robots by whole-arm retargeting of each frame instead of a model: no training,
    /// the posture `retarget` gives the same pose in a file (about 1 ms a frame per robot),
    /// within the same velocity and self-collision limits; nothing is held for trust.
    #[arg(long, conflicts_with = "model")]
    retarget: bool,
    /// A robot to drive: a robot of its model, or with --retarget a built-in robot or one given
    /// by --urdf (repeat for several).
    #[arg(long, required = true)]
    robot: Vec<String>,
    /// A robot's URDF as its maker publishes it, ROBOT=FILE (its limits bound the commands,
    /// its joints outside the arms are held, the live view draws it) [default: the built-in
    /// robot of that name].
    #[arg(long, value_name = "ROBOT=FILE")]
    urdf: Vec<String>,
    #[command(flatten)]
    body: BodyArgs,
    /// The human's sensor_msgs/msg/JointState topic (joints matched by name, any order).
    #[arg(long, default_value = "/human/joint_states")]
    input_topic: String,
    /// Where the human comes from: `joint-state` (the human model's angles on --input-topic),
    /// `mvn[:ADDR:PORT]` (an Xsens MVN suit's network stream, UDP, pose datagrams 01 or 02;
    /// default 0.0.0.0:9763) or `tf` (a skeleton's tf2_msgs/TFMessage frames on /tf and
    /// /tf_static, named as `sgplvm import` names a file's joints, or by --map), each frame
    /// fitted as `sgplvm import` fits a file's.
    #[arg(long, default_value = "joint-state", value_parser = parse_input)]
    input: HumanInput,
    /// With --input mvn: take pose datagrams only from this sender, IP (any of its ports) or
    /// IP:PORT [default: the host of the first datagram of MVN pose data, locked]. Datagrams
    /// of any other sender are counted, refused and reported on the status topic.
    #[arg(long, value_name = "IP[:PORT]", value_parser = sgplvm_live::mvn::Senders::parse)]
    mvn_from: Option<sgplvm_live::mvn::Senders>,
    /// With --input tf: a JSON map of the human model's joints to the skeleton's frames, as
    /// `sgplvm import --map` takes (e.g. {"jLeftShoulder": "L_UpperArm", ...}).
    #[arg(long, value_name = "FILE")]
    map: Option<PathBuf>,
    #[command(flatten)]
    calibration: CalibrationArgs,
    #[command(flatten)]
    girdle: GirdleArg,
    /// The command's message: joint-state (sensor_msgs/JointState on /ROBOT/joint_command),
    /// forward (std_msgs/Float64MultiArray for ros2_control's forward position controller),
    /// trajectory (trajectory_msgs/JointTrajectory, one point one frame ahead) or xbot
    /// (xbot_msgs/JointCommand on xbotcore/command, XBot2's).
    #[arg(long, default_value = "joint-state", value_parser = parse_form)]
    command: CommandForm,
    /// The command topic; `{robot}` stands for the robot's name [default: by --command; a
    /// controller's topic goes under /ROBOT/ when several robots share the node].
    #[arg(long)]
    command_topic: Option<String>,
    /// The joints each command names, in this order, comma-separated (arm joints and held
    /// ones; e.g. a forward position controller's joints) [default: --command-joints, for
    /// --command forward in the URDF's order].
    #[arg(long, value_delimiter = ',')]
    joints: Option<Vec<String>>,
    /// QoS of the input: best-effort (ROS 2's sensor-data profile, keep last 1) or reliable.
    #[arg(long, value_enum, default_value = "best-effort")]
    input_qos: QosArg,
    /// QoS of the commands.
    #[arg(long, value_enum, default_value = "reliable")]
    command_qos: QosArg,
    /// DDS domain [default: $ROS_DOMAIN_ID, else 0].
    #[arg(long)]
    domain_id: Option<u16>,
    /// Use only the network interface with this address for DDS (multicast, and the addresses
    /// announced in discovery); repeat for several [default: 127.0.0.1 when ROS 2's
    /// ROS_AUTOMATIC_DISCOVERY_RANGE is LOCALHOST or ROS_LOCALHOST_ONLY is 1, else every
    /// interface].
    #[arg(long, value_name = "IP")]
    dds_interface: Vec<std::net::IpAddr>,
    /// Seconds without a human frame after which the robots hold and the status says the input
    /// is stale.
    #[arg(long, default_value_t = 0.1)]
    timeout: f64,
    /// Which signals hold a robot when beyond their thresholds: known (the reconstruction
    /// error or the novelty: a pose the model does not know), reconstruction (how far the
    /// human pose is from the model's reconstruction of it: it sees input far from every
    /// training pose), novelty (how far the pose is from the nearest training pose, each joint
    /// in units of its spread: it sees a pose no one in the training data made), sd (the robot
    /// prediction's standard deviation: larger on any motion the training did not repeat) or
    /// both (sd or reconstruction).
    #[arg(long, value_enum, default_value = "known")]
    gate: GateArg,
    /// The reconstruction threshold (the human space's units, radians) instead of the model's
    /// (the larger of the 99th percentile of its training frames' errors, each reconstructed
    /// with its group of training frames held out, and the mean pose's error on them).
    #[arg(long)]
    reconstruction_threshold: Option<f64>,
    /// The model's reconstruction threshold multiplied by this [default: 1].
    #[arg(long)]
    reconstruction_scale: Option<f64>,
    /// The novelty threshold (RMS over the human's joints, each in units of its spread over the
    /// training poses) instead of the model's (the distance within which 1 % of poses drawn at
    /// random within the human's joint limits fall).
    #[arg(long)]
    novelty_threshold: Option<f64>,
    /// The model's novelty threshold multiplied by this [default: 1].
    #[arg(long)]
    novelty_scale: Option<f64>,
    /// The trust threshold (standardised predictive standard deviation) instead of the model's
    /// (the 99th percentile over its training frames, each predicted with its group of
    /// training frames held out); with --gate sd or both.
    #[arg(long)]
    trust_threshold: Option<f64>,
    /// The model's trust threshold multiplied by this, with --gate sd or both [default: 1].
    #[arg(long)]
    trust_scale: Option<f64>,
    /// Fraction of each joint's velocity limit at which an untrusted robot moves towards its
    /// last trusted target.
    #[arg(long, default_value_t = 0.25)]
    return_speed: f64,
    /// How far apart the robot's own collision shapes stay, metres: every command is the
    /// nearest one that keeps them so (0: no self-collision limit).
    #[arg(long, default_value_t = 0.01)]
    margin: f64,
    /// The status topic (diagnostic_msgs/msg/DiagnosticArray).
    #[arg(long, default_value = "/sgplvm/status")]
    status_topic: String,
    /// Stop after this many human frames, or once the input has stopped for 5 s short of them
    /// (default: run until Ctrl-C or SIGTERM).
    #[arg(long)]
    max_frames: Option<usize>,
    /// Serve a live view for Foxglove (WebSocket, `foxglove.sdk.v1`) on ADDR:PORT [default
    /// when given alone: 127.0.0.1:8765]: the human and the robots as `predict`'s scene files
    /// show them (open with the layout data/foxglove/sgplvm.json), the predictive standard
    /// deviation and each robot's trust.
    #[arg(long, value_name = "ADDR:PORT", num_args = 0..=1, default_missing_value = "127.0.0.1:8765")]
    foxglove: Option<std::net::SocketAddr>,
    #[command(flatten)]
    json: JsonArg,
}

#[derive(Clone, Copy, PartialEq, Eq, ValueEnum)]
pub(super) enum QosArg {
    /// Best effort, keep last 1.
    BestEffort,
    /// Reliable.
    Reliable,
}

/// `--gate`.
#[derive(Clone, Copy, PartialEq, Eq, ValueEnum)]
enum GateArg {
    /// The reconstruction error or the novelty of the human frame.
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

impl TeleopArgs {
    /// The safety rule's parameters; a threshold given for a signal that does not gate is an
    /// error (it would change nothing).
    fn gate(&self) -> Result<GateOptions> {
        let signals = match self.gate {
            GateArg::Known => Signals::Known,
            GateArg::Reconstruction => Signals::Reconstruction,
            GateArg::Novelty => Signals::Novelty,
            GateArg::Sd => Signals::Sd,
            GateArg::Both => Signals::Both,
        };
        let given = |flags: [(&str, Option<f64>); 2], gates: bool, gate: &str| -> Result<()> {
            for (flag, value) in flags {
                if let (Some(v), false) = (value, gates) {
                    let with = match flag.split('-').nth(2) {
                        Some("trust") => "sd or both",
                        Some("novelty") => "known or novelty",
                        _ => "known, reconstruction or both",
                    };
                    bail!("{flag} {v}: that signal does not hold the robots with --gate {gate}; it does with --gate {with}");
                }
                if let Some(v) = value.filter(|v| !(v.is_finite() && *v >= 0.0)) {
                    bail!("{flag} {v}: expected a number ≥ 0");
                }
            }
            Ok(())
        };
        let name = self
            .gate
            .to_possible_value()
            .map(|v| v.get_name().to_string())
            .unwrap_or_default();
        given(
            [
                ("--trust-threshold", self.trust_threshold),
                ("--trust-scale", self.trust_scale),
            ],
            signals.sd(),
            &name,
        )?;
        given(
            [
                ("--reconstruction-threshold", self.reconstruction_threshold),
                ("--reconstruction-scale", self.reconstruction_scale),
            ],
            signals.reconstruction(),
            &name,
        )?;
        given(
            [
                ("--novelty-threshold", self.novelty_threshold),
                ("--novelty-scale", self.novelty_scale),
            ],
            signals.novelty(),
            &name,
        )?;
        Ok(GateOptions {
            signals,
            threshold: self.trust_threshold,
            threshold_scale: self.trust_scale.unwrap_or(1.0),
            reconstruction_threshold: self.reconstruction_threshold,
            reconstruction_scale: self.reconstruction_scale.unwrap_or(1.0),
            novelty_threshold: self.novelty_threshold,
            novelty_scale: self.novelty_scale.unwrap_or(1.0),
            return_speed: self.return_speed,
            timeout_s: self.timeout,
            collision_margin_m: (self.margin > 0.0).then_some(self.margin),
        })
    }
}

impl QosArg {
    pub(super) fn reliability(self) -> Reliability {
        match self {
            QosArg::BestEffort => Reliability::BestEffort,
            QosArg::Reliable => Reliability::Reliable,
        }
    }
}

/// Where the human comes from.
#[derive(Clone, Copy, Debug)]
enum HumanInput {
    /// The JointState topic.
    JointState,
    /// An MVN stream on this UDP address.
    Mvn(std::net::SocketAddr),
    /// TF frames on /tf and /tf_static.
    Tf,
}

/// `joint-state`, `mvn[:ADDR:PORT]` or `tf`.
fn parse_input(s: &str) -> Result<HumanInput, String> {
    match s {
        "joint-state" => Ok(HumanInput::JointState),
        "tf" => Ok(HumanInput::Tf),
        "mvn" => Ok(HumanInput::Mvn(std::net::SocketAddr::from((
            [0, 0, 0, 0],
            9763,
        )))),
        other => match other.strip_prefix("mvn:") {
            Some(addr) => addr
                .parse()
                .map(HumanInput::Mvn)
                .map_err(|_| format!("`{addr}`: expected ADDR:PORT, e.g. 0.0.0.0:9763")),
            None => Err(format!(
                "unknown `{other}`; expected joint-state, mvn[:ADDR:PORT] or tf"
            )),
        },
    }
}

fn parse_form(s: &str) -> Result<CommandForm, String> {
    CommandForm::parse(s)
        .ok_or_else(|| format!("unknown `{s}`; expected joint-state, forward, trajectory or xbot"))
}

/// `--domain-id`, else `ROS_DOMAIN_ID`, else 0.
pub(super) fn domain_id(given: Option<u16>) -> Result<u16> {
    match given {
        Some(d) => Ok(d),
        None => match std::env::var("ROS_DOMAIN_ID") {
            Ok(v) if !v.trim().is_empty() => v
                .trim()
                .parse()
                .map_err(|_| anyhow!("ROS_DOMAIN_ID is `{v}`; expected a domain number (0–232)")),
            _ => Ok(0),
        },
    }
}

/// The interfaces DDS may use: those given, else loopback when ROS 2's environment keeps
/// discovery to this machine, else all (empty).
fn dds_interfaces(given: &[std::net::IpAddr]) -> Vec<std::net::IpAddr> {
    let env = |k: &str| {
        std::env::var(k)
            .unwrap_or_default()
            .trim()
            .to_ascii_uppercase()
    };
    if !given.is_empty() {
        given.to_vec()
    } else if env("ROS_AUTOMATIC_DISCOVERY_RANGE") == "LOCALHOST"
        || env("ROS_LOCALHOST_ONLY") == "1"
    {
        vec![std::net::Ipv4Addr::LOCALHOST.into()]
    } else {
        Vec::new()
    }
}

/// A flag set by Ctrl-C and SIGTERM.
pub(super) fn stop_flag() -> Result<Arc<AtomicBool>> {
    let stop = Arc::new(AtomicBool::new(false));
    let s = stop.clone();
    ctrlc::set_handler(move || s.store(true, Ordering::SeqCst))
        .context("installing the Ctrl-C / SIGTERM handler")?;
    Ok(stop)
}

/// One drive per `--robot`: its model (one for all, or one each; none to retarget) and its
/// body, with `--urdf ROBOT=FILE` where given; a robot other than the one a model learned on is
/// said.
fn drives(args: &TeleopArgs, models: &[Arc<AnyModel>]) -> Result<Vec<Drive>> {
    let model_for = |k: usize| -> Result<Option<Arc<AnyModel>>> {
        match models.len() {
            0 => Ok(None),
            1 => Ok(Some(models[0].clone())),
            n if n == args.robot.len() => Ok(Some(models[k].clone())),
            n => bail!("{n} --model files for {} --robot names: give one model per robot, or one model for all", args.robot.len()),
        }
    };
    let mut urdfs: Vec<(String, PathBuf)> = Vec::new();
    for u in &args.urdf {
        let (robot, file) = u
            .split_once('=')
            .ok_or_else(|| anyhow!("--urdf {u}: expected ROBOT=FILE"))?;
        if !args.robot.iter().any(|r| r == robot) {
            bail!(
                "--urdf {u}: `{robot}` is not one of the --robot names {:?}",
                args.robot
            );
        }
        urdfs.push((robot.to_string(), PathBuf::from(file)));
    }
    let names: Vec<&str> = args.robot.iter().map(String::as_str).collect();
    args.body.check_robots(&names)?;
    let mut drives = Vec::with_capacity(args.robot.len());
    for (k, robot) in args.robot.iter().enumerate() {
        let urdf = urdfs
            .iter()
            .find(|(r, _)| r == robot)
            .map(|(_, p)| p.as_path());
        let mut body = args.body.clone();
        if let Some(list) = &args.joints {
            body.command_joints.push(list.join(","));
        }
        let anatomy = body.load(
            robot,
            urdf,
            &format!("its joint limits bound the commands: give its URDF with --urdf {robot}=FILE"),
        )?;
        let model = model_for(k)?;
        if let Some(warning) = model
            .as_ref()
            .and_then(|m| other_robot(m.annotations(), robot, &anatomy))
        {
            eprintln!("warning: {warning}");
        }
        drives.push(Drive {
            robot: robot.clone(),
            model,
            anatomy,
        });
    }
    Ok(drives)
}

pub fn run(args: TeleopArgs) -> Result<()> {
    if args.map.is_some() && !matches!(args.input, HumanInput::Tf) {
        bail!("--map names a skeleton's frames: it goes with --input tf");
    }
    if args.mvn_from.is_some() && !matches!(args.input, HumanInput::Mvn(_)) {
        bail!("--mvn-from names the sender of an MVN stream: it goes with --input mvn");
    }
    let models: Vec<Arc<AnyModel>> = args
        .model
        .iter()
        .map(|p| load_any_model(p).map(Arc::new))
        .collect::<Result<_>>()?;
    let drives = drives(&args, &models)?;
    let options = TeleopOptions {
        domain_id: domain_id(args.domain_id)?,
        dds_interfaces: dds_interfaces(&args.dds_interface),
        input_topic: args.input_topic.clone(),
        input_qos: args.input_qos.reliability(),
        form: args.command,
        command_topic: args.command_topic.clone(),
        command_qos: args.command_qos.reliability(),
        joint_order: args.joints.clone(),
        gate: args.gate()?,
        status_topic: args.status_topic.clone(),
        max_frames: args.max_frames,
        status_period_s: 1.0,
        view: args.foxglove,
        mvn: match args.input {
            HumanInput::Mvn(a) => Some(a),
            _ => None,
        },
        mvn_from: args.mvn_from.unwrap_or_default(),
        tf: match args.input {
            HumanInput::Tf => Some(sgplvm_live::TfInputOptions {
                map: args
                    .map
                    .as_deref()
                    .map(sgplvm::capture::ArmMap::read)
                    .transpose()?,
            }),
            _ => None,
        },
        calibration: args
            .calibration
            .options(&models.iter().map(AsRef::as_ref).collect::<Vec<_>>())?,
        align_girdle: args.girdle.girdle == Girdle::Aligned,
    };
    if !(args.timeout.is_finite() && args.timeout > 0.0) {
        bail!(
            "--timeout {}: expected a positive number of seconds",
            args.timeout
        );
    }
    if !(args.margin.is_finite() && args.margin >= 0.0) {
        bail!(
            "--margin {}: expected metres ≥ 0 (0: no self-collision limit)",
            args.margin
        );
    }
    if !(args.return_speed.is_finite() && args.return_speed >= 0.0) {
        bail!(
            "--return-speed {}: expected a fraction ≥ 0 of the velocity limits",
            args.return_speed
        );
    }
    let stop = stop_flag()?;
    // What happens (states, warnings) on stderr whatever the output: --json is the summary.
    let summary = sgplvm_live::teleop(drives, &options, &stop, &mut |line| eprintln!("{line}"))?;
    args.calibration.write_used(
        summary
            .tf
            .as_ref()
            .and_then(|t| t.person.as_ref())
            .or(summary.mvn.as_ref().and_then(|m| m.person.as_ref())),
    )?;
    if args.json.json {
        println!("{}", serde_json::to_string_pretty(&summary)?);
    } else {
        let l = &summary.latency;
        eprintln!(
            "{} human frames; receive to publish {:.0} µs median, {:.0} µs at the 99th percentile, {:.0} µs at most",
            summary.frames, l.p50_us, l.p99_us, l.max_us
        );
        for (robot, r) in &summary.robots {
            eprintln!(
                "{robot}: {} frames not trusted, {} commands held within position limits, {} within velocity limits, {} kept out of self-collision, input stale {} time(s)",
                r.untrusted, r.position_clamped, r.velocity_clamped, r.collision_limited, r.stale
            );
        }
        for (kind, n) in &summary.dropped {
            eprintln!("dropped: {n} input message(s) ({kind})");
        }
        if let Some(t) = &summary.tf {
            eprintln!(
                "tf: {} frame sets fitted ({} superseded, {} incomplete); elbow {:.1} mm, wrist {:.1} mm from the capture (medians), {:.1} mm at most",
                t.sets.frames,
                t.sets.superseded,
                t.sets.incomplete,
                t.elbow_median_m * 1e3,
                t.wrist_median_m * 1e3,
                t.worst_m * 1e3
            );
            if let Some(e) = &t.error {
                eprintln!("{e}");
            }
        }
    }
    Ok(())
}
