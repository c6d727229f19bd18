//! L-BFGS training driver around argmin 0.11 (More–Thuente line search, `Vec<f64>` parameters).
//!
//! The solver's own loop is driven in `lbfgs.rs` (`Solver::init` then `Solver::next_iter`) so
//! that every iteration can be recorded, timed and shown to a callback that may stop training.
//!
//! Every run is bounded: each line search may evaluate the objective at most
//! [`TrainOptions::max_line_search_evaluations`] times (argmin's More–Thuente search has no cap
//! of its own), a run at most [`TrainOptions::max_evaluations`] times, and
//! [`TrainOptions::max_seconds`] and [`TrainOptions::interrupt`] are checked before every
//! evaluation and between iterations. Whatever stops training, the best point is kept.
//!
//! | file | what it holds |
//! |---|---|
//! | `options.rs` | [`TrainOptions`]: budgets, tolerances, history sizes, limits; their checks |
//! | `stop.rs` | [`StopReason`], the stop rules, the deadline and [`Interrupt`], the guard |
//! | `lbfgs.rs` | the L-BFGS loop: `minimise`, the capped first trial, the evaluation cache |
//!
//! Each training's history is a list of [`IterationRecord`]s; a callback sees each and answers
//! with a [`Control`].

mod lbfgs;
mod options;
mod stop;

pub(crate) use lbfgs::{minimise, minimise_capped};
pub use options::TrainOptions;
pub(crate) use stop::Limits;
pub use stop::{Interrupt, StopReason};

use serde::{Deserialize, Serialize};

use crate::error::Result;

/// One entry of a model's training history.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct IterationRecord {
    /// Iteration number; 0 is the initial point.
    pub iteration: usize,
    /// Negative log marginal likelihood (whole model, all spaces) after the iteration.
    pub objective: f64,
    /// Seconds since training started, excluding the time spent in the callback.
    pub seconds: f64,
    /// Largest absolute gradient component (unconstrained parametrisation).
    pub gradient_norm: f64,
    /// Objective + gradient evaluations since training started, the initial point's
    /// included (the line searches' trials count; 0 in files written before it was recorded).
    #[serde(default)]
    pub evaluations: usize,
}

/// What a training callback wants.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Control {
    /// Keep training.
    Continue,
    /// Stop now and keep the current parameters.
    Stop,
}

/// A differentiable objective on an unconstrained vector.
pub(crate) trait Objective {
    /// Objective value; writes the gradient into `grad` (same length as `theta`).
    fn eval(&self, theta: &[f64], grad: &mut [f64]) -> Result<f64>;
}

#[cfg(test)]
mod tests;
