//! `sgplvm replay`: a recorded human (a JointState series) published on the input topic at its
//! own timestamps, so the whole live chain runs without a person in a suit.

use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use ros2_client::dds::Publisher;
use ros2_client::MessageTypeName;
use sgplvm_robots::joint_state::JointStates;

use crate::msgs::{types, Header, JointState, Time};
use crate::node::{new_node, qos, topic_name, Reliability};
use crate::LiveError;

/// How to replay.
#[derive(Debug, Clone)]
pub struct ReplayOptions {
    /// DDS domain.
    pub domain_id: u16,
    /// Topic to publish on.
    pub topic: String,
    /// Playback speed (2 = twice as fast); the stamps keep the recording's times.
    pub rate: f64,
    /// Start again at the end (stamps go on increasing).
    pub looped: bool,
    /// QoS of the publisher (reliable by default: it matches best-effort and reliable
    /// subscribers alike).
    pub qos: Reliability,
    /// Seconds to wait for a subscriber before the first message (0: do not wait).
    pub wait_s: f64,
    /// Stop after this many messages.
    pub max_messages: Option<usize>,
}

impl Default for ReplayOptions {
    fn default() -> Self {
        ReplayOptions {
            domain_id: 0,
            topic: "/human/joint_states".into(),
            rate: 1.0,
            looped: false,
            qos: Reliability::Reliable,
            wait_s: 5.0,
            max_messages: None,
        }
    }
}

/// Publishes `series` as JointState messages until it ends (or `stop`); returns the count sent.
pub fn replay(
    series: &JointStates,
    options: &ReplayOptions,
    stop: &AtomicBool,
) -> Result<usize, LiveError> {
    check(series, options)?;
    let mut node = new_node(options.domain_id, "sgplvm_replay")?;
    let dds = |e: String| LiveError::Dds { message: e };
    let (pkg, name) = types::JOINT_STATE;
    let topic = node
        .create_topic(
            &topic_name(&options.topic)?,
            MessageTypeName::new(pkg, name),
            &qos(options.qos),
        )
        .map_err(|e| dds(format!("{e:?}")))?;
    let publisher: Publisher<JointState> = node
        .create_publisher(&topic, Some(qos(options.qos)))
        .map_err(|e| dds(format!("{e:?}")))?;
    wait_for_subscriber(&node, &options.topic, options, stop);
    let start = Instant::now();
    play(
        &series.times_ns,
        options,
        stop,
        start,
        period_ns(&series.times_ns),
        |k, stamp_ns, _| {
            let msg = JointState {
                header: Header {
                    stamp: Time::from_ns(stamp_ns),
                    frame_id: String::new(),
                },
                name: series.names.clone(),
                position: series.row(k).to_vec(),
                velocity: Vec::new(),
                effort: Vec::new(),
            };
            publisher.publish(msg).map_err(|e| LiveError::Publish {
                topic: options.topic.clone(),
                message: format!("{e:?}"),
            })
        },
    )
}

/// Sends `series` (the human model's angles) as an Xsens MVN stream to `to` (type 02 pose
/// datagrams, the human model's segments as [`crate::mvn::HumanSegments`] places them) at its
/// own times scaled by `options.rate` (a receiver calibrates on any frame: the segments'
/// offsets in their parents' frames are the null pose's): the live chain with a suit's
/// protocol and no suit. Returns the frames sent.
pub fn replay_mvn(
    series: &JointStates,
    to: std::net::SocketAddr,
    options: &ReplayOptions,
    stop: &AtomicBool,
) -> Result<usize, LiveError> {
    use crate::mvn::{HumanSegments, MvnSender, PoseType};
    check(series, options)?;
    let config = |e: String| LiveError::Config(format!("--as mvn: {e}"));
    let segments = HumanSegments::new().map_err(|e| config(e.to_string()))?;
    let order = model_order(series, "--as mvn")?;
    let sender = MvnSender::new(to).map_err(|e| config(e.to_string()))?;
    let send = |q: &[f64], sample: u32, t_ms: u32| -> Result<(), LiveError> {
        let frame = segments
            .frame(q, sample, t_ms)
            .map_err(|e| config(e.to_string()))?;
        sender
            .send(&frame, PoseType::Quaternion)
            .map_err(|e| config(e.to_string()))
    };
    let start = Instant::now() + Duration::from_millis(50);
    let mut sample: u32 = 1;
    play(
        &series.times_ns,
        options,
        stop,
        start,
        25_000_000,
        |k, _, offset_ns| {
            let row = series.row(k);
            let q: Vec<f64> = order.iter().map(|&i| row[i]).collect();
            let t_ms = u32::try_from(offset_ns / 1_000_000).unwrap_or(u32::MAX);
            send(&q, sample, t_ms)?;
            sample = sample.wrapping_add(1);
            Ok(())
        },
    )
}

/// Plays `series` from `start` at its own times scaled by `options.rate`: calls `each(row,
/// stamp_ns, offset_ns)` when a frame is due — `stamp_ns` its time on the recording's clock,
/// going on lap after lap with `--loop` (a lap is the recording and `gap_ns`), `offset_ns` its
/// time since the first frame — until the end, `stop` or `options.max_messages`. Returns the
/// frames sent.
fn play(
    times_ns: &[i64],
    options: &ReplayOptions,
    stop: &AtomicBool,
    start: Instant,
    gap_ns: i64,
    mut each: impl FnMut(usize, i64, i64) -> Result<(), LiveError>,
) -> Result<usize, LiveError> {
    let (Some(&t0), Some(&last)) = (times_ns.first(), times_ns.last()) else {
        return Ok(0);
    };
    let lap_ns = last - t0 + gap_ns;
    let mut sent = 0usize;
    for lap in 0i64.. {
        for (k, &t) in times_ns.iter().enumerate() {
            if stop.load(Ordering::Relaxed) || options.max_messages.is_some_and(|m| sent >= m) {
                return Ok(sent);
            }
            let offset_ns = lap * lap_ns + (t - t0);
            let due = start + Duration::from_secs_f64(offset_ns as f64 * 1e-9 / options.rate);
            if let Some(wait) = due.checked_duration_since(Instant::now()) {
                std::thread::sleep(wait);
            }
            each(k, t + lap * lap_ns, offset_ns)?;
            sent += 1;
        }
        if !options.looped {
            break;
        }
    }
    Ok(sent)
}

/// The mean frame period of frames at `times_ns` (25 ms for a single frame): the gap between
/// laps.
fn period_ns(times_ns: &[i64]) -> i64 {
    match times_ns {
        [first, .., last] => (last - first) / (times_ns.len() as i64 - 1),
        _ => 25_000_000,
    }
}

/// A series and options that can be replayed.
fn check(series: &JointStates, options: &ReplayOptions) -> Result<(), LiveError> {
    if series.is_empty() {
        return Err(LiveError::Config(
            "nothing to replay: the series has no frames".into(),
        ));
    }
    check_rate(options)
}

/// A playback speed that can be kept.
fn check_rate(options: &ReplayOptions) -> Result<(), LiveError> {
    if !(options.rate.is_finite() && options.rate > 0.0) {
        return Err(LiveError::Config(format!(
            "rate {}; expected a positive speed factor",
            options.rate
        )));
    }
    Ok(())
}

/// For each of the human model's joints, its column in `series` (all 18 are needed to place
/// the segments); `what` names the output in the error.
fn model_order(series: &JointStates, what: &str) -> Result<Vec<usize>, LiveError> {
    let config = |e: String| LiveError::Config(format!("{what}: {e}"));
    let model = sgplvm_robots::Robot::builtin("human")
        .map_err(|e| config(e.to_string()))?
        .joint_names();
    model
        .iter()
        .map(|n| {
            series.names.iter().position(|s| s == n).ok_or_else(|| {
                config(format!(
                    "the series has no joint `{n}` of the human model (the segments' poses need all 18)"
                ))
            })
        })
        .collect()
}

/// Waits up to `options.wait_s` for a subscriber of `topic` (or `stop`).
fn wait_for_subscriber(
    node: &ros2_client::Node,
    topic: &str,
    options: &ReplayOptions,
    stop: &AtomicBool,
) {
    let waited = Instant::now();
    while options.wait_s > 0.0
        && node.subscription_count(topic) == 0
        && waited.elapsed().as_secs_f64() < options.wait_s
        && !stop.load(Ordering::Relaxed)
    {
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// A node publishing TF: `/tf` (reliable, volatile) and `/tf_static` (reliable, transient
/// local: latched for late subscribers).
struct TfPublishers {
    node: ros2_client::Node,
    dynamic: Publisher<crate::msgs::TFMessage>,
    statics: Publisher<crate::msgs::TFMessage>,
}

impl TfPublishers {
    fn new(options: &ReplayOptions) -> Result<TfPublishers, LiveError> {
        use crate::tf::{TF_STATIC_TOPIC, TF_TOPIC};
        use ros2_client::qos::{Durability, History, WhenFull};
        use ros2_client::QosProfile;
        let mut node = new_node(options.domain_id, "sgplvm_replay")?;
        let dds = |e: String| LiveError::Dds { message: e };
        let (pkg, name) = types::TF_MESSAGE;
        let mut publisher = |topic: &str, q: QosProfile| {
            let t = node
                .create_topic(&topic_name(topic)?, MessageTypeName::new(pkg, name), &q)
                .map_err(|e| dds(format!("{e:?}")))?;
            node.create_publisher(&t, Some(q))
                .map_err(|e| dds(format!("{e:?}")))
        };
        let dynamic = publisher(
            TF_TOPIC,
            QosProfile::publisher_default()
                .reliability_reliable(WhenFull::DEFAULT)
                .durability(Durability::Volatile)
                .history(History::KeepLast { depth: 100 }),
        )?;
        let statics = publisher(
            TF_STATIC_TOPIC,
            QosProfile::publisher_default()
                .reliability_reliable(WhenFull::DEFAULT)
                .durability(Durability::TransientLocal)
                .history(History::KeepLast { depth: 1 }),
        )?;
        Ok(TfPublishers {
            node,
            dynamic,
            statics,
        })
    }

    fn publish(&self, statics: bool, msg: crate::msgs::TFMessage) -> Result<(), LiveError> {
        use crate::tf::{TF_STATIC_TOPIC, TF_TOPIC};
        let (publisher, topic) = match statics {
            true => (&self.statics, TF_STATIC_TOPIC),
            false => (&self.dynamic, TF_TOPIC),
        };
        publisher.publish(msg).map_err(|e| LiveError::Publish {
            topic: topic.to_string(),
            message: format!("{e:?}"),
        })
    }
}

/// Publishes `series` (the human model's angles) as a TF tree of the human model's segments
/// ([`crate::tf::HumanTf`], frame names after `prefix`): the fixed part once on `/tf_static`
/// (reliable, transient local: latched for late subscribers), then one `TFMessage` per frame
/// on `/tf` stamped with the frame's time, at its own times scaled by `options.rate`.
/// `options.topic` is not used. Returns the frames published.
pub fn replay_tf(
    series: &JointStates,
    prefix: &str,
    options: &ReplayOptions,
    stop: &AtomicBool,
) -> Result<usize, LiveError> {
    use crate::tf::{HumanTf, TF_TOPIC};
    check(series, options)?;
    let config = |e: String| LiveError::Config(format!("--as tf: {e}"));
    let tree = HumanTf::new(prefix).map_err(|e| config(e.to_string()))?;
    let order = model_order(series, "--as tf")?;
    let tf = TfPublishers::new(options)?;
    tf.publish(true, tree.static_message(Time::from_ns(series.times_ns[0])))?;
    wait_for_subscriber(&tf.node, TF_TOPIC, options, stop);
    play(
        &series.times_ns,
        options,
        stop,
        Instant::now(),
        period_ns(&series.times_ns),
        |k, stamp_ns, _| {
            let row = series.row(k);
            let q: Vec<f64> = order.iter().map(|&i| row[i]).collect();
            let msg = tree
                .message(&q, Time::from_ns(stamp_ns))
                .map_err(|e| config(e.to_string()))?;
            tf.publish(false, msg)
        },
    )
}

/// Publishes a motion capture's own skeleton as a tracker streams it: per frame one
/// `TFMessage` on `/tf` with every joint of `bvh` in its parent's frame (the root in
/// `{prefix}world`; frame names the file's joint names after `prefix`), in metres, every frame
/// of the file from the first one its import `motion` kept, stamped on the import's clock (the
/// import's first time, then the file's frame time: an import at the file's own rate takes
/// every frame at these times), at those times scaled by `options.rate`.
/// Fitted by `teleop --input tf`, the stream gives the import's angles where the import's rate
/// is the file's (`import --rate`): the check that a file and a stream of one motion agree,
/// through the skeleton and calibration of the file. Returns the frames published.
pub fn replay_tf_skeleton(
    bvh: &sgplvm_capture::bvh::Bvh,
    motion: &sgplvm_capture::CapturedMotion,
    prefix: &str,
    options: &ReplayOptions,
    stop: &AtomicBool,
) -> Result<usize, LiveError> {
    use crate::tf::{transform, TF_TOPIC};
    use nalgebra::{Isometry3, Translation3, UnitQuaternion};
    let config = |e: String| LiveError::Config(format!("--as tf --skeleton source: {e}"));
    let metres = motion
        .source
        .calibration
        .as_ref()
        .and_then(|c| c.metres_per_unit)
        .ok_or_else(|| {
            config("the file's length units are unknown (import --units names them)".into())
        })?;
    let dt = bvh.frame_time;
    let first = (motion.source.span_s.0 / dt).round() as usize;
    let t0 = *motion
        .times_ns
        .first()
        .ok_or_else(|| config("no frames".into()))?;
    let times_ns: Vec<i64> = (first..bvh.frames())
        .map(|f| t0 + ((f - first) as f64 * dt * 1e9).round() as i64)
        .collect();
    check_rate(options)?;
    let names: Vec<String> = bvh
        .joints
        .iter()
        .map(|j| format!("{prefix}{}", j.name))
        .collect();
    let world = format!("{prefix}world");
    let tf = TfPublishers::new(options)?;
    wait_for_subscriber(&tf.node, TF_TOPIC, options, stop);
    play(
        &times_ns,
        options,
        stop,
        Instant::now(),
        period_ns(&times_ns),
        |k, stamp_ns, _| {
            let values = bvh.frame(first + k);
            let stamp = Time::from_ns(stamp_ns);
            let transforms = bvh
                .joints
                .iter()
                .enumerate()
                .map(|(j, joint)| {
                    let (t, r) = joint.local(values);
                    let local = Isometry3::from_parts(
                        Translation3::from(t * metres),
                        UnitQuaternion::from_rotation_matrix(&r),
                    );
                    let parent = joint.parent.map_or(world.as_str(), |p| names[p].as_str());
                    transform(parent, &names[j], stamp, &local)
                })
                .collect();
            tf.publish(false, crate::msgs::TFMessage { transforms })
        },
    )
}
