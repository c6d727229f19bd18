//! `sgplvm simulate`: replay a joint trajectory — given, or predicted by a model from human
//! frames — on a robot in the physics engine, and report tracking, limits and collisions.

use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use clap::Args;
use sgplvm::robots::urdf::MeshSearch;
use sgplvm::robots::{PhysicsError, ReplayOptions, Robot, Trajectory};

use super::args::load_any_model;
use super::args::GirdleArg;
use super::body::BodyArgs;
use super::frames::{builtin_urdf, read_human_frames, read_trajectory, require_robot};
use super::predict::Target;
use super::progress::Activity;
use super::report;

mod scene;

#[derive(Args)]
pub struct SimulateArgs {
    /// A built-in robot (walkman, coman, centauro, human, ur5e) or the robot of the model.
    #[arg(long, required_unless_present = "urdf")]
    robot: Option<String>,
    /// A URDF file instead of a built-in robot. Its collision meshes (STL, COLLADA, OBJ) are
    /// simulated as convex hulls (a concave one as its convex parts): relative paths are found beside the file, package://PKG/…
    /// through --package-path, ROS_PACKAGE_PATH and AMENT_PREFIX_PATH. With --model: the URDF
    /// of the model's robot (--robot names it in the model).
    #[arg(long)]
    urdf: Option<PathBuf>,
    /// A folder holding ROS packages (package://PKG/… is DIR/PKG/…, or a PKG folder with a
    /// package.xml a few levels down), or a package folder itself; searched before
    /// ROS_PACKAGE_PATH and AMENT_PREFIX_PATH. Repeatable.
    #[arg(long = "package-path", value_name = "DIR")]
    package_paths: Vec<PathBuf>,
    /// An arm of the URDF robot, SIDE=FROM_LINK:TO_LINK, where its names do not tell (as
    /// `sgplvm robot --arm`; FILE.anatomy.json beside the URDF is read without it): the joints
    /// outside the arms are held still, and with --model the arms are kept within their limits.
    #[arg(long = "arm", value_name = "SIDE=FROM:TO", requires = "urdf")]
    arm: Vec<String>,
    /// Hold a joint the trajectory leaves out (waist, legs, head, grippers of a URDF robot) at
    /// VALUE [default: its hold value, as `sgplvm robot FILE` shows: 0 within its limits].
    #[arg(long = "hold", value_name = "JOINT=VALUE", requires = "urdf")]
    hold: Vec<String>,
    /// Joint trajectory to replay (MCAP or CSV with a header of joint names and a time column;
    /// the `<joint>_std` columns of `sgplvm predict --std` output are ignored).
    #[arg(long, required_unless_present = "model", conflicts_with = "model")]
    trajectory: Option<String>,
    /// Topic of the trajectory (or of the human, with --model) in an MCAP file.
    #[arg(long)]
    topic: Option<String>,
    /// Predict the trajectory with this model from --input human frames, held within the
    /// joints' position and velocity limits as `predict` and `teleop` send commands (as the
    /// robot's controller would take them), then replay it.
    #[arg(long, requires = "input")]
    model: Option<PathBuf>,
    /// Human frames (MCAP or CSV) for --model.
    #[arg(long, requires = "model")]
    input: Option<String>,
    /// With --model: how far apart the robot's own collision shapes stay, metres, as `predict`
    /// keeps them (0: no self-collision limit).
    #[arg(long, default_value_t = 0.01, requires = "model")]
    margin: f64,
    /// Print the whole report as JSON (every violation and collision interval).
    #[arg(long)]
    json: bool,
    /// List every violation and collision interval, not only the worst.
    #[arg(long, short)]
    verbose: bool,
    /// Also write the replay to this .mcap file for Foxglove: commanded and simulated joints
    /// (/ROBOT/joint_command, /ROBOT/joint_states), the robot's description, /tf_static and /tf
    /// of the simulated robot, and the limit and collision events as markers (/ROBOT/events).
    #[arg(long)]
    out: Option<PathBuf>,
    #[command(flatten)]
    girdle: GirdleArg,
}

pub fn run(args: SimulateArgs) -> Result<()> {
    let (xml, source) = match (&args.urdf, args.robot.as_deref()) {
        (Some(path), _) => {
            let xml = std::fs::read_to_string(path)
                .with_context(|| format!("{}: cannot read", path.display()))?;
            (xml, path.display().to_string())
        }
        (None, Some(name)) => (builtin_urdf(name)?.to_string(), format!("builtin:{name}")),
        (None, None) => bail!("name the robot with --robot or --urdf"),
    };
    // Before any work: the replay's file must be writable where it is named.
    if let Some(out) = &args.out {
        if out.extension().and_then(|e| e.to_str()) != Some("mcap") {
            bail!(
                "{}: --out writes MCAP; expected a name ending in .mcap",
                out.display()
            );
        }
        if let Some(folder) = out.parent().filter(|p| !p.as_os_str().is_empty()) {
            if !folder.is_dir() {
                bail!(
                    "{}: cannot write the replay: no folder {}",
                    out.display(),
                    folder.display()
                );
            }
        }
    }
    // The robot's name: given, else the URDF's own (`<robot name>`: its trajectory's topic
    // `/NAME/joint_command` found with no --topic, and the replay's topics named so).
    let urdf_name = match (&args.robot, &args.urdf) {
        (None, Some(_)) => Robot::from_urdf_str(&xml, &source)
            .map(|r| r.name().to_string())
            .ok(),
        _ => None,
    };
    let robot = args
        .robot
        .as_deref()
        .or(urdf_name.as_deref())
        .unwrap_or("robot");
    let topic = args.topic.as_deref();
    let mut trajectory = match (
        args.model.as_deref().zip(args.input.as_deref()),
        &args.trajectory,
    ) {
        (Some((model, input)), _) => predicted_trajectory(model, input, &args, robot)?,
        (None, Some(path)) => read_trajectory(path, topic, robot)?,
        (None, None) => bail!("give --trajectory FILE, or --model MODEL with --input FILE"),
    };
    let held = match &args.urdf {
        Some(urdf) => held_joints(&trajectory, urdf, &args.hold, &args.arm)?,
        None => Vec::new(),
    };
    // Report times from the start of the trajectory (recordings carry wall-clock stamps).
    let t0 = trajectory.times.first().copied().unwrap_or(0.0);
    trajectory.times.iter_mut().for_each(|t| *t -= t0);
    if let Some(dir) = args.package_paths.iter().find(|d| !d.is_dir()) {
        bail!(
            "--package-path {}: no such folder; expected a folder holding ROS packages (or a package)",
            dir.display()
        );
    }
    let meshes = mesh_search(args.urdf.as_deref(), &args.package_paths);
    let options = ReplayOptions {
        record_simulated: args.out.is_some(),
        meshes: meshes.clone(),
        held,
        ..ReplayOptions::default()
    };
    let detail = format!(
        ", {:.1} s of motion at 1 kHz",
        trajectory.times.last().copied().unwrap_or(0.0)
    );
    let activity = Activity::start(&format!("replaying on {source}"), &detail);
    let report = sgplvm::robots::replay(&xml, &source, &trajectory, &options);
    activity.finish();
    let report = report.map_err(|e| in_trajectory(e, args.trajectory.as_deref()))?;
    if let Some(out) = &args.out {
        let body = scene::Body {
            xml: &xml,
            source: &source,
            name: robot,
            meshes,
        };
        scene::write(out, &body, &trajectory, t0, &report)?;
    }
    Ok(report::replay(&source, &report, args.json, args.verbose)?)
}

/// Every joint of a URDF robot that the trajectory leaves out and the robot's anatomy holds
/// (its waist, legs, head, grippers, fingers: `retarget`, `predict` and `teleop` command the arm
/// joints only), at its hold value, said on stderr: the replay holds them still, as their
/// controllers would. A robot whose arms cannot be found holds nothing (the replay then names
/// the joints without a column), unless `--hold` or `--arm` asked for the anatomy.
fn held_joints(
    trajectory: &Trajectory,
    urdf: &Path,
    hold: &[String],
    arm: &[String],
) -> Result<Vec<(String, f64)>> {
    let body = BodyArgs {
        hold: hold.to_vec(),
        arm: arm.to_vec(),
        ..BodyArgs::default()
    };
    let anatomy = match body.load("robot", Some(urdf), "") {
        Ok(anatomy) => anatomy,
        Err(_) if hold.is_empty() && arm.is_empty() => return Ok(Vec::new()),
        Err(e) if arm.is_empty() => return Err(e.context("--hold needs the robot's arms")),
        Err(e) => return Err(e),
    };
    let held: Vec<(String, f64)> = anatomy
        .held_joints()
        .into_iter()
        .filter(|(name, _)| !trajectory.joint_names.contains(name))
        .collect();
    if !held.is_empty() {
        eprintln!(
            "{}: {} joint(s) without a column held still at their hold values, as their controllers would ({}; --hold JOINT=VALUE to change)",
            urdf.display(),
            held.len(),
            {
                let shown: Vec<String> = held
                    .iter()
                    .take(8)
                    .map(|(n, v)| format!("{n} {v:.3}"))
                    .collect();
                match held.len() {
                    n if n > 8 => format!("{}, and {} more", shown.join(", "), n - 8),
                    _ => shown.join(", "),
                }
            }
        );
    }
    Ok(held)
}

/// Where the robot's meshes are found: beside the URDF file (none for a built-in robot), in
/// the package paths given, then through ROS_PACKAGE_PATH and AMENT_PREFIX_PATH.
fn mesh_search(urdf: Option<&Path>, package_paths: &[PathBuf]) -> MeshSearch {
    let search = urdf.map_or_else(MeshSearch::new, MeshSearch::for_urdf_file);
    package_paths
        .iter()
        .fold(search, |s, dir| s.with_package_path(dir))
        .with_env()
}

/// A replay error, with the trajectory file named when the error is about the trajectory (its
/// columns, frames or values); errors about the robot name the robot's file themselves.
fn in_trajectory(e: PhysicsError, file: Option<&str>) -> anyhow::Error {
    let about_trajectory = matches!(
        e,
        PhysicsError::UnknownJoint { .. }
            | PhysicsError::MissingJoint { .. }
            | PhysicsError::Trajectory { .. }
            | PhysicsError::NonFinitePosition { .. }
    );
    match file {
        Some(file) if about_trajectory => anyhow::Error::new(e).context(file.to_string()),
        _ => e.into(),
    }
}

/// The commands `model` (one shared latent space, or one per body part) predicts for the
/// robot from the human frames of `input`, as `predict` sends them: the robot's command
/// joints, within its position and velocity limits and out of self-collision by `--margin`.
/// The robot: `--robot`, else `named` (the URDF's name) where the model knows it, else the
/// model's only robot.
fn predicted_trajectory(
    model_path: &Path,
    input: &str,
    args: &SimulateArgs,
    named: &str,
) -> Result<Trajectory> {
    let loaded = load_any_model(model_path)?;
    let model = loaded.predictor();
    let robots = model.output_names();
    let robot = match (args.robot.as_deref(), robots.as_slice()) {
        (Some(given), _) => given,
        (None, _) if robots.contains(&named) => named,
        (None, [only]) => only,
        (None, _) => bail!(
            "{}: the model predicts for {robots:?}: name one with --robot",
            model_path.display()
        ),
    };
    require_robot(model, model_path, robot)?;
    let body = BodyArgs {
        hold: args.hold.clone(),
        arm: args.arm.clone(),
        package_path: args.package_paths.clone(),
        ..BodyArgs::default()
    };
    let target = Target::load(model, robot, args.urdf.as_deref(), &body, false)?;
    let human = read_human_frames(model, input, args.topic.as_deref())?;
    let mut commands = target.commands(human.timed, args.margin, false)?;
    let aligned = args.girdle.aligned_rows(&loaded, &human.frames);
    let input = aligned.as_ref().unwrap_or(&human.frames);
    let mean = model.predict(input.as_ref(), robot, false)?.mean;
    let rows: Vec<f64> = (0..mean.nrows())
        .flat_map(|i| (0..mean.ncols()).map(move |j| (i, j)))
        .map(|(i, j)| mean[(i, j)])
        .collect();
    let mut positions = target.columns.rows(&rows, false);
    let names = target.names();
    let (counts, kept) = commands.apply(&mut positions, names.len(), &human.times_ns);
    if let Some(counts) = counts {
        eprintln!("{}", counts.summary(robot, names));
    }
    if let Some(kept) = kept {
        eprintln!("{}", kept.summary(robot));
    }
    Ok(Trajectory::from_ns(
        names.to_vec(),
        &human.times_ns,
        positions,
    )?)
}
