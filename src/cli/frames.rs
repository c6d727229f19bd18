//! Reading what `predict` and `simulate` are given: human frames in the model's joint order and
//! robot trajectories, from an MCAP JointState topic or a CSV file; and the checks that name what
//! a model or the built-in robots do not know.

use std::path::Path;

use anyhow::{anyhow, bail, Context, Result};
use sgplvm::csv::{read_frames, CsvFrames, STD_SUFFIX};
use sgplvm::robots::joint_state::{list_channels, read_topics, topic_for, TopicRequest};
use sgplvm::robots::names::{count, few, SHOWN};
use sgplvm::robots::Trajectory;
use sgplvm::{Mat, Predictor, Robot};

/// Human frames read for prediction: times (ns) and rows in the model's human joint order.
pub struct HumanFrames {
    pub times_ns: Vec<i64>,
    pub frames: Mat<f64>,
    /// Whether the times are the input's (false: a CSV without a time column, 40 Hz assumed).
    pub timed: bool,
}

/// The joint names of `space` in `model` (`<space>_<j>` when the model has none stored).
pub fn model_joint_names(model: &dyn Predictor, space: &str) -> Vec<String> {
    match model.column_names(space) {
        Some(names) => names.to_vec(),
        None => (0..model.space_dim(space).unwrap_or(0))
            .map(|j| format!("{space}_{j}"))
            .collect(),
    }
}

/// Positions of the model's joints among the file's columns; missing ones are an error that
/// names the first few of them and of the file's columns, with counts (the whole lists of 18
/// joints made a line no one reads).
pub fn column_order(wanted: &[String], found: &[String], source: &str) -> Result<Vec<usize>> {
    let missing: Vec<&String> = wanted.iter().filter(|w| !found.contains(w)).collect();
    if !missing.is_empty() {
        let which = if missing.len() == wanted.len() {
            format!(
                "none of the model's {} human joint columns is there",
                wanted.len()
            )
        } else {
            format!(
                "{} of the model's {} human joint columns {} missing",
                missing.len(),
                wanted.len(),
                if missing.len() == 1 { "is" } else { "are" }
            )
        };
        bail!(
            "{source}: {which}: {}; the file has {}: {} (`sgplvm joints --model MODEL` lists the \
             model's)",
            few(&missing, SHOWN),
            count(found.len(), "column"),
            few(found, 3),
        );
    }
    Ok(wanted
        .iter()
        .map(|w| found.iter().position(|f| f == w).expect("checked above"))
        .collect())
}

/// What to do about a space of `model` that stores no joint names (a model fitted in Python
/// without `column_names`, on a space not named after a built-in body): `None` when it has them.
pub fn unnamed_space(model: &dyn Predictor, space: &str) -> Option<String> {
    if model.column_names(space).is_some() {
        return None;
    }
    Some(format!(
        "the model stores no joint names for its space `{space}`, so its columns are called \
         {space}_0, {space}_1, …: fit it in Python with the joint names, \
         `fit(..., column_names={{\"{space}\": demo[...][\"joint_names\"], ...}})` (and \
         `transfer(..., column_names=...)`), or with spaces named after built-in bodies \
         (human, {}) whose joints are in the built-in order, which fit names itself",
        Robot::builtin_names().join(", ")
    ))
}

/// Adds [`unnamed_space`]'s advice to `result`'s error when `space` has no joint names.
pub fn advise_unnamed<T>(result: Result<T>, model: &dyn Predictor, space: &str) -> Result<T> {
    match (result, unnamed_space(model, space)) {
        (Err(e), Some(advice)) => Err(e.context(advice)),
        (result, _) => result,
    }
}

/// Fails unless `model` (read from `path`) predicts for `robot`.
pub fn require_robot(model: &dyn Predictor, path: &Path, robot: &str) -> Result<()> {
    if !model.output_names().contains(&robot) {
        bail!(
            "{}: the model does not know robot '{robot}'; it predicts for {:?}",
            path.display(),
            model.output_names()
        );
    }
    Ok(())
}

/// The URDF of a built-in robot; an unknown name is an error listing the known ones.
pub fn builtin_urdf(name: &str) -> Result<&'static str> {
    Robot::builtin_urdf(name).ok_or_else(|| {
        anyhow!(
            "unknown robot '{name}'; expected one of {:?} or --urdf FILE",
            Robot::builtin_names()
        )
    })
}

/// The topic to read in an MCAP file: `given`, else the one JointState channel (not a `_std`
/// one) whose topic contains `hint` (with `or_only`, also the file's only such channel); anything else asks for `--topic`, naming what
/// was looked for (`what`).
fn pick_topic(
    path: &str,
    given: Option<&str>,
    what: &str,
    hint: &str,
    or_only: bool,
) -> Result<String> {
    if let Some(t) = given {
        return Ok(t.to_string());
    }
    let channels = list_channels(path)?;
    // JointState topics only, and not the standard deviations `predict --std` writes beside
    // the commands (`/ROBOT/joint_command_std`).
    let joint_states: Vec<_> = channels
        .iter()
        .filter(|c| c.schema.is_empty() || c.schema.ends_with("JointState"))
        .filter(|c| !c.topic.ends_with(STD_SUFFIX))
        .collect();
    let topics: Vec<&str> = joint_states.iter().map(|c| c.topic.as_str()).collect();
    match (topic_for(&topics, hint), topics.as_slice()) {
        (Some(one), _) => Ok(one.to_string()),
        (None, [one]) if or_only => Ok(one.to_string()),
        _ => bail!(
            "{path}: cannot tell the {what} topic among {:?}; name it with --topic",
            channels.iter().map(|c| &c.topic).collect::<Vec<_>>()
        ),
    }
}

/// Reads a whole CSV table of frames from the file `path`.
fn read_csv(path: &str) -> Result<CsvFrames> {
    let file = std::fs::File::open(path).with_context(|| format!("{path}: cannot open"))?;
    Ok(read_frames(std::io::BufReader::new(file), path)?)
}

/// Reads the human frames of `input` (MCAP or CSV) in the model's human joint order.
pub fn read_human_frames(
    model: &dyn Predictor,
    input: &str,
    topic: Option<&str>,
) -> Result<HumanFrames> {
    advise_unnamed(
        read_human_frames_named(model, input, topic),
        model,
        model.input_name(),
    )
}

/// [`read_human_frames`] without the advice for a model that names no joints.
fn read_human_frames_named(
    model: &dyn Predictor,
    input: &str,
    topic: Option<&str>,
) -> Result<HumanFrames> {
    let wanted = model_joint_names(model, model.input_name());
    if input.ends_with(".mcap") {
        let topic = pick_topic(input, topic, "human", "human", false)?;
        let read = read_topics(input, &[TopicRequest::joints(&topic, &wanted)])?;
        let states = &read.states[0];
        // The model would refuse them naming only its space: name the file, topic and joint.
        for i in 0..states.len() {
            if let Some(j) = states.row(i).iter().position(|v| !v.is_finite()) {
                bail!(
                    "{input}: topic {topic}: joint '{}' is {} in message {} (t = {} s); \
                     expected a finite number",
                    wanted[j],
                    states.row(i)[j],
                    i + 1,
                    states.times_ns[i] as f64 * 1e-9
                );
            }
        }
        let frames = Mat::from_fn(states.len(), wanted.len(), |i, j| states.row(i)[j]);
        return Ok(HumanFrames {
            times_ns: states.times_ns.clone(),
            frames,
            timed: true,
        });
    }
    let table = read_csv(input)?;
    let order = column_order(&wanted, &table.header.joints, input)?;
    let d = table.header.joints.len();
    let frames = Mat::from_fn(table.rows, wanted.len(), |i, j| {
        table.values[i * d + order[j]]
    });
    Ok(HumanFrames {
        times_ns: table.times_ns(),
        frames,
        timed: table.times.is_some(),
    })
}

/// Reads a robot trajectory from an MCAP JointState topic or a CSV file.
pub fn read_trajectory(path: &str, topic: Option<&str>, robot: &str) -> Result<Trajectory> {
    if path.ends_with(".mcap") {
        let topic = pick_topic(path, topic, "trajectory", robot, true)?;
        let states = &read_topics(path, &[TopicRequest::all(topic)])?.states[0];
        return Ok(Trajectory::try_from(states)?);
    }
    // `predict --std` output replays as it is: its `<joint>_std` columns are not joints.
    let table = read_csv(path)?.without_std_columns();
    let times = table.times_seconds();
    Trajectory::new(table.header.joints, times, table.values).with_context(|| path.to_string())
}
