//! The experiment as a plan of tasks: [`plan`] lists every training of [`super::run`] in the
//! order the serial run performs them, with its seed and the task whose model it starts from;
//! [`execute`] performs one task (inputs → records, nothing shared); [`assemble`] joins the
//! records of all tasks, in plan order, into [`Results`].
//!
//! The serial CLI runs exactly these, one after another; a cluster scheduler (the Python
//! `sgplvm.ray`) runs them as tasks and gets bit-identical records (all but the measured
//! seconds) because the same code trains the same model from the same inputs. Tasks, their
//! records and the data travel as JSON ([`Task`], [`TaskResult`], [`ExperimentData::to_json`]),
//! models as their own bytes ([`SharedGplvm::to_bytes`]).

use std::time::Instant;

use serde::{Deserialize, Serialize};
use sgplvm_core::{BackConstraint, GpRegression, Mat, MatRef, SharedGplvm, Validation};

use super::all_frames;
use super::less_data::{rows_of, subset};
use super::{
    fit, mean_squared_error, model_config, stages, stop_reason, validation, AllFrames,
    AllFramesRecord, DirectRecord, ExperimentConfig, ExperimentData, ExperimentError,
    LessDataRecord, ModelKind, Recorder, Results, RunRecord, SplitData,
};

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
    },
    /// Human + all robots, seed `config.seed + run`.
    Multi {
        /// Back constraint.
        back_constraint: BackConstraint,
        /// Run (seed) index.
        run: usize,
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
}

/// Every task of the experiment on `data`, in the order the serial run performs them.
pub fn plan(config: &ExperimentConfig, data: &ExperimentData) -> Vec<Task> {
    let robots: Vec<&String> = data.robots.iter().map(|(n, _)| n).collect();
    let frames = data.human.train.nrows();
    let n = robots.len();
    let stage_names: Vec<String> = stages(config, n).into_iter().map(|s| s.name).collect();
    let stage_of = |name: &str| stage_names.iter().position(|s| s == name).unwrap_or(0);
    let mut tasks: Vec<Task> = Vec::new();
    let mut push = |stage: usize, context: String, spec, source, keep_model| {
        let id = tasks.len();
        tasks.push(Task {
            id,
            stage,
            context,
            spec,
            source,
            keep_model,
        });
        id
    };
    let direct = stage_of("direct GP regression H → R");
    for (r, robot) in robots.iter().enumerate() {
        push(
            direct,
            format!("direct GP regression H → {robot}"),
            TaskSpec::Direct { robot: r },
            None,
            false,
        );
    }
    // Input-back-constrained baselines by (run, robot): the less-data transfers' sources.
    let mut input_sources = vec![vec![0; n]; config.runs];
    for bc in BackConstraint::ALL {
        let is_source = bc != BackConstraint::Output; // Fig. 6 compares fully trained models only.
        let stage = stage_of(&format!("baselines, {bc} BC"));
        let mut sources = vec![vec![0; n]; config.runs];
        for (run, ids) in sources.iter_mut().enumerate() {
            for (r, robot) in robots.iter().enumerate() {
                ids[r] = push(
                    stage,
                    format!("baseline {robot}, {bc} back constraints, run {run}"),
                    TaskSpec::Baseline {
                        back_constraint: bc,
                        run,
                        robot: r,
                    },
                    None,
                    is_source,
                );
            }
        }
        if !is_source {
            continue;
        }
        let stage = stage_of(&format!("transfers, {bc} BC"));
        for (run, ids) in sources.iter().enumerate() {
            for (s, source_name) in robots.iter().enumerate() {
                for (t, target) in robots.iter().enumerate() {
                    if t == s {
                        continue;
                    }
                    for k in 0..config.transfers_per_run {
                        push(
                            stage,
                            format!(
                                "transfer {source_name} → {target}, {bc} back constraints, run {run}.{k}"
                            ),
                            TaskSpec::Transfer {
                                back_constraint: bc,
                                source_run: run,
                                source: s,
                                target: t,
                                run: run * config.transfers_per_run + k,
                            },
                            Some(ids[s]),
                            false,
                        );
                    }
                }
            }
        }
        let stage = stage_of(&format!("multi-robot, {bc} BC"));
        for run in 0..config.runs {
            push(
                stage,
                format!("multi-robot, {bc} back constraints, run {run}"),
                TaskSpec::Multi {
                    back_constraint: bc,
                    run,
                },
                None,
                false,
            );
        }
        if bc == BackConstraint::Input {
            input_sources = sources;
        }
    }
    if !config.fractions.is_empty() {
        let stage = stage_of("less data, input BC");
        for (f, &fraction) in config.fractions.iter().enumerate() {
            for (run, ids) in input_sources.iter().enumerate() {
                for (t, target) in robots.iter().enumerate() {
                    let context = format!(
                        "less data: {target} on {} of {frames} frames, run {run}",
                        subset(frames, fraction).len()
                    );
                    push(
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
                        push(
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
    if let Some(m) = config.inducing {
        let all = data.all_frames.as_ref().map_or(0, |a| a.human.nrows());
        for bc in all_frames::BACK_CONSTRAINTS {
            for full_rate in [false, true] {
                let stage = stage_of(&all_frames::stage_name(config, bc, full_rate));
                let count = if full_rate { all } else { frames };
                for run in 0..config.runs {
                    for (r, robot) in robots.iter().enumerate() {
                        push(
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
    tasks
}

/// Performs one task of [`plan`] on `data` with `config`; `source` is the model of the task's
/// [`Task::source`] (required when it has one). Returns its records and, when
/// [`Task::keep_model`], its model.
pub fn execute(
    task: &Task,
    data: &ExperimentData,
    config: &ExperimentConfig,
    source: Option<&SharedGplvm>,
) -> Result<(TaskResult, Option<SharedGplvm>), ExperimentError> {
    let fail = |source| ExperimentError::Model {
        context: task.context.clone(),
        source,
    };
    let robot = |r: usize| {
        data.robots.get(r).ok_or_else(|| ExperimentError::Task {
            context: task.context.clone(),
            problem: format!("robot {r} of {} robots", data.robots.len()),
        })
    };
    let need_source = || {
        source.ok_or_else(|| ExperimentError::Task {
            context: task.context.clone(),
            problem: "the model of its source task was not given".into(),
        })
    };
    let human_test = data.human.test.as_ref();
    let input = data.input_name.as_str();
    let mut result = TaskResult {
        task: task.id,
        ..TaskResult::default()
    };
    let mut model = None;
    match task.spec {
        TaskSpec::Direct { robot: r } => {
            let (name, split) = robot(r)?;
            let options = config.options(config.direct_max_iters);
            let started = Instant::now();
            let regression =
                GpRegression::fit(data.human.train.as_ref(), split.train.as_ref(), &options)
                    .map_err(fail)?;
            let seconds = started.elapsed().as_secs_f64();
            let predicted = regression.predict(human_test).map_err(fail)?;
            result.direct = Some(DirectRecord {
                robot: name.clone(),
                test_mse: mean_squared_error(predicted.as_ref(), split.test.as_ref()),
                seconds,
            });
        }
        TaskSpec::Baseline {
            back_constraint: bc,
            run,
            robot: r,
        } => {
            let (name, split) = robot(r)?;
            let options = config.options(config.max_iters);
            let spaces = [
                (input, data.human.train.as_ref()),
                (name.as_str(), split.train.as_ref()),
            ];
            let mut recorder =
                Recorder::new(human_test, vec![(name.as_str(), split.test.as_ref())]);
            let m = fit(
                config,
                data,
                bc,
                run,
                &spaces,
                &options,
                Some(&mut |it, m| recorder.record(it, m)),
            )
            .map_err(fail)?;
            result.runs = recorder
                .into_records(&m, ModelKind::Baseline, bc, run, None)
                .map_err(fail)?;
            model = Some(m);
        }
        TaskSpec::Transfer {
            back_constraint: bc,
            source_run,
            source: s,
            target: t,
            run,
        } => {
            let source = need_source()?;
            let (source_name, _) = robot(s)?;
            let (target, split) = robot(t)?;
            let options = config.options(config.transfer_max_iters);
            let seed = config.seed + run as u64;
            let train = split.train.as_ref();
            let mut recorder =
                Recorder::new(human_test, vec![(target.as_str(), split.test.as_ref())]);
            let cb: sgplvm_core::Callback<'_> = &mut |it, m| recorder.record(it, m);
            let m = match validation(config, data) {
                Some(v) => {
                    source.transfer_validated(target, train, Some(seed), &options, &v, Some(cb))
                }
                None => source.transfer_seeded(target, train, seed, &options, Some(cb)),
            }
            .map_err(fail)?;
            result.runs = recorder
                .into_records(
                    &m,
                    ModelKind::Transfer,
                    bc,
                    run,
                    Some((source_name.as_str(), source_run)),
                )
                .map_err(fail)?;
        }
        TaskSpec::Multi {
            back_constraint: bc,
            run,
        } => {
            let options = config.options(config.max_iters);
            let mut spaces = vec![(input, data.human.train.as_ref())];
            spaces.extend(
                data.robots
                    .iter()
                    .map(|(n, s)| (n.as_str(), s.train.as_ref())),
            );
            let tests = data
                .robots
                .iter()
                .map(|(n, s)| (n.as_str(), s.test.as_ref()))
                .collect();
            let mut recorder = Recorder::new(human_test, tests);
            let m = fit(
                config,
                data,
                bc,
                run,
                &spaces,
                &options,
                Some(&mut |it, m| recorder.record(it, m)),
            )
            .map_err(fail)?;
            result.runs = recorder
                .into_records(&m, ModelKind::Multi, bc, run, None)
                .map_err(fail)?;
        }
        TaskSpec::LessDataBaseline {
            fraction,
            run,
            target: t,
        } => {
            let (target, split) = robot(t)?;
            let less = LessData::new(task, data, config, fraction)?;
            let joints = rows_of(split.train.as_ref(), &less.rows);
            let spaces = [
                (input, less.human.as_ref()),
                (target.as_str(), joints.as_ref()),
            ];
            let model_config = model_config(config, BackConstraint::Input, run);
            let options = config.options(config.max_iters);
            let m = match &less.validation {
                Some(v) => {
                    SharedGplvm::fit_validated(&model_config, &spaces, input, &options, v, None)
                }
                None => SharedGplvm::fit(&model_config, &spaces, input, &options, None),
            }
            .map_err(fail)?;
            let predicted = m.predict(human_test, target, false).map_err(fail)?.mean;
            result.less_data = Some(less.record(target, split, run, None, predicted));
        }
        TaskSpec::LessDataTransfer {
            fraction,
            run,
            target: t,
            source: s,
        } => {
            let source = need_source()?;
            let (source_name, _) = robot(s)?;
            let (target, split) = robot(t)?;
            let less = LessData::new(task, data, config, fraction)?;
            let joints = rows_of(split.train.as_ref(), &less.rows);
            let options = config.options(config.transfer_max_iters);
            let seed = config.seed + run as u64;
            let partial = source
                .transfer_partial(
                    target,
                    &less.rows,
                    joints.as_ref(),
                    Some(seed),
                    &options,
                    less.validation.as_ref(),
                )
                .map_err(fail)?;
            let predicted = partial.predict(source, human_test).map_err(fail)?;
            result.less_data = Some(less.record(target, split, run, Some(source_name), predicted));
        }
        TaskSpec::AllFrames {
            back_constraint: bc,
            full_rate,
            run,
            robot: r,
        } => {
            let (name, split) = robot(r)?;
            result.all_frames = Some(all_frames_record(
                task,
                data,
                config,
                (bc, full_rate),
                run,
                r,
                name,
                split,
            )?);
        }
    }
    Ok((result, model.filter(|_| task.keep_model)))
}

/// Trains the sparse model of the all-frames study for robot `r` (`name`, test frames in
/// `split`) and records its test error.
#[allow(clippy::too_many_arguments)]
fn all_frames_record(
    task: &Task,
    data: &ExperimentData,
    config: &ExperimentConfig,
    (bc, full_rate): (BackConstraint, bool),
    run: usize,
    r: usize,
    name: &str,
    split: &SplitData,
) -> Result<AllFramesRecord, ExperimentError> {
    let missing = |problem: String| ExperimentError::Task {
        context: task.context.clone(),
        problem,
    };
    let fail = |source| ExperimentError::Model {
        context: task.context.clone(),
        source,
    };
    let inducing = config
        .inducing
        .ok_or_else(|| missing("the configuration sets no inducing inputs".into()))?;
    let (human, joints, held) = if full_rate {
        let all: &AllFrames = data.all_frames.as_ref().ok_or_else(|| {
            missing("the experiment data holds no full-rate training frames (all_frames)".into())
        })?;
        let joints = all.robots.get(r).ok_or_else(|| {
            missing(format!(
                "robot {r} of the {} robots of the full-rate frames",
                all.robots.len()
            ))
        })?;
        (all.human.as_ref(), joints.as_ref(), &all.validation)
    } else {
        let (_, split) = data
            .robots
            .get(r)
            .ok_or_else(|| missing(format!("robot {r} of {} robots", data.robots.len())))?;
        (
            data.human.train.as_ref(),
            split.train.as_ref(),
            &data.validation,
        )
    };
    let input = data.input_name.as_str();
    let spaces = [(input, human), (name, joints)];
    let model = model_config(config, bc, run).with_inducing(Some(inducing));
    let options = config.options(config.max_iters);
    let m = match config.patience {
        Some(p) => {
            let v = Validation::new(held.clone()).with_patience(p);
            SharedGplvm::fit_validated(&model, &spaces, input, &options, &v, None)
        }
        None => SharedGplvm::fit(&model, &spaces, input, &options, None),
    }
    .map_err(fail)?;
    let predicted = m
        .predict(data.human.test.as_ref(), name, false)
        .map_err(fail)?
        .mean;
    Ok(AllFramesRecord {
        robot: name.to_string(),
        back_constraint: bc.to_string(),
        run,
        full_rate,
        frames: human.nrows(),
        subsampled_frames: data.human.train.nrows(),
        inducing,
        iteration: super::shipped_iteration(&m),
        seconds: super::shipped_seconds(&m),
        test_mse: mean_squared_error(predicted.as_ref(), split.test.as_ref()),
        stop_reason: stop_reason(&m),
    })
}

/// The frames of one fraction of the less-data study.
struct LessData {
    fraction: f64,
    /// Training rows used.
    rows: Vec<usize>,
    /// The human's training frames among them.
    human: Mat<f64>,
    /// Budgets chosen on the held-out frames among them (positions in `rows`).
    validation: Option<Validation>,
}

impl LessData {
    fn new(
        task: &Task,
        data: &ExperimentData,
        config: &ExperimentConfig,
        fraction: usize,
    ) -> Result<Self, ExperimentError> {
        let fraction = *config
            .fractions
            .get(fraction)
            .ok_or_else(|| ExperimentError::Task {
                context: task.context.clone(),
                problem: format!("fraction {fraction} of {}", config.fractions.len()),
            })?;
        let rows = subset(data.human.train.nrows(), fraction);
        let held: Vec<usize> = (0..rows.len())
            .filter(|&i| data.validation.binary_search(&rows[i]).is_ok())
            .collect();
        let validation = config
            .patience
            .filter(|_| !held.is_empty())
            .map(|p| Validation::new(held).with_patience(p));
        let human = rows_of(data.human.train.as_ref(), &rows);
        Ok(LessData {
            fraction,
            rows,
            human,
            validation,
        })
    }

    fn record(
        &self,
        target: &str,
        split: &SplitData,
        run: usize,
        source_robot: Option<&String>,
        predicted: Mat<f64>,
    ) -> LessDataRecord {
        LessDataRecord {
            robot: target.to_string(),
            fraction: self.fraction,
            frames: self.rows.len(),
            model: if source_robot.is_some() {
                ModelKind::Transfer
            } else {
                ModelKind::Baseline
            },
            run,
            source_robot: source_robot.cloned(),
            test_mse: mean_squared_error(predicted.as_ref(), split.test.as_ref()),
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
    };
    for r in results {
        out.runs.extend(r.runs);
        out.direct_regression.extend(r.direct);
        out.less_data.extend(r.less_data);
        out.all_frames.extend(r.all_frames);
    }
    Ok(out)
}

/// A matrix as it travels in JSON (row-major values).
#[derive(Serialize, Deserialize)]
struct MatrixJson {
    rows: usize,
    cols: usize,
    values: Vec<f64>,
}

impl MatrixJson {
    fn from(m: MatRef<'_, f64>) -> Self {
        MatrixJson {
            rows: m.nrows(),
            cols: m.ncols(),
            values: (0..m.nrows())
                .flat_map(|i| (0..m.ncols()).map(move |j| m[(i, j)]))
                .collect(),
        }
    }

    fn into_mat(self, what: &str) -> Result<Mat<f64>, String> {
        if self.rows.checked_mul(self.cols) != Some(self.values.len()) {
            return Err(format!(
                "{what}: {} values; expected rows × cols = {} × {}",
                self.values.len(),
                self.rows,
                self.cols
            ));
        }
        let cols = self.cols;
        Ok(Mat::from_fn(self.rows, cols, |i, j| {
            self.values[i * cols + j]
        }))
    }
}

#[derive(Serialize, Deserialize)]
struct SplitJson {
    train: MatrixJson,
    test: MatrixJson,
}

#[derive(Serialize, Deserialize)]
struct DataJson {
    input_name: String,
    human: SplitJson,
    robots: Vec<(String, SplitJson)>,
    validation: Vec<usize>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    all_frames: Option<AllFramesJson>,
}

/// [`AllFrames`] as it travels in JSON.
#[derive(Serialize, Deserialize)]
struct AllFramesJson {
    human: MatrixJson,
    robots: Vec<MatrixJson>,
    validation: Vec<usize>,
}

impl AllFramesJson {
    fn from(a: &AllFrames) -> Self {
        AllFramesJson {
            human: MatrixJson::from(a.human.as_ref()),
            robots: a
                .robots
                .iter()
                .map(|m| MatrixJson::from(m.as_ref()))
                .collect(),
            validation: a.validation.clone(),
        }
    }

    fn into_all_frames(self) -> Result<AllFrames, String> {
        Ok(AllFrames {
            human: self.human.into_mat("all_frames.human")?,
            robots: self
                .robots
                .into_iter()
                .enumerate()
                .map(|(k, m)| m.into_mat(&format!("all_frames.robots[{k}]")))
                .collect::<Result<_, String>>()?,
            validation: self.validation,
        })
    }
}

impl SplitJson {
    fn from(s: &SplitData) -> Self {
        SplitJson {
            train: MatrixJson::from(s.train.as_ref()),
            test: MatrixJson::from(s.test.as_ref()),
        }
    }

    fn into_split(self, what: &str) -> Result<SplitData, String> {
        Ok(SplitData {
            train: self.train.into_mat(&format!("{what}.train"))?,
            test: self.test.into_mat(&format!("{what}.test"))?,
        })
    }
}

impl ExperimentData {
    /// The data as JSON (exact: floats round-trip), to send to other processes.
    pub fn to_json(&self) -> Vec<u8> {
        let data = DataJson {
            input_name: self.input_name.clone(),
            human: SplitJson::from(&self.human),
            robots: self
                .robots
                .iter()
                .map(|(n, s)| (n.clone(), SplitJson::from(s)))
                .collect(),
            validation: self.validation.clone(),
            all_frames: self.all_frames.as_ref().map(AllFramesJson::from),
        };
        // Finite matrices and plain fields: serialising cannot fail.
        serde_json::to_vec(&data).unwrap_or_default()
    }

    /// The data back from [`ExperimentData::to_json`].
    pub fn from_json(bytes: &[u8]) -> Result<Self, ExperimentError> {
        let bad = |problem: String| ExperimentError::Task {
            context: "experiment data".into(),
            problem,
        };
        let data: DataJson = serde_json::from_slice(bytes).map_err(|e| bad(e.to_string()))?;
        let robots = data
            .robots
            .into_iter()
            .map(|(n, s)| {
                let split = s.into_split(&format!("robots.{n}"))?;
                Ok((n, split))
            })
            .collect::<Result<Vec<_>, String>>()
            .map_err(bad)?;
        let all_frames = data
            .all_frames
            .map(AllFramesJson::into_all_frames)
            .transpose()
            .map_err(bad)?;
        Ok(ExperimentData {
            input_name: data.input_name,
            human: data.human.into_split("human").map_err(bad)?,
            robots,
            validation: data.validation,
            all_frames,
        })
    }
}

#[cfg(test)]
mod tests {
    //! The pieces against the serial run: tasks executed out of order (sources first), their
    //! records assembled, equal the serial results but for the measured seconds.

    use super::*;
    use crate::experiment::tests::toy;

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
