//! The experiments of the paper's Section IV-B: fully trained single-robot models (the baseline),
//! transfer from a model trained on another robot, and the multi-robot model, each without and
//! with back constraints on the input (Figs. 4 and 5), and fully trained models with no, input
//! and output back constraints (Fig. 6). Test error is recorded at every optimisation iteration.
//!
//! This module holds the protocol ([`run`]), the records ([`Results`]) and the report judging the
//! paper's claims ([`report`]); the figures are drawn by [`crate::figures`].

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};
use sgplvm_core::{
    BackConstraint, Control, IterationRecord, Mat, MatRef, ModelConfig, SharedGplvm, TrainOptions,
};

use crate::figures;
use crate::files::atomic_write;

/// Training and test matrices of one observation space (rows are frames).
#[derive(Debug, Clone)]
pub struct SplitData {
    /// Training frames.
    pub train: Mat<f64>,
    /// Test frames.
    pub test: Mat<f64>,
}

/// The human input and every robot, split into training and test frames.
#[derive(Debug, Clone)]
pub struct ExperimentData {
    /// Name of the input space (the human).
    pub input_name: String,
    /// The human joint angles.
    pub human: SplitData,
    /// The robots' joint commands, by name.
    pub robots: Vec<(String, SplitData)>,
}

/// How much to run.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct ExperimentConfig {
    /// Independent runs (seeds) of every baseline and multi-robot model.
    pub runs: usize,
    /// Transfer runs per trained source model.
    pub transfers_per_run: usize,
    /// Iteration budget of full and multi-robot training.
    pub max_iters: usize,
    /// Iteration budget of transfer training.
    pub transfer_max_iters: usize,
    /// Latent dimension (the paper's 5).
    pub latent_dim: usize,
    /// Seed of the first run; run k uses `seed + k`.
    pub seed: u64,
}

impl ExperimentConfig {
    /// The paper's protocol: 10 runs, 10 transfers per source run.
    pub fn paper() -> Self {
        ExperimentConfig {
            runs: 10,
            transfers_per_run: 10,
            max_iters: 300,
            transfer_max_iters: 300,
            latent_dim: 5,
            seed: 0,
        }
    }

    /// A few minutes' worth: 2 runs, 2 transfers per source run, fewer iterations.
    pub fn quick() -> Self {
        ExperimentConfig {
            runs: 2,
            transfers_per_run: 2,
            max_iters: 60,
            transfer_max_iters: 60,
            latent_dim: 5,
            seed: 0,
        }
    }
}

/// Which of the paper's models a run trained.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, PartialOrd, Ord)]
#[serde(rename_all = "lowercase")]
pub enum ModelKind {
    /// Human + this robot, everything trained.
    Baseline,
    /// From a baseline model of another robot, only this robot's kernel trained.
    Transfer,
    /// Human + all robots trained jointly.
    Multi,
}

/// One training run and its test error after every iteration.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct RunRecord {
    /// The robot whose test error is recorded.
    pub robot: String,
    /// The kind of model.
    pub model: ModelKind,
    /// `none`, `input` or `output`.
    pub back_constraint: String,
    /// Run index (for transfer: source run × transfers per run + transfer index).
    pub run: usize,
    /// For transfer runs, the robot the source model was trained on.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub source_robot: Option<String>,
    /// Iteration numbers at which the test error was measured.
    pub iterations: Vec<usize>,
    /// Training seconds spent up to each of those iterations (test evaluation excluded).
    pub seconds: Vec<f64>,
    /// Test mean squared error (rad², over all joints and frames) at each of those iterations.
    pub test_mse: Vec<f64>,
}

/// All runs of an experiment.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Results {
    /// The robots, in the order of the data.
    pub robots: Vec<String>,
    /// What was run.
    pub config: ExperimentConfig,
    /// Every run.
    pub runs: Vec<RunRecord>,
}

/// Errors of an experiment.
#[derive(Debug, thiserror::Error)]
pub enum ExperimentError {
    /// The model failed.
    #[error("{context}: {source}")]
    Model {
        /// Which run.
        context: String,
        /// The model error.
        #[source]
        source: sgplvm_core::Error,
    },
    /// Results could not be written.
    #[error(transparent)]
    File(#[from] crate::files::FileError),
    /// A figure could not be drawn.
    #[error(transparent)]
    Plot(#[from] crate::plots::PlotError),
}

/// Mean squared error between two matrices of the same shape.
pub fn mean_squared_error(predicted: MatRef<'_, f64>, desired: MatRef<'_, f64>) -> f64 {
    let n = (predicted.nrows() * predicted.ncols()).max(1);
    let mut sum = 0.0;
    for j in 0..predicted.ncols() {
        for i in 0..predicted.nrows() {
            let d = predicted[(i, j)] - desired[(i, j)];
            sum += d * d;
        }
    }
    sum / n as f64
}

/// Records the test error of some robots at every iteration of one training.
struct Recorder<'a> {
    human_test: MatRef<'a, f64>,
    robots: Vec<(&'a str, MatRef<'a, f64>)>,
    iterations: Vec<usize>,
    seconds: Vec<f64>,
    mse: Vec<Vec<f64>>,
    failure: Option<sgplvm_core::Error>,
}

impl<'a> Recorder<'a> {
    fn new(human_test: MatRef<'a, f64>, robots: Vec<(&'a str, MatRef<'a, f64>)>) -> Self {
        let count = robots.len();
        Recorder {
            human_test,
            robots,
            iterations: Vec::new(),
            seconds: Vec::new(),
            mse: vec![Vec::new(); count],
            failure: None,
        }
    }

    fn record(&mut self, iteration: &IterationRecord, model: &SharedGplvm) -> Control {
        for (k, (robot, desired)) in self.robots.iter().enumerate() {
            match model.predict(self.human_test, robot, false) {
                Ok(prediction) => {
                    self.mse[k].push(mean_squared_error(prediction.mean.as_ref(), *desired))
                }
                Err(e) => {
                    self.failure = Some(e);
                    return Control::Stop;
                }
            }
        }
        self.iterations.push(iteration.iteration);
        self.seconds.push(iteration.seconds);
        Control::Continue
    }

    fn into_records(
        self,
        model: ModelKind,
        bc: BackConstraint,
        run: usize,
        source_robot: Option<&str>,
    ) -> Result<Vec<RunRecord>, sgplvm_core::Error> {
        if let Some(e) = self.failure {
            return Err(e);
        }
        Ok(self
            .robots
            .iter()
            .zip(self.mse)
            .map(|((robot, _), test_mse)| RunRecord {
                robot: robot.to_string(),
                model,
                back_constraint: bc.to_string(),
                run,
                source_robot: source_robot.map(str::to_string),
                iterations: self.iterations.clone(),
                seconds: self.seconds.clone(),
                test_mse,
            })
            .collect())
    }
}

/// Progress of a running experiment, for progress bars.
#[derive(Debug, Clone)]
pub struct Progress {
    /// Trainings done.
    pub done: usize,
    /// Trainings in all.
    pub total: usize,
    /// What was just finished.
    pub message: String,
}

/// Number of trainings [`run`] performs for `robots` robots.
pub fn training_count(config: &ExperimentConfig, robots: usize) -> usize {
    let per_bc = config.runs * robots // baselines
        + config.runs * robots * robots.saturating_sub(1) * config.transfers_per_run
        + config.runs; // multi-robot
    2 * per_bc + config.runs * robots // output back constraints (Fig. 6)
}

/// Everything one training run of the experiment needs to record its test error.
struct RunSpec<'a> {
    context: String,
    kind: ModelKind,
    back_constraint: BackConstraint,
    run: usize,
    source_robot: Option<&'a str>,
    /// Robots whose test error is recorded, with their test frames.
    robots: Vec<(&'a str, MatRef<'a, f64>)>,
}

/// The state of a running experiment: records, progress and the human test frames.
struct Runner<'a, 'p> {
    human_test: MatRef<'a, f64>,
    runs: Vec<RunRecord>,
    done: usize,
    total: usize,
    progress: &'p mut dyn FnMut(&Progress),
}

impl<'a> Runner<'a, '_> {
    /// Trains with `train`, recording the test error of `spec.robots` at every iteration.
    fn record(
        &mut self,
        spec: RunSpec<'a>,
        train: impl FnOnce(Option<sgplvm_core::Callback<'_>>) -> sgplvm_core::Result<SharedGplvm>,
    ) -> Result<SharedGplvm, ExperimentError> {
        let mut recorder = Recorder::new(self.human_test, spec.robots);
        let fail = |source| ExperimentError::Model {
            context: spec.context.clone(),
            source,
        };
        let model = train(Some(&mut |it: &IterationRecord, m: &SharedGplvm| {
            recorder.record(it, m)
        }))
        .map_err(fail)?;
        let records = recorder
            .into_records(spec.kind, spec.back_constraint, spec.run, spec.source_robot)
            .map_err(fail)?;
        self.runs.extend(records);
        self.done += 1;
        (self.progress)(&Progress {
            done: self.done,
            total: self.total,
            message: spec.context,
        });
        Ok(model)
    }
}

/// Runs every model of Figs. 4, 5 and 6.
pub fn run(
    data: &ExperimentData,
    config: &ExperimentConfig,
    progress: &mut dyn FnMut(&Progress),
) -> Result<Results, ExperimentError> {
    let mut runner = Runner {
        human_test: data.human.test.as_ref(),
        runs: Vec::new(),
        done: 0,
        total: training_count(config, data.robots.len()),
        progress,
    };
    for bc in BackConstraint::ALL {
        let sources = runner.baselines(data, config, bc)?;
        if bc == BackConstraint::Output {
            continue; // Fig. 6 compares fully trained models only.
        }
        runner.transfers(data, config, bc, &sources)?;
        runner.multi_robot(data, config, bc)?;
    }
    Ok(Results {
        robots: data.robots.iter().map(|(n, _)| n.clone()).collect(),
        config: config.clone(),
        runs: runner.runs,
    })
}

/// The model configuration of run `run` with back constraint `bc`.
fn model_config(config: &ExperimentConfig, bc: BackConstraint, run: usize) -> ModelConfig {
    ModelConfig::default()
        .with_latent_dim(config.latent_dim)
        .with_back_constraint(bc)
        .with_seed(config.seed + run as u64)
}

/// Fully trained models of one back constraint, by (run, source robot index).
type Sources = BTreeMap<(usize, usize), SharedGplvm>;

impl<'a> Runner<'a, '_> {
    /// Baselines: human + one robot, trained fully; kept as transfer sources.
    fn baselines(
        &mut self,
        data: &'a ExperimentData,
        config: &ExperimentConfig,
        bc: BackConstraint,
    ) -> Result<Sources, ExperimentError> {
        let options = TrainOptions::default().with_max_iters(config.max_iters);
        let input = data.input_name.as_str();
        let mut sources = Sources::new();
        for run in 0..config.runs {
            for (r, (robot, split)) in data.robots.iter().enumerate() {
                let spec = RunSpec {
                    context: format!("baseline {robot}, {bc} back constraints, run {run}"),
                    kind: ModelKind::Baseline,
                    back_constraint: bc,
                    run,
                    source_robot: None,
                    robots: vec![(robot.as_str(), split.test.as_ref())],
                };
                let spaces = [
                    (input, data.human.train.as_ref()),
                    (robot.as_str(), split.train.as_ref()),
                ];
                let model = self.record(spec, |cb| {
                    SharedGplvm::fit(&model_config(config, bc, run), &spaces, input, &options, cb)
                })?;
                sources.insert((run, r), model);
            }
        }
        Ok(sources)
    }

    /// Transfer: from each source robot's model to every other robot, from differently seeded
    /// initial kernels.
    fn transfers(
        &mut self,
        data: &'a ExperimentData,
        config: &ExperimentConfig,
        bc: BackConstraint,
        sources: &Sources,
    ) -> Result<(), ExperimentError> {
        let options = TrainOptions::default().with_max_iters(config.transfer_max_iters);
        for ((run, s), source) in sources {
            let source_name = data.robots[*s].0.as_str();
            for (t, (target, split)) in data.robots.iter().enumerate() {
                if t == *s {
                    continue;
                }
                for k in 0..config.transfers_per_run {
                    let index = run * config.transfers_per_run + k;
                    let spec = RunSpec {
                        context: format!(
                            "transfer {source_name} → {target}, {bc} back constraints, run {run}.{k}"
                        ),
                        kind: ModelKind::Transfer,
                        back_constraint: bc,
                        run: index,
                        source_robot: Some(source_name),
                        robots: vec![(target.as_str(), split.test.as_ref())],
                    };
                    let seed = config.seed + index as u64;
                    self.record(spec, |cb| {
                        source.transfer_seeded(target, split.train.as_ref(), seed, &options, cb)
                    })?;
                }
            }
        }
        Ok(())
    }

    /// Multi-robot: human + all robots.
    fn multi_robot(
        &mut self,
        data: &'a ExperimentData,
        config: &ExperimentConfig,
        bc: BackConstraint,
    ) -> Result<(), ExperimentError> {
        let options = TrainOptions::default().with_max_iters(config.max_iters);
        let input = data.input_name.as_str();
        let mut spaces = vec![(input, data.human.train.as_ref())];
        spaces.extend(
            data.robots
                .iter()
                .map(|(n, s)| (n.as_str(), s.train.as_ref())),
        );
        for run in 0..config.runs {
            let spec = RunSpec {
                context: format!("multi-robot, {bc} back constraints, run {run}"),
                kind: ModelKind::Multi,
                back_constraint: bc,
                run,
                source_robot: None,
                robots: data
                    .robots
                    .iter()
                    .map(|(n, s)| (n.as_str(), s.test.as_ref()))
                    .collect(),
            };
            self.record(spec, |cb| {
                SharedGplvm::fit(&model_config(config, bc, run), &spaces, input, &options, cb)
            })?;
        }
        Ok(())
    }
}

fn final_mse(run: &RunRecord) -> f64 {
    run.test_mse.last().copied().unwrap_or(f64::NAN)
}

fn mean(values: impl Iterator<Item = f64>) -> f64 {
    let (sum, count) = values.fold((0.0, 0usize), |(s, c), v| (s + v, c + 1));
    if count == 0 {
        f64::NAN
    } else {
        sum / count as f64
    }
}

impl Results {
    /// The runs of one robot, kind of model and back constraint (by name).
    pub(crate) fn select(&self, robot: &str, model: ModelKind, bc: &str) -> Vec<&RunRecord> {
        self.runs
            .iter()
            .filter(|r| r.robot == robot && r.model == model && r.back_constraint == bc)
            .collect()
    }

    /// Mean final test error of a group of runs.
    pub fn final_mean(&self, robot: &str, model: ModelKind, bc: &str) -> f64 {
        mean(self.select(robot, model, bc).into_iter().map(final_mse))
    }

    /// Mean training seconds a group of runs needed to first reach `level` of test error
    /// (runs that never reach it count with their total time; `None` if none reached it).
    pub fn seconds_to_reach(
        &self,
        robot: &str,
        model: ModelKind,
        bc: &str,
        level: f64,
    ) -> Option<f64> {
        let runs = self.select(robot, model, bc);
        let mut reached = false;
        let times = runs
            .iter()
            .map(|r| match r.test_mse.iter().position(|&m| m <= level) {
                Some(i) => {
                    reached = true;
                    r.seconds[i]
                }
                None => r.seconds.last().copied().unwrap_or(f64::NAN),
            });
        let value = mean(times);
        reached.then_some(value)
    }
}

/// Writes `results.json`, the figures (SVG and PNG) and `report.md` into `dir`; returns the paths.
pub fn write_outputs(results: &Results, dir: &Path) -> Result<Vec<PathBuf>, ExperimentError> {
    let mut written = Vec::new();
    let json = serde_json::to_vec_pretty(results).expect("results serialise");
    let path = dir.join("results.json");
    atomic_write(&path, &json)?;
    written.push(path);
    written.extend(figures::learning_curves(results, dir)?);
    written.extend(figures::back_constraints(results, dir)?);
    let path = dir.join("report.md");
    atomic_write(&path, report(results).as_bytes())?;
    written.push(path);
    Ok(written)
}

/// The report: a table of final test errors and, for each of the paper's claims, whether these
/// results support it.
pub fn report(results: &Results) -> String {
    let mut out = String::from("# Experiment report (paper Section IV-B)\n\n");
    out.push_str(&format!(
        "{} runs per baseline and multi-robot model, {} transfer runs per source run, {} iterations (transfer: {}), Q = {}.\n\n",
        results.config.runs,
        results.config.transfers_per_run,
        results.config.max_iters,
        results.config.transfer_max_iters,
        results.config.latent_dim
    ));
    out.push_str(&final_table(results));
    out.push_str("\n## The paper's claims\n\n");
    let input = BackConstraint::Input.name();

    out.push_str(&claim(
        results,
        "1. Back constraints on the input give the best fully trained model (Fig. 6)",
        |robot| {
            let [none, input, output] = BackConstraint::ALL
                .map(|bc| results.final_mean(robot, ModelKind::Baseline, bc.name()));
            (
                input <= none && input <= output,
                format!("   - {robot}: none {none:.5}, input {input:.5}, output {output:.5}"),
            )
        },
    ));
    out.push_str(&claim(
        results,
        "2. With input back constraints, transfer reaches the baseline's error faster (Fig. 5)",
        |robot| {
            let baseline_final = results.final_mean(robot, ModelKind::Baseline, input);
            let level = baseline_final * 1.1;
            let baseline_t = results.seconds_to_reach(robot, ModelKind::Baseline, input, level);
            let transfer_t = results.seconds_to_reach(robot, ModelKind::Transfer, input, level);
            let show = |t: Option<f64>| t.map_or("never".to_string(), |t| format!("{t:.3} s"));
            (
                matches!((baseline_t, transfer_t), (Some(b), Some(t)) if t < b),
                format!(
                    "  - {robot}: time to reach 1.1 × the baseline's final test MSE ({level:.5}): baseline {}, transfer {}",
                    show(baseline_t),
                    show(transfer_t)
                ),
            )
        },
    ));
    out.push_str(&claim(
        results,
        "3. The multi-robot model performs similarly to the baseline (ratio within 1/1.5 … 1.5, input back constraints)",
        |robot| {
            let baseline = results.final_mean(robot, ModelKind::Baseline, input);
            let multi = results.final_mean(robot, ModelKind::Multi, input);
            let ratio = multi / baseline;
            (
                ratio.is_finite() && (1.0 / 1.5..=1.5).contains(&ratio),
                format!("   - {robot}: multi-robot / baseline final test MSE = {ratio:.2}"),
            )
        },
    ));
    out.push_str("\nFigures: fig4.svg/png, fig5.svg/png (against iterations; `_seconds` against training time), fig6.svg/png.\n");
    out
}

/// The table of final test errors: a row per robot and back constraint, a column per model.
fn final_table(results: &Results) -> String {
    let mut out = String::from("## Final test MSE (rad², mean over runs)\n\n| robot | back constraint | baseline | transfer | multi-robot |\n|---|---|---|---|---|\n");
    for robot in &results.robots {
        for bc in BackConstraint::ALL {
            let cell = |kind| {
                let v = results.final_mean(robot, kind, bc.name());
                if v.is_nan() {
                    "—".to_string()
                } else {
                    format!("{v:.5}")
                }
            };
            out.push_str(&format!(
                "| {robot} | {bc} | {} | {} | {} |\n",
                cell(ModelKind::Baseline),
                cell(ModelKind::Transfer),
                cell(ModelKind::Multi)
            ));
        }
    }
    out
}

/// One of the paper's claims, supported when it holds for every robot: `check` tells for one
/// robot whether it holds, with the line of numbers shown under the claim.
fn claim(results: &Results, statement: &str, check: impl Fn(&str) -> (bool, String)) -> String {
    let (holds, lines): (Vec<bool>, Vec<String>) =
        results.robots.iter().map(|robot| check(robot)).unzip();
    let verdict = if holds.iter().all(|&ok| ok) {
        "supported"
    } else {
        "**not supported**"
    };
    format!("{statement}: {verdict}.\n{}\n", lines.join("\n"))
}

#[cfg(test)]
mod tests {
    //! The judge of the paper's claims on synthetic run records whose verdicts are known.

    use super::*;

    fn record(robot: &str, model: ModelKind, bc: &str, seconds: &[f64], mse: &[f64]) -> RunRecord {
        RunRecord {
            robot: robot.into(),
            model,
            back_constraint: bc.into(),
            run: 0,
            source_robot: None,
            iterations: (0..mse.len()).collect(),
            seconds: seconds.to_vec(),
            test_mse: mse.to_vec(),
        }
    }

    fn results(robots: &[&str], runs: Vec<RunRecord>) -> Results {
        Results {
            robots: robots.iter().map(|r| r.to_string()).collect(),
            config: ExperimentConfig::quick(),
            runs,
        }
    }

    /// One robot whose records support all three claims; `tweak` edits them before judging.
    fn supporting(robot: &str) -> Vec<RunRecord> {
        use ModelKind::*;
        let t = [0.0, 1.0, 2.0, 3.0];
        vec![
            // Claim 1: input (final 0.10) beats none (0.20) and output (0.30).
            record(robot, Baseline, "none", &t, &[1.0, 0.5, 0.3, 0.2]),
            record(robot, Baseline, "input", &t, &[1.0, 0.5, 0.2, 0.1]),
            record(robot, Baseline, "input", &t, &[1.0, 0.4, 0.2, 0.1]),
            record(robot, Baseline, "output", &t, &[1.0, 0.6, 0.4, 0.3]),
            // Claim 2: transfer reaches 1.1 × 0.1 = 0.11 after 0.5 s, the baseline after 3 s.
            record(
                robot,
                Transfer,
                "input",
                &[0.0, 0.5, 1.0],
                &[0.5, 0.105, 0.1],
            ),
            // Claim 3: multi / baseline = 0.12 / 0.1 = 1.2.
            record(robot, Multi, "input", &t, &[1.0, 0.5, 0.2, 0.12]),
        ]
    }

    /// The verdict line of claim `number` (1-based) in the report.
    fn verdict(report: &str, number: usize) -> &str {
        let line = report
            .lines()
            .find(|l| l.starts_with(&format!("{number}. ")))
            .unwrap_or_else(|| panic!("claim {number} missing from\n{report}"));
        if line.ends_with(": supported.") {
            "supported"
        } else if line.ends_with(": **not supported**.") {
            "not supported"
        } else {
            panic!("no verdict in {line:?}")
        }
    }

    fn verdicts(r: &Results) -> [&'static str; 3] {
        let rep = report(r);
        [1, 2, 3].map(|k| match verdict(&rep, k) {
            "supported" => "supported",
            _ => "not supported",
        })
    }

    const ALL_SUPPORTED: [&str; 3] = ["supported", "supported", "supported"];

    #[test]
    fn final_mean_averages_the_last_values_of_the_selected_runs() {
        let r = results(&["a"], supporting("a"));
        assert_eq!(r.final_mean("a", ModelKind::Baseline, "input"), 0.1);
        assert_eq!(r.final_mean("a", ModelKind::Baseline, "none"), 0.2);
        assert_eq!(r.final_mean("a", ModelKind::Multi, "input"), 0.12);
        // Two runs: (0.1 + 0.3) / 2, not the last run only or the sum.
        let mut runs = supporting("a");
        runs[2].test_mse[3] = 0.3;
        let r = results(&["a"], runs);
        assert!((r.final_mean("a", ModelKind::Baseline, "input") - 0.2).abs() < 1e-15);
        // Missing group or robot: NaN, never 0.
        assert!(r.final_mean("a", ModelKind::Multi, "none").is_nan());
        assert!(r.final_mean("b", ModelKind::Baseline, "input").is_nan());
        // An empty record counts as NaN (not dropped silently).
        let mut runs = supporting("a");
        runs[0].test_mse.clear();
        let r = results(&["a"], runs);
        assert!(r.final_mean("a", ModelKind::Baseline, "none").is_nan());
    }

    #[test]
    fn seconds_to_reach_takes_the_first_time_at_or_below_the_level() {
        use ModelKind::*;
        let t = [0.0, 1.0, 2.0, 3.0];
        let r = results(
            &["a"],
            vec![
                record("a", Baseline, "input", &t, &[1.0, 0.5, 0.2, 0.1]),
                record("a", Baseline, "input", &t, &[1.0, 0.2, 0.3, 0.1]),
            ],
        );
        let at = |level| r.seconds_to_reach("a", Baseline, "input", level);
        // A tie counts as reached (≤): the first run at 2 s, the second at 1 s (not its later
        // rise to 0.3, nor its last time).
        assert_eq!(at(0.2), Some(1.5));
        assert_eq!(at(0.1), Some(3.0));
        assert_eq!(at(1.0), Some(0.0));
        // Nobody reaches it: None (not the mean total time).
        assert_eq!(at(0.05), None);
        // One of the two reaches it: the other counts with its total time.
        let r = results(
            &["a"],
            vec![
                record("a", Baseline, "input", &t, &[1.0, 0.5, 0.2, 0.1]),
                record("a", Baseline, "input", &t, &[1.0, 0.5, 0.4, 0.3]),
            ],
        );
        assert_eq!(r.seconds_to_reach("a", Baseline, "input", 0.2), Some(2.5));
        // No runs at all: None.
        assert_eq!(r.seconds_to_reach("a", Transfer, "input", 1.0), None);
    }

    #[test]
    fn every_claim_is_supported_by_supporting_records() {
        let mut runs = supporting("a");
        runs.extend(supporting("b"));
        let r = results(&["a", "b"], runs);
        assert_eq!(verdicts(&r), ALL_SUPPORTED);
        let rep = report(&r);
        assert!(
            rep.contains("| a | input | 0.10000 | 0.10000 | 0.12000 |"),
            "{rep}"
        );
        assert!(rep.contains("| a | output | 0.30000 | — | — |"), "{rep}");
        assert!(rep.contains("baseline 3.000 s, transfer 0.500 s"), "{rep}");
        assert!(
            rep.contains("multi-robot / baseline final test MSE = 1.20"),
            "{rep}"
        );
    }

    #[test]
    fn claim_1_needs_input_to_beat_both_others_on_every_robot() {
        let judge = |none: f64, output: f64| {
            let mut runs = supporting("a");
            runs[0].test_mse[3] = none;
            runs[3].test_mse[3] = output;
            verdicts(&results(&["a"], runs))[0]
        };
        assert_eq!(judge(0.09, 0.3), "not supported", "none better");
        assert_eq!(judge(0.2, 0.09), "not supported", "output better");
        // Ties go to the claim (input ≤ the others).
        assert_eq!(judge(0.1, 0.1), "supported", "ties");
        assert_eq!(judge(0.1000001, 0.3), "supported");
        // A second robot that contradicts it makes it unsupported.
        let mut runs = supporting("a");
        let mut b = supporting("b");
        b[3].test_mse[3] = 0.05;
        runs.extend(b);
        assert_eq!(verdicts(&results(&["a", "b"], runs))[0], "not supported");
        // Missing input runs (NaN) never support it.
        let runs: Vec<_> = supporting("a")
            .into_iter()
            .filter(|r| !(r.model == ModelKind::Baseline && r.back_constraint == "input"))
            .collect();
        assert_eq!(verdicts(&results(&["a"], runs))[0], "not supported");
    }

    #[test]
    fn claim_2_needs_transfer_strictly_faster_to_the_baselines_level() {
        let judge = |transfer_seconds: &[f64], transfer_mse: &[f64]| {
            let mut runs = supporting("a");
            runs[4].seconds = transfer_seconds.to_vec();
            runs[4].test_mse = transfer_mse.to_vec();
            verdicts(&results(&["a"], runs))[1]
        };
        // The level is 1.1 × the baseline's final 0.1 = 0.11, reached by the baseline at 3 s.
        assert_eq!(judge(&[0.0, 2.9], &[0.5, 0.11]), "supported");
        assert_eq!(judge(&[0.0, 3.1], &[0.5, 0.11]), "not supported", "slower");
        assert_eq!(judge(&[0.0, 3.0], &[0.5, 0.11]), "not supported", "a tie");
        // 0.1101 misses 1.1 × 0.1; with the level at 1.0 × or 1.2 × it would flip.
        assert_eq!(judge(&[0.0, 0.5], &[0.5, 0.1101]), "not supported");
        assert_eq!(judge(&[0.0, 0.5], &[0.5, 0.1099]), "supported");
        // A transfer curve that never reaches the level.
        assert_eq!(judge(&[0.0, 0.5, 1.0], &[0.5, 0.3, 0.2]), "not supported");
        // No transfer runs at all.
        let runs: Vec<_> = supporting("a")
            .into_iter()
            .filter(|r| r.model != ModelKind::Transfer)
            .collect();
        let r = results(&["a"], runs);
        assert_eq!(verdicts(&r)[1], "not supported");
        assert!(report(&r).contains("baseline 3.000 s, transfer never"));
    }

    #[test]
    fn claim_3_needs_the_ratio_within_a_factor_1_5() {
        let judge = |multi: f64| {
            let mut runs = supporting("a");
            runs[5].test_mse[3] = multi;
            verdicts(&results(&["a"], runs))[2]
        };
        // Baseline final 0.1: the band is [0.1/1.5, 0.15], both ends included.
        assert_eq!(judge(0.15), "supported");
        assert_eq!(judge(0.1 / 1.5 + 1e-12), "supported");
        assert_eq!(judge(0.1), "supported");
        assert_eq!(judge(0.1501), "not supported", "too large");
        assert_eq!(
            judge(0.066),
            "not supported",
            "too small (much better is not similar)"
        );
        // No multi-robot runs: NaN ratio, not supported.
        let runs: Vec<_> = supporting("a")
            .into_iter()
            .filter(|r| r.model != ModelKind::Multi)
            .collect();
        assert_eq!(verdicts(&results(&["a"], runs))[2], "not supported");
    }

    #[test]
    fn the_verdict_is_per_robot_and_all_must_hold() {
        // Robot b has records for claim 1 only: claims 2 and 3 fail for it alone.
        let mut runs = supporting("a");
        runs.extend(
            supporting("b")
                .into_iter()
                .filter(|r| r.model == ModelKind::Baseline),
        );
        assert_eq!(
            verdicts(&results(&["a", "b"], runs)),
            ["supported", "not supported", "not supported"]
        );
        // Records of a robot not in `robots` are not judged.
        let mut runs = supporting("a");
        let mut c = supporting("c");
        c[1].test_mse[3] = 9.0;
        c[2].test_mse[3] = 9.0;
        runs.extend(c);
        assert_eq!(verdicts(&results(&["a"], runs)), ALL_SUPPORTED);
    }
}
