//! Training and transfer on a demonstration file's training frames: which frames a model trains
//! on ([`FrameSet`]: the exact model the subsampled training set, the sparse and Bayesian
//! models every frame of the training motions), the frames held out of them to choose the
//! iteration budget, and the groups the trust thresholds hold out.

use std::borrow::Cow;

use sgplvm_core::{Callback, Mat, MatRef, ModelConfig, SharedGplvm, TrainOptions, Validation};
use sgplvm_robots::dataset::Dataset;

use super::{to_mat, Demonstrations, PipelineError};

/// Which of a demonstration file's training frames a model trains on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FrameSet {
    /// The training set as stored: subsampled (every 12th frame of the training motions in the
    /// shipped files), what the exact model trains on (O(N³) time, O(N²) memory).
    Subsampled,
    /// Every frame of the training motions ([`Dataset::every_training_frame`]): what the
    /// sparse and the Bayesian models train on (O(N M²) time, O(N M) memory).
    Every,
}

impl FrameSet {
    /// The frames a model of `config` trains on: every frame for the sparse and Bayesian models
    /// ([`ModelConfig::inducing`]), the subsampled ones for the exact model.
    pub fn for_config(config: &ModelConfig) -> FrameSet {
        match config.inducing {
            Some(_) => FrameSet::Every,
            None => FrameSet::Subsampled,
        }
    }

    /// What the set is, for messages: `subsampled training frames` or `every frame of the
    /// training motions`.
    pub fn describe(self) -> &'static str {
        match self {
            FrameSet::Subsampled => "subsampled training frames",
            FrameSet::Every => "every frame of the training motions",
        }
    }
}

/// What training the human and some robots takes from the data: each body's name, joint names
/// and training rows (the human first), the groups the trust thresholds hold out and the
/// human's joint limits the novelty threshold is calibrated within.
pub(crate) struct TrainingSpaces {
    /// Name, joint names and training rows of each body.
    pub bodies: Vec<(String, Vec<String>, Mat<f64>)>,
    /// [`Dataset::training_groups`] of the training frames.
    pub groups: Vec<usize>,
    /// [`human_pose_bounds`] of the human's joints, where every one is the built-in human's.
    pub pose_bounds: Option<Vec<(f64, f64)>>,
}

/// The built-in human's joint limits (data/urdf/human.urdf) of the human joints `names`, in
/// their order; a joint it does not have is named in the error.
pub fn human_pose_bounds(names: &[String]) -> Result<Vec<(f64, f64)>, String> {
    let human = sgplvm_robots::Robot::builtin("human").map_err(|e| e.to_string())?;
    let (known, limits) = (human.joint_names(), human.joint_limits());
    names
        .iter()
        .map(|name| match known.iter().position(|k| k == name) {
            Some(k) => Ok(limits[k]),
            None => Err(format!(
                "the data's human joint `{name}` is not a joint of the built-in human \
                 (data/urdf/human.urdf), whose limits bound the random poses"
            )),
        })
        .collect()
}

impl TrainingSpaces {
    /// The spaces as the core's `fit` takes them.
    pub fn views(&self) -> Vec<(&str, MatRef<'_, f64>)> {
        self.bodies
            .iter()
            .map(|(name, _, m)| (name.as_str(), m.as_ref()))
            .collect()
    }

    /// The human's (input) space name.
    pub fn input(&self) -> &str {
        &self.bodies[0].0
    }
}

impl Demonstrations {
    /// The training rows of the human and `robots` on the frames `frames` says.
    pub(crate) fn training_spaces(
        &self,
        robots: &[String],
        frames: FrameSet,
    ) -> Result<TrainingSpaces, PipelineError> {
        self.check_training()?;
        let ds = self.training_set(frames);
        let mut bodies = vec![&ds.human];
        for name in robots {
            self.robot(name)?;
            bodies.extend(ds.robot(name));
        }
        Ok(TrainingSpaces {
            bodies: bodies
                .iter()
                .map(|b| {
                    let rows = to_mat(&b.rows(&ds.train));
                    (b.name.clone(), b.joint_names.clone(), rows)
                })
                .collect(),
            groups: ds.training_groups().groups,
            pose_bounds: human_pose_bounds(&ds.human.joint_names).ok(),
        })
    }

    /// The dataset with `frames` as its training set (the test set unchanged).
    pub fn training_set(&self, frames: FrameSet) -> Cow<'_, Dataset> {
        match frames {
            FrameSet::Subsampled => Cow::Borrowed(&self.dataset),
            FrameSet::Every => Cow::Owned(self.dataset.with_every_training_frame()),
        }
    }

    /// The frames of `frames` held out to choose the iteration budget (the same motions
    /// whatever the set: [`Dataset::validation_split`]), with `patience`.
    pub fn validation_of(&self, frames: FrameSet, patience: usize) -> Validation {
        Validation::new(self.training_set(frames).validation_split().rows).with_patience(patience)
    }

    /// The frame set `model` was trained on, told by its number of frames: the subsampled
    /// training set, or every frame of the training motions (a sparse model trained since
    /// issue 49). Neither: [`PipelineError::FrameCount`].
    pub fn frames_of(&self, model: &SharedGplvm) -> Result<FrameSet, PipelineError> {
        self.frames_for(model.num_points(), model.config())
    }

    /// [`Demonstrations::frames_of`] a model of `config` trained on `n` frames.
    pub fn frames_for(&self, n: usize, config: &ModelConfig) -> Result<FrameSet, PipelineError> {
        let subsampled = self.dataset.train.len();
        let every = self.dataset.every_training_frame().len();
        let preferred = FrameSet::for_config(config);
        let other = match preferred {
            FrameSet::Every => FrameSet::Subsampled,
            FrameSet::Subsampled => FrameSet::Every,
        };
        let count = |set| match set {
            FrameSet::Subsampled => subsampled,
            FrameSet::Every => every,
        };
        [preferred, other]
            .into_iter()
            .find(|&set| count(set) == n)
            .ok_or_else(|| PipelineError::FrameCount {
                source_name: self.source_name.clone(),
                model: n,
                subsampled,
                every,
            })
    }

    /// Trains a model on the training frames of the human and `robots` (one robot: the full
    /// model; several: the multi-robot model): the frames [`FrameSet::for_config`] says. With
    /// `patience`, the iteration budget is chosen on held-out training frames
    /// ([`SharedGplvm::fit_validated`], [`Demonstrations::validation_of`]). Joint names and the
    /// groups the trust thresholds hold out ([`Dataset::training_groups`]) are stored in the
    /// model.
    pub fn train(
        &self,
        robots: &[String],
        config: &ModelConfig,
        options: &TrainOptions,
        patience: Option<usize>,
        callback: Option<Callback<'_>>,
    ) -> Result<SharedGplvm, PipelineError> {
        let frames = FrameSet::for_config(config);
        let training = self.training_spaces(robots, frames)?;
        let (spaces, input) = (training.views(), training.input());
        let mut model = match patience {
            Some(p) => {
                let v = self.validation_of(frames, p);
                SharedGplvm::fit_validated(config, &spaces, input, options, &v, callback)?
            }
            None => SharedGplvm::fit(config, &spaces, input, options, callback)?,
        };
        for (name, joints, _) in &training.bodies {
            model.set_column_names(name, joints.clone())?;
        }
        model.set_trust_groups(training.groups)?;
        if let Some(bounds) = training.pose_bounds {
            model.set_pose_bounds(bounds, sgplvm_core::RANDOM_PERCENTILE)?;
        }
        Ok(model)
    }

    /// Transfers `model` to `robot` on this data's training frames: the frame set the model
    /// was trained on ([`Demonstrations::frames_of`]; the human joints are checked too). With
    /// `patience`, the iteration budget is chosen on held-out frames
    /// ([`SharedGplvm::transfer_validated`]).
    pub fn transfer(
        &self,
        model: &SharedGplvm,
        robot: &str,
        options: &TrainOptions,
        patience: Option<usize>,
        callback: Option<Callback<'_>>,
    ) -> Result<SharedGplvm, PipelineError> {
        self.check_training()?;
        self.check_human(model)?;
        let body = self.robot(robot)?;
        let frames = self.frames_of(model)?;
        let ds = self.training_set(frames);
        let data = to_mat(&body.rows(&ds.train));
        let mut transferred = match patience {
            Some(p) => {
                let v = self.validation_of(frames, p);
                model.transfer_validated(robot, data.as_ref(), None, options, &v, callback)?
            }
            None => model.transfer(robot, data.as_ref(), options, callback)?,
        };
        transferred.set_column_names(robot, body.joint_names.clone())?;
        // A model file written before the groups existed: they are this data's.
        if transferred.trust_groups().is_none() {
            transferred.set_trust_groups(ds.training_groups().groups)?;
        }
        if transferred.pose_bounds().is_none() {
            if let Ok(bounds) = human_pose_bounds(&ds.human.joint_names) {
                transferred.set_pose_bounds(bounds, sgplvm_core::RANDOM_PERCENTILE)?;
            }
        }
        Ok(transferred)
    }
}
