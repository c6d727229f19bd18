//! From demonstration files to trained models and test errors: the glue between the robots
//! crate's [`Dataset`] and the core's matrices, used by the command line and the Python module.

use std::path::{Path, PathBuf};

use nalgebra::DMatrix;
use sgplvm_core::{
    Callback, GpRegression, Mat, MatRef, ModelConfig, Predictor, SharedGplvm, TrainOptions,
    Validation,
};
use sgplvm_robots::dataset::{load_demonstrations, BodyData, Dataset, ValidationSplit};
use sgplvm_robots::generator::{generate, GeneratorConfig};

use crate::results::ModelKind;

mod parts;
mod training;
pub use parts::{arm_columns, known_anatomy, Parts, ARM_PARTS};
pub use training::{human_pose_bounds, FrameSet};

/// Where the shipped demonstrations live, relative to the repository root.
pub const DEFAULT_DEMOS: &str = "data/demos/bimanual.mcap";

/// Errors of the pipeline. Each names the file, robot or space concerned.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum PipelineError {
    /// A demonstration file could not be read or generated.
    #[error(transparent)]
    Data(#[from] sgplvm_robots::joint_state::JointStateError),
    /// The demonstrations could not be generated.
    #[error(transparent)]
    Generate(#[from] sgplvm_robots::generator::GenerateError),
    /// The model failed.
    #[error(transparent)]
    Model(#[from] sgplvm_core::Error),
    /// A robot the data does not contain.
    #[error("{source_name}: no robot named '{name}'; {}", if known.is_empty() {
        "the data holds the human's frames only (an imported capture?): retarget it onto the robot first (sgplvm retarget --demos FILE)".to_string()
    } else {
        format!("the data has {known:?}")
    })]
    UnknownRobot {
        /// The data file.
        source_name: String,
        /// The requested robot.
        name: String,
        /// The robots in the file.
        known: Vec<String>,
    },
    /// Model and data disagree on the joints of a space.
    #[error(
        "{source_name}: the {space} joints do not match the model's: {}",
        sgplvm_robots::names::difference(model, data, "joint")
    )]
    JointMismatch {
        /// The data file.
        source_name: String,
        /// The space (human or robot name).
        space: String,
        /// Joint names in the model.
        model: Vec<String>,
        /// Joint names in the data.
        data: Vec<String>,
    },
    /// Model (without stored joint names) and data have different numbers of joints in a space.
    #[error(
        "{source_name}: the {space} has {data} joints; the model's {space} space has {model} \
         columns"
    )]
    ColumnCount {
        /// The data file.
        source_name: String,
        /// The space (human or robot name).
        space: String,
        /// Columns of the model's space.
        model: usize,
        /// Joints in the data.
        data: usize,
    },
    /// A model's training frames are neither of the data's training frame sets.
    #[error(
        "{source_name}: the model was trained on {model} frames; this data's training set has \
         {subsampled} frames and {every} at full rate (every frame of its training motions): \
         transfer on the demonstrations the model was trained on"
    )]
    FrameCount {
        /// The data file.
        source_name: String,
        /// The model's training frames.
        model: usize,
        /// The data's subsampled training frames.
        subsampled: usize,
        /// The data's training frames at full rate.
        every: usize,
    },
    /// A body's columns could not be divided into the parts asked for.
    #[error("{body}: {detail}")]
    Parts {
        /// The body (human or robot).
        body: String,
        /// What could not be divided, and how to say it.
        detail: String,
    },
    /// The data has no training or no test frames.
    #[error("{source_name}: the {split} set is empty ({})", empty_split_hint(.split))]
    EmptySplit {
        /// The data file.
        source_name: String,
        /// `training` or `test`.
        split: &'static str,
    },
}

/// What to do about an empty training or test set.
fn empty_split_hint(split: &str) -> &'static str {
    if split == "test" {
        "evaluating needs test frames: `sgplvm retarget` makes them with --split blocks (a \
         shorter --block-seconds or a smaller --test-every for a short capture) or --split files"
    } else {
        "expected demonstrations with training frames: `sgplvm retarget` writes them"
    }
}

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
    /// Rows of the training matrices held out to choose each training's iteration budget
    /// (see [`ExperimentConfig::patience`](crate::results::ExperimentConfig::patience)).
    pub validation: Vec<usize>,
    /// The training frames at full rate, for the all-frames study
    /// ([`ExperimentConfig::inducing`](crate::results::ExperimentConfig::inducing)); `None` when it is not run.
    pub all_frames: Option<AllFrames>,
    /// The arms' columns and the recombined frames, for the study of a latent space per arm
    /// ([`ExperimentConfig::parts`](crate::results::ExperimentConfig::parts),
    /// [`Demonstrations::parts_data`]); `None` when it is not run.
    pub parts: Option<crate::experiment::PartsData>,
    /// Each robot's joint names and who the frames are of, for the study of the learned mapping
    /// against retargeting each frame directly ([`crate::experiment::RetargetingData`]);
    /// `None`: not run.
    pub retargeting: Option<crate::experiment::RetargetingData>,
}

/// The training frames at full rate: every frame of the training motions (test frames are the
/// experiment's usual ones).
#[derive(Debug, Clone)]
pub struct AllFrames {
    /// The human's frames.
    pub human: Mat<f64>,
    /// Every robot's frames, in the order of [`ExperimentData::robots`].
    pub robots: Vec<Mat<f64>>,
    /// Rows held out to choose the iteration budget (the same motions as
    /// [`ExperimentData::validation`] holds out of the subsampled frames).
    pub validation: Vec<usize>,
}

/// The mean squared error of predicting the mean of the `train` frames for every `test` frame:
/// what a model that learned nothing scores.
pub fn mean_pose_mse(train: MatRef<'_, f64>, test: MatRef<'_, f64>) -> f64 {
    let mean = Mat::from_fn(test.nrows(), test.ncols(), |_, j| {
        (0..train.nrows()).map(|i| train[(i, j)]).sum::<f64>() / train.nrows().max(1) as f64
    });
    mean_squared_error(mean.as_ref(), test)
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

/// A dataset and a name for it in messages.
#[derive(Debug, Clone)]
pub struct Demonstrations {
    /// The data.
    pub dataset: Dataset,
    /// The file it came from (or a description of how it was made).
    pub source_name: String,
}

/// Loads demonstrations from `path`; with `None`, the shipped `data/demos/bimanual.mcap` when run
/// from the repository, else the same data generated in memory with the default (seeded)
/// generator settings.
pub fn load(path: Option<&Path>) -> Result<Demonstrations, PipelineError> {
    let path: Option<PathBuf> = match path {
        Some(p) => Some(p.to_path_buf()),
        None => Some(PathBuf::from(DEFAULT_DEMOS)).filter(|p| p.exists()),
    };
    match path {
        Some(path) => Ok(Demonstrations {
            dataset: load_demonstrations(&path)?,
            source_name: path.display().to_string(),
        }),
        None => Ok(Demonstrations {
            dataset: generate(&GeneratorConfig::default())?.dataset,
            source_name: "generated demonstrations (default settings)".into(),
        }),
    }
}

/// A faer matrix from a nalgebra one.
pub fn to_mat(m: &DMatrix<f64>) -> Mat<f64> {
    Mat::from_fn(m.nrows(), m.ncols(), |i, j| m[(i, j)])
}

/// A nalgebra matrix from a faer one.
pub fn to_dmatrix(m: MatRef<'_, f64>) -> DMatrix<f64> {
    DMatrix::from_fn(m.nrows(), m.ncols(), |i, j| m[(i, j)])
}

impl Demonstrations {
    /// The robot called `name`.
    pub fn robot(&self, name: &str) -> Result<&BodyData, PipelineError> {
        self.dataset
            .robot(name)
            .ok_or_else(|| PipelineError::UnknownRobot {
                source_name: self.source_name.clone(),
                name: name.to_string(),
                known: self
                    .dataset
                    .robot_names()
                    .iter()
                    .map(|s| s.to_string())
                    .collect(),
            })
    }

    pub(crate) fn check_splits(&self) -> Result<(), PipelineError> {
        self.check_training()?;
        if self.dataset.test.is_empty() {
            return Err(PipelineError::EmptySplit {
                source_name: self.source_name.clone(),
                split: "test",
            });
        }
        Ok(())
    }

    /// Training needs training frames only (a short capture may have no test frames).
    pub(crate) fn check_training(&self) -> Result<(), PipelineError> {
        for (split, rows) in [("training", &self.dataset.train)] {
            if rows.is_empty() {
                return Err(PipelineError::EmptySplit {
                    source_name: self.source_name.clone(),
                    split,
                });
            }
        }
        Ok(())
    }

    /// Training and test matrices of the human and every robot, for the experiments.
    pub fn experiment_data(&self) -> Result<ExperimentData, PipelineError> {
        self.check_splits()?;
        let ds = &self.dataset;
        let split = |body: &BodyData| SplitData {
            train: to_mat(&body.rows(&ds.train)),
            test: to_mat(&body.rows(&ds.test)),
        };
        Ok(ExperimentData {
            input_name: ds.human.name.clone(),
            human: split(&ds.human),
            robots: ds
                .robots
                .iter()
                .map(|r| (r.name.clone(), split(r)))
                .collect(),
            validation: self.validation_split().rows,
            all_frames: None,
            parts: None,
            retargeting: Some(crate::experiment::RetargetingData {
                robot_joints: ds.robots.iter().map(|r| r.joint_names.clone()).collect(),
                test_people: ds.people_of(&ds.test),
                training_people: ds.people_of(&ds.train),
            }),
        })
    }

    /// Every training frame at the recording's full rate
    /// ([`Dataset::every_training_frame`]): the frames of the training motions, of which the
    /// training set is every 12th, without the guard frames a block split leaves next to its
    /// test blocks.
    pub fn all_training_frames(&self) -> Vec<usize> {
        self.dataset.every_training_frame()
    }

    /// The training frames at full rate ([`Demonstrations::all_training_frames`]) of the
    /// human and every robot, and the frames held out of them to choose iteration budgets
    /// (the same rule, hence the same motions, as [`Demonstrations::validation_split`]).
    pub fn all_frames_data(&self) -> Result<AllFrames, PipelineError> {
        self.check_splits()?;
        let full = self.dataset.with_every_training_frame();
        Ok(AllFrames {
            human: to_mat(&full.human.rows(&full.train)),
            robots: full
                .robots
                .iter()
                .map(|r| to_mat(&r.rows(&full.train)))
                .collect(),
            validation: full.validation_split().rows,
        })
    }

    /// The training frames held out to choose the iteration budget
    /// ([`Dataset::validation_split`]) and the rule that chose them.
    pub fn validation_split(&self) -> ValidationSplit {
        self.dataset.validation_split()
    }

    /// [`Demonstrations::validation_split`] as the core takes it, with `patience`.
    pub fn validation(&self, patience: usize) -> Validation {
        Validation::new(self.validation_split().rows).with_patience(patience)
    }

    /// Checks that the data's human joints are the model's (by name, in order).
    pub fn check_human(&self, model: &dyn Predictor) -> Result<(), PipelineError> {
        self.check_joints(model, model.input_name(), &self.dataset.human.joint_names)
    }

    pub(crate) fn check_joints(
        &self,
        model: &dyn Predictor,
        space: &str,
        data: &[String],
    ) -> Result<(), PipelineError> {
        let expected: Vec<String> = match model.column_names(space) {
            Some(names) => names.to_vec(),
            None => match model.space_dim(space) {
                Some(d) if d == data.len() => return Ok(()),
                d => {
                    return Err(PipelineError::ColumnCount {
                        source_name: self.source_name.clone(),
                        space: space.to_string(),
                        model: d.unwrap_or(0),
                        data: data.len(),
                    })
                }
            },
        };
        if expected != data {
            return Err(PipelineError::JointMismatch {
                source_name: self.source_name.clone(),
                space: space.to_string(),
                model: expected,
                data: data.to_vec(),
            });
        }
        Ok(())
    }

    /// Test error of `model` (either kind) for `robot` on this data's test frames.
    pub fn evaluate(
        &self,
        model: &dyn Predictor,
        robot: &str,
    ) -> Result<Evaluation, PipelineError> {
        self.check_splits()?;
        self.check_human(model)?;
        let body = self.robot(robot)?;
        self.check_joints(model, robot, &body.joint_names)?;
        let human = to_mat(&self.dataset.human.rows(&self.dataset.test));
        let predicted = model.predict(human.as_ref(), robot, false)?.mean;
        Ok(self.test_error(body, predicted.as_ref()))
    }

    /// How many of this data's test frames `model` would not trust for `robot`: their
    /// predictive standard deviation exceeds the model's trust threshold (a live controller
    /// holds the robot on them). A report, never a choice: nothing is tuned on it.
    pub fn test_trust(&self, model: &SharedGplvm, robot: &str) -> Result<TestTrust, PipelineError> {
        self.check_splits()?;
        self.check_human(model)?;
        let body = self.robot(robot)?;
        self.check_joints(model, robot, &body.joint_names)?;
        let human = to_mat(&self.dataset.human.rows(&self.dataset.test));
        let desired = to_mat(&body.rows(&self.dataset.test));
        let predicted = model.predict(human.as_ref(), robot, false)?.mean;
        let sd = model.prediction_sd(human.as_ref(), robot)?;
        let threshold = model.trust_threshold(robot)?;
        // Mean squared error over the joints of the frames on either side of the threshold.
        let (mut sums, mut counts) = ([0.0; 2], [0usize; 2]);
        for (i, s) in sd.iter().enumerate() {
            // The live rule: a standard deviation that is not a number is not trusted either.
            let trusted = s.is_finite() && *s <= threshold;
            let side = usize::from(!trusted);
            let row = mean_squared_error(
                predicted.as_ref().subrows(i, 1),
                desired.as_ref().subrows(i, 1),
            );
            sums[side] += row;
            counts[side] += 1;
        }
        let mean = |k: usize| (counts[k] > 0).then(|| sums[k] / counts[k] as f64);
        Ok(TestTrust {
            threshold,
            frames: sd.len(),
            untrusted: counts[1],
            mse_trusted: mean(0),
            mse_untrusted: mean(1),
        })
    }

    /// The yardstick the paper measures its model against: a direct GP regression human →
    /// `robot` ([`GpRegression`]) trained on the training frames, and its test error.
    pub fn direct_regression(
        &self,
        robot: &str,
        options: &TrainOptions,
    ) -> Result<(GpRegression, Evaluation), PipelineError> {
        self.check_splits()?;
        let body = self.robot(robot)?;
        let ds = &self.dataset;
        let human = to_mat(&ds.human.rows(&ds.train));
        let joints = to_mat(&body.rows(&ds.train));
        let regression = GpRegression::fit(human.as_ref(), joints.as_ref(), options)?;
        let test_human = to_mat(&ds.human.rows(&ds.test));
        let predicted = regression.predict(test_human.as_ref())?;
        let evaluation = self.test_error(body, predicted.as_ref());
        Ok((regression, evaluation))
    }

    /// Test error of `predicted` (test frames × joints of `body`).
    fn test_error(&self, body: &BodyData, predicted: MatRef<'_, f64>) -> Evaluation {
        let desired = to_mat(&body.rows(&self.dataset.test));
        let per_joint = body
            .joint_names
            .iter()
            .enumerate()
            .map(|(j, name)| {
                let mse =
                    mean_squared_error(predicted.subcols(j, 1), desired.as_ref().subcols(j, 1));
                (name.clone(), mse)
            })
            .collect();
        let train = to_mat(&body.rows(&self.dataset.train));
        Evaluation {
            robot: body.name.clone(),
            frames: desired.nrows(),
            mse: mean_squared_error(predicted, desired.as_ref()),
            per_joint,
            mean_pose_mse: mean_pose_mse(train.as_ref(), desired.as_ref()),
        }
    }
}

/// One training of a [`Demonstrations::transfer_study`], as its runner is told of it.
#[derive(Debug, Clone, Copy)]
pub struct StudyTraining<'a> {
    /// The robot trained (or transferred to).
    pub robot: &'a str,
    /// [`ModelKind::Baseline`]: human + this robot trained fully; [`ModelKind::Transfer`]: from
    /// the source robot's model, only this robot's kernel trained.
    pub kind: ModelKind,
    /// The robot trained fully first, whose model every transfer starts from.
    pub source: &'a str,
}

/// One training, handed to a study's runner: call it (with or without a per-iteration callback)
/// for the model.
pub type TrainFn<'f> = dyn FnMut(Option<Callback<'_>>) -> Result<SharedGplvm, PipelineError> + 'f;

/// Runs each training of a study: returns the model and its training seconds (the command line
/// draws a progress bar and saves the model here).
pub type StudyRunner<'r, E> =
    dyn FnMut(&StudyTraining<'_>, &mut TrainFn<'_>) -> Result<(SharedGplvm, f64), E> + 'r;

/// A model of a [`Demonstrations::transfer_study`] and its test error.
#[derive(Debug, Clone)]
pub struct StudyModel {
    /// The robot.
    pub robot: String,
    /// Trained fully ([`ModelKind::Baseline`]) or transferred ([`ModelKind::Transfer`]).
    pub kind: ModelKind,
    /// The trained model.
    pub model: SharedGplvm,
    /// Training seconds, as the runner measured them.
    pub seconds: f64,
    /// Iterations of the training.
    pub iterations: usize,
    /// Test error for `robot`.
    pub evaluation: Evaluation,
}

impl Demonstrations {
    /// The demo's small experiment (one run of the paper's transfer comparison): `source` trained
    /// fully, then every other robot of the data transferred from it and, for comparison,
    /// trained fully from scratch — all with `config`, `options` and `patience` (budgets chosen
    /// on held-out frames: [`Demonstrations::train`]) — each model
    /// evaluated on the test frames as soon as it is trained. `run` runs each training, in this
    /// order.
    pub fn transfer_study<E: From<PipelineError>>(
        &self,
        source: &str,
        config: &ModelConfig,
        options: &TrainOptions,
        patience: Option<usize>,
        run: &mut StudyRunner<'_, E>,
    ) -> Result<Vec<StudyModel>, E> {
        let full = |robot: &str| {
            let robots = vec![robot.to_string()];
            move |cb: Option<Callback<'_>>| self.train(&robots, config, options, patience, cb)
        };
        let training = |robot, kind| StudyTraining {
            robot,
            kind,
            source,
        };
        let first = self.study_model(
            training(source, ModelKind::Baseline),
            run,
            &mut full(source),
        )?;
        let mut models = Vec::new();
        for target in self
            .dataset
            .robot_names()
            .into_iter()
            .filter(|r| *r != source)
        {
            let transferred =
                self.study_model(training(target, ModelKind::Transfer), run, &mut |cb| {
                    self.transfer(&first.model, target, options, patience, cb)
                })?;
            let baseline = self.study_model(
                training(target, ModelKind::Baseline),
                run,
                &mut full(target),
            )?;
            models.extend([transferred, baseline]);
        }
        models.insert(0, first);
        Ok(models)
    }

    /// Runs one training of a study and evaluates the model.
    fn study_model<E: From<PipelineError>>(
        &self,
        training: StudyTraining<'_>,
        run: &mut StudyRunner<'_, E>,
        train: &mut TrainFn<'_>,
    ) -> Result<StudyModel, E> {
        let (model, seconds) = run(&training, train)?;
        let evaluation = self.evaluate(&model, training.robot)?;
        Ok(StudyModel {
            robot: training.robot.to_string(),
            kind: training.kind,
            iterations: model.history().last().map_or(0, |r| r.iteration),
            seconds,
            evaluation,
            model,
        })
    }
}

/// Test error of one robot.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Evaluation {
    /// The robot.
    pub robot: String,
    /// Number of test frames.
    pub frames: usize,
    /// Mean squared error over all joints and frames (rad²).
    pub mse: f64,
    /// Mean squared error of each joint (rad²).
    pub per_joint: Vec<(String, f64)>,
    /// The test MSE of predicting the mean training pose on every frame (rad²): the error of a
    /// model that learned nothing, which a model must beat.
    pub mean_pose_mse: f64,
}

/// Test frames a model would not trust ([`Demonstrations::test_trust`]).
#[derive(Debug, Clone, Copy, serde::Serialize)]
pub struct TestTrust {
    /// The model's trust threshold for the robot (standardised standard deviation).
    pub threshold: f64,
    /// Number of test frames.
    pub frames: usize,
    /// Test frames above the threshold.
    pub untrusted: usize,
    /// Mean squared error (rad², over joints and frames) of the frames within the threshold.
    pub mse_trusted: Option<f64>,
    /// The same of the frames above it: larger when the threshold flags the worse predictions.
    pub mse_untrusted: Option<f64>,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_joint_mismatch_names_the_difference_not_both_lists() {
        let model: Vec<String> = (0..18).map(|k| format!("j{k}")).collect();
        let mut data = model.clone();
        data.swap(3, 4);
        let e = PipelineError::JointMismatch {
            source_name: "d.mcap".into(),
            space: "human".into(),
            model: model.clone(),
            data,
        };
        assert_eq!(
            e.to_string(),
            "d.mcap: the human joints do not match the model's: the same 18 joints in another \
             order: position 4 has \"j4\" where \"j3\" is expected"
        );
        let e = PipelineError::JointMismatch {
            source_name: "d.mcap".into(),
            space: "coman".into(),
            model,
            data: vec!["a".into()],
        };
        let text = e.to_string();
        assert!(
            text.contains("18 of the 18 joints expected are missing: \"j0\"")
                && text.contains("and 13 more; 1 joint is not expected: \"a\""),
            "{text}"
        );
    }

    fn generated(train_subsample: usize) -> Demonstrations {
        let config = GeneratorConfig {
            repetitions: 2,
            train_subsample,
            ..GeneratorConfig::default()
        };
        Demonstrations {
            dataset: generate(&config).expect("generates").dataset,
            source_name: "test".into(),
        }
    }

    /// The full-rate training frames of subsampled demonstrations are the training set the
    /// generator writes with `--subsample 1`: every frame of the training motions, a superset of
    /// the subsample, no test frame; their held-out frames are the same motions'.
    #[test]
    fn all_training_frames_are_the_training_motions_at_full_rate() {
        let sub = generated(12);
        let full = generated(1);
        let frames = sub.all_training_frames();
        assert_eq!(frames, full.dataset.train);
        assert!(frames.len() > 11 * sub.dataset.train.len());
        assert!(sub
            .dataset
            .train
            .iter()
            .all(|f| frames.binary_search(f).is_ok()));
        assert!(sub
            .dataset
            .test
            .iter()
            .all(|f| frames.binary_search(f).is_err()));
        let data = sub.all_frames_data().expect("all frames");
        assert_eq!(data.human.nrows(), frames.len());
        assert_eq!(data.robots.len(), 3);
        assert_eq!(data.validation, full.validation_split().rows);
        // A segment with test frames in it gives only its training frames.
        let mut mixed = sub.clone();
        let segment = mixed
            .dataset
            .segment_of(sub.dataset.train[0])
            .expect("segment")
            .clone();
        mixed.dataset.test.insert(0, segment.end - 1);
        mixed.dataset.test.sort_unstable();
        let own: Vec<usize> = sub
            .dataset
            .train
            .iter()
            .copied()
            .filter(|&f| f < segment.end)
            .collect();
        let frames = mixed.all_training_frames();
        assert_eq!(&frames[..own.len()], own.as_slice());
        assert!(frames[own.len()] >= segment.end);
    }
}
