//! # sgplvm
//!
//! Teach a family of robots the same motions from one set of human demonstrations: a shared
//! Gaussian-process latent variable model between human and robot joint spaces, trained fully
//! on one robot and transferred to others (see the README and `../shared/paper.md`).
//!
//! This facade joins the statistical core ([`core`], which knows nothing of robots) and the
//! robot crate ([`robots`], which knows nothing of statistics): it turns demonstration files into
//! the core's matrices, runs the paper's experiments and draws the pictures. The `sgplvm`
//! command-line program is built on it.

#![deny(clippy::unwrap_used)]

pub use sgplvm_capture as capture;
pub use sgplvm_core as core;
pub use sgplvm_core::{
    AnyModel, BackConstraint, Mat, ModelConfig, PartsConfig, PartsGplvm, Predictor, SharedGplvm,
    StopReason, TrainOptions, Validation,
};
pub use sgplvm_robots as robots;
pub use sgplvm_robots::Robot;

pub mod arms;
pub mod csv;
pub mod experiment;
pub mod figures;
pub mod files;
pub mod girdle;
pub mod pipeline;
pub mod plots;
pub mod provenance;
pub mod results;
pub mod stats;
