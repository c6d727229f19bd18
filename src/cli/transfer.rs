//! `sgplvm transfer`: a trained model to another robot, training only that robot's kernel.

use std::path::PathBuf;

use anyhow::{bail, Result};
use clap::Args;

use super::args::{load_model, BudgetArg, DataArg, TrainOutputArgs};
use super::progress::train_with_progress;
use super::report;

#[derive(Args)]
#[command(mut_arg("data", |a| a.help(
    "Demonstrations with the same training frames the model was trained on"
)))]
#[command(mut_arg("out", |a| a.help("Where to write the new model")))]
pub struct TransferArgs {
    /// The trained model.
    #[arg(long)]
    model: PathBuf,
    #[command(flatten)]
    data: DataArg,
    /// The new robot.
    #[arg(long)]
    robot: String,
    #[command(flatten)]
    budget: BudgetArg,
    #[command(flatten)]
    output: TrainOutputArgs,
}

pub fn run(args: TransferArgs) -> Result<()> {
    let source = load_model(&args.model)?;
    if source.output_names().contains(&args.robot.as_str()) {
        bail!(
            "{}: the model already predicts for '{}' (it has {:?}); transfer to another robot, \
             or train it afresh with `sgplvm train`",
            args.model.display(),
            args.robot,
            source.output_names()
        );
    }
    let demos = args.data.load()?;
    let options = args.budget.options();
    let patience = args.budget.patience();
    let robot = &args.robot;
    let (model, seconds) = train_with_progress(
        &format!("transfer to {robot}"),
        args.budget.max_iters,
        |cb| demos.transfer(&source, robot, &options, patience, cb),
    )?;
    model.save(&args.output.out)?;
    report::transfer(
        &source,
        robot,
        &model,
        seconds,
        &args.output.out,
        args.output.json.json,
    );
    Ok(())
}
