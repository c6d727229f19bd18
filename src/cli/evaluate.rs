//! `sgplvm evaluate`: a model's test error on a demonstration file, overall and per joint.

use anyhow::Result;
use clap::Args;

use super::args::{DataArg, JsonArg, ModelFileArg};
use super::report;

#[derive(Args)]
pub struct EvaluateArgs {
    #[command(flatten)]
    model: ModelFileArg,
    #[command(flatten)]
    data: DataArg,
    /// The robot.
    #[arg(long)]
    robot: String,
    #[command(flatten)]
    json: JsonArg,
}

pub fn run(args: EvaluateArgs) -> Result<()> {
    let model = args.model.load()?;
    let demos = args.data.load()?;
    let evaluation = demos.evaluate(&model, &args.robot)?;
    Ok(report::evaluation(&evaluation, args.json.json)?)
}
