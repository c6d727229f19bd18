//! `sgplvm experiment`: the paper's Section IV-B — every run, Figs. 4–6, 9, 10 (and 11 with
//! `--all-frames`, 12 with `--bayesian`), results.json and report.md. Progress: a bar on a terminal, else one line per group of runs on stderr.

use std::path::PathBuf;
use std::time::Instant;

use anyhow::{Context, Result};
use clap::Args;
use sgplvm::experiment::{self, BayesianStudy, ExperimentConfig};

use super::args::{output_folder, parse_seconds, DataArg, ValidationArg};
use super::progress::{progress_bar, StageLines};

/// Inducing inputs of `--all-frames` without `--inducing` (the M = 100, as in
/// BENCHMARKS.md's sparse section).
const DEFAULT_INDUCING: usize = 100;

#[derive(Args)]
pub struct ExperimentArgs {
    /// Fewer runs (2, with 2 transfers each) and a budget of 60 iterations per model: about a
    /// minute on the shipped data. The report shows the numbers but judges no claim.
    #[arg(long)]
    quick: bool,
    /// Output folder: results.json, report.md and the figures (see above).
    #[arg(long, default_value = "experiment-out")]
    out: PathBuf,
    #[command(flatten)]
    data: DataArg,
    /// Override the number of runs.
    #[arg(long, value_parser = clap::value_parser!(u64).range(1..))]
    runs: Option<u64>,
    /// Override the iteration budget of every training.
    #[arg(long, value_parser = clap::value_parser!(u64).range(1..))]
    max_iters: Option<u64>,
    /// How each training's iteration budget is chosen: `auto` on held-out training frames (as
    /// `train` does by default; `--max-iters` is then an upper bound), `none` the paper's fixed
    /// budgets.
    #[arg(long, value_enum, default_value = "auto")]
    validation: ValidationArg,
    /// With `--validation auto`: iterations without a lower validation error before a
    /// selection run stops.
    #[arg(long, default_value_t = sgplvm::Validation::DEFAULT_PATIENCE as u64)]
    patience: u64,
    /// Wall-clock budget of each training in seconds, as for `train` (every direct
    /// regression, full, multi-robot, transfer and less-data training; with `--validation
    /// auto` half of it chooses the iteration count): when it runs out, the training keeps its
    /// best parameters so far. results.json records it. Default: no limit.
    #[arg(long, value_parser = parse_seconds)]
    max_seconds: Option<f64>,
    /// Also train the sparse model on every training frame at the recording's full rate (not
    /// the every-12th-frame subsample), per run and robot with input back constraints, and
    /// report its test error beside the subsampled exact model's: does using all the data help?
    #[arg(long)]
    all_frames: bool,
    /// With `--all-frames`: the sparse model's number of inducing inputs M.
    #[arg(long, requires = "all_frames", value_parser = clap::value_parser!(u64).range(1..))]
    inducing: Option<u64>,
    /// Also train the Bayesian shared GP-LVM (q(X), ARD kernels, inducing inputs): its
    /// baselines, transfers and multi-robot models with no and input back constraints, with the
    /// same seeds, each to convergence (never a budget chosen on held-out frames). Figs. 4–6
    /// get its curves, Fig. 12 its ARD weights, report.md a comparison with the paper's model.
    #[arg(long)]
    bayesian: bool,
    /// With `--bayesian`: inducing inputs M per space.
    #[arg(long, requires = "bayesian", value_parser = clap::value_parser!(u64).range(1..))]
    bayesian_inducing: Option<u64>,
    /// With `--bayesian`: iteration budget of its every training (an upper bound: training stops
    /// earlier when it converges). `--max-iters` does not apply to it.
    #[arg(long, requires = "bayesian", value_parser = clap::value_parser!(u64).range(1..))]
    bayesian_max_iters: Option<u64>,
    /// Also compare a latent space per arm (`train --parts arms`) with the single shared latent
    /// space on recombined motions — one frame's left arm with another frame's right arm, from
    /// the test frames and from the training frames — per run and robot, trained and
    /// transferred, with the GP regressions on all joints and per arm as yardsticks (report.md's
    /// section on it).
    #[arg(long)]
    parts: bool,
    /// Train nothing: draw the figures and write report.md into `--out` from a results.json an
    /// earlier `sgplvm experiment` wrote (e.g. to see a finished run with a newer report).
    #[arg(long, value_name = "RESULTS_JSON")]
    from_results: Option<PathBuf>,
    /// Print the results JSON to stdout as well.
    #[arg(long)]
    json: bool,
}

impl ExperimentArgs {
    /// The protocol (`--quick` or the paper's) with the overrides applied.
    fn config(&self) -> ExperimentConfig {
        let mut config = if self.quick {
            ExperimentConfig::quick()
        } else {
            ExperimentConfig::paper()
        };
        if let Some(r) = self.runs {
            config.runs = r as usize;
            config.transfers_per_run = config.transfers_per_run.min(r as usize);
        }
        config.patience =
            (self.validation == ValidationArg::Auto).then_some(self.patience as usize);
        if let Some(m) = self.max_iters {
            config.max_iters = m as usize;
            config.transfer_max_iters = m as usize;
        }
        config.max_seconds = self.max_seconds;
        config.inducing = self
            .all_frames
            .then(|| self.inducing.map_or(DEFAULT_INDUCING, |m| m as usize));
        config.parts = self.parts;
        config.bayesian = self.bayesian.then(|| {
            let default = BayesianStudy::DEFAULT;
            BayesianStudy {
                inducing: self
                    .bayesian_inducing
                    .map_or(default.inducing, |m| m as usize),
                max_iters: self
                    .bayesian_max_iters
                    .map_or(default.max_iters, |m| m as usize),
            }
        });
        config
    }
}

pub fn run(args: ExperimentArgs) -> Result<()> {
    if let Some(path) = &args.from_results {
        let bytes = std::fs::read(path)
            .with_context(|| format!("cannot read the results file {}", path.display()))?;
        let results: experiment::Results = serde_json::from_slice(&bytes).with_context(|| {
            format!(
                "{}: not the results.json of `sgplvm experiment`",
                path.display()
            )
        })?;
        output_folder(&args.out)?;
        return write(&args, &results);
    }
    let config = args.config();
    let demos = args.data.load()?;
    output_folder(&args.out)?;
    let mut data = demos.experiment_data()?;
    if config.inducing.is_some() {
        data.all_frames = Some(demos.all_frames_data()?);
    }
    if config.parts {
        data.parts = Some(demos.parts_data()?);
    }
    let plan = experiment::stages(&config, data.robots.len());
    let bar = progress_bar(plan.iter().map(|s| s.trainings as u64).sum(), "experiment");
    // Without a terminal to draw the bar on (a log, CI): one line per finished stage.
    let mut lines = StageLines::new(plan);
    let started = Instant::now();
    let results = experiment::run(&data, &config, &mut |p| {
        if bar.is_hidden() {
            if let Some(line) = lines.update(p, started.elapsed()) {
                eprintln!("{line}");
            }
        } else {
            bar.set_position(p.done as u64);
            bar.set_message(p.message.clone());
        }
    })?;
    bar.finish_and_clear();
    write(&args, &results)
}

/// Writes results.json, the figures and report.md into `--out`, and prints the report (or the
/// JSON with `--json`).
fn write(args: &ExperimentArgs, results: &experiment::Results) -> Result<()> {
    let written = experiment::write_outputs(results, &args.out)?;
    if args.json {
        println!("{}", serde_json::to_string(results)?);
    } else {
        println!("{}", experiment::report(results));
        for path in written {
            eprintln!("wrote {}", path.display());
        }
    }
    Ok(())
}
