//! The demonstration dataset: human joint angles H (N × 18), one joint-command matrix R per
//! robot (N × 14), the frame clock, a label per frame saying which pose-to-pose trajectory it
//! belongs to, and the train/test split.
//!
//! A dataset lives in one MCAP file: each body is a `sensor_msgs/msg/JointState` topic (what
//! ROS 2 tools open), and a Metadata record named [`DATASET_METADATA`] carries the labels and
//! the split as JSON (key `json`). A foreign MCAP without that record still loads: all its
//! frames form one unlabelled segment, all of them in the training set. Writing and reading
//! the file are in `file`; this file holds the dataset itself.

use nalgebra::DMatrix;
use serde::{Deserialize, Serialize};

use crate::joint_state::{JointStateError, Result};

/// Name of the MCAP Metadata record that holds a dataset's labels and split.
pub const DATASET_METADATA: &str = "sgplvm.dataset";

/// Version of the JSON layout stored under [`DATASET_METADATA`].
pub const DATASET_FORMAT_VERSION: u32 = 1;

/// Name of the MCAP Metadata record that says where imported frames came from (key `json`: a
/// JSON list, one object per captured file with at least its `file`). The capture crate writes
/// and reads its meaning; here it is carried through unchanged, and each entry's `file` names
/// the segments made from it.
pub const CAPTURE_METADATA: &str = "sgplvm.capture";

/// The entries of `path`'s [`CAPTURE_METADATA`] record, as JSON objects (empty if it has none).
pub fn capture_records(
    path: impl AsRef<std::path::Path>,
) -> Result<Vec<serde_json::Map<String, serde_json::Value>>> {
    let path = path.as_ref();
    capture_records_in(path, &crate::joint_state::read_topics(path, &[])?.metadata)
}

/// [`capture_records`] from the metadata records already read from `path` (named in errors).
pub fn capture_records_in(
    path: &std::path::Path,
    metadata: &std::collections::BTreeMap<String, std::collections::BTreeMap<String, String>>,
) -> Result<Vec<serde_json::Map<String, serde_json::Value>>> {
    match metadata.get(CAPTURE_METADATA).and_then(|m| m.get("json")) {
        None => Ok(Vec::new()),
        Some(json) => serde_json::from_str(json).map_err(|e| JointStateError::BadDatasetMetadata {
            path: path.to_path_buf(),
            detail: format!("record `{CAPTURE_METADATA}` is not a list of JSON objects: {e}"),
        }),
    }
}

/// One body's joint values over the dataset's frames.
#[derive(Debug, Clone, PartialEq)]
pub struct BodyData {
    /// Body name, e.g. `human` or `walkman`.
    pub name: String,
    /// Topic the body is stored on, e.g. `/walkman/joint_command`.
    pub topic: String,
    /// Joint names, one per column of `positions`.
    pub joint_names: Vec<String>,
    /// Joint values, N × D (one row per frame).
    pub positions: DMatrix<f64>,
}

impl BodyData {
    /// Rows `indices` of `positions`, in that order.
    pub fn rows(&self, indices: &[usize]) -> DMatrix<f64> {
        self.positions.select_rows(indices)
    }
}

/// A run of consecutive frames belonging to one pose-to-pose trajectory.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct Segment {
    /// First frame (inclusive).
    pub start: usize,
    /// One past the last frame.
    pub end: usize,
    /// Key pose the trajectory starts from (index into `pose_names`); `None` if unlabelled.
    pub from_pose: Option<usize>,
    /// Key pose the trajectory goes to; `None` if unlabelled.
    pub to_pose: Option<usize>,
    /// Repetition (0-based) of this pose-to-pose motion; `None` if unlabelled.
    pub repetition: Option<usize>,
    /// Who performed it (a captured person's name, `sgplvm import --person`); `None` if
    /// unknown. Training frames of three or more people are validated and calibrated a person
    /// at a time ([`ValidationRule::EveryThirdPerson`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub person: Option<String>,
}

impl Segment {
    /// Number of frames.
    pub fn len(&self) -> usize {
        self.end - self.start
    }

    /// Whether the segment has no frames.
    pub fn is_empty(&self) -> bool {
        self.end == self.start
    }
}

/// How [`Dataset::validation_split`] chose its frames.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ValidationRule {
    /// The last repetition of every training motion.
    LastRepetition,
    /// Every third training trajectory.
    EveryThirdTrajectory,
    /// Every third of nine equal blocks of training frames.
    EveryThirdBlock,
    /// Every third person of the training frames (in order of first appearance): held-out
    /// frames are then of people the model never saw, as a stranger's are.
    EveryThirdPerson,
}

impl std::fmt::Display for ValidationRule {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Self::LastRepetition => "the last repetition of every training motion",
            Self::EveryThirdTrajectory => "every third training trajectory",
            Self::EveryThirdBlock => "every third of nine blocks of training frames",
            Self::EveryThirdPerson => "every third person in training",
        })
    }
}

/// Training frames held out for validation: positions in [`Dataset::train`].
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ValidationSplit {
    /// Positions in the training frames (ascending).
    pub rows: Vec<usize>,
    /// The rule that chose them.
    pub rule: ValidationRule,
}

/// The training frames in groups: see [`Dataset::training_groups`].
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TrainingGroups {
    /// The group of each training frame (by position in [`Dataset::train`]).
    pub groups: Vec<usize>,
    /// The groups the validation split holds out.
    pub validation: Vec<usize>,
    /// The rule that formed the groups.
    pub rule: ValidationRule,
}

/// Demonstrations of one human and several robots on a common frame clock.
#[derive(Debug, Clone, PartialEq)]
pub struct Dataset {
    /// Frame timestamps in nanoseconds (N, increasing).
    pub times_ns: Vec<i64>,
    /// The human demonstrator, N × D_H.
    pub human: BodyData,
    /// The robots' joint commands, each N × D_R, in a fixed order.
    pub robots: Vec<BodyData>,
    /// Names of the key poses the segment labels refer to (empty if unlabelled).
    pub pose_names: Vec<String>,
    /// Consecutive segments covering frames `0..N` in order.
    pub segments: Vec<Segment>,
    /// Frames of the training set (increasing).
    pub train: Vec<usize>,
    /// Frames of the test set (increasing, disjoint from `train`).
    pub test: Vec<usize>,
}

impl Dataset {
    /// Frames without labels: one segment covering them all, every frame in the training set,
    /// no test set (what a recording without the generator's protocol holds).
    pub fn unlabelled(times_ns: Vec<i64>, human: BodyData, robots: Vec<BodyData>) -> Dataset {
        let n = times_ns.len();
        Dataset {
            times_ns,
            human,
            robots,
            pose_names: Vec::new(),
            segments: vec![Segment {
                start: 0,
                end: n,
                from_pose: None,
                to_pose: None,
                repetition: None,
                person: None,
            }],
            train: (0..n).collect(),
            test: Vec::new(),
        }
    }

    /// Number of frames N.
    pub fn len(&self) -> usize {
        self.times_ns.len()
    }

    /// Whether there are no frames.
    pub fn is_empty(&self) -> bool {
        self.times_ns.is_empty()
    }

    /// The robot called `name`.
    pub fn robot(&self, name: &str) -> Option<&BodyData> {
        self.robots.iter().find(|r| r.name == name)
    }

    /// Robot names in storage order.
    pub fn robot_names(&self) -> Vec<&str> {
        self.robots.iter().map(|r| r.name.as_str()).collect()
    }

    /// The segment frame `frame` belongs to.
    pub fn segment_of(&self, frame: usize) -> Option<&Segment> {
        let i = self.segments.partition_point(|s| s.end <= frame);
        self.segments.get(i).filter(|s| s.start <= frame)
    }

    /// Human rows of the training set (N_train × D_H).
    pub fn human_train(&self) -> DMatrix<f64> {
        self.human.rows(&self.train)
    }

    /// Human rows of the test set.
    pub fn human_test(&self) -> DMatrix<f64> {
        self.human.rows(&self.test)
    }

    /// The training frames to hold out for choosing a model's iteration budget: positions in
    /// [`Dataset::train`] (not frame numbers), with the rule that chose them.
    ///
    /// The training frames are grouped into trajectories (runs of training frames in one
    /// segment; without segments, runs of consecutive frames). When the trajectories are
    /// When every training frame names who performed it and they are three or more people, every
    /// third person is held out ([`ValidationRule::EveryThirdPerson`]). Otherwise, when
    /// the trajectories are labelled with two or more repetitions, the last repetition of every
    /// motion is held out
    /// ([`ValidationRule::LastRepetition`]): held-out frames are then as far from the others
    /// as test motions are from the training motions. Otherwise every third trajectory is held
    /// out ([`ValidationRule::EveryThirdTrajectory`]), or, with fewer than three trajectories,
    /// every third of nine equal blocks of training frames ([`ValidationRule::EveryThirdBlock`]).
    /// Test frames are never looked at.
    pub fn validation_split(&self) -> ValidationSplit {
        let t = self.training_groups();
        ValidationSplit {
            rows: (0..t.groups.len())
                .filter(|&p| t.validation.contains(&t.groups[p]))
                .collect(),
            rule: t.rule,
        }
    }

    /// The training frames in the groups [`Dataset::validation_split`] holds out (by its
    /// rule): the person who performed each frame, the repetition of its motion, its
    /// trajectory, or its block of nine. A model's trust threshold holds each group out in turn.
    pub fn training_groups(&self) -> TrainingGroups {
        if let Some(groups) = self.people_groups() {
            return groups;
        }
        let mut runs: Vec<(Option<usize>, Vec<usize>)> = Vec::new();
        for (pos, &frame) in self.train.iter().enumerate() {
            let segment = self.segment_of(frame);
            let key = segment.map(|s| s.start);
            let continues = match runs.last() {
                Some((k, members)) => match segment {
                    Some(_) => *k == key,
                    None => members.last().is_some_and(|&p| self.train[p] + 1 == frame),
                },
                None => false,
            };
            match runs.last_mut() {
                Some((_, members)) if continues => members.push(pos),
                _ => runs.push((key, vec![pos])),
            }
        }
        let repetition = |key: Option<usize>| {
            key.and_then(|start| self.segment_of(start))
                .and_then(|s| s.repetition)
        };
        let repetitions: std::collections::BTreeSet<usize> =
            runs.iter().filter_map(|(k, _)| repetition(*k)).collect();
        let n = self.train.len();
        let mut groups = vec![0; n];
        match repetitions.last() {
            Some(&last) if repetitions.len() >= 2 => {
                // Trajectories without a repetition label: each its own group, never held out.
                for (r, (key, members)) in runs.iter().enumerate() {
                    let g = repetition(*key).unwrap_or(last + 1 + r);
                    members.iter().for_each(|&p| groups[p] = g);
                }
                TrainingGroups {
                    groups,
                    validation: vec![last],
                    rule: ValidationRule::LastRepetition,
                }
            }
            _ if runs.len() >= 3 => {
                for (r, (_, members)) in runs.iter().enumerate() {
                    members.iter().for_each(|&p| groups[p] = r);
                }
                TrainingGroups {
                    groups,
                    validation: (2..runs.len()).step_by(3).collect(),
                    rule: ValidationRule::EveryThirdTrajectory,
                }
            }
            _ => {
                for (p, g) in groups.iter_mut().enumerate() {
                    *g = p * 9 / n;
                }
                TrainingGroups {
                    groups,
                    validation: vec![2, 5, 8],
                    rule: ValidationRule::EveryThirdBlock,
                }
            }
        }
    }

    /// The training frames grouped by person, when every one names its person and there are
    /// at least three (in order of first appearance; every third held out).
    fn people_groups(&self) -> Option<TrainingGroups> {
        let mut people: Vec<&str> = Vec::new();
        let mut groups = Vec::with_capacity(self.train.len());
        for &frame in &self.train {
            let person = self.segment_of(frame)?.person.as_deref()?;
            let g = match people.iter().position(|p| *p == person) {
                Some(g) => g,
                None => {
                    people.push(person);
                    people.len() - 1
                }
            };
            groups.push(g);
        }
        (people.len() >= 3).then(|| TrainingGroups {
            groups,
            validation: (2..people.len()).step_by(3).collect(),
            rule: ValidationRule::EveryThirdPerson,
        })
    }

    /// The people who performed the frames `frames` (each named once, in order of first
    /// appearance; frames of no named person are left out).
    pub fn people_of(&self, frames: &[usize]) -> Vec<String> {
        let mut people: Vec<String> = Vec::new();
        for &f in frames {
            if let Some(p) = self.segment_of(f).and_then(|s| s.person.as_ref()) {
                if !people.contains(p) {
                    people.push(p.clone());
                }
            }
        }
        people
    }

    /// Training rows of robot `name`, if there is such a robot.
    pub fn robot_train(&self, name: &str) -> Option<DMatrix<f64>> {
        self.robot(name).map(|r| r.rows(&self.train))
    }

    /// Test rows of robot `name`, if there is such a robot.
    pub fn robot_test(&self, name: &str) -> Option<DMatrix<f64>> {
        self.robot(name).map(|r| r.rows(&self.test))
    }

    /// Checks shapes, segment coverage, split bounds, ordering and disjointness.
    pub fn validate(&self) -> Result<()> {
        let bad = |detail: String| JointStateError::InvalidInput {
            what: "dataset".into(),
            detail,
        };
        let n = self.len();
        if !self.times_ns.windows(2).all(|w| w[0] < w[1]) {
            return Err(bad("frame times must increase strictly".into()));
        }
        for b in std::iter::once(&self.human).chain(&self.robots) {
            if b.positions.nrows() != n || b.positions.ncols() != b.joint_names.len() {
                return Err(bad(format!(
                    "body `{}` has a {}×{} matrix, expected {n}×{} (frames × joints)",
                    b.name,
                    b.positions.nrows(),
                    b.positions.ncols(),
                    b.joint_names.len()
                )));
            }
        }
        let mut names: Vec<&str> = vec![&self.human.name];
        let mut topics: Vec<&str> = vec![&self.human.topic];
        for r in &self.robots {
            if names.contains(&r.name.as_str()) || topics.contains(&r.topic.as_str()) {
                return Err(bad(format!(
                    "body `{}` (topic `{}`) repeats a name or topic",
                    r.name, r.topic
                )));
            }
            names.push(&r.name);
            topics.push(&r.topic);
        }
        let mut at = 0;
        for s in &self.segments {
            if s.start != at || s.end < s.start {
                return Err(bad(format!(
                    "segment {}..{} does not continue at frame {at}",
                    s.start, s.end
                )));
            }
            for p in [s.from_pose, s.to_pose].into_iter().flatten() {
                if p >= self.pose_names.len() {
                    return Err(bad(format!(
                        "segment {}..{} names pose {p}, but there are {} pose names",
                        s.start,
                        s.end,
                        self.pose_names.len()
                    )));
                }
            }
            at = s.end;
        }
        if at != n {
            return Err(bad(format!("segments cover {at} frames, expected {n}")));
        }
        for (what, set) in [("train", &self.train), ("test", &self.test)] {
            if !set.windows(2).all(|w| w[0] < w[1]) || set.last().is_some_and(|&l| l >= n) {
                return Err(bad(format!(
                    "{what} frames must increase strictly and be < {n}"
                )));
            }
        }
        if let Some(f) = self
            .train
            .iter()
            .find(|f| self.test.binary_search(f).is_ok())
        {
            return Err(bad(format!("frame {f} is in both train and test sets")));
        }
        Ok(())
    }
}

/// Joins datasets one after another on one clock: each part's frames follow the previous
/// part's last frame after `gap_ns`, with its segments and its train and test frames shifted.
/// The human comes from every part (the same joints in each); a robot is kept if every part
/// has it with the same joints. Pose names must agree where parts have them.
pub fn concatenate(parts: &[Dataset], gap_ns: i64) -> Result<Dataset> {
    let bad = |detail: String| JointStateError::InvalidInput {
        what: "demonstrations to join".into(),
        detail,
    };
    let first = parts
        .first()
        .ok_or_else(|| bad("no dataset to join".into()))?;
    for (k, p) in parts.iter().enumerate() {
        if p.human.joint_names != first.human.joint_names {
            return Err(bad(format!(
                "part {k}'s human joints are not part 0's: {}",
                crate::names::difference(&first.human.joint_names, &p.human.joint_names, "joint")
            )));
        }
        if !p.pose_names.is_empty()
            && !first.pose_names.is_empty()
            && p.pose_names != first.pose_names
        {
            return Err(bad(format!("part {k} names other key poses than part 0")));
        }
    }
    let robots: Vec<&BodyData> = first
        .robots
        .iter()
        .filter(|r| {
            parts.iter().all(|p| {
                p.robot(&r.name)
                    .is_some_and(|o| o.joint_names == r.joint_names)
            })
        })
        .collect();
    let total: usize = parts.iter().map(Dataset::len).sum();
    let mut times = Vec::with_capacity(total);
    let mut human = DMatrix::zeros(total, first.human.joint_names.len());
    let mut robot_rows: Vec<DMatrix<f64>> = robots
        .iter()
        .map(|r| DMatrix::zeros(total, r.joint_names.len()))
        .collect();
    let (mut segments, mut train, mut test) = (Vec::new(), Vec::new(), Vec::new());
    for p in parts {
        let offset = times.len();
        let shift = match (times.last(), p.times_ns.first()) {
            (Some(&last), Some(&start)) => last + gap_ns - start,
            _ => 0,
        };
        times.extend(p.times_ns.iter().map(|t| t + shift));
        human
            .rows_mut(offset, p.len())
            .copy_from(&p.human.positions);
        for (m, r) in robot_rows.iter_mut().zip(&robots) {
            if let Some(o) = p.robot(&r.name) {
                m.rows_mut(offset, p.len()).copy_from(&o.positions);
            }
        }
        segments.extend(p.segments.iter().map(|s| Segment {
            start: s.start + offset,
            end: s.end + offset,
            ..s.clone()
        }));
        train.extend(p.train.iter().map(|f| f + offset));
        test.extend(p.test.iter().map(|f| f + offset));
    }
    let ds = Dataset {
        times_ns: times,
        human: BodyData {
            positions: human,
            ..first.human.clone()
        },
        robots: robots
            .iter()
            .zip(robot_rows)
            .map(|(r, positions)| BodyData {
                positions,
                ..(*r).clone()
            })
            .collect(),
        pose_names: parts
            .iter()
            .find(|p| !p.pose_names.is_empty())
            .map(|p| p.pose_names.clone())
            .unwrap_or_default(),
        segments,
        train,
        test,
    };
    ds.validate()?;
    Ok(ds)
}

mod every_frame;
mod file;

pub use file::{
    load_demonstrations, load_demonstrations_with, write_demonstrations, write_demonstrations_with,
    write_demonstrations_with_metadata, LoadOptions,
};

#[cfg(test)]
mod tests {
    use super::file::body_name_of_topic;
    use super::*;
    use crate::joint_state::{
        write_joint_states, write_topics, Compression, JointStates, MessageEncoding, TopicData,
        WriteSettings,
    };

    fn tmp(tag: &str) -> std::path::PathBuf {
        let d = std::env::temp_dir().join(format!("sgplvm-ds-{tag}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).expect("mkdir");
        d
    }

    fn body(name: &str, topic: &str, n: usize, d: usize, seed: f64) -> BodyData {
        BodyData {
            name: name.into(),
            topic: topic.into(),
            joint_names: (0..d).map(|j| format!("{name}_j{j}")).collect(),
            positions: DMatrix::from_fn(n, d, |r, c| ((r * d + c) as f64 * 0.37 + seed).sin()),
        }
    }

    fn small() -> Dataset {
        let n = 12;
        Dataset {
            times_ns: (0..n as i64)
                .map(|k| 1_000_000_000 + k * 25_000_000)
                .collect(),
            human: body("human", "/human/joint_states", n, 18, 0.0),
            robots: vec![
                body("walkman", "/walkman/joint_command", n, 14, 1.0),
                body("coman", "/coman/joint_command", n, 14, 2.0),
            ],
            pose_names: vec!["neutral".into(), "up".into(), "side".into()],
            segments: vec![
                Segment {
                    start: 0,
                    end: 5,
                    from_pose: Some(0),
                    to_pose: Some(1),
                    repetition: Some(0),
                    person: None,
                },
                Segment {
                    start: 5,
                    end: 8,
                    from_pose: Some(1),
                    to_pose: Some(0),
                    repetition: Some(0),
                    person: None,
                },
                Segment {
                    start: 8,
                    end: 12,
                    from_pose: Some(1),
                    to_pose: Some(2),
                    repetition: Some(0),
                    person: None,
                },
            ],
            train: vec![0, 2, 4],
            test: vec![8, 9, 10, 11],
        }
    }

    #[test]
    fn validation_holds_out_the_last_repetition_else_every_third_trajectory() {
        let segment = |start, end, to_pose, repetition| Segment {
            start,
            end,
            from_pose: Some(0),
            to_pose: Some(to_pose),
            repetition,
            person: None,
        };
        let mut ds = small();
        // Three motions, two repetitions each: frames 0..12 in six segments of two.
        ds.segments = (0..6)
            .map(|k| segment(2 * k, 2 * k + 2, 1 + k % 3, Some(k / 3)))
            .collect();
        ds.train = vec![0, 1, 2, 4, 5, 6, 7, 9, 10, 11];
        ds.test = vec![3, 8];
        let split = ds.validation_split();
        assert_eq!(split.rule, ValidationRule::LastRepetition);
        // Repetition 1 is frames 6..12: training positions 5..10.
        assert_eq!(split.rows, vec![5, 6, 7, 8, 9]);
        // Unlabelled repetitions: every third trajectory (one per segment here).
        for s in &mut ds.segments {
            s.repetition = None;
        }
        let split = ds.validation_split();
        assert_eq!(split.rule, ValidationRule::EveryThirdTrajectory);
        // Trajectories: [0,1] [2] [4,5] [6,7] [9] [10,11] → the third and the sixth.
        assert_eq!(split.rows, vec![3, 4, 8, 9]);
        // No segments: trajectories are runs of consecutive frames.
        ds.segments.clear();
        let split = ds.validation_split();
        assert_eq!(split.rule, ValidationRule::EveryThirdTrajectory);
        // Runs: [0,1,2] [4..7] [9,10,11] → the third.
        assert_eq!(split.rows, vec![7, 8, 9]);
        // One run: nine blocks.
        ds.train = (0..9).collect();
        let split = ds.validation_split();
        assert_eq!(split.rule, ValidationRule::EveryThirdBlock);
        assert_eq!(split.rows, vec![2, 5, 8]);
    }

    #[test]
    fn training_frames_of_three_or_more_people_are_grouped_and_held_out_by_person() {
        let mut ds = small();
        // Segments 0..5, 5..8, 8..12 of people a, b, a: two people, trajectories as before.
        for (s, p) in ds.segments.iter_mut().zip(["a", "b", "a"]) {
            s.person = Some(p.into());
        }
        ds.train = vec![0, 2, 4, 5, 6, 7, 8];
        ds.test = vec![10, 11];
        assert_ne!(ds.validation_split().rule, ValidationRule::EveryThirdPerson);
        assert_eq!(ds.people_of(&ds.test), vec!["a".to_string()]);
        // Three people: c's frames (the third named) are held out, whichever segment they are in.
        ds.segments[2].person = Some("c".into());
        let groups = ds.training_groups();
        assert_eq!(groups.rule, ValidationRule::EveryThirdPerson);
        assert_eq!(groups.groups, vec![0, 0, 0, 1, 1, 1, 2]);
        assert_eq!(groups.validation, vec![2]);
        assert_eq!(ds.validation_split().rows, vec![6]);
        // A training frame of nobody named: the people rule does not apply.
        ds.segments[1].person = None;
        assert_ne!(ds.validation_split().rule, ValidationRule::EveryThirdPerson);
        // Persons survive the file.
        ds.segments[1].person = Some("b".into());
        let p = tmp("people").join("d.mcap");
        write_demonstrations(&p, &ds).expect("write");
        assert_eq!(load_demonstrations(&p).expect("load").segments, ds.segments);
    }

    #[test]
    fn dataset_round_trips_exactly_through_mcap() {
        let dir = tmp("rt");
        let ds = small();
        let p = dir.join("d.mcap");
        write_demonstrations(&p, &ds).expect("write");
        let back = load_demonstrations(&p).expect("load");
        assert_eq!(back, ds);
        assert_eq!(back.segment_of(6).map(|s| s.from_pose), Some(Some(1)));
        assert_eq!(back.segment_of(12), None);
        assert_eq!(back.human_train().shape(), (3, 18));
        assert_eq!(back.robot_test("coman").map(|m| m.shape()), Some((4, 14)));
        assert_eq!(
            back.robot_train("coman").map(|m| m[(1, 3)]),
            Some(ds.robots[1].positions[(2, 3)])
        );
        assert!(back.robot("centauro").is_none());
        let _ = std::fs::remove_dir_all(dir);
    }

    #[test]
    fn invalid_datasets_are_rejected_before_writing() {
        let dir = tmp("bad");
        let p = dir.join("d.mcap");
        let mut ds = small();
        ds.test.push(2);
        ds.test.sort();
        assert!(write_demonstrations(&p, &ds).is_err(), "overlapping split");
        let mut ds = small();
        ds.segments[1].end = 7;
        assert!(ds.validate().is_err(), "gap in segments");
        let mut ds = small();
        ds.segments[2].to_pose = Some(3);
        assert!(ds.validate().is_err(), "pose out of range");
        let mut ds = small();
        ds.robots[1].positions = DMatrix::zeros(11, 14);
        assert!(ds.validate().is_err(), "shape");
        let mut ds = small();
        ds.robots[1].topic = ds.robots[0].topic.clone();
        assert!(ds.validate().is_err(), "duplicate topic");
        assert!(!p.exists());
        let _ = std::fs::remove_dir_all(dir);
    }

    #[test]
    fn foreign_file_loads_unlabelled_and_aligned() {
        let dir = tmp("foreign");
        let p = dir.join("f.mcap");
        let a = JointStates::new(
            (0..=40).map(|k| k * 25_000_000).collect(),
            vec!["h".into()],
            (0..=40).map(|k| k as f64).collect(),
        )
        .expect("a");
        let b = JointStates::new(
            (0..=100).map(|k| k * 10_000_000).collect(),
            vec!["r".into()],
            (0..=100).map(|k| 2.0 * k as f64).collect(),
        )
        .expect("b");
        write_topics(
            &p,
            &[
                TopicData {
                    topic: "/human/joint_states",
                    states: &a,
                    encoding: MessageEncoding::Cdr,
                },
                TopicData {
                    topic: "/bot/joint_command",
                    states: &b,
                    encoding: MessageEncoding::Json,
                },
            ],
            &WriteSettings::default(),
        )
        .expect("write");
        let ds = load_demonstrations(&p).expect("load");
        assert_eq!(ds.len(), 41);
        assert_eq!(ds.robot_names(), ["bot"]);
        assert_eq!(ds.segments.len(), 1);
        assert_eq!(ds.segments[0].from_pose, None);
        assert_eq!(ds.train.len(), 41);
        assert!(ds.test.is_empty());
        // b at t = k·25 ms is 2·(2.5 k) = 5 k.
        assert!((ds.robots[0].positions[(3, 0)] - 15.0).abs() < 1e-12);

        // Without a `human` topic, the caller must say which one it is.
        let q = dir.join("g.mcap");
        write_joint_states(&q, "/person", &a, Compression::None).expect("write");
        assert!(load_demonstrations(&q).is_err());
        let mut opts = LoadOptions {
            human_topic: Some("/person".into()),
            ..LoadOptions::default()
        };
        let ds = load_demonstrations_with(&q, &opts).expect("load");
        assert_eq!(ds.human.positions.nrows(), 41);
        assert!(ds.robots.is_empty());

        // A body model's joint order: missing joints are an error naming them.
        opts.joint_order
            .insert("/person".into(), vec!["h".into(), "elbow".into()]);
        let err = load_demonstrations_with(&q, &opts).unwrap_err();
        assert!(err.to_string().contains("elbow"), "{err}");
        let _ = std::fs::remove_dir_all(dir);
    }

    #[test]
    fn topic_names_give_body_names() {
        assert_eq!(body_name_of_topic("/walkman/joint_command"), "walkman");
        assert_eq!(body_name_of_topic("joint_states"), "joint_states");
        assert_eq!(body_name_of_topic("/"), "/");
    }
}
