//! `sgplvm replay`: a recorded human published for `teleop` — as JointState, as an Xsens MVN
//! stream, or as TF frames of the human model's segments or of a capture's own skeleton.

use std::path::PathBuf;

use anyhow::{bail, Result};
use clap::{Args, ValueEnum};
use sgplvm::robots::joint_state::{read_joint_states, JointStates};
use sgplvm_live::ReplayOptions;

use super::teleop::{domain_id, stop_flag, QosArg};

#[derive(Args)]
pub struct ReplayArgs {
    /// Human frames: an MCAP with the human's JointState topic (--topic), e.g. from `sgplvm
    /// import`, `sgplvm export --body human` or a ROS 2 recording; published with its stamps.
    #[arg(long, required_unless_present = "bvh", conflicts_with = "bvh")]
    input: Option<PathBuf>,
    /// Or a motion capture (BVH), imported as `sgplvm import` does (40 Hz).
    #[arg(long)]
    bvh: Option<PathBuf>,
    /// The topic to publish on (and, for a plain MCAP, to read).
    #[arg(long, default_value = "/human/joint_states")]
    topic: String,
    /// Playback speed (2 = twice as fast); the stamps keep the recording's times.
    #[arg(long, default_value_t = 1.0)]
    rate: f64,
    /// Start again at the end (stamps go on increasing).
    #[arg(long = "loop")]
    looped: bool,
    /// QoS of the publisher (reliable matches reliable and best-effort subscribers).
    #[arg(long, value_enum, default_value = "reliable")]
    qos: QosArg,
    /// DDS domain [default: $ROS_DOMAIN_ID, else 0].
    #[arg(long)]
    domain_id: Option<u16>,
    /// Use only the network interface with this address for DDS (multicast, and the addresses
    /// announced in discovery); repeat for several [default: 127.0.0.1 when ROS 2's
    /// ROS_AUTOMATIC_DISCOVERY_RANGE is LOCALHOST or ROS_LOCALHOST_ONLY is 1, else every
    /// interface].
    #[arg(long, value_name = "IP")]
    dds_interface: Vec<std::net::IpAddr>,
    /// Seconds to wait for a subscriber before the first message.
    #[arg(long, default_value_t = 5.0)]
    wait: f64,
    /// Stop after this many messages.
    #[arg(long)]
    max_messages: Option<usize>,
    /// Send the frames as `joint-state` (the human model's angles on --topic), as `mvn` (an
    /// Xsens MVN network stream of the human model's segments, UDP to --to), for `teleop
    /// --input mvn`, or as `tf` (the human model's segments as tf2_msgs/TFMessage on /tf, the
    /// fixed part on /tf_static, Xsens MVN frame names), for `teleop --input tf`.
    #[arg(long = "as", value_enum, default_value = "joint-state")]
    send_as: SendAs,
    /// With --as mvn: where to send, ADDR:PORT.
    #[arg(long, default_value = "127.0.0.1:9763")]
    to: std::net::SocketAddr,
    /// With --as tf: a prefix of every frame name (a namespace such as `actor1/`).
    #[arg(long, default_value = "")]
    tf_prefix: String,
    /// With --as tf and --bvh: whose skeleton the frames are — `model`, the human model's
    /// segments (Xsens MVN names), or `source`, the file's own joints, every frame of the file
    /// at its own rate, as a tracker streams that skeleton (teleop then fits it through the
    /// calibration the file was imported with: `import --rate` at the file's rate gives the
    /// same frames).
    #[arg(long, value_enum, default_value = "model")]
    skeleton: Skeleton,
}

#[derive(Clone, Copy, PartialEq, Eq, ValueEnum)]
enum Skeleton {
    /// The human model's segments.
    Model,
    /// The capture file's own joints.
    Source,
}

#[derive(Clone, Copy, PartialEq, Eq, ValueEnum)]
enum SendAs {
    /// sensor_msgs/msg/JointState on ROS 2.
    JointState,
    /// Xsens MVN network streaming, UDP.
    Mvn,
    /// tf2_msgs/msg/TFMessage on /tf and /tf_static.
    Tf,
}

impl ReplayArgs {
    /// How to replay, as the flags say.
    fn options(&self) -> Result<ReplayOptions> {
        Ok(ReplayOptions {
            domain_id: domain_id(self.domain_id)?,
            topic: self.topic.clone(),
            rate: self.rate,
            looped: self.looped,
            qos: self.qos.reliability(),
            wait_s: self.wait,
            max_messages: self.max_messages,
        })
    }
}

/// `replay --bvh FILE --as tf --skeleton source`: the file's own joints on /tf.
fn replay_source_skeleton(args: &ReplayArgs) -> Result<()> {
    let (Some(path), SendAs::Tf) = (&args.bvh, args.send_as) else {
        bail!("--skeleton source: expected --bvh FILE and --as tf (the file's own joints are sent as TF frames)");
    };
    let bvh = sgplvm::capture::Bvh::read(path)?;
    // Imported at the file's own rate: its frames as they are, on the clock of the stream.
    let own_rate = sgplvm::capture::ImportOptions {
        rate_hz: 1.0 / bvh.frame_time,
        ..Default::default()
    };
    let motion = sgplvm::capture::import_parsed(&bvh, &path.display().to_string(), &own_rate)?;
    let options = args.options()?;
    let stop = stop_flag()?;
    eprintln!(
        "replaying {} of {} (its own {} joints at {:.0} Hz) on /tf{}",
        sgplvm::robots::names::count(
            bvh.frames() - (motion.source.span_s.0 / bvh.frame_time).round() as usize,
            "frame"
        ),
        path.display(),
        bvh.joints.len(),
        1.0 / bvh.frame_time,
        if args.looped { ", looped" } else { "" }
    );
    let sent = sgplvm_live::replay_tf_skeleton(&bvh, &motion, &args.tf_prefix, &options, &stop)?;
    eprintln!("published {sent} messages");
    Ok(())
}

/// The human series of `path`: its JointState `topic` as recorded (stamps and all).
fn human_series(path: &std::path::Path, topic: &str) -> Result<JointStates> {
    Ok(read_joint_states(path, topic)?)
}

pub fn run_replay(args: ReplayArgs) -> Result<()> {
    if args.skeleton == Skeleton::Source {
        return replay_source_skeleton(&args);
    }
    let (series, source) = match (&args.input, &args.bvh) {
        (Some(input), _) => (human_series(input, &args.topic)?, input.clone()),
        (None, Some(bvh)) => {
            let m = sgplvm::capture::import_bvh(bvh, &Default::default())?;
            let values = (0..m.positions.nrows())
                .flat_map(|i| (0..m.positions.ncols()).map(move |j| (i, j)))
                .map(|(i, j)| m.positions[(i, j)])
                .collect();
            (
                JointStates::new(m.times_ns, m.joint_names, values)?,
                bvh.clone(),
            )
        }
        (None, None) => bail!("name the frames to replay: --input MCAP or --bvh FILE"),
    };
    let options = args.options()?;
    let stop = stop_flag()?;
    eprintln!(
        "replaying {} frames of {} ({} joints) on {}{}",
        series.len(),
        source.display(),
        series.dof(),
        match args.send_as {
            SendAs::JointState => args.topic.clone(),
            SendAs::Mvn => format!("udp://{}", args.to),
            SendAs::Tf => "/tf".to_string(),
        },
        if args.looped { ", looped" } else { "" }
    );
    let sent = match args.send_as {
        SendAs::JointState => sgplvm_live::replay(&series, &options, &stop)?,
        SendAs::Mvn => sgplvm_live::replay_mvn(&series, args.to, &options, &stop)?,
        SendAs::Tf => sgplvm_live::replay_tf(&series, &args.tf_prefix, &options, &stop)?,
    };
    eprintln!("published {sent} messages");
    Ok(())
}
