//! `sgplvm joints`: the joint names of a built-in body or of a trained model, in column order —
//! the header a CSV for `predict` or `simulate` needs.

use std::path::PathBuf;

use anyhow::Result;
use clap::Args;
use sgplvm::Robot;

use super::args::load_any_model;
use super::frames::model_joint_names;

#[derive(Args)]
pub struct JointsArgs {
    /// A built-in body (human, walkman, coman, centauro, ur5e); default: every one.
    #[arg(conflicts_with = "model")]
    body: Option<String>,
    /// List the joints of each space of this model instead (its human first).
    #[arg(long)]
    model: Option<PathBuf>,
}

pub fn run(args: JointsArgs) -> Result<()> {
    if let Some(path) = &args.model {
        let loaded = load_any_model(path)?;
        let model = loaded.predictor();
        let spaces = std::iter::once(model.input_name()).chain(model.output_names());
        for space in spaces {
            println!("{space}: {}", model_joint_names(model, space).join(","));
        }
        return Ok(());
    }
    let bodies: Vec<&str> = match &args.body {
        Some(name) => vec![name.as_str()],
        None => Robot::builtin_names().to_vec(),
    };
    for name in bodies {
        let robot = Robot::builtin(name)?;
        println!("{name}: {}", robot.joint_names().join(","));
    }
    Ok(())
}
