//! `sgplvm evaluate`: a model's test error on a demonstration file, overall and per joint, and
//! how many test frames it would not trust live.

use anyhow::Result;
use clap::Args;

use super::args::{DataArg, JsonArg, ModelFileArg};
use super::frames::require_robot;
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
    // Before the data: "the model does not know coman; it predicts for [...]" says more than a
    // mismatch of joint lists would.
    require_robot(&model, &args.model.model, &args.robot)?;
    let demos = args.data.load()?;
    let evaluation = demos.evaluate(&model, &args.robot)?;
    let trust = demos.test_trust(&model, &args.robot)?;
    Ok(report::evaluation(&evaluation, &trust, args.json.json)?)
}
