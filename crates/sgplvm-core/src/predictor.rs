//! What every kind of trained model offers the programs that use it: its spaces and joint
//! names, human → robot prediction (batch and frame by frame) and latent points
//! ([`Predictor`]); and a model file of either kind, read without knowing which it holds
//! ([`AnyModel`]).

use std::path::Path;

use faer::{Mat, MatRef};

use crate::error::Result;
use crate::io::{read_file, split_header, PARTS_FORMAT_VERSION};
use crate::model::SharedGplvm;
use crate::parts::PartsGplvm;
use crate::predict::Prediction;

/// A trained model as a mapping from human frames to robot joint commands: what prediction,
/// evaluation and the command line need, whatever the model's structure (one shared latent
/// space, or one per body part).
pub trait Predictor {
    /// Name of the input (human) space.
    fn input_name(&self) -> &str;
    /// Names of the output (robot) spaces, in model order.
    fn output_names(&self) -> Vec<&str>;
    /// Number of columns of a space, if the model has it.
    fn space_dim(&self, name: &str) -> Option<usize>;
    /// Column (joint) names of a space, if stored.
    fn column_names(&self, space: &str) -> Option<&[String]>;
    /// Number of latent coordinates of a frame (the columns of [`Predictor::latent`]).
    fn latent_dim(&self) -> usize;
    /// Posterior mean (and optionally variance) of robot `space` for the raw human frames in
    /// the rows of `h`.
    fn predict(&self, h: MatRef<'_, f64>, space: &str, with_variance: bool) -> Result<Prediction>;
    /// Posterior mean of robot `space` for one raw human frame, written to `out`.
    fn predict_frame(&self, h: &[f64], space: &str, out: &mut [f64]) -> Result<()>;
    /// Latent points of raw human frames (n × [`Predictor::latent_dim`]).
    fn latent(&self, h: MatRef<'_, f64>) -> Result<Mat<f64>>;
    /// What users attached to the model ([`SharedGplvm::annotations`]).
    fn annotations(&self) -> &std::collections::BTreeMap<String, serde_json::Value>;
}

impl Predictor for SharedGplvm {
    fn input_name(&self) -> &str {
        SharedGplvm::input_name(self)
    }
    fn output_names(&self) -> Vec<&str> {
        SharedGplvm::output_names(self)
    }
    fn space_dim(&self, name: &str) -> Option<usize> {
        SharedGplvm::space_dim(self, name)
    }
    fn column_names(&self, space: &str) -> Option<&[String]> {
        SharedGplvm::column_names(self, space)
    }
    fn latent_dim(&self) -> usize {
        self.config().latent_dim
    }
    fn predict(&self, h: MatRef<'_, f64>, space: &str, with_variance: bool) -> Result<Prediction> {
        SharedGplvm::predict(self, h, space, with_variance)
    }
    fn predict_frame(&self, h: &[f64], space: &str, out: &mut [f64]) -> Result<()> {
        SharedGplvm::predict_frame(self, h, space, out)
    }
    fn latent(&self, h: MatRef<'_, f64>) -> Result<Mat<f64>> {
        SharedGplvm::latent(self, h)
    }
    fn annotations(&self) -> &std::collections::BTreeMap<String, serde_json::Value> {
        SharedGplvm::annotations(self)
    }
}

impl Predictor for PartsGplvm {
    fn input_name(&self) -> &str {
        PartsGplvm::input_name(self)
    }
    fn output_names(&self) -> Vec<&str> {
        PartsGplvm::output_names(self)
    }
    fn space_dim(&self, name: &str) -> Option<usize> {
        PartsGplvm::space_dim(self, name)
    }
    fn column_names(&self, space: &str) -> Option<&[String]> {
        PartsGplvm::column_names(self, space)
    }
    fn latent_dim(&self) -> usize {
        PartsGplvm::latent_dim(self)
    }
    fn predict(&self, h: MatRef<'_, f64>, space: &str, with_variance: bool) -> Result<Prediction> {
        PartsGplvm::predict(self, h, space, with_variance)
    }
    fn predict_frame(&self, h: &[f64], space: &str, out: &mut [f64]) -> Result<()> {
        PartsGplvm::predict_frame(self, h, space, out)
    }
    fn latent(&self, h: MatRef<'_, f64>) -> Result<Mat<f64>> {
        PartsGplvm::latent(self, h)
    }
    fn annotations(&self) -> &std::collections::BTreeMap<String, serde_json::Value> {
        PartsGplvm::annotations(self)
    }
}

/// A model file of either kind: one shared latent space ([`SharedGplvm`], formats 1–3) or a
/// latent space per body part ([`PartsGplvm`], format 4).
#[derive(Clone, Debug)]
pub enum AnyModel {
    /// One shared latent space.
    Single(SharedGplvm),
    /// A latent space per body part.
    Parts(PartsGplvm),
}

impl AnyModel {
    /// Reads a model of either kind from a file's bytes (the errors of
    /// [`SharedGplvm::from_bytes`] for bad input).
    pub fn from_bytes(bytes: &[u8]) -> Result<AnyModel> {
        let (version, payload) = split_header(bytes)?;
        if version == PARTS_FORMAT_VERSION {
            PartsGplvm::from_payload(payload).map(AnyModel::Parts)
        } else {
            SharedGplvm::from_payload(version, payload).map(AnyModel::Single)
        }
    }

    /// Reads a model file of either kind.
    pub fn load(path: &Path) -> Result<AnyModel> {
        Self::from_bytes(&read_file(path)?)
    }

    /// The model's file bytes.
    pub fn to_bytes(&self) -> Vec<u8> {
        match self {
            AnyModel::Single(m) => m.to_bytes(),
            AnyModel::Parts(m) => m.to_bytes(),
        }
    }

    /// Writes the model file atomically.
    pub fn save(&self, path: &Path) -> Result<()> {
        match self {
            AnyModel::Single(m) => m.save(path),
            AnyModel::Parts(m) => m.save(path),
        }
    }

    /// The model as a [`Predictor`].
    pub fn predictor(&self) -> &dyn Predictor {
        match self {
            AnyModel::Single(m) => m,
            AnyModel::Parts(m) => m,
        }
    }

    /// Number of training frames N.
    pub fn num_points(&self) -> usize {
        match self {
            AnyModel::Single(m) => m.num_points(),
            AnyModel::Parts(m) => m.num_points(),
        }
    }

    /// Attaches `value` under `key` ([`SharedGplvm::annotate`]).
    pub fn annotate(&mut self, key: &str, value: serde_json::Value) {
        match self {
            AnyModel::Single(m) => m.annotate(key, value),
            AnyModel::Parts(m) => m.annotate(key, value),
        }
    }

    /// The mean of each human column over the training frames.
    pub fn input_means(&self) -> Vec<f64> {
        match self {
            AnyModel::Single(m) => m.input_means(),
            AnyModel::Parts(m) => m.input_means(),
        }
    }

    /// The configuration the model (each of its parts) was trained with.
    pub fn config(&self) -> &crate::ModelConfig {
        match self {
            AnyModel::Single(m) => m.config(),
            AnyModel::Parts(m) => m.config(),
        }
    }
}

impl Predictor for AnyModel {
    fn input_name(&self) -> &str {
        self.predictor().input_name()
    }
    fn output_names(&self) -> Vec<&str> {
        self.predictor().output_names()
    }
    fn space_dim(&self, name: &str) -> Option<usize> {
        self.predictor().space_dim(name)
    }
    fn column_names(&self, space: &str) -> Option<&[String]> {
        self.predictor().column_names(space)
    }
    fn latent_dim(&self) -> usize {
        self.predictor().latent_dim()
    }
    fn predict(&self, h: MatRef<'_, f64>, space: &str, with_variance: bool) -> Result<Prediction> {
        self.predictor().predict(h, space, with_variance)
    }
    fn predict_frame(&self, h: &[f64], space: &str, out: &mut [f64]) -> Result<()> {
        self.predictor().predict_frame(h, space, out)
    }
    fn latent(&self, h: MatRef<'_, f64>) -> Result<Mat<f64>> {
        self.predictor().latent(h)
    }
    fn annotations(&self) -> &std::collections::BTreeMap<String, serde_json::Value> {
        self.predictor().annotations()
    }
}
