//! `sgplvm transfer`: a trained model to another robot, training only that robot's kernel (of
//! each body part, for a model with a latent space per part).

use std::path::PathBuf;

use anyhow::{bail, Result};
use clap::Args;
use sgplvm::AnyModel;

use super::args::{load_any_model, BudgetArg, DataArg, TrainOutputArgs};
use super::progress::{train_parts_with_progress, train_with_progress};
use super::report;

#[derive(Args)]
#[command(mut_arg("data", |a| a.help(
    "Demonstrations with the same training frames the model was trained on"
)))]
#[command(mut_arg("out", |a| a.help("Where to write the new model")))]
pub struct TransferArgs {
    /// The trained model (one shared latent space, or one per body part: `train --parts`).
    #[arg(long)]
    model: PathBuf,
    #[command(flatten)]
    data: DataArg,
    /// The new robot.
    #[arg(long)]
    robot: String,
    /// For a model with a latent space per arm: the new robot's URDF, whose anatomy (with the
    /// description file beside it) says which joints are its arms, where its joint names do
    /// not [default: the built-in robot's anatomy, else its joint names].
    #[arg(long, value_name = "FILE")]
    urdf: Option<PathBuf>,
    #[command(flatten)]
    budget: BudgetArg,
    #[command(flatten)]
    output: TrainOutputArgs,
}

pub fn run(args: TransferArgs) -> Result<()> {
    let source = load_any_model(&args.model)?;
    let known = source.predictor().output_names();
    if known.contains(&args.robot.as_str()) {
        bail!(
            "{}: the model already predicts for '{}' (it has {known:?}); transfer to another \
             robot, or train it afresh with `sgplvm train`",
            args.model.display(),
            args.robot,
        );
    }
    let demos = args.data.load()?;
    let options = args.budget.options();
    let patience = args.budget.patience();
    let robot = &args.robot;
    let label = format!("transfer to {robot}");
    match &source {
        AnyModel::Single(source) => {
            if args.urdf.is_some() {
                bail!(
                    "--urdf says which joints are a robot's arms, for a model with a latent \
                     space per arm; {} has one shared latent space",
                    args.model.display()
                );
            }
            // A sparse model's transfer budget cannot be chosen on held-out frames yet: the
            // default validation gives way to the budget, said (it was an error, the flag to
            // get past it nowhere in the guides).
            let patience = match (patience, source.config().inducing) {
                (Some(_), Some(m)) => {
                    eprintln!(
                        "note: {} is sparse ({m} inducing inputs): its transfer's budget is not chosen on held-out frames (not supported yet); the robot's kernel trains to convergence or --max-iters {}",
                        args.model.display(),
                        args.budget.max_iters
                    );
                    None
                }
                (p, _) => p,
            };
            let (mut model, seconds) = train_with_progress(&label, args.budget.max_iters, |cb| {
                demos.transfer(source, robot, &options, patience, cb)
            })?;
            for (key, value) in args
                .data
                .annotations(std::slice::from_ref(robot), model.annotations())?
            {
                model.annotate(key, value);
            }
            model.save(&args.output.out)?;
            report::transfer(
                source,
                robot,
                &model,
                seconds,
                &args.output.out,
                args.output.json.json,
            );
        }
        AnyModel::Parts(source) => {
            let mut model = train_parts_with_progress(&label, args.budget.max_iters, |cb| {
                demos.transfer_parts(source, robot, args.urdf.as_deref(), &options, patience, cb)
            })?;
            for (key, value) in args
                .data
                .annotations(std::slice::from_ref(robot), model.annotations())?
            {
                model.annotate(key, value);
            }
            model.save(&args.output.out)?;
            report::parts_transfer(robot, &model, &args.output.out, args.output.json.json);
        }
    }
    Ok(())
}
