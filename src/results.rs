//! The records of an experiment, as `results.json` holds them: what was run
//! ([`ExperimentConfig`]) and what every training measured ([`Results`]: the runs of Figs. 4-6
//! and 10, the direct GP regressions, the less-data and all-frames studies).
//!
//! [`crate::experiment`] writes them; the figures ([`crate::figures`]) and the report
//! ([`crate::experiment::report()`]) read them. They depend on nothing of either, so the data
//! flows one way: files → pipeline → experiment → records → figures and report.

use serde::{Deserialize, Serialize};
use sgplvm_core::{TrainOptions, Validation};

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
    /// Iteration budget of the direct GP regressions H → R (the yardstick).
    #[serde(default = "default_direct_max_iters")]
    pub direct_max_iters: usize,
    /// `Some(p)`: every training chooses its iteration budget on the held-out training frames
    /// ([`ExperimentData::validation`](crate::pipeline::ExperimentData::validation)) with
    /// patience `p`, as `train` does by default; `None`: the paper's fixed budgets (`max_iters`,
    /// `transfer_max_iters`). Results written before validation existed read as `None`.
    #[serde(default)]
    pub patience: Option<usize>,
    /// Fractions of the training frames of the less-data study (Fig. 9); empty: not run (and
    /// in results written before it existed).
    #[serde(default)]
    pub fractions: Vec<f64>,
    /// Wall-clock budget of each training in seconds (every direct regression, full,
    /// multi-robot, transfer and less-data training; a validated one spends half of it choosing
    /// its budget): when it runs out the training keeps its best parameters so far. `None`: no
    /// limit (and in results written before it existed).
    #[serde(default)]
    pub max_seconds: Option<f64>,
    /// `Some(M)`: the all-frames study — per run and robot, the sparse model with M inducing
    /// inputs trained on every training frame
    /// ([`ExperimentData::all_frames`](crate::pipeline::ExperimentData::all_frames)) beside the
    /// subsampled exact baseline. `None`: not run (and in results written before it existed).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub inducing: Option<usize>,
    /// `Some`: the Bayesian study (issue 34) — the Bayesian shared GP-LVM's baselines,
    /// transfers and multi-robot models beside the paper's, trained to convergence without a
    /// chosen budget. `None`: not run (and in results written before it existed).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub bayesian: Option<BayesianStudy>,
    /// The study of a latent space per arm on recombined motions (issue 49;
    /// [`crate::experiment::PartsRecord`]): per run and robot, the single latent space and a
    /// latent space per arm, trained and transferred. `false`: not run (and in results written
    /// before it existed).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub parts: bool,
}

/// The share of a space's largest ARD weight above which a latent dimension counts as used by
/// that space (as `train --bayesian` prints).
pub const ARD_USED_SHARE: f64 = 0.05;

/// Which latent dimensions a space with ARD weights `weights` uses (weight above
/// [`ARD_USED_SHARE`] of the largest).
pub fn used_dimensions(weights: &[f64]) -> Vec<bool> {
    let largest = weights.iter().copied().fold(0.0, f64::max);
    weights
        .iter()
        .map(|w| *w > ARD_USED_SHARE * largest)
        .collect()
}

/// How the Bayesian study trains its models.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct BayesianStudy {
    /// Inducing inputs M of every space.
    pub inducing: usize,
    /// Iteration budget of every training (full, transfer and multi-robot): an upper bound,
    /// training to convergence, never chosen on held-out frames.
    pub max_iters: usize,
}

impl BayesianStudy {
    /// The study's settings unless told otherwise: M = 50 (as `train --bayesian`) and up to
    /// 1,000 iterations.
    pub const DEFAULT: BayesianStudy = BayesianStudy {
        inducing: 50,
        max_iters: 1000,
    };
}

/// The direct regression's budget in results written before it was recorded.
fn default_direct_max_iters() -> usize {
    1000
}

impl ExperimentConfig {
    /// The options of one training of at most `max_iters` iterations, within
    /// [`ExperimentConfig::max_seconds`].
    pub fn options(&self, max_iters: usize) -> TrainOptions {
        TrainOptions::default()
            .with_max_iters(max_iters)
            .with_max_seconds(self.max_seconds)
    }

    /// The paper's protocol: 10 runs, 10 transfers per source run.
    pub fn paper() -> Self {
        ExperimentConfig {
            runs: 10,
            transfers_per_run: 10,
            max_iters: 300,
            transfer_max_iters: 300,
            latent_dim: 5,
            seed: 0,
            direct_max_iters: default_direct_max_iters(),
            patience: Some(Validation::DEFAULT_PATIENCE),
            fractions: vec![0.1, 0.25, 0.5, 1.0],
            max_seconds: None,
            inducing: None,
            bayesian: None,
            parts: false,
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
            direct_max_iters: default_direct_max_iters(),
            patience: Some(Validation::DEFAULT_PATIENCE),
            fractions: vec![0.1, 0.25, 0.5, 1.0],
            max_seconds: None,
            inducing: None,
            bayesian: None,
            parts: false,
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
    /// For transfer runs, the run of the source model (whose seed its baselines share).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub source_run: Option<usize>,
    /// Iteration numbers at which the test error was measured.
    pub iterations: Vec<usize>,
    /// Training seconds spent up to each of those iterations (test evaluation excluded).
    pub seconds: Vec<f64>,
    /// Test mean squared error (rad², over all joints and frames) at each of those iterations.
    pub test_mse: Vec<f64>,
    /// The model the training handed back (absent in results written before it was recorded:
    /// see [`RunRecord::shipped`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub shipped: Option<Shipped>,
    /// Why the final training stopped ([`sgplvm_core::StopReason::name`]; `time_limit`: cut
    /// short by `--max-seconds`). Absent in results written before it was recorded.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stop_reason: Option<String>,
    /// A model of the Bayesian study ([`ExperimentConfig::bayesian`]); absent: the paper's
    /// model.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub bayesian: bool,
    /// The Bayesian model's ARD weights α²/ℓ² per latent dimension, per space of the shipped
    /// model (the human first); empty for the paper's model.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub ard_weights: Vec<(String, Vec<f64>)>,
    /// The shipped model's commands on the test frames against the person, on bone lines (the
    /// paper's model on a robot with a built-in body; absent otherwise and in results written
    /// before it was recorded).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub arms_from_person: Option<crate::arms::ArmSummary>,
}

/// The model a training hands back, which the report judges: when training reached its
/// parameters and its test error.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Shipped {
    /// Iteration at which training reached the shipped parameters.
    pub iteration: usize,
    /// Training seconds until then (test evaluation excluded).
    pub seconds: f64,
    /// Test mean squared error of the shipped model (rad²).
    pub test_mse: f64,
}

impl RunRecord {
    /// The shipped model; for records without one, the last recorded iteration (what training
    /// handed back before training could select an earlier one). NaN where nothing was recorded.
    pub fn shipped(&self) -> Shipped {
        self.shipped.unwrap_or_else(|| Shipped {
            iteration: self.iterations.last().copied().unwrap_or(0),
            seconds: self.seconds.last().copied().unwrap_or(f64::NAN),
            test_mse: self.test_mse.last().copied().unwrap_or(f64::NAN),
        })
    }
}

/// The direct GP regression H → R of one robot (deterministic: one fit).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct DirectRecord {
    /// The robot.
    pub robot: String,
    /// Test mean squared error (rad²).
    pub test_mse: f64,
    /// Seconds the fit took.
    pub seconds: f64,
    /// The test MSE of the mean training pose on every frame (rad²): a model that learned
    /// nothing (absent from results written before 2026-12-07).
    #[serde(default)]
    pub mean_pose_mse: Option<f64>,
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
    /// The direct GP regression of every robot (empty in results written before it was).
    #[serde(default)]
    pub direct_regression: Vec<DirectRecord>,
    /// Joints of each robot, in the order of `robots` (empty in results written before they
    /// were recorded): which transfers go to a robot of a different kinematic structure.
    #[serde(default)]
    pub robot_joints: Vec<usize>,
    /// The less-data study (Fig. 9; empty when not run).
    #[serde(default)]
    pub less_data: Vec<LessDataRecord>,
    /// The all-frames study (the sparse model on every training frame; empty when not run).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub all_frames: Vec<AllFramesRecord>,
    /// The study of a latent space per arm on recombined motions (empty when not run).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub parts: Vec<crate::experiment::PartsRecord>,
    /// The retargeted test frames against the person, and who the frames are of: the yardstick
    /// of the learned mapping ([`RunRecord::arms_from_person`]; absent in results written before
    /// it was recorded).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub retargeting: Option<crate::experiment::RetargetingStudy>,
}

impl Results {
    /// The runs of one robot, kind of model and back constraint (by name) of the paper's model.
    pub(crate) fn select(&self, robot: &str, model: ModelKind, bc: &str) -> Vec<&RunRecord> {
        self.select_of(false, robot, model, bc)
    }

    /// The runs of one robot, kind of model and back constraint of the Bayesian study (`true`)
    /// or of the paper's model (`false`).
    pub(crate) fn select_of(
        &self,
        bayesian: bool,
        robot: &str,
        model: ModelKind,
        bc: &str,
    ) -> Vec<&RunRecord> {
        self.runs
            .iter()
            .filter(|r| {
                r.bayesian == bayesian
                    && r.robot == robot
                    && r.model == model
                    && r.back_constraint == bc
            })
            .collect()
    }

    /// The Bayesian study's multi-robot models with back constraint `bc`, one record per run
    /// (a multi-robot training records one run per robot, each with the model's ARD weights).
    pub(crate) fn bayesian_multi_models(&self, bc: &str) -> Vec<&RunRecord> {
        let mut models: Vec<&RunRecord> = Vec::new();
        for r in &self.runs {
            let wanted = r.bayesian && r.model == ModelKind::Multi && r.back_constraint == bc;
            if wanted && !r.ard_weights.is_empty() && !models.iter().any(|m| m.run == r.run) {
                models.push(r);
            }
        }
        models
    }

    /// Mean test error of the shipped models of a group of runs (NaN without runs).
    pub fn shipped_mean(&self, robot: &str, model: ModelKind, bc: &str) -> f64 {
        let values: Vec<f64> = self
            .select(robot, model, bc)
            .iter()
            .map(|r| r.shipped().test_mse)
            .collect();
        crate::stats::mean(&values)
    }

    /// The test MSE of the mean training pose for `robot`, where it was measured.
    pub fn mean_pose_mse(&self, robot: &str) -> Option<f64> {
        self.direct_regression
            .iter()
            .find(|d| d.robot == robot)
            .and_then(|d| d.mean_pose_mse)
    }

    /// Test error of the direct GP regression for `robot` (NaN if it was not run).
    pub fn direct_mse(&self, robot: &str) -> f64 {
        self.direct_regression
            .iter()
            .find(|d| d.robot == robot)
            .map_or(f64::NAN, |d| d.test_mse)
    }
}

/// One model of the less-data study.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct LessDataRecord {
    /// The robot whose test error is recorded.
    pub robot: String,
    /// Fraction of the training frames used.
    pub fraction: f64,
    /// Training frames used.
    pub frames: usize,
    /// [`ModelKind::Baseline`] (trained on those frames alone) or [`ModelKind::Transfer`]
    /// (from `source_robot`'s model of the same run, trained on all frames).
    pub model: ModelKind,
    /// Run (seed) index.
    pub run: usize,
    /// For transfers, the robot of the source model.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub source_robot: Option<String>,
    /// Test MSE (rad²).
    pub test_mse: f64,
}

/// One sparse model trained on every training frame.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct AllFramesRecord {
    /// The robot.
    pub robot: String,
    /// The back constraint: `input` (the only one the study trains; why is said in the
    /// experiment's `all_frames` module).
    pub back_constraint: String,
    /// Run (seed) index: the exact baseline of the same run shares its seed.
    pub run: usize,
    /// `true`: trained on every training frame; `false`: the control, the sparse model on the
    /// subsampled training frames of the exact baseline.
    pub full_rate: bool,
    /// Training frames used.
    pub frames: usize,
    /// Training frames of the exact baseline it is compared with (the subsample).
    pub subsampled_frames: usize,
    /// Inducing inputs M.
    pub inducing: usize,
    /// Iteration of the final training at which the shipped parameters were reached.
    pub iteration: usize,
    /// Training seconds (budget selection included).
    pub seconds: f64,
    /// Test MSE (rad²).
    pub test_mse: f64,
    /// Why the final training stopped (`time_limit`: cut short by `--max-seconds`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stop_reason: Option<String>,
}
