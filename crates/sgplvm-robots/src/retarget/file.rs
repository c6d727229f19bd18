//! Retargeting whole files: human demonstrations (MCAP, e.g. from `sgplvm import`) in, the
//! robots' commands split for training out (MCAP: the human, each robot's
//! `/NAME/joint_command`, blocks as segments, the split and the reach reports as metadata) —
//! what `sgplvm retarget` and Python's `sgplvm.retarget(..., out=...)` both do.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use serde::Serialize;

use super::split::{split_into_blocks, SplitOptions, SplitRule, SplitSummary};
use super::{retarget, ReachReport, RetargetError, RetargetOptions};
use crate::anatomy::Anatomy;
use crate::dataset::{
    capture_records, concatenate, load_demonstrations, write_demonstrations_with_metadata, Dataset,
    CAPTURE_METADATA,
};
use crate::joint_state::Compression;
use crate::{RobotIdentity, Side};

/// Name of the MCAP metadata record with the retargeting's settings and reach reports.
pub const RETARGET_METADATA: &str = "sgplvm.retarget";

/// The arms `retarget` drove on one robot, as its file records them
/// ([`retargeted_arms`]).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct RetargetedArms {
    /// Which of the person's arms drove the robot's arms, left first.
    pub sides: Vec<Side>,
    /// The robot's joints of the arm each side drove, by [`Side::index`]: what the robot's
    /// anatomy took as that arm (names, structure or `--arm`). Both empty in a file written
    /// before they were recorded.
    pub joints: [Vec<String>; 2],
    /// The robot the commands were retargeted onto (`None` in a file written before it was
    /// recorded).
    pub identity: Option<RobotIdentity>,
}

/// The arms `retarget` drove on each robot of a file it wrote (robot name → arms), from its
/// [`RETARGET_METADATA`] record; empty for a file without one or written before the record
/// held them.
pub fn retargeted_arms(path: &Path) -> Result<BTreeMap<String, RetargetedArms>, RetargetError> {
    let read = crate::joint_state::read_topics(path, &[]).map_err(|e| {
        RetargetError::Invalid(format!(
            "{}: record `{RETARGET_METADATA}`: {e}",
            path.display()
        ))
    })?;
    retargeted_arms_in(path, &read.metadata)
}

/// [`retargeted_arms`] from the metadata records already read from `path` (named in errors).
pub fn retargeted_arms_in(
    path: &Path,
    metadata: &BTreeMap<String, BTreeMap<String, String>>,
) -> Result<BTreeMap<String, RetargetedArms>, RetargetError> {
    let bad = |detail: String| {
        RetargetError::Invalid(format!(
            "{}: record `{RETARGET_METADATA}`: {detail}",
            path.display()
        ))
    };
    let Some(json) = metadata.get(RETARGET_METADATA).and_then(|m| m.get("json")) else {
        return Ok(BTreeMap::new());
    };
    let value: serde_json::Value =
        serde_json::from_str(json).map_err(|e| bad(format!("not JSON: {e}")))?;
    let Some(arms) = value.get("arms") else {
        return Ok(BTreeMap::new());
    };
    let side = |robot: &str, s: &str| match s {
        "left" => Ok(Side::Left),
        "right" => Ok(Side::Right),
        other => Err(bad(format!(
            "robot `{robot}`: arm side `{other}`; expected \"left\" or \"right\""
        ))),
    };
    let arms: BTreeMap<String, Vec<String>> =
        serde_json::from_value(arms.clone()).map_err(|e| {
            bad(format!(
                "`arms` is not robot → [\"left\"|\"right\", …]: {e}"
            ))
        })?;
    let joints: BTreeMap<String, BTreeMap<String, Vec<String>>> = match value.get("arm_joints") {
        Some(j) => serde_json::from_value(j.clone()).map_err(|e| {
            bad(format!(
                "`arm_joints` is not robot → {{\"left\"|\"right\": [joint, …]}}: {e}"
            ))
        })?,
        None => BTreeMap::new(),
    };
    // A record that cannot be read only costs the warning it would give: none.
    let mut identities: BTreeMap<String, RobotIdentity> = value
        .get("kinematics")
        .and_then(|k| serde_json::from_value(k.clone()).ok())
        .unwrap_or_default();
    arms.into_iter()
        .map(|(robot, sides)| {
            let mut found = RetargetedArms {
                sides: sides
                    .iter()
                    .map(|s| side(&robot, s))
                    .collect::<Result<Vec<_>, _>>()?,
                identity: identities.remove(&robot),
                ..RetargetedArms::default()
            };
            for (s, names) in joints.get(&robot).into_iter().flatten() {
                found.joints[side(&robot, s)?.index()].clone_from(names);
            }
            Ok((robot, found))
        })
        .collect()
}

/// Which frames are kept for testing, as a user names them.
#[derive(Debug, Clone, PartialEq)]
pub enum TestChoice {
    /// Every `n`-th block.
    EveryNthBlock(usize),
    /// These files (by file stem or 0-based index), whole.
    Files(Vec<String>),
    /// Every file of these people (as `sgplvm import --person` named them), whole.
    People(Vec<String>),
    /// None: every frame for training.
    AllTraining,
}

/// What retargeting a set of files did.
#[derive(Debug, Clone, Serialize)]
pub struct FilesRetargeted {
    /// Frames retargeted.
    pub frames: usize,
    /// The split.
    pub split: SplitSummary,
    /// Per robot, how its hands followed.
    pub reach: Vec<ReachReport>,
    /// Seconds the retargeting took (without reading and writing).
    pub seconds: f64,
    /// The file stems of the inputs' segments (what `TestChoice::Files` names).
    pub files: Vec<String>,
    /// The stems of the files kept whole for testing (`TestChoice::Files`, `TestChoice::People`),
    /// in input order.
    pub test_files: Vec<String>,
    /// The people of the training frames and of the test frames (each once, in order; empty
    /// where the captures name nobody).
    pub train_people: Vec<String>,
    /// See `train_people`.
    pub test_people: Vec<String>,
    /// Each input file's frame rate (Hz, from its median frame step), in input order: the
    /// training subsample counts frames, so files at different rates weigh differently.
    pub rates_hz: Vec<f64>,
}

/// One entry of a file's [`CAPTURE_METADATA`] record: where a captured file's frames came from
/// (the capture crate's `CaptureSource`), carried through unchanged.
pub type CaptureRecord = serde_json::Map<String, serde_json::Value>;

/// The demonstrations of `demos`, one after another, with their capture records and the stem
/// of each segment's file.
pub fn read_human(demos: &[PathBuf]) -> Result<HumanFiles, RetargetError> {
    let mut parts = Vec::with_capacity(demos.len());
    let mut sources: Vec<CaptureRecord> = Vec::new();
    let mut stems = Vec::new();
    let mut rates = Vec::with_capacity(demos.len());
    let invalid = |e: &dyn std::fmt::Display| RetargetError::Invalid(e.to_string());
    for path in demos {
        let mut ds = load_demonstrations(path).map_err(|e| invalid(&e))?;
        let mut file_sources = capture_records(path).map_err(|e| invalid(&e))?;
        files_again(&mut ds, file_sources.len());
        // Each input file is one part; its capture files (if it was imported from several)
        // stay its segments, each with its person.
        stems.extend(file_stems(&ds, &file_sources, path));
        if file_sources.len() == ds.segments.len() {
            for (segment, source) in ds.segments.iter_mut().zip(&file_sources) {
                segment.person = source
                    .get("person")
                    .and_then(|p| p.as_str())
                    .map(str::to_string);
            }
        }
        sources.append(&mut file_sources);
        rates.push(frame_rate(&ds.times_ns));
        parts.push(Dataset {
            robots: Vec::new(),
            ..ds
        });
    }
    let dataset = concatenate(&parts, 1_000_000_000).map_err(|e| invalid(&e))?;
    Ok((dataset, sources, stems, rates))
}

/// The human of [`read_human`]: the frames joined, the capture records, the file stems of the
/// segments and each file's frame rate.
pub type HumanFiles = (Dataset, Vec<CaptureRecord>, Vec<String>, Vec<f64>);

/// The frame rate (Hz) of frames at `times_ns`, from the median step; NaN for fewer than two.
fn frame_rate(times_ns: &[i64]) -> f64 {
    let mut steps: Vec<f64> = times_ns
        .windows(2)
        .map(|w| (w[1] - w[0]) as f64)
        .filter(|d| *d > 0.0)
        .collect();
    if steps.is_empty() {
        return f64::NAN;
    }
    1e9 / crate::series::median(&mut steps)
}

/// Retargets the human of `demos` onto `robots`, splits the frames as `split` and `test` say
/// and writes the demonstrations to `out` (whole or not at all).
pub fn retarget_files(
    demos: &[PathBuf],
    robots: &[(String, Anatomy)],
    options: &RetargetOptions,
    split: &SplitOptions,
    test: &TestChoice,
    out: &Path,
) -> Result<FilesRetargeted, RetargetError> {
    let (mut dataset, sources, stems, rates_hz) = read_human(demos)?;
    let mut split = split.clone();
    split.rule = match test {
        TestChoice::EveryNthBlock(n) => SplitRule::Blocks { test_every: *n },
        TestChoice::Files(names) => SplitRule::Files {
            test: test_file_indices(names, &stems)?,
        },
        TestChoice::People(names) => SplitRule::Files {
            test: test_people_files(names, &dataset)?,
        },
        TestChoice::AllTraining => SplitRule::AllTraining,
    };
    let test_files = match &split.rule {
        SplitRule::Files { test } => (0..stems.len())
            .filter(|k| test.contains(k))
            .map(|k| stems[k].clone())
            .collect(),
        _ => Vec::new(),
    };
    let started = std::time::Instant::now();
    let results = retarget(&dataset, robots, options)?;
    let seconds = started.elapsed().as_secs_f64();
    let summary = split_into_blocks(&mut dataset, &split)?;
    let reach: Vec<ReachReport> = results.iter().map(|r| r.report.clone()).collect();
    dataset.robots = results.into_iter().map(|r| r.body).collect();
    let mut extra = Vec::new();
    if !sources.is_empty() {
        let mut m = BTreeMap::new();
        m.insert(
            "json".to_string(),
            serde_json::Value::from(sources).to_string(),
        );
        extra.push((CAPTURE_METADATA.to_string(), m));
    }
    let mut m = BTreeMap::new();
    // Which of the person's arms drove each robot's arms (a one-armed robot's side is chosen
    // here, by its names or `--arm`): what a latent space per arm is trained on.
    let arms: BTreeMap<&str, Vec<&str>> = robots
        .iter()
        .map(|(name, anatomy)| {
            let sides = anatomy.sides().into_iter().map(Side::as_str).collect();
            (name.as_str(), sides)
        })
        .collect();
    // And each arm's joints: what a latent space per arm takes as that arm's columns, with no
    // URDF or flag needed where the names do not tell.
    let arm_joints: BTreeMap<&str, BTreeMap<&str, Vec<String>>> = robots
        .iter()
        .map(|(name, anatomy)| {
            let joints = anatomy
                .sides()
                .into_iter()
                .filter_map(|side| {
                    Some((
                        side.as_str(),
                        anatomy.arm(side)?.chain.joint_names().to_vec(),
                    ))
                })
                .collect();
            (name.as_str(), joints)
        })
        .collect();
    // And the robot itself, as its commands depend on it: a model trained on these commands
    // then tells when it is given another robot of the same joint names.
    let kinematics: BTreeMap<&str, RobotIdentity> = robots
        .iter()
        .map(|(name, anatomy)| {
            let joints = anatomy.arm_joint_names();
            (name.as_str(), anatomy.robot().identity(&joints))
        })
        .collect();
    let settings = serde_json::json!({
        "match": options.mode,
        "redundancy": options.redundancy,
        "split": split,
        "summary": summary,
        "reach": reach,
        "arms": arms,
        "arm_joints": arm_joints,
        "kinematics": kinematics,
    });
    m.insert("json".to_string(), settings.to_string());
    extra.push((RETARGET_METADATA.to_string(), m));
    write_demonstrations_with_metadata(out, &dataset, Compression::Zstd, extra)
        .map_err(|e| RetargetError::Invalid(e.to_string()))?;
    Ok(FilesRetargeted {
        frames: dataset.len(),
        split: summary,
        reach,
        seconds,
        files: stems,
        test_files,
        train_people: dataset.people_of(&dataset.train),
        test_people: dataset.people_of(&dataset.test),
        rates_hz,
    })
}

/// A file retargeted before holds its capture files cut into blocks: its segments become its
/// capture files again — the runs of frames between the gaps that joined them — when there
/// are as many runs as capture files, so that retargeting it again splits it as the first
/// time.
fn files_again(ds: &mut Dataset, files: usize) {
    if files == 0 || ds.segments.len() == files || ds.len() < 2 {
        return;
    }
    let mut steps: Vec<i64> = ds.times_ns.windows(2).map(|w| w[1] - w[0]).collect();
    steps.sort_unstable();
    let typical = steps[steps.len() / 2].max(1);
    let mut starts = vec![0];
    starts.extend((1..ds.len()).filter(|&i| ds.times_ns[i] - ds.times_ns[i - 1] > 2 * typical));
    if starts.len() != files {
        return;
    }
    ds.segments = starts
        .iter()
        .enumerate()
        .map(|(k, &start)| crate::dataset::Segment {
            start,
            end: starts.get(k + 1).copied().unwrap_or(ds.len()),
            from_pose: None,
            to_pose: None,
            repetition: None,
            person: None,
        })
        .collect();
}

/// Names of the files behind the segments of one input: the capture files it was imported
/// from, or the input file itself.
fn file_stems(ds: &Dataset, sources: &[CaptureRecord], path: &Path) -> Vec<String> {
    let stem = |p: &str| {
        Path::new(p)
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| p.to_string())
    };
    if sources.len() == ds.segments.len() {
        sources
            .iter()
            .map(|s| stem(s.get("file").and_then(|f| f.as_str()).unwrap_or_default()))
            .collect()
    } else {
        let base = stem(&path.display().to_string());
        (0..ds.segments.len())
            .map(|k| {
                if ds.segments.len() == 1 {
                    base.clone()
                } else {
                    format!("{base}#{k}")
                }
            })
            .collect()
    }
}

/// The indices of the files (segments of `dataset`) of the people `names`.
fn test_people_files(names: &[String], dataset: &Dataset) -> Result<Vec<usize>, RetargetError> {
    let all = dataset.people_of(&(0..dataset.len()).collect::<Vec<_>>());
    if all.is_empty() {
        return Err(RetargetError::Invalid(
            "--split people: the captures name nobody; import each person's files with \
             `sgplvm import --person NAME`"
                .into(),
        ));
    }
    if names.is_empty() {
        return Err(RetargetError::Invalid(format!(
            "--split people needs --test-people NAME[,NAME...] (of: {})",
            all.join(", ")
        )));
    }
    if let Some(unknown) = names.iter().find(|n| !all.contains(n)) {
        return Err(RetargetError::Invalid(format!(
            "--test-people: nobody called `{unknown}` in the captures; they are: {}",
            all.join(", ")
        )));
    }
    Ok((0..dataset.segments.len())
        .filter(|&k| {
            dataset.segments[k]
                .person
                .as_ref()
                .is_some_and(|p| names.contains(p))
        })
        .collect())
}

/// The indices of the test files named among the input files `stems`.
fn test_file_indices(names: &[String], stems: &[String]) -> Result<Vec<usize>, RetargetError> {
    if names.is_empty() {
        return Err(RetargetError::Invalid(format!(
            "--split files needs --test-files NAME[,NAME...] (of: {})",
            stems.join(", ")
        )));
    }
    names
        .iter()
        .map(|n| {
            stems
                .iter()
                .position(|s| s == n)
                .or_else(|| n.parse::<usize>().ok().filter(|&i| i < stems.len()))
                .ok_or_else(|| {
                    RetargetError::Invalid(format!(
                        "--test-files: no file `{n}`; the files are: {}",
                        stems.join(", ")
                    ))
                })
        })
        .collect()
}
