//! `sgplvm demo`: the library's transfer study on the demonstrations — one robot trained fully,
//! the others transferred to and trained from scratch — beside the yardstick of each robot (a
//! direct GP regression human → robot), its models saved, Figs. 7 and 8 drawn, and the test
//! frames predicted by the source model and each transfer written as MCAP for Foxglove.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::Result;
use clap::Args;
use sgplvm::experiment::ModelKind;
use sgplvm::pipeline::{to_mat, Demonstrations, StudyModel, StudyTraining, TrainFn};
use sgplvm::{figures, BackConstraint, Mat, ModelConfig, SharedGplvm, TrainOptions};

use super::args::{output_folder, BudgetArg, DataArg, BAYESIAN_INDUCING};
use super::progress::{on_terminal, train_with_progress, StepLines};
use super::report::{self, Yardstick};

#[derive(Args)]
#[command(mut_arg("data", |a| a.help(
    "Demonstrations (MCAP); default: data/demos/bimanual.mcap, or outside the repository the \
     same data generated in memory"
)))]
#[command(mut_arg("max_iters", |a| a.default_value("500")))]
pub struct DemoArgs {
    #[command(flatten)]
    data: DataArg,
    /// Output folder: the models, Figs. 7 and 8 (SVG and PNG) and the test predictions (MCAP).
    #[arg(long, default_value = "sgplvm-demo")]
    out: PathBuf,
    /// Robot trained fully; the others in the data are transferred to.
    #[arg(long, default_value = "walkman")]
    source: String,
    #[command(flatten)]
    budget: BudgetArg,
    /// Latent dimension Q.
    #[arg(long, default_value_t = 5, value_parser = clap::value_parser!(u64).range(1..))]
    latent_dim: u64,
    /// Print machine-readable results (JSON) instead of a table.
    #[arg(long)]
    json: bool,
    /// The Bayesian shared GP-LVM (see `train --help`) with 50 inducing inputs, every model
    /// trained to convergence or the budget: --validation is not used (no early stopping).
    #[arg(long)]
    bayesian: bool,
}

pub fn run(args: DemoArgs) -> Result<()> {
    let demos = args.data.load()?;
    output_folder(&args.out)?;
    if !args.json {
        report::demo_data(&demos);
    }
    let config = ModelConfig::default()
        .with_latent_dim(args.latent_dim as usize)
        .with_back_constraint(BackConstraint::Input)
        .with_inducing(args.bayesian.then_some(BAYESIAN_INDUCING))
        .with_bayesian(args.bayesian);
    let options = args.budget.options();
    let patience = match args.bayesian {
        true => None,
        false => args.budget.patience(),
    };
    // The study trains the source fully, each other robot by transfer and fully, then fits
    // every robot's direct regression and draws the figures.
    let robots = demos.dataset.robots.len();
    let mut steps = DemoSteps::new(2 * robots.max(1) - 1 + robots + 1);
    let mut written = Vec::new();
    let models = demos.transfer_study(
        &args.source,
        &config,
        &options,
        patience,
        &mut |training: &StudyTraining<'_>, train: &mut TrainFn<'_>| {
            let result = train_and_save(
                training,
                train,
                args.budget.max_iters,
                &args.out,
                &mut written,
            );
            let label = report::demo_label(training.kind);
            steps.done(&format!("{} {label} trained", training.robot));
            result
        },
    )?;
    let yardsticks = direct_regressions(&demos, &models, &options, &mut steps)?;
    written.extend(draw_figures(&demos, &args.source, &models, &args.out)?);
    written.extend(write_scenes(&demos, &models, &args.out)?);
    steps.done("figures");
    report::demo(
        &demos,
        &args.source,
        &models,
        &yardsticks,
        &args.out,
        &written,
        args.json,
    );
    Ok(())
}

/// The demo's progress where no bar can be drawn (a log): a line per finished step, with an
/// estimate of the time left.
struct DemoSteps {
    lines: Option<StepLines>,
    started: Instant,
}

impl DemoSteps {
    /// Lines for `total` steps when stderr is not a terminal; nothing otherwise.
    fn new(total: usize) -> Self {
        DemoSteps {
            lines: (!on_terminal()).then(|| StepLines::new(total)),
            started: Instant::now(),
        }
    }

    /// Says that `what` is done.
    fn done(&mut self, what: &str) {
        if let Some(lines) = &mut self.lines {
            eprintln!("demo: {}", lines.step(what, self.started.elapsed()));
        }
    }
}

/// The yardstick of every robot of the study, in the study's order: a direct GP regression
/// human → robot on the same training frames, with its training seconds.
fn direct_regressions(
    demos: &Demonstrations,
    models: &[StudyModel],
    options: &TrainOptions,
    steps: &mut DemoSteps,
) -> Result<Vec<Yardstick>> {
    let mut robots: Vec<&str> = models.iter().map(|m| m.robot.as_str()).collect();
    robots.dedup();
    robots
        .into_iter()
        .map(|robot| {
            let start = Instant::now();
            let (_, evaluation) = demos.direct_regression(robot, options)?;
            steps.done(&format!("direct GP {robot}"));
            Ok(Yardstick {
                seconds: start.elapsed().as_secs_f64(),
                evaluation,
            })
        })
        .collect()
}

/// Runs one training of the study under a progress bar; saves the source model and the
/// transferred ones into `out`, adding their paths to `saved`.
fn train_and_save(
    training: &StudyTraining<'_>,
    train: &mut TrainFn<'_>,
    max_iters: u64,
    out: &Path,
    saved: &mut Vec<PathBuf>,
) -> Result<(SharedGplvm, f64)> {
    let (robot, source) = (training.robot, training.source);
    let (label, file) = match training.kind {
        ModelKind::Transfer => (
            format!("transfer to {robot}"),
            Some(format!("{source}_to_{robot}.sgp")),
        ),
        _ => (
            format!("training {robot}"),
            (robot == source).then(|| format!("{source}.sgp")),
        ),
    };
    let (model, seconds) = train_with_progress(&label, max_iters, train)?;
    if let Some(file) = file {
        output_folder(out)?;
        let path = out.join(file);
        model.save(&path)?;
        saved.push(path);
    }
    Ok((model, seconds))
}

/// Fig. 7 for the source model, Fig. 8 for the transfer to COMAN (or the first transfer).
fn draw_figures(
    demos: &Demonstrations,
    source: &str,
    models: &[StudyModel],
    out: &Path,
) -> Result<Vec<PathBuf>> {
    let mut written = Vec::new();
    if let Some(full) = models.first() {
        written.extend(figures::latent_space(
            &full.model,
            demos,
            source,
            &out.join("latent_space"),
        )?);
    }
    let transfers = || models.iter().filter(|m| m.kind == ModelKind::Transfer);
    if let Some(t) = transfers()
        .find(|m| m.robot == "coman")
        .or_else(|| transfers().next())
    {
        written.extend(figures::trajectories(
            &t.model,
            demos,
            &t.robot,
            &out.join(format!("{}_trajectories", t.robot)),
        )?);
    }
    Ok(written)
}

/// The test frames predicted by the source model and by each transfer, one MCAP file each
/// (`<robot>_test.mcap`, `<source>_to_<robot>_test.mcap`) with the same topics as
/// `predict --raw --out x.mcap`: the human and the robot side by side, animated by `/tf`, with
/// the predictive standard deviation and the latent point.
fn write_scenes(demos: &Demonstrations, models: &[StudyModel], out: &Path) -> Result<Vec<PathBuf>> {
    let ds = &demos.dataset;
    let times_ns: Vec<i64> = ds.test.iter().map(|&i| ds.times_ns[i]).collect();
    let human = to_mat(&ds.human.rows(&ds.test));
    let rows = |m: &Mat<f64>, f: fn(f64) -> f64| -> Vec<f64> {
        (0..m.nrows())
            .flat_map(|i| (0..m.ncols()).map(move |j| (i, j)))
            .map(|(i, j)| f(m[(i, j)]))
            .collect()
    };
    let human_rows = rows(&human, |v| v);
    let mut written = Vec::new();
    for (k, m) in models.iter().enumerate() {
        let file = match m.kind {
            ModelKind::Transfer => {
                let source = models.first().map_or("source", |s| s.robot.as_str());
                format!("{source}_to_{}_test.mcap", m.robot)
            }
            _ if k == 0 => format!("{}_test.mcap", m.robot),
            _ => continue,
        };
        let prediction = m.model.predict(human.as_ref(), &m.robot, true)?;
        let std = prediction
            .variance
            .as_ref()
            .map(|v| rows(v, f64::sqrt))
            .unwrap_or_default();
        output_folder(out)?;
        let path = out.join(file);
        super::predict::scene::write(
            &m.model,
            &super::predict::Target::builtin_raw(&m.model, &m.robot)?,
            &super::predict::scene::Frames {
                times_ns: &times_ns,
                human: &human_rows,
                mean: &rows(&prediction.mean, |v| v),
                std: &std,
                latent: &rows(&prediction.latent, |v| v),
            },
            None,
            // The model's prediction drawn for analysis, as `predict --raw` writes it.
            super::limits::Commands::Raw.metadata(&m.robot, None),
            &path.display().to_string(),
        )?;
        written.push(path);
    }
    Ok(written)
}
