//! `simulate --out x.mcap`: the replay for Foxglove — the commanded and the simulated joints,
//! the robot drawn by `/tf` from the simulated joints, and the events as markers (see
//! `sgplvm::robots::scene`).

use std::path::Path;

use anyhow::{bail, Context, Result};
use nalgebra::Isometry3;
use sgplvm::robots::joint_state::JointStates;
use sgplvm::robots::physics::ReplayReport;
use sgplvm::robots::scene::{
    replay_markers, write_scene_with_markers, ArraySeries, ArrayTopic, SceneBody, SceneOptions,
    SceneSeries,
};
use sgplvm::robots::urdf::MeshSearch;
use sgplvm::robots::{Robot, Trajectory};

/// The replayed robot: its URDF text, the file it came from, its name in the scene and where
/// its meshes are found.
pub struct Body<'a> {
    pub xml: &'a str,
    pub source: &'a str,
    pub name: &'a str,
    pub meshes: MeshSearch,
}

/// Writes the replay of `trajectory` (times from 0; `t0` seconds is the first frame's time in
/// the input) on `replayed` to `out`, atomically.
pub fn write(
    out: &Path,
    replayed: &Body<'_>,
    trajectory: &Trajectory,
    t0: f64,
    report: &ReplayReport,
) -> Result<()> {
    let Body {
        xml, source, name, ..
    } = *replayed;
    let shown = out.display();
    if name.is_empty() || name.contains('/') {
        bail!("{shown}: the robot's name '{name}' cannot prefix its topics and frames; name it with --robot NAME (no '/')");
    }
    let t0_ns = (t0 * 1e9).round() as i64;
    let times_ns: Vec<i64> = trajectory
        .times
        .iter()
        .map(|t| t0_ns.saturating_add((t * 1e9).round() as i64))
        .collect();
    if let Some(i) = times_ns.iter().position(|t| *t < 0) {
        bail!(
            "{shown}: frame {} of the trajectory has the negative time {} s; an MCAP output \
             needs times ≥ 0 (shift the input's times)",
            i + 1,
            times_ns[i] as f64 * 1e-9
        );
    }
    let simulated = report
        .simulated
        .as_ref()
        .with_context(|| format!("{shown}: the replay recorded no simulated joints"))?;
    let robot = Robot::from_urdf_str(xml, source)?;
    let body = SceneBody {
        name: name.to_string(),
        robot,
        placement: Isometry3::identity(),
        joint_topic: format!("/{name}/joint_states"),
        meshes: Some(replayed.meshes.clone()),
        rest: None,
    };
    let states = JointStates::new(
        times_ns.clone(),
        simulated.joint_names.clone(),
        simulated.positions.clone(),
    )?;
    let command = ArrayTopic::joint_state(
        &format!("/{name}/joint_command"),
        trajectory.joint_names.clone(),
    );
    let markers = replay_markers(&body, report, t0_ns, &format!("/{name}/events"));
    write_scene_with_markers(
        out,
        &[SceneSeries {
            body: &body,
            states: &states,
        }],
        &[ArraySeries {
            topic: &command,
            values: &trajectory.positions,
        }],
        &markers,
        &SceneOptions::default(),
    )
    .with_context(|| format!("{shown}: cannot write the replay"))?;
    eprintln!(
        "wrote {} frames of the replay on {source} to {shown} (/{name}/joint_command, /{name}/joint_states, /tf, {} events on /{name}/events)",
        times_ns.len(),
        markers.len()
    );
    Ok(())
}
