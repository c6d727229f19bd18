//! The shared GP-LVM: the model's state (its spaces, latent representation, input map and
//! prediction caches) and its read-only accessors. Training lives in `fit` and `transfer`,
//! prediction in `predict`, parameters in `params`, files in `io`.

use std::sync::{Mutex, OnceLock};

use faer::{Mat, MatRef};

use crate::back_constraint::BcCache;
use crate::config::ModelConfig;
use crate::error::{Error, Result};
use crate::input_map::InputMap;
use crate::kernel::KernelParams;
use crate::likelihood::{eval_space, SpaceEval, SpaceWork, Wanted};
use crate::pool::lock;
use crate::predict::Prepared;
use crate::train::{Control, IterationRecord, StopReason};
use crate::validation::Selection;

/// One observation space.
#[derive(Clone, Debug)]
pub(crate) struct Space {
    pub name: String,
    /// Centred (and scaled) data, N×D.
    pub data: Mat<f64>,
    pub offset: Vec<f64>,
    pub scale: Vec<f64>,
    pub kernel: KernelParams,
    pub columns: Option<Vec<String>>,
}

impl Space {
    /// This space's negative log marginal likelihood at latent points `x_rows` (row-major, `q`
    /// columns), without gradients; leaves its Cholesky factor and `K⁻¹Y` in `work`.
    pub(crate) fn factorise(
        &self,
        x_rows: &[f64],
        q: usize,
        work: &mut SpaceWork,
    ) -> Result<SpaceEval> {
        eval_space(
            x_rows,
            q,
            self.data.as_ref(),
            &self.kernel,
            work,
            1,
            Wanted::Objective,
        )
        .map_err(|e| e.in_space(&self.name))
    }
}

impl Space {
    /// Predictions `p` of this space (centred and scaled, one column per data column) back in
    /// the user's units.
    pub(crate) fn unscale(&self, p: &mut Mat<f64>) {
        unscale(p, &self.offset, &self.scale);
    }
}

/// `p · scale + offset`, column by column.
pub(crate) fn unscale(p: &mut Mat<f64>, offset: &[f64], scale: &[f64]) {
    for j in 0..p.ncols() {
        for i in 0..p.nrows() {
            p[(i, j)] = p[(i, j)] * scale[j] + offset[j];
        }
    }
}

/// Latent representation.
#[derive(Clone, Debug)]
pub(crate) enum Latent {
    Free {
        x: Mat<f64>,
    },
    Back {
        weights: Mat<f64>,
        bandwidth: f64,
        data: Mat<f64>,
    },
}

/// A trained shared GP-LVM over named observation spaces (input first, then robots).
///
/// Build with [`SharedGplvm::fit`]; extend to a new robot with [`SharedGplvm::transfer`];
/// predict with [`SharedGplvm::predict`] / [`SharedGplvm::predict_frame`]; store with
/// [`SharedGplvm::save`] / [`SharedGplvm::to_bytes`].
#[derive(Clone, Debug)]
pub struct SharedGplvm {
    pub(crate) config: ModelConfig,
    pub(crate) spaces: Vec<Space>,
    pub(crate) latent: Latent,
    pub(crate) map: Option<InputMap>,
    pub(crate) history: Vec<IterationRecord>,
    pub(crate) stop_reason: Option<StopReason>,
    /// How the iteration budget was chosen on held-out frames, when it was.
    pub(crate) selection: Option<Selection>,
    /// Inducing inputs and caches of the sparse model (`None`: the exact model).
    pub(crate) sparse: Option<crate::sparse::SparseState>,
    /// Trust thresholds per robot space as read from a model file (`trust`); others are
    /// computed when asked for.
    pub(crate) trust: std::collections::BTreeMap<String, f64>,
    /// The groups of training frames the trust thresholds hold out in turn (`None`: the
    /// `trust` module's consecutive blocks).
    pub(crate) trust_groups: Option<Vec<usize>>,
    /// The reconstruction threshold as read from a model file (`reconstruction`); computed
    /// when asked for otherwise.
    pub(crate) reconstruction: Option<f64>,
    /// The human's joint limits the novelty threshold's random poses are drawn within
    /// (`novelty` module), and the novelty threshold as read from a model file.
    pub(crate) pose_bounds: Option<Vec<(f64, f64)>>,
    pub(crate) random_followed: f64,
    pub(crate) novelty: Option<f64>,
    /// True after `set_params` until the input map is refitted to the new latent points: the
    /// refitted map then lives in `prepared` (the stored one is only its warm start).
    pub(crate) map_stale: bool,
    /// What users attach to the model, opaque to it (e.g. where its training data came from):
    /// kept through saving, transfer and new parameters.
    pub(crate) annotations: std::collections::BTreeMap<String, serde_json::Value>,
    // ----- derived -----
    pub(crate) x: Mat<f64>,
    pub(crate) x_rows: Vec<f64>,
    /// Prediction caches, built by `rebuild` (after training, on load) or on the first
    /// prediction after `set_params` (an optimiser driving the model through `set_params`
    /// and `gradient` never pays for them).
    pub(crate) prepared: OnceLock<Prepared>,
    /// The standardised training poses novelty is measured against, built on first use.
    pub(crate) novelty_reference: OnceLock<std::sync::Arc<crate::novelty::Reference>>,
    /// The back-constraint matrices (empty for free latent points; reset when the bandwidth
    /// changes).
    pub(crate) bc: BcCache,
    /// Evaluation buffers kept between calls of [`SharedGplvm::evaluate`] (fresh N×N buffers
    /// cost more than the evaluation itself: page faults on every call).
    pub(crate) workspace: Workspace,
}

/// Reusable per-space evaluation buffers; a clone starts empty.
#[derive(Default)]
pub(crate) struct Workspace(Mutex<Vec<SpaceWork>>);

impl Workspace {
    /// Buffers for spaces of `dims` output columns at `n` points: the kept ones if they fit.
    pub(crate) fn take(&self, n: usize, dims: &[usize]) -> Vec<SpaceWork> {
        let kept = std::mem::take(&mut *lock(&self.0));
        if kept.len() == dims.len() && kept.iter().zip(dims).all(|(w, &d)| w.fits(n, d)) {
            kept
        } else {
            dims.iter().map(|&d| SpaceWork::new(n, d)).collect()
        }
    }

    /// Every kept buffer, leaving none.
    pub(crate) fn take_all(&self) -> Vec<SpaceWork> {
        std::mem::take(&mut *lock(&self.0))
    }

    /// Keeps `works` for the next evaluation.
    pub(crate) fn put(&self, works: Vec<SpaceWork>) {
        *lock(&self.0) = works;
    }
}

impl Clone for Workspace {
    fn clone(&self) -> Self {
        Self::default()
    }
}

impl std::fmt::Debug for Workspace {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("Workspace")
    }
}

// the model

/// Callback type of training: sees each accepted iteration and a snapshot of the model.
pub type Callback<'c> = &'c mut dyn FnMut(&IterationRecord, &SharedGplvm) -> Control;

impl SharedGplvm {
    /// A model of preprocessed `spaces` (input first) and a latent representation, before
    /// training: no history, no input map, derived state empty until `update_latent_points`
    /// and `rebuild`.
    pub(crate) fn new(config: ModelConfig, spaces: Vec<Space>, latent: Latent) -> Self {
        SharedGplvm {
            config,
            spaces,
            latent,
            map: None,
            history: Vec::new(),
            stop_reason: None,
            selection: None,
            sparse: None,
            trust: std::collections::BTreeMap::new(),
            trust_groups: None,
            reconstruction: None,
            pose_bounds: None,
            random_followed: crate::novelty::RANDOM_PERCENTILE,
            novelty: None,
            map_stale: false,
            annotations: std::collections::BTreeMap::new(),
            x: Mat::zeros(0, 0),
            x_rows: Vec::new(),
            prepared: OnceLock::new(),
            novelty_reference: OnceLock::new(),
            bc: BcCache::default(),
            workspace: Workspace::default(),
        }
    }

    pub(crate) fn n(&self) -> usize {
        self.spaces[0].data.nrows()
    }

    pub(crate) fn q(&self) -> usize {
        self.config.latent_dim
    }

    // accessors

    /// Name of the input (human) space.
    pub fn input_name(&self) -> &str {
        &self.spaces[0].name
    }

    /// Names of the output (robot) spaces, in model order.
    pub fn output_names(&self) -> Vec<&str> {
        self.spaces[1..].iter().map(|s| s.name.as_str()).collect()
    }

    /// Number of columns of a space, if the model has it.
    pub fn space_dim(&self, name: &str) -> Option<usize> {
        self.spaces
            .iter()
            .find(|s| s.name == name)
            .map(|s| s.data.ncols())
    }

    /// Training latent points X (N×Q).
    pub fn latent_points(&self) -> MatRef<'_, f64> {
        self.x.as_ref()
    }

    /// Objective and time per iteration of the last training run (iteration 0 = start).
    pub fn history(&self) -> &[IterationRecord] {
        &self.history
    }

    /// How the iteration budget was chosen on held-out frames, for a model trained by
    /// [`SharedGplvm::fit_validated`] or [`SharedGplvm::transfer_validated`].
    pub fn selection(&self) -> Option<&Selection> {
        self.selection.as_ref()
    }

    /// Seconds spent training this model: the selection run on held-out frames, if any, and
    /// the final training (callbacks excluded).
    pub fn training_seconds(&self) -> f64 {
        self.selection.as_ref().map_or(0.0, |s| s.seconds)
            + self.history.last().map_or(0.0, |r| r.seconds)
    }

    /// Why the last training run stopped.
    pub fn stop_reason(&self) -> Option<&StopReason> {
        self.stop_reason.as_ref()
    }

    /// Largest diagonal jitter the final kernel matrices needed (0 when none).
    /// NaN when a kernel matrix cannot be factorised (after `set_params`; see
    /// [`SharedGplvm::predict`] for the error).
    pub fn jitter(&self) -> f64 {
        self.prepared().map_or(f64::NAN, |p| p.training_jitter)
    }

    /// The configuration the model was built with.
    pub fn config(&self) -> &ModelConfig {
        &self.config
    }

    /// Number of training frames N.
    pub fn num_points(&self) -> usize {
        self.n()
    }

    /// Kernel hyperparameters of a space.
    pub fn kernel(&self, space: &str) -> Option<&KernelParams> {
        self.spaces
            .iter()
            .find(|s| s.name == space)
            .map(|s| &s.kernel)
    }

    /// Hyperparameters of the human → latent GP regression (models without input back
    /// constraints), with the latent mean it adds back.
    pub fn input_map(&self) -> Option<(&KernelParams, &[f64])> {
        self.current_map()
            .ok()
            .flatten()
            .map(|m| (&m.kernel, m.x_mean.as_slice()))
    }

    /// Column (joint) names of a space, if set.
    pub fn column_names(&self, space: &str) -> Option<&[String]> {
        self.spaces
            .iter()
            .find(|s| s.name == space)
            .and_then(|s| s.columns.as_deref())
    }

    /// Stores column (joint) names for a space (saved with the model).
    pub fn set_column_names(&mut self, space: &str, names: Vec<String>) -> Result<()> {
        let known: Vec<String> = self.spaces.iter().map(|s| s.name.clone()).collect();
        let Some(s) = self.spaces.iter_mut().find(|s| s.name == space) else {
            return Err(Error::UnknownSpace {
                name: space.into(),
                known,
            });
        };
        if names.len() != s.data.ncols() {
            return Err(Error::DimensionMismatch {
                what: format!("column names of '{space}'"),
                expected: s.data.ncols(),
                found: names.len(),
            });
        }
        s.columns = Some(names);
        Ok(())
    }

    /// The mean of each input (human) column over the training frames, in the user's units:
    /// the pose the people the model learned from hold on average.
    pub fn input_means(&self) -> Vec<f64> {
        let s = &self.spaces[0];
        let n = s.data.nrows().max(1) as f64;
        (0..s.data.ncols())
            .map(|t| {
                let mean = (0..s.data.nrows()).map(|i| s.data[(i, t)]).sum::<f64>() / n;
                s.offset[t] + s.scale[t] * mean
            })
            .collect()
    }

    /// Per-column offset (mean) and scale of a space's preprocessing.
    pub fn normalisation(&self, space: &str) -> Option<(&[f64], &[f64])> {
        self.spaces
            .iter()
            .find(|s| s.name == space)
            .map(|s| (s.offset.as_slice(), s.scale.as_slice()))
    }
}

#[cfg(test)]
#[path = "model_tests.rs"]
mod tests;
