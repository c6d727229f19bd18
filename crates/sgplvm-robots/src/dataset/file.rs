//! A dataset as a file: written as a ROS 2 MCAP (a `sensor_msgs/msg/JointState` topic per body
//! and the [`DATASET_METADATA`] record with the labels and split), and read back — our own
//! files by their record, foreign MCAPs as one unlabelled training segment.

use std::collections::BTreeMap;
use std::path::Path;

use serde::{Deserialize, Serialize};

use super::{BodyData, Dataset, Segment, DATASET_FORMAT_VERSION, DATASET_METADATA};
use crate::joint_state::{
    align_onto_clock, read_topics, topic_for, write_topics, Compression, JointStateError,
    JointStates, MessageEncoding, Result, TopicData, TopicRequest, TopicsRead, WriteSettings,
    DEFAULT_RATE_HZ, JOINT_STATE_SCHEMA,
};

#[derive(Serialize, Deserialize)]
struct BodyMeta {
    name: String,
    topic: String,
}

#[derive(Serialize, Deserialize)]
struct DatasetMeta {
    version: u32,
    frames: usize,
    human: BodyMeta,
    robots: Vec<BodyMeta>,
    pose_names: Vec<String>,
    segments: Vec<Segment>,
    train: Vec<usize>,
    test: Vec<usize>,
}

/// Writes `dataset` as a ROS 2 MCAP (zstd chunks, CDR JointState topics) with its labels and
/// split in the [`DATASET_METADATA`] record. Atomic (temporary file + rename).
pub fn write_demonstrations(path: impl AsRef<Path>, dataset: &Dataset) -> Result<()> {
    write_demonstrations_with(path, dataset, Compression::Zstd)
}

/// [`write_demonstrations`] with a chosen chunk compression.
pub fn write_demonstrations_with(
    path: impl AsRef<Path>,
    dataset: &Dataset,
    compression: Compression,
) -> Result<()> {
    write_demonstrations_with_metadata(path, dataset, compression, Vec::new())
}

/// [`write_demonstrations_with`] plus further MCAP metadata records (name → key/value map),
/// e.g. where captured demonstrations came from.
pub fn write_demonstrations_with_metadata(
    path: impl AsRef<Path>,
    dataset: &Dataset,
    compression: Compression,
    extra: Vec<(String, BTreeMap<String, String>)>,
) -> Result<()> {
    dataset.validate()?;
    let meta = DatasetMeta {
        version: DATASET_FORMAT_VERSION,
        frames: dataset.len(),
        human: BodyMeta {
            name: dataset.human.name.clone(),
            topic: dataset.human.topic.clone(),
        },
        robots: dataset
            .robots
            .iter()
            .map(|r| BodyMeta {
                name: r.name.clone(),
                topic: r.topic.clone(),
            })
            .collect(),
        pose_names: dataset.pose_names.clone(),
        segments: dataset.segments.clone(),
        train: dataset.train.clone(),
        test: dataset.test.clone(),
    };
    let json = serde_json::to_string(&meta).map_err(|e| JointStateError::InvalidInput {
        what: "dataset".into(),
        detail: format!("cannot encode metadata: {e}"),
    })?;
    let mut map = BTreeMap::new();
    map.insert("version".to_string(), DATASET_FORMAT_VERSION.to_string());
    map.insert("json".to_string(), json);
    let bodies: Vec<(&BodyData, JointStates)> = std::iter::once(&dataset.human)
        .chain(&dataset.robots)
        .map(|b| (b, b.to_joint_states(&dataset.times_ns)))
        .collect();
    let topics: Vec<TopicData<'_>> = bodies
        .iter()
        .map(|(b, s)| TopicData {
            topic: &b.topic,
            states: s,
            encoding: MessageEncoding::Cdr,
        })
        .collect();
    write_topics(
        path,
        &topics,
        &WriteSettings {
            compression,
            metadata: std::iter::once((DATASET_METADATA.to_string(), map))
                .chain(extra)
                .collect(),
        },
    )
}

/// How to interpret an MCAP without [`DATASET_METADATA`].
#[derive(Debug, Clone, PartialEq)]
pub struct LoadOptions {
    /// Topic of the human; `None` picks the one JointState topic whose name contains `human`.
    pub human_topic: Option<String>,
    /// Rate of the common clock the topics are aligned onto.
    pub rate_hz: f64,
    /// Joint order per topic (e.g. a body model's `joint_names()`): listed topics keep only
    /// these joints, in this order (missing ones are an error); others keep their messages'.
    pub joint_order: BTreeMap<String, Vec<String>>,
}

impl Default for LoadOptions {
    fn default() -> Self {
        Self {
            human_topic: None,
            rate_hz: DEFAULT_RATE_HZ,
            joint_order: BTreeMap::new(),
        }
    }
}

/// Loads a dataset written by [`write_demonstrations`] exactly; a foreign MCAP with JointState
/// topics loads too (see [`load_demonstrations_with`]).
pub fn load_demonstrations(path: impl AsRef<Path>) -> Result<Dataset> {
    load_demonstrations_with(path, &LoadOptions::default())
}

/// Loads a dataset. With [`DATASET_METADATA`], bodies, labels and split come from it and the
/// frame clock is the human topic's timestamps (`options` are not used then). Without it, every JointState topic is a body
/// (the human chosen by `options.human_topic` or by name; a robot is named after the first
/// component of its topic), the topics are aligned onto a `rate_hz` clock by linear
/// interpolation, all frames form one unlabelled segment and all are in the training set.
pub fn load_demonstrations_with(path: impl AsRef<Path>, options: &LoadOptions) -> Result<Dataset> {
    let path = path.as_ref();
    let probe = read_topics(path, &[])?;
    match probe.metadata.get(DATASET_METADATA) {
        Some(map) => load_own(path, map),
        None => load_foreign(path, &probe, options),
    }
}

/// Loads a file written by [`write_demonstrations`]: bodies, labels and split as its
/// [`DATASET_METADATA`] metadata record `map` declares them.
fn load_own(path: &Path, map: &BTreeMap<String, String>) -> Result<Dataset> {
    let bad_meta = |detail: String| JointStateError::BadDatasetMetadata {
        path: path.to_path_buf(),
        detail,
    };
    let json = map
        .get("json")
        .ok_or_else(|| bad_meta("no `json` key".into()))?;
    let meta: DatasetMeta =
        serde_json::from_str(json).map_err(|e| bad_meta(format!("invalid JSON: {e}")))?;
    if meta.version != DATASET_FORMAT_VERSION {
        return Err(bad_meta(format!(
            "format version {} (this library reads version {DATASET_FORMAT_VERSION})",
            meta.version
        )));
    }
    let mut requests = vec![TopicRequest::all(meta.human.topic.clone())];
    requests.extend(
        meta.robots
            .iter()
            .map(|r| TopicRequest::all(r.topic.clone())),
    );
    let read = read_topics(path, &requests)?;
    let human_states = &read.states[0];
    let times = human_states.times_ns.clone();
    if times.len() != meta.frames {
        return Err(bad_meta(format!(
            "{} frames declared, topic `{}` has {}",
            meta.frames,
            meta.human.topic,
            times.len()
        )));
    }
    let human = BodyData::from_joint_states(&meta.human.name, &meta.human.topic, human_states)?;
    let mut robots = Vec::with_capacity(meta.robots.len());
    for (r, s) in meta.robots.iter().zip(&read.states[1..]) {
        let s = if s.times_ns == times {
            s.clone()
        } else {
            s.resample(&times).map_err(|e| {
                bad_meta(format!("topic `{}` does not span the frames: {e}", r.topic))
            })?
        };
        robots.push(BodyData::from_joint_states(&r.name, &r.topic, &s)?);
    }
    let ds = Dataset {
        times_ns: times,
        human,
        robots,
        pose_names: meta.pose_names,
        segments: meta.segments,
        train: meta.train,
        test: meta.test,
    };
    ds.validate().map_err(|e| bad_meta(e.to_string()))?;
    Ok(ds)
}

/// Loads a foreign file: its JointState topics aligned onto one clock, the human topic chosen
/// by `options` or by name, one unlabelled segment, every frame for training.
fn load_foreign(path: &Path, probe: &TopicsRead, options: &LoadOptions) -> Result<Dataset> {
    let mut topics: Vec<String> = Vec::new();
    for c in &probe.channels {
        let is_js = c.schema == JOINT_STATE_SCHEMA || c.schema == "sensor_msgs/JointState";
        if is_js && !topics.contains(&c.topic) {
            topics.push(c.topic.clone());
        }
    }
    let human_topic = match &options.human_topic {
        Some(t) => t.clone(),
        None => {
            let names: Vec<&str> = topics.iter().map(String::as_str).collect();
            match topic_for(&names, "human") {
                Some(one) => one.to_string(),
                None => {
                    return Err(JointStateError::InvalidInput {
                        what: path.display().to_string(),
                        detail: format!(
                            "no `{DATASET_METADATA}` metadata and not exactly one JointState topic containing `human` among {topics:?}: say which topic is the human"
                        ),
                    })
                }
            }
        }
    };
    let request = |t: &str| match options.joint_order.get(t) {
        Some(names) => TopicRequest::joints(t, names),
        None => TopicRequest::all(t),
    };
    let mut requests = vec![request(&human_topic)];
    let robot_topics: Vec<&String> = topics.iter().filter(|t| **t != human_topic).collect();
    requests.extend(robot_topics.iter().map(|t| request(t)));
    let read = read_topics(path, &requests)?;
    let aligned = align_onto_clock(&read.states, options.rate_hz)
        .map_err(|e| e.in_file(path, Some(format!("{topics:?}"))))?;

    let times = aligned[0].times_ns.clone();
    let n = times.len();
    let human = BodyData::from_joint_states("human", &human_topic, &aligned[0])?;
    let robots = robot_topics
        .iter()
        .zip(&aligned[1..])
        .map(|(t, s)| BodyData::from_joint_states(&body_name_of_topic(t), t, s))
        .collect::<Result<_>>()?;
    debug_assert_eq!(n, human.positions.nrows());
    Ok(Dataset::unlabelled(times, human, robots))
}

/// `/walkman/joint_command` → `walkman`; a topic without a namespace keeps its name.
pub(super) fn body_name_of_topic(topic: &str) -> String {
    topic
        .trim_start_matches('/')
        .split('/')
        .next()
        .filter(|s| !s.is_empty())
        .unwrap_or(topic)
        .to_string()
}
