//! The experiment as a plan of tasks: [`plan`] lists every training of [`super::run`] in the
//! order the serial run performs them, with its seed and the task whose model it starts from;
//! [`execute`] performs one task (inputs → records, nothing shared); [`assemble`] joins the
//! records of all tasks, in plan order, into [`Results`].
//!
//! The serial CLI runs exactly these, one after another; a cluster scheduler (the Python
//! `sgplvm.ray`) runs them as tasks and gets bit-identical records (all but the measured
//! seconds) because the same code trains the same model from the same inputs. Tasks, their
//! records and the data travel as JSON ([`Task`], [`TaskResult`], [`ExperimentData::to_json`]),
//! models as their own bytes ([`SharedGplvm::to_bytes`](sgplvm_core::SharedGplvm::to_bytes)).
//!
//! This file writes the plan and assembles the records; performing a task is in `execution`,
//! the data's JSON form in `json`.

use serde::{Deserialize, Serialize};
use sgplvm_core::BackConstraint;

use super::less_data::subset;
use super::{all_frames, bayesian, parts};
use super::{
    stages, AllFramesRecord, DirectRecord, ExperimentConfig, ExperimentData, ExperimentError,
    LessDataRecord, PartsRecord, Results, RunRecord,
};

mod execution;
mod json;

pub use execution::execute;

/// What one task trains. Robots are indices into [`ExperimentData::robots`], fractions into
/// [`ExperimentConfig::fractions`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum TaskSpec {
    /// The direct GP regression human → `robot` (the yardstick).
    Direct {
        /// The robot.
        robot: usize,
    },
    /// Human + `robot`, trained fully with seed `config.seed + run`.
    Baseline {
        /// Back constraint.
        back_constraint: BackConstraint,
        /// Run (seed) index.
        run: usize,
        /// The robot.
        robot: usize,
        /// A model of the Bayesian study ([`ExperimentConfig::bayesian`]).
        #[serde(default, skip_serializing_if = "std::ops::Not::not")]
        bayesian: bool,
    },
    /// From the baseline of `source` (run `source_run`) to `target`, seed `config.seed + run`.
    Transfer {
        /// Back constraint (of the source model).
        back_constraint: BackConstraint,
        /// Run of the source model.
        source_run: usize,
        /// Source robot.
        source: usize,
        /// Target robot.
        target: usize,
        /// Transfer index: source run × transfers per run + k.
        run: usize,
        /// A model of the Bayesian study ([`ExperimentConfig::bayesian`]).
        #[serde(default, skip_serializing_if = "std::ops::Not::not")]
        bayesian: bool,
    },
    /// Human + all robots, seed `config.seed + run`.
    Multi {
        /// Back constraint.
        back_constraint: BackConstraint,
        /// Run (seed) index.
        run: usize,
        /// A model of the Bayesian study ([`ExperimentConfig::bayesian`]).
        #[serde(default, skip_serializing_if = "std::ops::Not::not")]
        bayesian: bool,
    },
    /// Less data: `target` trained on a fraction of the frames alone (input back constraints).
    LessDataBaseline {
        /// Index into the fractions.
        fraction: usize,
        /// Run (seed) index.
        run: usize,
        /// The robot.
        target: usize,
    },
    /// Less data: `target`'s mapping learned from a fraction of the frames, from `source`'s
    /// input-back-constrained baseline of run `run` (trained on all frames).
    LessDataTransfer {
        /// Index into the fractions.
        fraction: usize,
        /// Run (seed) index.
        run: usize,
        /// The robot with less data.
        target: usize,
        /// The source robot.
        source: usize,
    },
    /// All frames: human + `robot` trained fully by the sparse model on every training frame
    /// ([`ExperimentData::all_frames`]) or, as the control, on the subsampled training frames;
    /// seed `config.seed + run`.
    AllFrames {
        /// Back constraint (the study trains `input` only).
        back_constraint: BackConstraint,
        /// `true`: every training frame; `false`: the subsampled ones (the control that
        /// separates the effect of the data from that of the approximation).
        full_rate: bool,
        /// Run (seed) index.
        run: usize,
        /// The robot.
        robot: usize,
    },
    /// A latent space per arm against the single latent space (issue 49): both trained on
    /// `robot` with seed `config.seed + run`, transferred to every other robot, evaluated on
    /// the test frames and the recombined ones (the experiment's `parts` module).
    Parts {
        /// Run (seed) index.
        run: usize,
        /// The robot trained on.
        robot: usize,
    },
    /// The GP regressions of the same study: on all human joints and one per arm, for `robot`.
    PartsDirect {
        /// The robot.
        robot: usize,
    },
}

/// One training of the experiment.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Task {
    /// Position in the plan (and in the serial run).
    pub id: usize,
    /// Index of its group in [`stages`].
    pub stage: usize,
    /// What it is, for progress lines and errors.
    pub context: String,
    /// What it trains.
    pub spec: TaskSpec,
    /// The task whose model it starts from (always earlier in the plan).
    pub source: Option<usize>,
    /// Whether later tasks start from its model (so it must be handed back).
    pub keep_model: bool,
}

/// The records one task produced.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct TaskResult {
    /// The task's id.
    pub task: usize,
    /// Training runs (one per robot recorded).
    #[serde(default)]
    pub runs: Vec<RunRecord>,
    /// A direct regression.
    #[serde(default)]
    pub direct: Option<DirectRecord>,
    /// A model of the less-data study.
    #[serde(default)]
    pub less_data: Option<LessDataRecord>,
    /// A model of the all-frames study.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub all_frames: Option<AllFramesRecord>,
    /// The models of the study of a latent space per arm.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub parts: Vec<PartsRecord>,
}

/// Every task of the experiment on `data`, in the order the serial run performs them.
pub fn plan(config: &ExperimentConfig, data: &ExperimentData) -> Vec<Task> {
    let mut planner = Planner::new(config, data);
    planner.direct();
    // Input-back-constrained baselines by (run, robot): the less-data transfers' sources.
    let mut input_sources = vec![vec![0; planner.robots.len()]; config.runs];
    for bc in BackConstraint::ALL {
        let is_source = bc != BackConstraint::Output; // Fig. 6 compares fully trained models only.
        let sources = planner.baselines(bc, is_source);
        if !is_source {
            continue;
        }
        planner.transfers(bc, &sources);
        planner.multi(bc);
        if bc == BackConstraint::Input {
            input_sources = sources;
        }
    }
    if !config.fractions.is_empty() {
        planner.less_data(&input_sources);
    }
    if let Some(m) = config.inducing {
        planner.all_frames(m, data);
    }
    if config.parts {
        planner.parts();
    }
    if config.bayesian.is_some() {
        planner.bayesian = true;
        for bc in bayesian::BACK_CONSTRAINTS {
            let sources = planner.baselines(bc, true);
            planner.transfers(bc, &sources);
            planner.multi(bc);
        }
    }
    planner.tasks
}

/// The plan being written: the tasks so far, and what they are named and grouped by.
struct Planner<'a> {
    config: &'a ExperimentConfig,
    /// The robots' names.
    robots: Vec<&'a String>,
    /// Training frames (subsampled).
    frames: usize,
    /// The names of the [`stages`], in order.
    stage_names: Vec<String>,
    tasks: Vec<Task>,
    /// Whether the baselines, transfers and multi-robot models being planned are the Bayesian
    /// study's.
    bayesian: bool,
}

impl<'a> Planner<'a> {
    fn new(config: &'a ExperimentConfig, data: &'a ExperimentData) -> Self {
        let robots: Vec<&String> = data.robots.iter().map(|(n, _)| n).collect();
        let stage_names = stages(config, robots.len())
            .into_iter()
            .map(|s| s.name)
            .collect();
        Planner {
            config,
            robots,
            frames: data.human.train.nrows(),
            stage_names,
            tasks: Vec::new(),
            bayesian: false,
        }
    }

    /// The index of the stage called `name` (of the Bayesian study's stages when planning
    /// them).
    fn stage_of(&self, name: &str) -> usize {
        let name = match self.bayesian {
            true => bayesian::stage_name(name),
            false => name.to_string(),
        };
        self.stage_names
            .iter()
            .position(|s| *s == name)
            .unwrap_or(0)
    }

    /// "Bayesian " before a task's context when planning the Bayesian study.
    fn model_name(&self) -> &'static str {
        if self.bayesian {
            "Bayesian "
        } else {
            ""
        }
    }

    /// Appends a task; returns its id.
    fn push(
        &mut self,
        stage: usize,
        context: String,
        spec: TaskSpec,
        source: Option<usize>,
        keep_model: bool,
    ) -> usize {
        let id = self.tasks.len();
        self.tasks.push(Task {
            id,
            stage,
            context,
            spec,
            source,
            keep_model,
        });
        id
    }

    /// The direct GP regression of every robot.
    fn direct(&mut self) {
        let direct = self.stage_of("direct GP regression H → R");
        for (r, robot) in self.robots.clone().into_iter().enumerate() {
            self.push(
                direct,
                format!("direct GP regression H → {robot}"),
                TaskSpec::Direct { robot: r },
                None,
                false,
            );
        }
    }

    /// The fully trained models with back constraint `bc`, by run and robot; their ids by
    /// (run, robot). `is_source`: later tasks start from them.
    fn baselines(&mut self, bc: BackConstraint, is_source: bool) -> Vec<Vec<usize>> {
        let stage = self.stage_of(&format!("baselines, {bc} BC"));
        let robots = self.robots.clone();
        let mut sources = vec![vec![0; robots.len()]; self.config.runs];
        for (run, ids) in sources.iter_mut().enumerate() {
            for (r, robot) in robots.iter().enumerate() {
                ids[r] = self.push(
                    stage,
                    format!(
                        "{}baseline {robot}, {bc} back constraints, run {run}",
                        self.model_name()
                    ),
                    TaskSpec::Baseline {
                        back_constraint: bc,
                        run,
                        robot: r,
                        bayesian: self.bayesian,
                    },
                    None,
                    is_source,
                );
            }
        }
        sources
    }

    /// The transfers from each baseline of `sources` (by run and robot) to every other robot.
    fn transfers(&mut self, bc: BackConstraint, sources: &[Vec<usize>]) {
        let stage = self.stage_of(&format!("transfers, {bc} BC"));
        let robots = self.robots.clone();
        let transfers_per_run = self.config.transfers_per_run;
        for (run, ids) in sources.iter().enumerate() {
            for (s, source_name) in robots.iter().enumerate() {
                for (t, target) in robots.iter().enumerate() {
                    if t == s {
                        continue;
                    }
                    for k in 0..transfers_per_run {
                        self.push(
                            stage,
                            format!(
                                "{}transfer {source_name} → {target}, {bc} back constraints, run {run}.{k}",
                                self.model_name()
                            ),
                            TaskSpec::Transfer {
                                back_constraint: bc,
                                source_run: run,
                                source: s,
                                target: t,
                                run: run * transfers_per_run + k,
                                bayesian: self.bayesian,
                            },
                            Some(ids[s]),
                            false,
                        );
                    }
                }
            }
        }
    }

    /// The multi-robot models with back constraint `bc`, one per run.
    fn multi(&mut self, bc: BackConstraint) {
        let stage = self.stage_of(&format!("multi-robot, {bc} BC"));
        for run in 0..self.config.runs {
            self.push(
                stage,
                format!(
                    "{}multi-robot, {bc} back constraints, run {run}",
                    self.model_name()
                ),
                TaskSpec::Multi {
                    back_constraint: bc,
                    run,
                    bayesian: self.bayesian,
                },
                None,
                false,
            );
        }
    }

    /// The less-data study: per fraction, run and robot, the robot trained on the fraction alone
    /// and transferred to from each other robot's input-back-constrained baseline
    /// (`input_sources`, by run and robot).
    fn less_data(&mut self, input_sources: &[Vec<usize>]) {
        let stage = self.stage_of("less data, input BC");
        let robots = self.robots.clone();
        let frames = self.frames;
        for (f, &fraction) in self.config.fractions.iter().enumerate() {
            for (run, ids) in input_sources.iter().enumerate() {
                for (t, target) in robots.iter().enumerate() {
                    let context = format!(
                        "less data: {target} on {} of {frames} frames, run {run}",
                        subset(frames, fraction).len()
                    );
                    self.push(
                        stage,
                        context.clone(),
                        TaskSpec::LessDataBaseline {
                            fraction: f,
                            run,
                            target: t,
                        },
                        None,
                        false,
                    );
                    for (s, source_name) in robots.iter().enumerate() {
                        if s == t {
                            continue;
                        }
                        self.push(
                            stage,
                            format!("{context}, from {source_name}"),
                            TaskSpec::LessDataTransfer {
                                fraction: f,
                                run,
                                target: t,
                                source: s,
                            },
                            Some(ids[s]),
                            false,
                        );
                    }
                }
            }
        }
    }

    /// The study of a latent space per arm: the regressions of every robot, then per run and
    /// robot the two models trained and transferred.
    fn parts(&mut self) {
        let robots = self.robots.clone();
        let direct = self.stage_of(parts::DIRECT_STAGE);
        for (r, robot) in robots.iter().enumerate() {
            self.push(
                direct,
                format!("GP regressions H → {robot}, whole and per arm"),
                TaskSpec::PartsDirect { robot: r },
                None,
                false,
            );
        }
        let stage = self.stage_of(parts::STAGE);
        for run in 0..self.config.runs {
            for (r, robot) in robots.iter().enumerate() {
                self.push(
                    stage,
                    format!("one latent space and one per arm: {robot} and transfers, run {run}"),
                    TaskSpec::Parts { run, robot: r },
                    None,
                    false,
                );
            }
        }
    }

    /// The all-frames study with `m` inducing inputs: per back constraint, on the subsample and
    /// on every frame, run and robot.
    fn all_frames(&mut self, m: usize, data: &ExperimentData) {
        let all = data.all_frames.as_ref().map_or(0, |a| a.human.nrows());
        let robots = self.robots.clone();
        for bc in all_frames::BACK_CONSTRAINTS {
            for full_rate in [false, true] {
                let stage = self.stage_of(&all_frames::stage_name(self.config, bc, full_rate));
                let count = if full_rate { all } else { self.frames };
                for run in 0..self.config.runs {
                    for (r, robot) in robots.iter().enumerate() {
                        self.push(
                            stage,
                            format!(
                                "sparse (M = {m}): {robot} on {count} frames, {bc} back constraints, run {run}"
                            ),
                            TaskSpec::AllFrames {
                                back_constraint: bc,
                                full_rate,
                                run,
                                robot: r,
                            },
                            None,
                            false,
                        );
                    }
                }
            }
        }
    }
}

/// The results of an experiment from the records of every task of its [`plan`] (any order:
/// they are put in plan order). Fails when a task's records are missing or doubled.
pub fn assemble(
    data: &ExperimentData,
    config: &ExperimentConfig,
    mut results: Vec<TaskResult>,
) -> Result<Results, ExperimentError> {
    let expected = plan(config, data).len();
    results.sort_by_key(|r| r.task);
    let ids: Vec<usize> = results.iter().map(|r| r.task).collect();
    if ids != (0..expected).collect::<Vec<_>>() {
        return Err(ExperimentError::Task {
            context: "assembling the results".into(),
            problem: format!(
                "got the records of {} tasks (ids {:?}…); expected each of the plan's {expected} tasks once",
                ids.len(),
                &ids[..ids.len().min(5)]
            ),
        });
    }
    let mut out = Results {
        robots: data.robots.iter().map(|(n, _)| n.clone()).collect(),
        config: config.clone(),
        runs: Vec::new(),
        direct_regression: Vec::new(),
        robot_joints: data.robots.iter().map(|(_, s)| s.train.ncols()).collect(),
        less_data: Vec::new(),
        all_frames: Vec::new(),
        parts: Vec::new(),
        retargeting: super::retargeting::study(data)?,
    };
    for r in results {
        out.runs.extend(r.runs);
        out.direct_regression.extend(r.direct);
        out.less_data.extend(r.less_data);
        out.all_frames.extend(r.all_frames);
        out.parts.extend(r.parts);
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    //! The pieces against the serial run: tasks executed out of order (sources first), their
    //! records assembled, equal the serial results but for the measured seconds.

    use super::*;
    use crate::experiment::tests::toy;
    use sgplvm_core::SharedGplvm;

    fn config() -> ExperimentConfig {
        ExperimentConfig {
            runs: 1,
            transfers_per_run: 1,
            max_iters: 4,
            transfer_max_iters: 4,
            latent_dim: 2,
            seed: 3,
            direct_max_iters: 10,
            patience: Some(2),
            fractions: vec![0.5],
            max_seconds: None,
            inducing: Some(6),
            bayesian: None,
            parts: true,
        }
    }

    /// The results as JSON with every `seconds` field removed (wall-clock, never reproducible).
    fn without_seconds(results: &Results) -> serde_json::Value {
        fn strip(v: &mut serde_json::Value) {
            match v {
                serde_json::Value::Object(map) => {
                    map.remove("seconds");
                    map.values_mut().for_each(strip);
                }
                serde_json::Value::Array(items) => items.iter_mut().for_each(strip),
                _ => {}
            }
        }
        let mut v = serde_json::to_value(results).unwrap();
        strip(&mut v);
        v
    }

    #[test]
    fn tasks_run_in_any_order_from_json_assemble_to_the_serial_results() {
        let data = toy();
        let config = config();
        let serial = crate::experiment::run(&data, &config, &mut |_| {}).unwrap();
        // The data and every task cross as JSON, as to another process.
        let data = ExperimentData::from_json(&data.to_json()).unwrap();
        let tasks: Vec<Task> =
            serde_json::from_str(&serde_json::to_string(&plan(&config, &data)).unwrap()).unwrap();
        assert_eq!(tasks.len(), crate::experiment::training_count(&config, 2));
        // Sources first, then the rest from the last task back.
        let mut models = std::collections::BTreeMap::new();
        let mut records = Vec::new();
        let (sources, rest): (Vec<&Task>, Vec<&Task>) = tasks.iter().partition(|t| t.keep_model);
        for task in sources.into_iter().chain(rest.into_iter().rev()) {
            assert!(task
                .source
                .is_none_or(|s| s < task.id && tasks[s].keep_model));
            let source = task.source.map(|s| &models[&s]);
            let (record, model) = execute(task, &data, &config, source).unwrap();
            assert_eq!(model.is_some(), task.keep_model, "{}", task.context);
            if let Some(m) = model {
                models.insert(task.id, SharedGplvm::from_bytes(&m.to_bytes()).unwrap());
            }
            let json = serde_json::to_string(&record).unwrap();
            records.push(serde_json::from_str::<TaskResult>(&json).unwrap());
        }
        let assembled = assemble(&data, &config, records.clone()).unwrap();
        assert_eq!(without_seconds(&assembled), without_seconds(&serial));
        // A missing or doubled task is an error, never a partial report.
        let mut missing = records.clone();
        missing.pop();
        assert!(assemble(&data, &config, missing).is_err());
        let mut doubled = records;
        doubled.push(doubled[0].clone());
        assert!(assemble(&data, &config, doubled).is_err());
    }

    #[test]
    fn a_transfer_without_its_source_and_bad_data_are_errors() {
        let data = toy();
        let config = config();
        let tasks = plan(&config, &data);
        let transfer = tasks.iter().find(|t| t.source.is_some()).unwrap();
        let e = execute(transfer, &data, &config, None).unwrap_err();
        assert!(e.to_string().contains("source"), "{e}");
        // The all-frames study without full-rate frames is an error naming them.
        let all = tasks
            .iter()
            .find(|t| {
                matches!(
                    t.spec,
                    TaskSpec::AllFrames {
                        full_rate: true,
                        ..
                    }
                )
            })
            .unwrap();
        let without = ExperimentData {
            all_frames: None,
            ..data.clone()
        };
        let e = execute(all, &without, &config, None).unwrap_err();
        assert!(e.to_string().contains("full-rate training frames"), "{e}");
        let e = ExperimentData::from_json(br#"{"input_name": "h"}"#).unwrap_err();
        assert!(e.to_string().starts_with("experiment data:"), "{e}");
        let mut json: serde_json::Value = serde_json::from_slice(&data.to_json()).unwrap();
        json["human"]["train"]["rows"] = 1000.into();
        let e = ExperimentData::from_json(json.to_string().as_bytes()).unwrap_err();
        assert!(e.to_string().contains("human.train"), "{e}");
    }
}
