//! `predict`'s MCAP output for Foxglove: the human and the robot side by side, animated by
//! `/tf` from our forward kinematics, with the predictive standard deviation and the latent
//! point per frame (see `sgplvm::robots::scene`).

use std::io::BufRead;

use anyhow::{bail, Context, Result};
use sgplvm::robots::joint_state::JointStates;
use sgplvm::robots::scene::{
    write_scene, ArraySeries, ArrayTopic, SceneBody, SceneOptions, SceneSeries, SceneWriter,
};
use sgplvm::{Mat, Predictor};

use super::super::frames::{advise_unnamed, column_order, model_joint_names};
use super::super::limits::Commands;
use super::{StreamLimits, Target};
use sgplvm::capture::girdle::GirdleAlignment;
use sgplvm::csv::read_header;

/// Where the human's root link stands in `world` (metres): on the left, seen from the front.
const HUMAN_AT: [f64; 3] = [0.0, 0.6, 0.0];
/// Where the robot's root link stands: on the right.
const ROBOT_AT: [f64; 3] = [0.0, -0.6, 0.0];

/// The values of every frame, row-major.
pub struct Frames<'a> {
    /// Frame times, nanoseconds.
    pub times_ns: &'a [i64],
    /// Human joint values in the model's human column order.
    pub human: &'a [f64],
    /// Predicted robot joint values.
    pub mean: &'a [f64],
    /// Their standard deviations.
    pub std: &'a [f64],
    /// Latent points.
    pub latent: &'a [f64],
}

/// The two bodies (human, robot) with the joint names of their columns: the robot as its
/// anatomy has it (its own URDF), drawn with the joints it is commanded.
fn bodies(model: &dyn Predictor, target: &Target) -> Result<Vec<(SceneBody, Vec<String>)>> {
    let human = model.input_name();
    let robot = target.robot.as_str();
    let human_body = SceneBody::builtin(human, &format!("/{human}/joint_states"), HUMAN_AT)
        .with_context(|| {
            format!("cannot draw '{human}' in the MCAP output: it is not a built-in body; write --no-tf for joint commands only")
        })?;
    let Some(anatomy) = &target.anatomy else {
        bail!("cannot draw '{robot}' in the MCAP output: it is neither built in nor given by --urdf FILE; give its URDF, or write --no-tf for joint commands only");
    };
    let robot_body = SceneBody {
        name: robot.to_string(),
        robot: anatomy.robot().clone(),
        placement: nalgebra::Isometry3::translation(ROBOT_AT[0], ROBOT_AT[1], ROBOT_AT[2]),
        joint_topic: format!("/{robot}/joint_command"),
        meshes: sgplvm::robots::urdf::MeshSearch::for_robot(anatomy.robot()),
        // The joints it is not commanded (a waist, legs) where they are held.
        rest: Some(anatomy.hold_configuration().to_vec()),
    };
    Ok(vec![
        (human_body, model_joint_names(model, human)),
        (robot_body, target.names().to_vec()),
    ])
}

/// The per-frame topics beside the bodies: the `_std` JointState (with `--std`), the standard
/// deviation and the latent point as Float64MultiArray.
fn arrays(model: &dyn Predictor, target: &Target, std_topic: Option<&str>) -> Vec<ArrayTopic> {
    let robot = target.robot.as_str();
    let joints = target.names().to_vec();
    let d = joints.len();
    let mut arrays: Vec<ArrayTopic> = std_topic
        .map(|t| ArrayTopic::joint_state(t, joints))
        .into_iter()
        .collect();
    arrays.push(ArrayTopic::float64(
        &format!("/{robot}/prediction_std"),
        "joint",
        d,
    ));
    arrays.push(ArrayTopic::float64("/latent", "latent", model.latent_dim()));
    arrays
}

/// Writes a whole prediction as a scene, atomically.
pub fn write(
    model: &dyn Predictor,
    target: &Target,
    f: &Frames<'_>,
    std_topic: Option<&str>,
    metadata: (String, std::collections::BTreeMap<String, String>),
    out: &str,
) -> Result<()> {
    let bodies = bodies(model, target)?;
    let states = [f.human, f.mean]
        .iter()
        .zip(&bodies)
        .map(|(values, (_, names))| {
            JointStates::new(f.times_ns.to_vec(), names.clone(), values.to_vec())
        })
        .collect::<Result<Vec<_>, _>>()?;
    let series: Vec<SceneSeries<'_>> = bodies
        .iter()
        .zip(&states)
        .map(|((body, _), states)| SceneSeries { body, states })
        .collect();
    let topics = arrays(model, target, std_topic);
    let values: Vec<&[f64]> = topics
        .iter()
        .map(|t| {
            if t.topic == "/latent" {
                f.latent
            } else {
                f.std
            }
        })
        .collect();
    let arrays: Vec<ArraySeries<'_>> = topics
        .iter()
        .zip(values)
        .map(|(topic, values)| ArraySeries { topic, values })
        .collect();
    let options = SceneOptions {
        metadata: vec![metadata],
        ..SceneOptions::default()
    };
    write_scene(out, &series, &arrays, &options)?;
    Ok(())
}

/// Teleoperation into an MCAP file: CSV lines in on stdin, one frame written (and flushed as a
/// finished chunk) per line, so that the file is readable up to its last whole frame even if
/// the process is killed; summary and footer once the input ends. The file is written in
/// place, not renamed into place: a recording in progress is meant to be seen.
pub fn predict_stream_mcap(
    model: &dyn Predictor,
    target: &Target,
    out: &str,
    tf: bool,
    commands: Commands,
    mut girdle: Option<GirdleAlignment>,
) -> Result<()> {
    let stdin = std::io::stdin();
    let mut lines = stdin.lock().lines();
    let (header, header_line) = read_header(&mut lines, "stdin")?;
    let wanted = model_joint_names(model, model.input_name());
    let order = advise_unnamed(
        column_order(&wanted, &header.joints, "stdin"),
        model,
        model.input_name(),
    )?;
    let robot = target.robot.as_str();
    let topics = arrays(model, target, None);
    let mut limited = StreamLimits::new(commands, header.time_column.as_deref());
    let options = SceneOptions {
        tf,
        metadata: vec![limited.commands.metadata(robot, None)],
        ..SceneOptions::default()
    };
    let mut writer = SceneWriter::create(out, bodies(model, target)?, topics, &options, true)?;
    let mut human = vec![0.0; wanted.len()];
    let d = target.names().len();
    let m = target.columns.model_columns();
    let mut frame = 0i64;
    for (i, line) in lines.enumerate() {
        let line = line.context("stdin")?;
        if line.trim().is_empty() || line.starts_with('#') {
            continue;
        }
        let (time, values) = header.parse_line(&line, header_line + i + 1, "stdin")?;
        for (h, &k) in human.iter_mut().zip(&order) {
            *h = values[k];
        }
        let time_ns = match (time, header.time_column.as_deref()) {
            (Some(t), Some("time_ns")) => t as i64,
            (Some(t), _) => (t * 1e9).round() as i64,
            (None, _) => frame * 25_000_000,
        };
        if time_ns < 0 {
            bail!(
                "{out}: line {} of stdin has the negative time {} s; an MCAP output needs times ≥ 0 \
                 (shift the input's times, or write CSV); the {frame} frames before it are in {out}",
                header_line + i + 1,
                time_ns as f64 * 1e-9
            );
        }
        // The model takes the person's clavicles aligned; the scene draws them as captured.
        let mut h = Mat::from_fn(1, human.len(), |_, j| human[j]);
        if let Some(g) = girdle.as_mut() {
            sgplvm::girdle::align_rows(g, &mut h);
        }
        let p = model.predict(h.as_ref(), robot, true)?;
        let model_mean: Vec<f64> = (0..m).map(|j| p.mean[(0, j)]).collect();
        let mut mean = vec![0.0; d];
        target.columns.fill(&model_mean, &mut mean);
        limited.push(&mut mean, time);
        let model_std: Vec<f64> = match &p.variance {
            Some(v) => (0..m).map(|j| v[(0, j)].sqrt()).collect(),
            None => vec![f64::NAN; m],
        };
        let mut std = vec![0.0; d];
        target.columns.fill_std(&model_std, &mut std);
        let latent: Vec<f64> = (0..p.latent.ncols()).map(|j| p.latent[(0, j)]).collect();
        writer.write_frame(time_ns, &[&human, &mean], &[&std, &latent])?;
        frame += 1;
    }
    let frames = writer.frames();
    writer.finish()?;
    limited.report(robot, target.names());
    eprintln!(
        "wrote {frames} frames of {robot} joint commands to {out} (topic /{robot}/joint_command)"
    );
    Ok(())
}
