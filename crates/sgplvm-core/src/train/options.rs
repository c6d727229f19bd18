//! The options of a training run ([`TrainOptions`]): iteration budget, tolerances, L-BFGS
//! history sizes, the wall-clock and evaluation limits and the interrupt, with their builders,
//! serde defaults and checks.

use serde::{Deserialize, Serialize};

use super::Interrupt;
use crate::error::{Error, Result};

/// Options of one training run (full fit, transfer, or the human-to-latent regression).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TrainOptions {
    /// Iteration budget (L-BFGS iterations, each one line search).
    pub max_iters: usize,
    /// Stop when the largest absolute component of the objective's gradient with respect to the
    /// unconstrained vector (log of positive parameters) is below this (scipy's `pgtol`).
    pub grad_tol: f64,
    /// Stop when `(f_prev − f) / max(|f_prev|, |f|, 1)` is below this (scipy's `factr·eps`).
    pub rel_tol: f64,
    /// L-BFGS history size m (every training but the one
    /// [`TrainOptions::back_constraint_memory`] names).
    pub memory: usize,
    /// L-BFGS history size of the exact model's full training with back constraints. Its
    /// weights W are badly conditioned (K_bc's condition number enters the Hessian squared),
    /// so after the first few iterations the optimiser crawls; a longer history reaches a given
    /// objective in about a third fewer evaluations (BENCHMARKS.md, issue 18, eleventh pass).
    /// The first `min(memory, back_constraint_memory)` iterations do not depend on it, so
    /// trainings stopped that early on held-out frames are unchanged.
    #[serde(default = "default_back_constraint_memory")]
    pub back_constraint_memory: usize,
    /// Iteration budget of the GP regression human → latent fitted after training for models
    /// without input back constraints.
    pub map_max_iters: usize,
    /// Wall-clock budget in seconds of the whole call the options are given to (`fit`,
    /// `fit_validated`, `transfer`, …, selection runs and the input map included), from the
    /// moment it starts. Checked between iterations and before every objective evaluation;
    /// when it runs out, training stops with
    /// [`StopReason::TimeLimit`](super::StopReason::TimeLimit) and keeps the best parameters
    /// so far. The call returns after at most one more evaluation and the final
    /// factorisations. `None`: no limit.
    #[serde(default)]
    pub max_seconds: Option<f64>,
    /// Objective evaluations one line search may make (argmin's More–Thuente search has no
    /// cap of its own and can otherwise search forever on badly scaled objectives). A line
    /// search that reaches the cap fails like any failed line search: the solver restarts once
    /// from the best point, and a second failure in a row ends training with
    /// [`StopReason::LineSearch`](super::StopReason::LineSearch). Default
    /// [`TrainOptions::DEFAULT_LINE_SEARCH_EVALUATIONS`].
    #[serde(default = "default_line_search_evaluations")]
    pub max_line_search_evaluations: usize,
    /// Objective evaluations one training run may make in all (the initial point included);
    /// at the cap training stops with
    /// [`StopReason::EvaluationLimit`](super::StopReason::EvaluationLimit), keeping the best
    /// parameters. `None`: bounded only by `max_iters` × `max_line_search_evaluations`.
    #[serde(default)]
    pub max_evaluations: Option<usize>,
    /// Asked before every objective evaluation and between iterations whether training must
    /// stop now (Ctrl-C in the Python module); when it says so, training stops with
    /// [`StopReason::Interrupted`](super::StopReason::Interrupted), keeping the best
    /// parameters. Not serialised.
    #[serde(skip)]
    pub interrupt: Option<Interrupt>,
    /// Train back-constraint weights in the whitened parametrisation `W = K_bc^(−1/2) V`
    /// (the optimiser moves V): the same latent points are reachable, but the problem is far
    /// better conditioned (K_bc's condition number enters once instead of squared), so L-BFGS
    /// needs fewer iterations. A different path through a non-convex objective ends at a
    /// different optimum; off by default (see BENCHMARKS.md, issue 18: on the shipped data
    /// the held-out error was worse with it). Needs the exact model with back constraints
    /// (input or output): [`SharedGplvm::fit`](crate::SharedGplvm::fit) and
    /// [`SharedGplvm::fit_validated`](crate::SharedGplvm::fit_validated) refuse it for free
    /// latent points and sparse models. No effect on transfer (the latent points are frozen).
    #[serde(default)]
    pub whiten_back_constraint: bool,
}

/// serde's default of [`TrainOptions::back_constraint_memory`].
fn default_back_constraint_memory() -> usize {
    TrainOptions::default().back_constraint_memory
}

/// serde's default of [`TrainOptions::max_line_search_evaluations`].
fn default_line_search_evaluations() -> usize {
    TrainOptions::DEFAULT_LINE_SEARCH_EVALUATIONS
}

impl Default for TrainOptions {
    fn default() -> Self {
        Self {
            max_iters: 1000,
            grad_tol: 1e-5,
            rel_tol: 2.2e-9,
            memory: 10,
            back_constraint_memory: 50,
            map_max_iters: 300,
            max_seconds: None,
            max_line_search_evaluations: Self::DEFAULT_LINE_SEARCH_EVALUATIONS,
            max_evaluations: None,
            interrupt: None,
            whiten_back_constraint: false,
        }
    }
}

impl TrainOptions {
    /// Sets the iteration budget.
    pub fn with_max_iters(mut self, n: usize) -> Self {
        self.max_iters = n;
        self
    }
    /// Sets the gradient tolerance.
    pub fn with_grad_tol(mut self, t: f64) -> Self {
        self.grad_tol = t;
        self
    }
    /// Sets the relative objective-change tolerance.
    pub fn with_rel_tol(mut self, t: f64) -> Self {
        self.rel_tol = t;
        self
    }
    /// Sets the L-BFGS history size.
    pub fn with_memory(mut self, m: usize) -> Self {
        self.memory = m;
        self
    }
    /// Sets the L-BFGS history size of back-constrained full training (see
    /// [`TrainOptions::back_constraint_memory`]).
    pub fn with_back_constraint_memory(mut self, m: usize) -> Self {
        self.back_constraint_memory = m;
        self
    }
    /// Sets the wall-clock budget in seconds (`None`: no limit).
    pub fn with_max_seconds(mut self, seconds: Option<f64>) -> Self {
        self.max_seconds = seconds;
        self
    }
    /// Sets the cap on objective evaluations per line search.
    pub fn with_max_line_search_evaluations(mut self, n: usize) -> Self {
        self.max_line_search_evaluations = n;
        self
    }
    /// Sets the cap on objective evaluations per training run (`None`: no cap of its own).
    pub fn with_max_evaluations(mut self, n: Option<usize>) -> Self {
        self.max_evaluations = n;
        self
    }
    /// Sets whether back-constraint weights are trained whitened (see
    /// [`TrainOptions::whiten_back_constraint`]).
    pub fn with_whiten_back_constraint(mut self, whiten: bool) -> Self {
        self.whiten_back_constraint = whiten;
        self
    }
    /// Sets the interrupt check.
    pub fn with_interrupt(mut self, interrupt: Interrupt) -> Self {
        self.interrupt = Some(interrupt);
        self
    }

    /// Objective evaluations one line search may make by default (scipy's L-BFGS-B `maxls`).
    pub const DEFAULT_LINE_SEARCH_EVALUATIONS: usize = 20;

    /// [`TrainOptions::check`], and whether these options can train a model of `config`:
    /// whitening needs back constraints and the exact model.
    pub(crate) fn check_for(&self, config: &crate::config::ModelConfig) -> Result<()> {
        self.check()?;
        if self.whiten_back_constraint {
            let reason = if config.back_constraint == crate::config::BackConstraint::None {
                Some("the model has free latent points (back constraint none); expected input or output back constraints")
            } else if config.inducing.is_some() {
                Some("the sparse model (inducing inputs) trains its weights as they are; expected the exact model")
            } else {
                None
            };
            if let Some(reason) = reason {
                return Err(Error::InvalidValue {
                    what: "TrainOptions::whiten_back_constraint".into(),
                    reason: reason.into(),
                });
            }
        }
        Ok(())
    }

    pub(crate) fn check(&self) -> Result<()> {
        let bad = |what: &str, reason: &str| {
            Err(Error::InvalidValue {
                what: what.into(),
                reason: reason.into(),
            })
        };
        if self.grad_tol.is_nan() || self.grad_tol < 0.0 || !self.grad_tol.is_finite() {
            return bad("TrainOptions::grad_tol", "expected a finite number ≥ 0");
        }
        if self.rel_tol.is_nan() || self.rel_tol < 0.0 || !self.rel_tol.is_finite() {
            return bad("TrainOptions::rel_tol", "expected a finite number ≥ 0");
        }
        if self.memory == 0 {
            return bad("TrainOptions::memory", "expected at least 1");
        }
        if self.back_constraint_memory == 0 {
            return bad(
                "TrainOptions::back_constraint_memory",
                "expected at least 1",
            );
        }
        if self.max_seconds.is_some_and(|s| s.is_nan() || s < 0.0) {
            return bad(
                "TrainOptions::max_seconds",
                "expected a number of seconds ≥ 0 (or None for no limit)",
            );
        }
        if self.max_line_search_evaluations == 0 {
            return bad(
                "TrainOptions::max_line_search_evaluations",
                "expected at least 1",
            );
        }
        Ok(())
    }
}
