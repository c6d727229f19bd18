//! The experiments of the paper's Section IV-B: fully trained single-robot models (the baseline),
//! transfer from a model trained on another robot, and the multi-robot model, each without and
//! with back constraints on the input (Figs. 4 and 5), and fully trained models with no, input
//! and output back constraints (Fig. 6). Test error is recorded at every optimisation iteration.
//!
//! Beside them, the yardstick the paper chose Q by: a direct GP regression H → R per robot.
//!
//! This module holds the protocol ([`run`]); the records it writes ([`Results`]) are defined in
//! [`crate::results`] and the matrices it reads ([`ExperimentData`]) in [`crate::pipeline`],
//! both re-exported here. The report judging the paper's claims with statistics over runs is
//! [`report()`], the figures are drawn by [`crate::figures`].

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use sgplvm_core::{
    BackConstraint, Control, IterationRecord, MatRef, ModelConfig, SharedGplvm, TrainOptions,
    Validation,
};

use crate::figures;
use crate::files::atomic_write;
pub use crate::pipeline::{mean_squared_error, AllFrames, ExperimentData, SplitData};
pub use crate::results::{
    AllFramesRecord, BayesianStudy, DirectRecord, ExperimentConfig, LessDataRecord, ModelKind,
    Results, RunRecord, Shipped,
};

mod all_frames;
mod bayesian;
mod less_data;
mod parts;
mod plan;
mod report;
mod retargeting;
pub use less_data::subset;
pub use parts::{pairs, recombine, PartsData, PartsRecord};
pub use plan::{assemble, execute, plan, Task, TaskResult, TaskSpec};
pub use report::{report, MIN_RUNS_TO_JUDGE};
pub use retargeting::{RetargetingData, RetargetingStudy};

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
    /// A task of the plan, or its inputs, did not fit the experiment.
    #[error("{context}: {problem}")]
    Task {
        /// Which task (or what was being read).
        context: String,
        /// What did not fit, and what was expected.
        problem: String,
    },
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

    /// Test error of `model` for robot `k` of the recorder.
    fn test_mse(&self, model: &SharedGplvm, k: usize) -> Result<f64, sgplvm_core::Error> {
        let (robot, desired) = self.robots[k];
        let prediction = model.predict(self.human_test, robot, false)?;
        Ok(mean_squared_error(prediction.mean.as_ref(), desired))
    }

    fn record(&mut self, iteration: &IterationRecord, model: &SharedGplvm) -> Control {
        for k in 0..self.robots.len() {
            match self.test_mse(model, k) {
                Ok(mse) => self.mse[k].push(mse),
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

    /// The records of the training that handed back `model`.
    fn into_records(
        self,
        model: &SharedGplvm,
        kind: ModelKind,
        bc: BackConstraint,
        run: usize,
        source: Option<(&str, usize)>,
    ) -> Result<Vec<RunRecord>, sgplvm_core::Error> {
        if let Some(e) = self.failure {
            return Err(e);
        }
        let shipped = (0..self.robots.len())
            .map(|k| {
                Ok(Shipped {
                    iteration: shipped_iteration(model),
                    seconds: shipped_seconds(model),
                    test_mse: self.test_mse(model, k)?,
                })
            })
            .collect::<Result<Vec<_>, sgplvm_core::Error>>()?;
        // The curve is the final training's; its seconds count the selection run before it. A
        // budget of 0 iterations (the initial model shipped) has no iterations to record: the
        // curve is then the shipped point alone.
        let selection_seconds = model.selection().map_or(0.0, |s| s.seconds);
        let stop_reason = stop_reason(model);
        let seconds: Vec<f64> = self.seconds.iter().map(|s| s + selection_seconds).collect();
        Ok(self
            .robots
            .iter()
            .zip(self.mse)
            .zip(shipped)
            .map(|(((robot, _), test_mse), shipped)| {
                let (iterations, seconds, test_mse) = if test_mse.is_empty() {
                    (
                        vec![shipped.iteration],
                        vec![shipped.seconds],
                        vec![shipped.test_mse],
                    )
                } else {
                    (self.iterations.clone(), seconds.clone(), test_mse)
                };
                RunRecord {
                    robot: robot.to_string(),
                    model: kind,
                    back_constraint: bc.to_string(),
                    run,
                    source_robot: source.map(|(robot, _)| robot.to_string()),
                    source_run: source.map(|(_, run)| run),
                    iterations,
                    seconds,
                    test_mse,
                    shipped: Some(shipped),
                    stop_reason: stop_reason.clone(),
                    bayesian: false,
                    ard_weights: Vec::new(),
                    arms_from_person: None,
                }
            })
            .collect())
    }
}

/// Training seconds until `model`'s parameters were reached: the time to the shipped model that
/// claim 2 compares — the selection run on held-out frames, if any, and the final training.
pub(super) fn shipped_seconds(model: &SharedGplvm) -> f64 {
    model.training_seconds()
}

/// Why `model`'s final training stopped, by name.
pub(super) fn stop_reason(model: &SharedGplvm) -> Option<String> {
    model.stop_reason().map(|r| r.name().to_string())
}

/// The iteration at which `model`'s parameters were reached in its final training (see
/// [`shipped_seconds`]).
pub(super) fn shipped_iteration(model: &SharedGplvm) -> usize {
    model.history().last().map_or(0, |r| r.iteration)
}

/// One group of trainings of [`run`], in the order they are run: the unit of progress lines.
#[derive(Debug, Clone, PartialEq)]
pub struct Stage {
    /// What the group trains, e.g. "baselines, input BC".
    pub name: String,
    /// The kind of model; `None` for the direct GP regressions.
    pub model: Option<ModelKind>,
    /// Trainings in the group.
    pub trainings: usize,
    /// Rough cost of one of its trainings (iteration budget × spaces trained), to estimate the
    /// time left before a kind of training has been timed.
    pub work: f64,
}

/// The groups of trainings [`run`] performs for `robots` robots, in order.
pub fn stages(config: &ExperimentConfig, robots: usize) -> Vec<Stage> {
    let stage = |name: String, model, trainings, iters: usize, spaces: usize| Stage {
        name,
        model,
        trainings,
        work: (iters * spaces) as f64,
    };
    let mut plan = vec![stage(
        "direct GP regression H → R".into(),
        None,
        robots,
        config.direct_max_iters,
        1,
    )];
    for bc in BackConstraint::ALL {
        plan.push(stage(
            format!("baselines, {bc} BC"),
            Some(ModelKind::Baseline),
            config.runs * robots,
            config.max_iters,
            2,
        ));
        if bc == BackConstraint::Output {
            continue; // Fig. 6 compares fully trained models only.
        }
        plan.push(stage(
            format!("transfers, {bc} BC"),
            Some(ModelKind::Transfer),
            config.runs * robots * robots.saturating_sub(1) * config.transfers_per_run,
            config.transfer_max_iters,
            1,
        ));
        plan.push(stage(
            format!("multi-robot, {bc} BC"),
            Some(ModelKind::Multi),
            config.runs,
            config.max_iters,
            robots + 1,
        ));
    }
    if !config.fractions.is_empty() {
        plan.push(stage(
            "less data, input BC".into(),
            Some(ModelKind::Baseline),
            less_data::trainings(config, robots),
            config.max_iters,
            1,
        ));
    }
    if config.inducing.is_some() {
        for bc in all_frames::BACK_CONSTRAINTS {
            for full_rate in [false, true] {
                plan.push(stage(
                    all_frames::stage_name(config, bc, full_rate),
                    Some(ModelKind::Baseline),
                    config.runs * robots,
                    config.max_iters,
                    2,
                ));
            }
        }
    }
    if config.parts {
        plan.push(stage(
            parts::DIRECT_STAGE.into(),
            None,
            robots,
            config.direct_max_iters,
            2,
        ));
        plan.push(stage(
            parts::STAGE.into(),
            Some(ModelKind::Baseline),
            config.runs * robots,
            config.max_iters,
            6 + 2 * robots.saturating_sub(1),
        ));
    }
    plan.extend(bayesian::stages(config, robots));
    plan
}

/// Progress of a running experiment, for progress bars and lines.
#[derive(Debug, Clone)]
pub struct Progress {
    /// Trainings done.
    pub done: usize,
    /// Trainings in all.
    pub total: usize,
    /// What was just finished.
    pub message: String,
    /// Index of the current group of trainings in [`stages`].
    pub stage: usize,
    /// Trainings of that group done (the group is complete when it reaches its `trainings`).
    pub stage_done: usize,
}

/// Number of trainings [`run`] performs for `robots` robots.
pub fn training_count(config: &ExperimentConfig, robots: usize) -> usize {
    stages(config, robots).iter().map(|s| s.trainings).sum()
}

/// Runs the direct regressions and every model of Figs. 4, 5 and 6, and the less-data study: the
/// tasks of [`plan()`] one after another, each by [`execute`], the records joined by
/// [`assemble`]. `progress` hears of every finished training.
pub fn run(
    data: &ExperimentData,
    config: &ExperimentConfig,
    progress: &mut dyn FnMut(&Progress),
) -> Result<Results, ExperimentError> {
    all_frames::check(config, data)?;
    if config.parts && data.parts.is_none() {
        return Err(ExperimentError::Task {
            context: "the study of a latent space per arm".into(),
            problem: "the experiment data holds no arm columns and recombined frames (parts)"
                .into(),
        });
    }
    let tasks = plan(config, data);
    let total = tasks.len();
    let mut stage_done = vec![0; stages(config, data.robots.len()).len()];
    // Models later tasks start from, by task id; dropped after their last user.
    let last_use: BTreeMap<usize, usize> = tasks
        .iter()
        .filter_map(|t| t.source.map(|s| (s, t.id)))
        .collect();
    let mut models: BTreeMap<usize, SharedGplvm> = BTreeMap::new();
    let mut records = Vec::with_capacity(total);
    for (done, task) in tasks.iter().enumerate() {
        let source = task.source.and_then(|s| models.get(&s));
        let (record, model) = execute(task, data, config, source)?;
        records.push(record);
        if let Some(s) = task.source.filter(|s| last_use.get(s) == Some(&task.id)) {
            models.remove(&s);
        }
        if let Some(model) = model.filter(|_| last_use.contains_key(&task.id)) {
            models.insert(task.id, model);
        }
        let stage_done = stage_done.get_mut(task.stage).map_or(0, |d| {
            *d += 1;
            *d
        });
        progress(&Progress {
            done: done + 1,
            total,
            message: task.context.clone(),
            stage: task.stage,
            stage_done,
        });
    }
    assemble(data, config, records)
}

/// The held-out frames of every training, when budgets are chosen on them.
fn validation(config: &ExperimentConfig, data: &ExperimentData) -> Option<Validation> {
    config
        .patience
        .map(|p| Validation::new(data.validation.clone()).with_patience(p))
}

/// A full or multi-robot training of run `run` with back constraint `bc` on `spaces`: the
/// paper's model (its budget chosen on held-out frames when the experiment does), or with
/// `bayesian` the Bayesian study's, trained to convergence or `options`' budget.
fn fit(
    config: &ExperimentConfig,
    data: &ExperimentData,
    (bc, run, bayesian): (BackConstraint, usize, bool),
    spaces: &[(&str, MatRef<'_, f64>)],
    options: &TrainOptions,
    callback: Option<sgplvm_core::Callback<'_>>,
) -> sgplvm_core::Result<SharedGplvm> {
    let input = data.input_name.as_str();
    if bayesian {
        let model = bayesian::configure(config, model_config(config, bc, run));
        return SharedGplvm::fit(&model, spaces, input, options, callback);
    }
    let model = model_config(config, bc, run);
    match validation(config, data) {
        Some(v) => SharedGplvm::fit_validated(&model, spaces, input, options, &v, callback),
        None => SharedGplvm::fit(&model, spaces, input, options, callback),
    }
}

/// The model configuration of run `run` with back constraint `bc`.
fn model_config(config: &ExperimentConfig, bc: BackConstraint, run: usize) -> ModelConfig {
    ModelConfig::default()
        .with_latent_dim(config.latent_dim)
        .with_back_constraint(bc)
        .with_seed(config.seed + run as u64)
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
    written.extend(figures::transfers_by_source(results, dir)?);
    if !results.less_data.is_empty() {
        written.extend(figures::less_data(results, dir)?);
    }
    if !results.all_frames.is_empty() {
        written.extend(figures::all_frames(results, dir)?);
    }
    if let Some(fig12) = figures::ard_weights(results, dir)? {
        written.extend(fig12);
    }
    let path = dir.join("report.md");
    atomic_write(&path, report(results).as_bytes())?;
    written.push(path);
    Ok(written)
}

#[cfg(test)]
mod tests {
    //! The protocol on a toy problem (the plan of stages against what `run` does, the shipped
    //! model and the direct regression recorded), and results files from before those records.

    use super::*;
    use sgplvm_core::Mat;

    /// A smooth toy problem: 3 inputs, two "robots" of 2 outputs each; the training frames
    /// every other frame of the "full-rate" ones.
    pub(super) fn toy() -> ExperimentData {
        let frames = |n: usize, offset: f64| {
            Mat::from_fn(n, 3, |i, j| ((i as f64 + offset) * 0.3 + j as f64).sin())
        };
        let full_human = Mat::from_fn(48, 3, |i, j| (i as f64 * 0.15 + j as f64).sin());
        let full_robot = |scale: f64| {
            Mat::from_fn(48, 2, |i, j| {
                scale * (full_human[(i, j)] + 0.5 * full_human[(i, 2)])
            })
        };
        let all_frames = AllFrames {
            robots: vec![full_robot(1.0), full_robot(0.7)],
            human: full_human.clone(),
            validation: (0..48).filter(|i| (i / 2) % 3 == 2).collect(),
        };
        let (h_train, h_test) = (frames(24, 0.0), frames(8, 0.45));
        let robot = |scale: f64| SplitData {
            train: Mat::from_fn(24, 2, |i, j| {
                scale * (h_train[(i, j)] + 0.5 * h_train[(i, 2)])
            }),
            test: Mat::from_fn(8, 2, |i, j| scale * (h_test[(i, j)] + 0.5 * h_test[(i, 2)])),
        };
        ExperimentData {
            input_name: "human".into(),
            human: SplitData {
                train: h_train.clone(),
                test: h_test.clone(),
            },
            robots: vec![("a".into(), robot(1.0)), ("b".into(), robot(0.7))],
            validation: (0..24).filter(|i| i % 3 == 2).collect(),
            all_frames: Some(all_frames),
            // Arms: the human's first input column and its other two; each robot's columns.
            parts: Some(PartsData {
                human_arms: [vec![0], vec![1, 2]],
                robot_arms: vec![[vec![0], vec![1]], [vec![0], vec![1]]],
                test_pairs: (0..8).map(|i| (i, (i + 4) % 8)).collect(),
                train_pairs: (0..24).map(|i| (i, (i + 12) % 24)).collect(),
            }),
            // Robots without a built-in body: the study names them and leaves them out.
            retargeting: Some(RetargetingData {
                robot_joints: vec![vec!["a0".into(), "a1".into()]; 2],
                test_people: vec!["s".into()],
                training_people: vec!["t".into()],
            }),
        }
    }

    /// With budgets chosen on held-out frames, every run ships the final training's last
    /// iterate, its time counts the selection run, and a budget of 0 still leaves a point.
    #[test]
    fn validated_runs_ship_the_chosen_budget() {
        let config = ExperimentConfig {
            runs: 1,
            transfers_per_run: 1,
            max_iters: 8,
            transfer_max_iters: 8,
            latent_dim: 2,
            seed: 0,
            direct_max_iters: 20,
            patience: Some(2),
            fractions: vec![0.5],
            max_seconds: None,
            inducing: Some(6),
            bayesian: None,
            parts: false,
        };
        let mut trainings = 0;
        let results = run(&toy(), &config, &mut |_| trainings += 1).unwrap();
        assert_eq!(trainings, training_count(&config, 2));
        // Less data: per robot one model trained on half the frames, one transfer to it.
        let kinds: Vec<(&str, ModelKind, usize)> = results
            .less_data
            .iter()
            .map(|r| (r.robot.as_str(), r.model, r.frames))
            .collect();
        assert_eq!(
            kinds,
            [
                ("a", ModelKind::Baseline, 12),
                ("a", ModelKind::Transfer, 12),
                ("b", ModelKind::Baseline, 12),
                ("b", ModelKind::Transfer, 12)
            ]
        );
        assert!(results.less_data.iter().all(|r| r.test_mse.is_finite()));
        // All frames: per robot one sparse model (input back constraints) on the 24 subsampled
        // frames (the control), then one on the 48 frames.
        let all: Vec<(&str, &str, bool, usize, usize)> = results
            .all_frames
            .iter()
            .map(|r| {
                let kind = (r.robot.as_str(), r.back_constraint.as_str());
                (kind.0, kind.1, r.full_rate, r.frames, r.inducing)
            })
            .collect();
        // An M the control's frames cannot hold is refused before anything is trained.
        let too_many = ExperimentConfig {
            inducing: Some(17),
            ..config.clone()
        };
        let mut trained = 0;
        let e = run(&toy(), &too_many, &mut |_| trained += 1).unwrap_err();
        assert_eq!(trained, 0);
        assert!(
            e.to_string().contains(
                "17 inducing inputs, but its control trains the sparse model on the 16 subsampled training frames not held out; expected at most 16"
            ),
            "{e}"
        );
        assert_eq!(
            all,
            [
                ("a", "input", false, 24, 6),
                ("b", "input", false, 24, 6),
                ("a", "input", true, 48, 6),
                ("b", "input", true, 48, 6)
            ]
        );
        for r in &results.all_frames {
            assert!(r.test_mse.is_finite() && r.test_mse > 0.0, "{r:?}");
            assert!(r.iteration <= 8 && r.stop_reason.is_some(), "{r:?}");
        }
        for r in &results.runs {
            let shipped = r.shipped.expect("recorded");
            assert!(shipped.iteration <= 8, "{r:?}");
            assert_eq!(Some(&shipped.iteration), r.iterations.last(), "{r:?}");
            assert_eq!(Some(&shipped.seconds), r.seconds.last(), "{r:?}");
            if r.back_constraint == "input" {
                assert_eq!(Some(&shipped.test_mse), r.test_mse.last(), "{r:?}");
            }
        }
    }

    #[test]
    fn progress_follows_the_plan_and_every_run_records_its_shipped_model() {
        let config = ExperimentConfig {
            runs: 1,
            transfers_per_run: 1,
            max_iters: 3,
            transfer_max_iters: 3,
            latent_dim: 2,
            seed: 0,
            direct_max_iters: 20,
            patience: None,
            fractions: Vec::new(),
            max_seconds: None,
            inducing: None,
            bayesian: None,
            parts: false,
        };
        let plan = stages(&config, 2);
        // Direct (2), then per back constraint baselines (2), transfers (2), multi (1); output:
        // baselines only.
        let counts: Vec<usize> = plan.iter().map(|s| s.trainings).collect();
        assert_eq!(counts, [2, 2, 2, 1, 2, 2, 1, 2]);
        assert_eq!(plan[5].name, "transfers, input BC");
        assert_eq!(training_count(&config, 2), 14);
        let mut events = Vec::new();
        let results = run(&toy(), &config, &mut |p| {
            events.push((p.stage, p.stage_done, p.done, p.total))
        })
        .unwrap();
        assert_eq!(events.len(), 14);
        // Every stage's events count 1..=trainings, in plan order.
        let mut expected = Vec::new();
        for (s, stage) in plan.iter().enumerate() {
            for k in 1..=stage.trainings {
                expected.push((s, k, expected.len() + 1, 14));
            }
        }
        assert_eq!(events, expected);
        // The direct regressions, one per robot, finite.
        let direct: Vec<&str> = results
            .direct_regression
            .iter()
            .map(|d| d.robot.as_str())
            .collect();
        assert_eq!(direct, ["a", "b"]);
        assert!(results.direct_mse("a").is_finite() && results.direct_mse("a") > 0.0);
        // Training hands back its last iterate today: the shipped model is the last record.
        for r in &results.runs {
            let shipped = r.shipped.expect("recorded");
            assert_eq!(Some(&shipped.iteration), r.iterations.last(), "{r:?}");
            assert_eq!(Some(&shipped.seconds), r.seconds.last(), "{r:?}");
            let last = *r.test_mse.last().unwrap();
            if r.back_constraint == "input" {
                assert_eq!(shipped.test_mse, last, "{r:?}");
            } else {
                // Without input back constraints the returned model's human → latent map is
                // fitted from a cold start, the snapshots' from the previous one: close, not
                // identical.
                assert!((shipped.test_mse - last).abs() <= 1e-3 * last, "{r:?}");
            }
        }
        // Transfers know their source run.
        let transfer = results
            .runs
            .iter()
            .find(|r| r.model == ModelKind::Transfer)
            .unwrap();
        assert_eq!(transfer.source_run, Some(0));
    }

    #[test]
    fn results_written_before_the_shipped_and_direct_records_still_load() {
        let old = r#"{"robots": ["a"],
            "config": {"runs": 2, "transfers_per_run": 2, "max_iters": 60,
                       "transfer_max_iters": 60, "latent_dim": 5, "seed": 0},
            "runs": [{"robot": "a", "model": "transfer", "back_constraint": "input", "run": 3,
                      "source_robot": "b", "iterations": [0, 5, 9],
                      "seconds": [0.0, 0.5, 0.8], "test_mse": [0.3, 0.1, 0.2]}]}"#;
        let results: Results = serde_json::from_str(old).unwrap();
        assert!(results.direct_regression.is_empty());
        assert!(results.direct_mse("a").is_nan());
        assert_eq!(results.config.direct_max_iters, 1000);
        let run = &results.runs[0];
        assert_eq!(run.source_run, None);
        // The shipped model of an old record is its last iterate (not its best).
        assert_eq!(
            run.shipped(),
            Shipped {
                iteration: 9,
                seconds: 0.8,
                test_mse: 0.2
            }
        );
        assert_eq!(results.shipped_mean("a", ModelKind::Transfer, "input"), 0.2);
        assert!(results
            .shipped_mean("a", ModelKind::Baseline, "input")
            .is_nan());
        // An empty record has NaN times and errors, never 0.
        let empty = RunRecord {
            iterations: vec![],
            seconds: vec![],
            test_mse: vec![],
            ..run.clone()
        };
        assert!(empty.shipped().test_mse.is_nan() && empty.shipped().seconds.is_nan());
    }
}
