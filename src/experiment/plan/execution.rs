//! How one task of the plan is performed: [`execute`] trains what its [`TaskSpec`] says on the
//! experiment's data, from its source task's model where it has one, and records the test
//! errors. Nothing is shared between tasks but that model, so they run in any order or process.

use std::time::Instant;

use sgplvm_core::{BackConstraint, GpRegression, Mat, SharedGplvm, Validation};

use super::{Task, TaskResult, TaskSpec};
use crate::experiment::less_data::{rows_of, subset};
use crate::experiment::{bayesian, parts, retargeting};
use crate::experiment::{
    fit, mean_squared_error, model_config, shipped_iteration, shipped_seconds, stop_reason,
    validation, AllFrames, AllFramesRecord, DirectRecord, ExperimentConfig, ExperimentData,
    ExperimentError, LessDataRecord, ModelKind, Recorder, RunRecord, SplitData,
};

/// Performs one task of [`plan`](super::plan) on `data` with `config`; `source` is the model of
/// the task's [`Task::source`] (required when it has one). Returns its records and, when
/// [`Task::keep_model`], its model.
pub fn execute(
    task: &Task,
    data: &ExperimentData,
    config: &ExperimentConfig,
    source: Option<&SharedGplvm>,
) -> Result<(TaskResult, Option<SharedGplvm>), ExperimentError> {
    let job = Job {
        task,
        data,
        config,
        source,
    };
    let mut result = TaskResult {
        task: task.id,
        ..TaskResult::default()
    };
    let mut model = None;
    match task.spec {
        TaskSpec::Direct { robot: r } => result.direct = Some(job.direct(r)?),
        TaskSpec::Baseline {
            back_constraint: bc,
            run,
            robot: r,
            bayesian,
        } => {
            let (runs, m) = job.baseline(bc, run, r, bayesian)?;
            result.runs = runs;
            model = Some(m);
        }
        TaskSpec::Transfer {
            back_constraint: bc,
            source_run,
            source: s,
            target: t,
            run,
            bayesian,
        } => result.runs = job.transfer(bc, (s, source_run), t, run, bayesian)?,
        TaskSpec::Multi {
            back_constraint: bc,
            run,
            bayesian,
        } => result.runs = job.multi(bc, run, bayesian)?,
        TaskSpec::LessDataBaseline {
            fraction,
            run,
            target: t,
        } => result.less_data = Some(job.less_data_baseline(fraction, run, t)?),
        TaskSpec::LessDataTransfer {
            fraction,
            run,
            target: t,
            source: s,
        } => result.less_data = Some(job.less_data_transfer(fraction, run, t, s)?),
        TaskSpec::AllFrames {
            back_constraint: bc,
            full_rate,
            run,
            robot: r,
        } => {
            let (name, split) = job.robot(r)?;
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
        TaskSpec::Parts { run, robot: r } => {
            job.robot(r)?;
            result.parts = parts::run_task(data, config, (run, r), &task.context)?;
        }
        TaskSpec::PartsDirect { robot: r } => {
            job.robot(r)?;
            result.parts = parts::direct_task(data, config, r, &task.context)?;
        }
    }
    Ok((result, model.filter(|_| task.keep_model)))
}

/// One task being performed: its inputs, and the errors that name it.
struct Job<'a> {
    task: &'a Task,
    data: &'a ExperimentData,
    config: &'a ExperimentConfig,
    source: Option<&'a SharedGplvm>,
}

impl<'a> Job<'a> {
    /// A model error of this task.
    fn fail(&self, source: sgplvm_core::Error) -> ExperimentError {
        ExperimentError::Model {
            context: self.task.context.clone(),
            source,
        }
    }

    /// Robot `r` of the data: its name and frames.
    fn robot(&self, r: usize) -> Result<&'a (String, SplitData), ExperimentError> {
        self.data
            .robots
            .get(r)
            .ok_or_else(|| ExperimentError::Task {
                context: self.task.context.clone(),
                problem: format!("robot {r} of {} robots", self.data.robots.len()),
            })
    }

    /// The options of a training whose paper's budget is `max_iters`: the Bayesian study's
    /// budget instead for its models.
    fn options(&self, max_iters: usize, bayesian: bool) -> sgplvm_core::TrainOptions {
        let study = self.config.bayesian.filter(|_| bayesian);
        self.config
            .options(study.map_or(max_iters, |s| s.max_iters))
    }

    /// The records of a training that handed back `model`: the Bayesian study's marked as such,
    /// with `model`'s ARD weights.
    fn records(
        &self,
        recorder: Recorder<'_>,
        model: &SharedGplvm,
        (kind, bc, run): (ModelKind, BackConstraint, usize),
        source: Option<(&str, usize)>,
        bayesian: bool,
    ) -> Result<Vec<RunRecord>, ExperimentError> {
        let mut runs = recorder
            .into_records(model, kind, bc, run, source)
            .map_err(|e| self.fail(e))?;
        if bayesian {
            bayesian::mark(&mut runs, model).map_err(|e| self.fail(e))?;
        } else {
            for run in &mut runs {
                run.arms_from_person = retargeting::learned(self.data, &run.robot, model)?;
            }
        }
        Ok(runs)
    }

    /// The model of the task's source task.
    fn need_source(&self) -> Result<&'a SharedGplvm, ExperimentError> {
        self.source.ok_or_else(|| ExperimentError::Task {
            context: self.task.context.clone(),
            problem: "the model of its source task was not given".into(),
        })
    }

    /// The direct GP regression human → robot `r`.
    fn direct(&self, r: usize) -> Result<DirectRecord, ExperimentError> {
        let (data, config) = (self.data, self.config);
        let (name, split) = self.robot(r)?;
        let options = config.options(config.direct_max_iters);
        let started = Instant::now();
        let regression =
            GpRegression::fit(data.human.train.as_ref(), split.train.as_ref(), &options)
                .map_err(|e| self.fail(e))?;
        let seconds = started.elapsed().as_secs_f64();
        let predicted = regression
            .predict(data.human.test.as_ref())
            .map_err(|e| self.fail(e))?;
        let (train, test) = (&split.train, &split.test);
        Ok(DirectRecord {
            robot: name.clone(),
            test_mse: mean_squared_error(predicted.as_ref(), test.as_ref()),
            seconds,
            mean_pose_mse: Some(crate::pipeline::mean_pose_mse(
                train.as_ref(),
                test.as_ref(),
            )),
        })
    }

    /// Human + robot `r` trained fully: its records and its model.
    fn baseline(
        &self,
        bc: BackConstraint,
        run: usize,
        r: usize,
        bayesian: bool,
    ) -> Result<(Vec<RunRecord>, SharedGplvm), ExperimentError> {
        let (data, config) = (self.data, self.config);
        let (name, split) = self.robot(r)?;
        let options = self.options(config.max_iters, bayesian);
        let spaces = [
            (data.input_name.as_str(), data.human.train.as_ref()),
            (name.as_str(), split.train.as_ref()),
        ];
        let mut recorder = Recorder::new(
            data.human.test.as_ref(),
            vec![(name.as_str(), split.test.as_ref())],
        );
        let m = fit(
            config,
            data,
            (bc, run, bayesian),
            &spaces,
            &options,
            Some(&mut |it, m| recorder.record(it, m)),
        )
        .map_err(|e| self.fail(e))?;
        let runs = self.records(recorder, &m, (ModelKind::Baseline, bc, run), None, bayesian)?;
        Ok((runs, m))
    }

    /// From the source model (robot `s` of run `source_run`) to robot `t`: its records.
    fn transfer(
        &self,
        bc: BackConstraint,
        (s, source_run): (usize, usize),
        t: usize,
        run: usize,
        bayesian: bool,
    ) -> Result<Vec<RunRecord>, ExperimentError> {
        let (data, config) = (self.data, self.config);
        let source = self.need_source()?;
        let (source_name, _) = self.robot(s)?;
        let (target, split) = self.robot(t)?;
        let options = self.options(config.transfer_max_iters, bayesian);
        let seed = config.seed + run as u64;
        let train = split.train.as_ref();
        let mut recorder = Recorder::new(
            data.human.test.as_ref(),
            vec![(target.as_str(), split.test.as_ref())],
        );
        let cb: sgplvm_core::Callback<'_> = &mut |it, m| recorder.record(it, m);
        let m = match validation(config, data).filter(|_| !bayesian) {
            Some(v) => source.transfer_validated(target, train, Some(seed), &options, &v, Some(cb)),
            None => source.transfer_seeded(target, train, seed, &options, Some(cb)),
        }
        .map_err(|e| self.fail(e))?;
        let source = Some((source_name.as_str(), source_run));
        self.records(
            recorder,
            &m,
            (ModelKind::Transfer, bc, run),
            source,
            bayesian,
        )
    }

    /// Human + all robots trained jointly: its records.
    fn multi(
        &self,
        bc: BackConstraint,
        run: usize,
        bayesian: bool,
    ) -> Result<Vec<RunRecord>, ExperimentError> {
        let (data, config) = (self.data, self.config);
        let options = self.options(config.max_iters, bayesian);
        let mut spaces = vec![(data.input_name.as_str(), data.human.train.as_ref())];
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
        let mut recorder = Recorder::new(data.human.test.as_ref(), tests);
        let m = fit(
            config,
            data,
            (bc, run, bayesian),
            &spaces,
            &options,
            Some(&mut |it, m| recorder.record(it, m)),
        )
        .map_err(|e| self.fail(e))?;
        self.records(recorder, &m, (ModelKind::Multi, bc, run), None, bayesian)
    }

    /// Less data: robot `t` trained fully on fraction `fraction` of the frames alone.
    fn less_data_baseline(
        &self,
        fraction: usize,
        run: usize,
        t: usize,
    ) -> Result<LessDataRecord, ExperimentError> {
        let (data, config) = (self.data, self.config);
        let input = data.input_name.as_str();
        let (target, split) = self.robot(t)?;
        let less = LessData::new(self.task, data, config, fraction)?;
        let joints = rows_of(split.train.as_ref(), &less.rows);
        let spaces = [
            (input, less.human.as_ref()),
            (target.as_str(), joints.as_ref()),
        ];
        let model_config = model_config(config, BackConstraint::Input, run);
        let options = config.options(config.max_iters);
        let m = match &less.validation {
            Some(v) => SharedGplvm::fit_validated(&model_config, &spaces, input, &options, v, None),
            None => SharedGplvm::fit(&model_config, &spaces, input, &options, None),
        }
        .map_err(|e| self.fail(e))?;
        let predicted = m
            .predict(data.human.test.as_ref(), target, false)
            .map_err(|e| self.fail(e))?
            .mean;
        Ok(less.record(target, split, run, None, predicted))
    }

    /// Less data: robot `t`'s mapping learned from fraction `fraction` of the frames, from the
    /// source model of robot `s`.
    fn less_data_transfer(
        &self,
        fraction: usize,
        run: usize,
        t: usize,
        s: usize,
    ) -> Result<LessDataRecord, ExperimentError> {
        let (data, config) = (self.data, self.config);
        let source = self.need_source()?;
        let (source_name, _) = self.robot(s)?;
        let (target, split) = self.robot(t)?;
        let less = LessData::new(self.task, data, config, fraction)?;
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
            .map_err(|e| self.fail(e))?;
        let predicted = partial
            .predict(source, data.human.test.as_ref())
            .map_err(|e| self.fail(e))?;
        Ok(less.record(target, split, run, Some(source_name), predicted))
    }
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
        iteration: shipped_iteration(&m),
        seconds: shipped_seconds(&m),
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
