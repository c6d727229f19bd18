//! `sgplvm train`: the full model (one robot) or the multi-robot model (several).

use anyhow::Result;
use clap::Args;

use super::args::{DataArg, ModelConfigArgs, TrainOutputArgs};
use super::progress::train_with_progress;
use super::report;

#[derive(Args)]
pub struct TrainArgs {
    #[command(flatten)]
    data: DataArg,
    /// Robot(s) to train on (repeat for the multi-robot model).
    #[arg(long = "robot", required = true)]
    robots: Vec<String>,
    #[command(flatten)]
    model: ModelConfigArgs,
    #[command(flatten)]
    output: TrainOutputArgs,
}

pub fn run(args: TrainArgs) -> Result<()> {
    let demos = args.data.load()?;
    let config = args.model.config();
    let options = args.model.options()?;
    let patience = args.model.budget.patience();
    let (model, seconds) = train_with_progress(
        &format!("training {}", args.robots.join(" + ")),
        args.model.budget.max_iters,
        |cb| demos.train(&args.robots, &config, &options, patience, cb),
    )?;
    model.save(&args.output.out)?;
    report::training(&model, seconds, &args.output.out, args.output.json.json);
    Ok(())
}
