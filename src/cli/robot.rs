//! `sgplvm robot`: what sgplvm makes of a robot — its arms, held joints, body frame, reach and
//! neutral posture — for a person to check at a glance, and the description file that keeps
//! it (`ROBOT.anatomy.json` beside the URDF, read by every command).

use std::path::PathBuf;

use anyhow::{bail, Result};
use clap::Args;
use sgplvm::files::atomic_write_with;
use sgplvm::robots::anatomy::description_path;

use super::args::JsonArg;
use super::body::BodyArgs;

#[derive(Args)]
pub struct RobotArgs {
    /// A URDF file, or the name of a built-in robot.
    robot: String,
    #[command(flatten)]
    body: BodyArgs,
    /// Write what was found (with the flags given) to the description file beside the URDF
    /// (ROBOT.anatomy.json), which every command then reads.
    #[arg(long)]
    write: bool,
    #[command(flatten)]
    json: JsonArg,
}

pub fn run(args: RobotArgs) -> Result<()> {
    let path = PathBuf::from(&args.robot);
    let is_file = path.extension().is_some_and(|e| e == "urdf" || e == "xml") || path.is_file();
    let name = if is_file {
        path.file_stem()
            .map_or_else(|| args.robot.clone(), |s| s.to_string_lossy().into_owned())
    } else {
        args.robot.clone()
    };
    let urdf = is_file.then_some(path.as_path());
    let anatomy = args
        .body
        .load(&name, urdf, "give a URDF file (sgplvm robot FILE.urdf)")?;
    if args.json.json {
        println!("{}", serde_json::to_string_pretty(&anatomy.report())?);
    } else {
        print!("{}", anatomy.summary());
    }
    let unseen = anatomy.visual_meshes_not_found();
    if let Some((_, first)) = unseen.first() {
        let mut links: Vec<&str> = unseen.iter().map(|(l, _)| l.as_str()).collect();
        links.dedup();
        eprintln!(
            "warning: {}: {} visual mesh(es) not found, on link(s) {}: Foxglove draws those links without them: {first}",
            anatomy.robot().name(),
            unseen.len(),
            sgplvm::robots::names::few(&links, 8)
        );
    }
    if args.write {
        let Some(urdf) = urdf else {
            bail!(
                "--write: `{}` is a built-in robot; a description file goes beside a URDF file",
                args.robot
            );
        };
        let out = description_path(urdf);
        let text = anatomy.to_file().to_json();
        atomic_write_with(&out, |tmp| std::fs::write(tmp, text.as_bytes()))?;
        eprintln!(
            "wrote {} (every command that loads {} reads it)",
            out.display(),
            urdf.display()
        );
    }
    Ok(())
}
