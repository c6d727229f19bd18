//! A robot as every command loads it: a built-in body, or a URDF with the description file
//! beside it and the flags that say what its names do not (`--arm`, `--hold`, `--up`,
//! `--forward`, `--mount-roll`, `--command-joints`), as an [`Anatomy`].

use std::path::Path;

use anyhow::{anyhow, bail, Context, Result};
use clap::Args;
use nalgebra::Vector3;
use sgplvm::robots::anatomy::{Anatomy, AnatomySpec, CommandJoints, Mount};
use sgplvm::robots::urdf::MeshSearch;
use sgplvm::robots::Robot;

// The flags a robot's anatomy takes. With several robots in one command a setting may be
// qualified `ROBOT/…` to apply to that robot alone; unqualified it applies to every robot.
#[derive(Args, Clone, Default)]
pub struct BodyArgs {
    /// An arm of a URDF robot, SIDE=FROM_LINK:TO_LINK (left and right both; one alone for a
    /// single-arm robot, driven by the person's arm of that side), where its names do not tell (`sgplvm robot FILE.urdf` shows what was found); `ROBOT/SIDE=…` for one of
    /// several robots. Written once in FILE.anatomy.json beside the URDF, every command reads it.
    #[arg(long = "arm", value_name = "[ROBOT/]SIDE=FROM:TO")]
    pub arm: Vec<String>,
    /// Hold a joint outside the arms (waist, legs, head, grippers) at VALUE (rad or m) [default:
    /// 0 within its limits].
    #[arg(long = "hold", value_name = "[ROBOT/]JOINT=VALUE")]
    pub hold: Vec<String>,
    /// The body's up direction in its torso link's frame (`z`, `-x`, or `X,Y,Z`) [default: the
    /// root link's z].
    #[arg(long, value_name = "[ROBOT/]DIR", allow_hyphen_values = true)]
    pub up: Vec<String>,
    /// The body's forward direction in its torso link's frame [default: left × up, left being
    /// from the right shoulder to the left one].
    #[arg(long, value_name = "[ROBOT/]DIR", allow_hyphen_values = true)]
    pub forward: Vec<String>,
    /// Degrees the person's arm is turned outward about the body's forward axis before the
    /// robot takes it (mirrored between the sides) [default: 0 where the robot's arms can
    /// hang, 90 where one cannot (an arm on a table): the person's hanging arm is then its arm
    /// out to the side, their forward reach its forward reach; `sgplvm robot` says which].
    #[arg(
        long = "mount-roll",
        value_name = "[ROBOT/]DEG",
        allow_hyphen_values = true
    )]
    pub mount_roll: Vec<String>,
    /// The joints the robot's commands name: `arms` (the default), `all` (held joints at their
    /// hold values) or a comma-separated list, in order.
    #[arg(long = "command-joints", value_name = "[ROBOT/]arms|all|LIST")]
    pub command_joints: Vec<String>,
    /// A folder where `package://PKG/...` meshes of a URDF are found (DIR/PKG or DIR itself;
    /// repeatable; ROS_PACKAGE_PATH and AMENT_PREFIX_PATH are searched after): the robot's
    /// collision meshes keep it out of self-collision, and Foxglove draws them.
    #[arg(long = "package-path", value_name = "DIR")]
    pub package_path: Vec<std::path::PathBuf>,
}

/// `ROBOT/rest` for robot `robot` or unqualified: the rest, when it applies to `robot`.
fn for_robot<'a>(setting: &'a str, robot: &str) -> Option<&'a str> {
    // A qualifier is a robot name before the first `/`, and never contains `=`.
    match setting.split_once('/') {
        Some((who, rest)) if !who.contains('=') => (who == robot).then_some(rest),
        _ => Some(setting),
    }
}

/// A direction: `x`, `+y`, `-z` or three comma-separated numbers.
fn direction(text: &str, flag: &str) -> Result<Vector3<f64>> {
    let t = text.trim();
    let (sign, axis) = match t.strip_prefix('-') {
        Some(a) => (-1.0, a),
        None => (1.0, t.strip_prefix('+').unwrap_or(t)),
    };
    let unit = match axis {
        "x" => Some(Vector3::x()),
        "y" => Some(Vector3::y()),
        "z" => Some(Vector3::z()),
        _ => None,
    };
    if let Some(u) = unit {
        return Ok(sign * u);
    }
    let parts: Vec<f64> = t
        .split(',')
        .map(|p| p.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|_| anyhow!("{flag} {text}: expected x, -y, +z … or X,Y,Z"))?;
    match parts.as_slice() {
        [x, y, z] if [x, y, z].iter().all(|v| v.is_finite()) => Ok(Vector3::new(*x, *y, *z)),
        _ => bail!("{flag} {text}: expected x, -y, +z … or three numbers X,Y,Z"),
    }
}

impl BodyArgs {
    /// What the flags say about robot `robot`.
    pub fn spec(&self, robot: &str) -> Result<AnatomySpec> {
        let mut spec = AnatomySpec::default();
        for a in self.arm.iter().filter_map(|s| for_robot(s, robot)) {
            spec.set_arm(a).map_err(|e| anyhow!(e))?;
        }
        for h in self.hold.iter().filter_map(|s| for_robot(s, robot)) {
            spec.set_hold(h).map_err(|e| anyhow!(e))?;
        }
        if let Some(u) = self.up.iter().rev().find_map(|s| for_robot(s, robot)) {
            spec.up = Some(direction(u, "--up")?);
        }
        if let Some(f) = self.forward.iter().rev().find_map(|s| for_robot(s, robot)) {
            spec.forward = Some(direction(f, "--forward")?);
        }
        if let Some(m) = self
            .mount_roll
            .iter()
            .rev()
            .find_map(|s| for_robot(s, robot))
        {
            let deg: f64 = m
                .trim()
                .parse()
                .ok()
                .filter(|&d: &f64| Mount::valid_roll(d))
                .ok_or_else(|| {
                    anyhow!("--mount-roll {m}: expected degrees within ±180 (0: the person's arm as it is)")
                })?;
            spec.mount_roll_deg = Some(deg);
        }
        if let Some(c) = self
            .command_joints
            .iter()
            .rev()
            .find_map(|s| for_robot(s, robot))
        {
            spec.command_joints = CommandJoints::parse(c);
        }
        Ok(spec)
    }

    /// Refuses a `ROBOT/` qualifier that names none of `robots`.
    pub fn check_robots(&self, robots: &[&str]) -> Result<()> {
        let all = self
            .arm
            .iter()
            .chain(&self.hold)
            .chain(&self.up)
            .chain(&self.forward)
            .chain(&self.mount_roll)
            .chain(&self.command_joints);
        for s in all {
            if let Some((who, _)) = s.split_once('/').filter(|(w, _)| !w.contains('=')) {
                if !robots.contains(&who) {
                    bail!("`{s}`: `{who}` is not one of this command's robots ({robots:?})");
                }
            }
        }
        Ok(())
    }

    /// The anatomy of robot `name`: its URDF `urdf` (with the description file beside it)
    /// when given, else the built-in robot of that name; `hint` says how to give a URDF when
    /// it is neither.
    pub fn load(&self, name: &str, urdf: Option<&Path>, hint: &str) -> Result<Anatomy> {
        let spec = self.spec(name)?;
        let anatomy = match urdf {
            Some(path) => {
                let mut search = MeshSearch::for_urdf_file(path);
                for dir in &self.package_path {
                    if !dir.is_dir() {
                        bail!("--package-path {}: not a folder", dir.display());
                    }
                    search = search.with_package_path(dir);
                }
                Anatomy::load(path, &spec)?.with_meshes(search.with_env())
            }
            None => {
                let robot = Robot::builtin(name).map_err(|_| {
                    anyhow!(
                        "robot `{name}` is not built in ({}); {hint}",
                        Robot::builtin_names().join(", ")
                    )
                })?;
                Anatomy::new(robot, &spec).with_context(|| format!("built-in robot `{name}`"))?
            }
        };
        Ok(anatomy)
    }
}
