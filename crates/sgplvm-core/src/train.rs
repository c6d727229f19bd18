//! L-BFGS training driver around argmin 0.11 (More–Thuente line search, `Vec<f64>` parameters).
//!
//! The solver's own loop is driven here (`Solver::init` then `Solver::next_iter`) so that every
//! iteration can be recorded, timed and shown to a callback that may stop training.
//!
//! Every run is bounded: each line search may evaluate the objective at most
//! [`TrainOptions::max_line_search_evaluations`] times (argmin's More–Thuente search has no cap
//! of its own), a run at most [`TrainOptions::max_evaluations`] times, and
//! [`TrainOptions::max_seconds`] and [`TrainOptions::interrupt`] are checked before every
//! evaluation and between iterations. Whatever stops training, the best point is kept.

use std::fmt;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use argmin::core::{CostFunction, Gradient, IterState, Problem, Solver, State};
use argmin::solver::linesearch::{LineSearch, MoreThuenteLineSearch};
use argmin::solver::quasinewton::LBFGS;
use serde::{Deserialize, Serialize};

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
    /// when it runs out, training stops with [`StopReason::TimeLimit`] and keeps the best
    /// parameters so far. The call returns after at most one more evaluation and the final
    /// factorisations. `None`: no limit.
    #[serde(default)]
    pub max_seconds: Option<f64>,
    /// Objective evaluations one line search may make (argmin's More–Thuente search has no
    /// cap of its own and can otherwise search forever on badly scaled objectives). A line
    /// search that reaches the cap fails like any failed line search: the solver restarts once
    /// from the best point, and a second failure in a row ends training with
    /// [`StopReason::LineSearch`]. Default [`TrainOptions::DEFAULT_LINE_SEARCH_EVALUATIONS`].
    #[serde(default = "default_line_search_evaluations")]
    pub max_line_search_evaluations: usize,
    /// Objective evaluations one training run may make in all (the initial point included);
    /// at the cap training stops with [`StopReason::EvaluationLimit`], keeping the best
    /// parameters. `None`: bounded only by `max_iters` × `max_line_search_evaluations`.
    #[serde(default)]
    pub max_evaluations: Option<usize>,
    /// Asked before every objective evaluation and between iterations whether training must
    /// stop now (Ctrl-C in the Python module); when it says so, training stops with
    /// [`StopReason::Interrupted`], keeping the best parameters. Not serialised.
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

/// A check, asked between objective evaluations, of whether training must stop now (see
/// [`TrainOptions::interrupt`]). It is called from the training thread, once per evaluation:
/// keep it cheap (rate-limit anything expensive inside it).
#[derive(Clone)]
pub struct Interrupt(Arc<dyn Fn() -> bool + Send + Sync>);

impl Interrupt {
    /// An interrupt that stops training when `should_stop` returns true.
    pub fn new(should_stop: impl Fn() -> bool + Send + Sync + 'static) -> Self {
        Self(Arc::new(should_stop))
    }

    /// True when training must stop now.
    pub fn should_stop(&self) -> bool {
        (self.0)()
    }
}

impl fmt::Debug for Interrupt {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("Interrupt(..)")
    }
}

impl PartialEq for Interrupt {
    /// The same check (clones of one interrupt are equal).
    fn eq(&self, other: &Self) -> bool {
        Arc::ptr_eq(&self.0, &other.0)
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

/// What stops a training call from outside its iterations: the deadline `max_seconds` set
/// when the call started, and the interrupt. Made once per call and shared by its runs.
#[derive(Clone, Debug, Default)]
pub(crate) struct Limits {
    deadline: Option<Instant>,
    interrupt: Option<Interrupt>,
}

impl Limits {
    /// The limits of a call that starts now with `options`.
    pub(crate) fn start(options: &TrainOptions) -> Self {
        let now = Instant::now();
        Self {
            deadline: options.max_seconds.and_then(|s| {
                Duration::try_from_secs_f64(s)
                    .ok()
                    .and_then(|d| now.checked_add(d))
            }),
            interrupt: options.interrupt.clone(),
        }
    }

    /// These limits with the deadline brought forward to `fraction` of the time left (for a
    /// run that must leave time to the runs after it).
    pub(crate) fn share(&self, fraction: f64) -> Self {
        let now = Instant::now();
        Self {
            deadline: self.deadline.map(|d| {
                let left = d.saturating_duration_since(now);
                now + left.mul_f64(fraction.clamp(0.0, 1.0))
            }),
            interrupt: self.interrupt.clone(),
        }
    }

    /// Why training must stop now, if it must: the deadline has passed or the interrupt says so.
    pub(crate) fn check(&self) -> Option<StopReason> {
        if self.deadline.is_some_and(|d| Instant::now() >= d) {
            Some(StopReason::TimeLimit)
        } else if self.interrupt.as_ref().is_some_and(Interrupt::should_stop) {
            Some(StopReason::Interrupted)
        } else {
            None
        }
    }
}

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

/// Why training ended.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[non_exhaustive]
pub enum StopReason {
    /// Gradient below `grad_tol`.
    GradientTolerance,
    /// Relative objective change below `rel_tol`.
    RelativeTolerance,
    /// Iteration budget used up.
    MaxIterations,
    /// The callback returned [`Control::Stop`].
    Callback,
    /// The line search could not find a better point (the best point is kept).
    LineSearch(String),
    /// Nothing to train (no free parameters).
    NothingToTrain,
    /// The wall-clock budget [`TrainOptions::max_seconds`] ran out (the best point is kept).
    TimeLimit,
    /// The evaluation budget [`TrainOptions::max_evaluations`] was used up (the best point is
    /// kept).
    EvaluationLimit,
    /// [`TrainOptions::interrupt`] asked training to stop (the best point is kept).
    Interrupted,
    /// The iteration budget chosen on held-out frames was reached: the final training on all
    /// frames ran for the iteration count at which the held-out error was lowest (the model's
    /// `Selection` says how it was chosen). Recorded instead of [`StopReason::MaxIterations`]
    /// when that budget, not the caller's `max_iters`, ended training (issue 38). Model files
    /// written before it hold `MaxIterations` there and are read as this (see the `io`
    /// module).
    ValidatedBudget,
}

impl StopReason {
    /// The reason's name in snake case: `gradient_tolerance`, `relative_tolerance`,
    /// `max_iterations`, `callback`, `line_search`, `nothing_to_train`, `time_limit`,
    /// `evaluation_limit`, `interrupted` or `validated_budget`.
    pub fn name(&self) -> &'static str {
        match self {
            Self::GradientTolerance => "gradient_tolerance",
            Self::RelativeTolerance => "relative_tolerance",
            Self::MaxIterations => "max_iterations",
            Self::Callback => "callback",
            Self::LineSearch(_) => "line_search",
            Self::NothingToTrain => "nothing_to_train",
            Self::TimeLimit => "time_limit",
            Self::EvaluationLimit => "evaluation_limit",
            Self::Interrupted => "interrupted",
            Self::ValidatedBudget => "validated_budget",
        }
    }
}

/// What happened, in words: `converged: gradient below tolerance`, `iteration budget used up`,
/// `validated budget reached`, ….
impl fmt::Display for StopReason {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::GradientTolerance => f.write_str("converged: gradient below tolerance"),
            Self::RelativeTolerance => f.write_str("converged: objective change below tolerance"),
            Self::MaxIterations => f.write_str("iteration budget used up"),
            Self::Callback => f.write_str("stopped by the callback"),
            Self::LineSearch(why) => write!(f, "line search found no better point ({why})"),
            Self::NothingToTrain => f.write_str("nothing to train"),
            Self::TimeLimit => f.write_str("time limit reached, best parameters kept"),
            Self::EvaluationLimit => f.write_str("evaluation limit reached, best parameters kept"),
            Self::Interrupted => f.write_str("interrupted, best parameters kept"),
            Self::ValidatedBudget => f.write_str("validated budget reached"),
        }
    }
}

/// A differentiable objective on an unconstrained vector.
pub(crate) trait Objective {
    /// Objective value; writes the gradient into `grad` (same length as `theta`).
    fn eval(&self, theta: &[f64], grad: &mut [f64]) -> Result<f64>;
}

/// Cost returned to the line search for a point where the objective cannot be evaluated
/// (non-positive-definite kernel, overflow): large and finite, so More–Thuente backtracks.
const FAILED_COST: f64 = 1e300;

/// Last evaluated point: parameters and, if it could be evaluated, the objective and gradient
/// (unscaled).
type Evaluated = (Vec<f64>, Option<(f64, Vec<f64>)>);

/// Counts a run's objective evaluations and refuses the next one when a limit is reached: the
/// line search's cap (the line search then fails), the run's cap, the deadline or the
/// interrupt (training then stops, for the reason kept here).
struct Guard<'a> {
    options: &'a TrainOptions,
    limits: &'a Limits,
    state: Mutex<GuardState>,
}

#[derive(Default)]
struct GuardState {
    /// Evaluations in the run, the initial point included.
    total: usize,
    /// Evaluations since the current line search began.
    in_line_search: usize,
    /// Why training must stop, once a limit other than the line search's was reached.
    stop: Option<StopReason>,
}

/// An evaluation the guard refused.
struct Refused;

impl<'a> Guard<'a> {
    fn new(options: &'a TrainOptions, limits: &'a Limits) -> Self {
        Self {
            options,
            limits,
            state: Mutex::new(GuardState {
                total: 1,
                ..GuardState::default()
            }),
        }
    }

    /// Lets one more evaluation happen, or says why not.
    fn admit(&self) -> std::result::Result<(), Refused> {
        let mut s = crate::pool::lock(&self.state);
        if s.stop.is_some() {
            return Err(Refused);
        }
        if self.options.max_evaluations.is_some_and(|m| s.total >= m) {
            s.stop = Some(StopReason::EvaluationLimit);
            return Err(Refused);
        }
        if let Some(reason) = self.limits.check() {
            s.stop = Some(reason);
            return Err(Refused);
        }
        if s.in_line_search >= self.options.max_line_search_evaluations {
            return Err(Refused);
        }
        s.total += 1;
        s.in_line_search += 1;
        Ok(())
    }

    /// Evaluations so far, the initial point's included.
    fn evaluations(&self) -> usize {
        crate::pool::lock(&self.state).total
    }

    /// Starts counting the evaluations of a new line search.
    fn new_line_search(&self) {
        crate::pool::lock(&self.state).in_line_search = 0;
    }

    /// Why training must stop now, if it must (a limit reached during an evaluation, or now).
    fn stop(&self) -> Option<StopReason> {
        let mut s = crate::pool::lock(&self.state);
        if s.stop.is_none() {
            if self.options.max_evaluations.is_some_and(|m| s.total >= m) {
                s.stop = Some(StopReason::EvaluationLimit);
            } else {
                s.stop = self.limits.check();
            }
        }
        s.stop.clone()
    }
}

/// Evaluates `obj` at `theta` through a one-entry cache: the line search asks for the cost and
/// the gradient of the same point separately, and the training loop asks once more for the
/// point the solver accepted — one evaluation serves all three. A new evaluation must first
/// be admitted by `guard`.
fn eval_cached<O: Objective>(
    obj: &O,
    cache: &Mutex<Option<Evaluated>>,
    guard: &Guard<'_>,
    theta: &[f64],
) -> std::result::Result<Option<(f64, Vec<f64>)>, Refused> {
    let mut guard_cache = crate::pool::lock(cache);
    if let Some((t, result)) = guard_cache.as_ref() {
        if t.as_slice() == theta {
            return Ok(result.clone());
        }
    }
    guard.admit()?;
    let mut grad = vec![0.0; theta.len()];
    let result = match obj.eval(theta, &mut grad) {
        Ok(f) if f.is_finite() && grad.iter().all(|g| g.is_finite()) => Some((f, grad)),
        _ => None,
    };
    *guard_cache = Some((theta.to_vec(), result.clone()));
    Ok(result)
}

struct Op<'a, O: Objective> {
    obj: &'a O,
    scale: f64,
    cache: &'a Mutex<Option<Evaluated>>,
    guard: &'a Guard<'a>,
}

impl<O: Objective> Op<'_, O> {
    /// Scaled objective and gradient as the solver sees them; an error when the guard
    /// refuses the evaluation (the solver's iteration then fails).
    fn eval(&self, theta: &[f64]) -> std::result::Result<(f64, Vec<f64>), argmin::core::Error> {
        match eval_cached(self.obj, self.cache, self.guard, theta) {
            Err(Refused) => Err(argmin::core::Error::msg(
                "objective evaluation refused: an evaluation limit was reached",
            )),
            Ok(Some((f, g))) => Ok((
                f * self.scale,
                g.into_iter().map(|g| g * self.scale).collect(),
            )),
            Ok(None) => Ok((FAILED_COST, vec![0.0; theta.len()])),
        }
    }
}

impl<O: Objective> CostFunction for Op<'_, O> {
    type Param = Vec<f64>;
    type Output = f64;
    fn cost(&self, p: &Vec<f64>) -> std::result::Result<f64, argmin::core::Error> {
        Ok(self.eval(p)?.0)
    }
}

impl<O: Objective> Gradient for Op<'_, O> {
    type Param = Vec<f64>;
    type Gradient = Vec<f64>;
    fn gradient(&self, p: &Vec<f64>) -> std::result::Result<Vec<f64>, argmin::core::Error> {
        Ok(self.eval(p)?.1)
    }
}

/// Outcome of [`minimise`].
pub(crate) struct Outcome {
    pub theta: Vec<f64>,
    pub history: Vec<IterationRecord>,
    pub reason: StopReason,
}

/// The objective's scale under which argmin's first L-BFGS step, the scaled gradient, has
/// unit length: 1/‖g‖₂, or 1 when that is not a finite positive number (a zero or non-finite
/// gradient, which training handles on its own).
fn unit_first_step(g: &[f64]) -> f64 {
    let scale = 1.0 / g.iter().map(|v| v * v).sum::<f64>().sqrt();
    if scale.is_finite() && scale > 0.0 {
        scale
    } else {
        1.0
    }
}

fn max_abs(g: &[f64]) -> f64 {
    g.iter().fold(0.0, |m, v| m.max(v.abs()))
}

/// Minimises `obj` from `theta0` with L-BFGS. `on_iter` sees every accepted iteration and the
/// current vector. `limits` (the calling training's deadline and interrupt) and the options'
/// evaluation caps bound the run.
///
/// The first step (and the first after a restart) is a steepest-descent step of unit length,
/// as L-BFGS-B takes it: the solver sees the objective divided by its gradient's norm at the
/// start point, so that argmin's first step (the gradient itself, H₀ = I) has length 1. Later
/// steps do not depend on that scale (H₀ = sᵀy / yᵀy adapts to it); records keep the true
/// objective. The start matters: on the bench's problem a first step of the gradient times
/// 1/(N·ΣD), this function's rule before, took about twice the evaluations (1,425 against 757)
/// to cover 99.9 % of the way from the start to the optimum (BENCHMARKS.md, "fifth pass").
pub(crate) fn minimise<O: Objective>(
    obj: &O,
    theta0: Vec<f64>,
    options: &TrainOptions,
    limits: &Limits,
    on_iter: impl FnMut(&IterationRecord, &[f64]) -> Control,
) -> Result<Outcome> {
    minimise_capped(obj, theta0, options, limits, f64::INFINITY, on_iter)
}

/// [`minimise`] whose line searches each try first a point at most `first_trial` away from
/// where they start (Euclidean norm of the change of θ): the quasi-Newton step is shortened to
/// that length when it is longer. The line search may still go further once it has seen the
/// objective there; only its first guess is bounded. `f64::INFINITY` is [`minimise`].
///
/// For θ made of log-parameters (a transfer's kernel) a first trial of length 1 changes them
/// by at most a factor e. Uncapped, the bench's transfer tried e^−7.6 of the noise after its
/// first step, and spent an evaluation learning that it went too far (BENCHMARKS.md, issue 18,
/// tenth pass).
pub(crate) fn minimise_capped<O: Objective>(
    obj: &O,
    theta0: Vec<f64>,
    options: &TrainOptions,
    limits: &Limits,
    first_trial: f64,
    mut on_iter: impl FnMut(&IterationRecord, &[f64]) -> Control,
) -> Result<Outcome> {
    options.check()?;
    let start = Instant::now();
    // Initial point must be evaluable: its error is the user's error.
    let mut g0 = vec![0.0; theta0.len()];
    let f0 = obj.eval(&theta0, &mut g0)?;
    let cache = Mutex::new(
        (f0.is_finite() && g0.iter().all(|g| g.is_finite()))
            .then(|| (theta0.clone(), Some((f0, g0.clone())))),
    );
    let guard = Guard::new(options, limits);
    let mut run = Run {
        start,
        paused: 0.0,
        history: vec![IterationRecord {
            iteration: 0,
            objective: f0,
            seconds: start.elapsed().as_secs_f64(),
            gradient_norm: max_abs(&g0),
            evaluations: 1,
        }],
        best: theta0,
        best_f: f0,
        best_g: g0,
    };
    if let Some(reason) = stop_before_start(&run.best, &run.best_g, options) {
        return Ok(run.finish(reason));
    }
    // A fresh problem and L-BFGS (empty memory) started at the best point, whose objective
    // and gradient are handed over (no evaluation). The problem is recreated too: argmin
    // 0.11's L-BFGS does not hand the problem back after a failed line search.
    let fresh = |run: &Run| -> Result<(Problem<Op<'_, O>>, Lbfgs, St)> {
        let scale = unit_first_step(&run.best_g);
        let mut problem = Problem::new(Op {
            obj,
            scale,
            cache: &cache,
            guard: &guard,
        });
        let search = FirstTrialCapped {
            search: MoreThuenteLineSearch::new(),
            first_trial,
        };
        let mut solver: Lbfgs = LBFGS::new(search, options.memory);
        let mut start = IterState::new().param(run.best.clone());
        if run.best_f.is_finite() && run.best_g.iter().all(|g| g.is_finite()) {
            start = start
                .cost(run.best_f * scale)
                .gradient(run.best_g.iter().map(|g| g * scale).collect());
        }
        let (state, _) = solver
            .init(&mut problem, start)
            .map_err(|e| Error::InvalidValue {
                what: "L-BFGS initialisation".into(),
                reason: e.to_string(),
            })?;
        Ok((problem, solver, state))
    };
    // A start the guard refused to evaluate (only a non-finite start is evaluated again) ends
    // training for the guard's reason.
    let (mut problem, mut solver, mut state) = match fresh(&run) {
        Ok(started) => started,
        Err(e) => return guard.stop().map(|r| run.finish(r)).ok_or(e),
    };
    // After a failed line search the solver is restarted once from the best point with an
    // empty memory (steepest descent step); a second failure in a row ends training.
    let mut restarted = false;
    loop {
        if run.history.len() > options.max_iters {
            return Ok(run.finish(StopReason::MaxIterations));
        }
        if let Some(reason) = guard.stop() {
            return Ok(run.finish(reason));
        }
        guard.new_line_search();
        let (accepted, failure) = step(
            &mut solver,
            &mut problem,
            &mut state,
            obj,
            &cache,
            &guard,
            run.best_f,
        );
        if let Some((param, f, g)) = accepted {
            restarted = false;
            if let Some(reason) =
                run.accept(param, f, g, guard.evaluations(), options, &mut on_iter)
            {
                return Ok(run.finish(reason));
            }
        }
        if let Some(reason) = guard.stop() {
            return Ok(run.finish(reason));
        }
        if let Some(msg) = failure {
            if restarted {
                return Ok(run.finish(StopReason::LineSearch(msg)));
            }
            restarted = true;
            (problem, solver, state) = match fresh(&run) {
                Ok(started) => started,
                Err(e) => return guard.stop().map(|r| run.finish(r)).ok_or(e),
            };
        }
    }
}

type Lbfgs = LBFGS<FirstTrialCapped, Vec<f64>, Vec<f64>, f64>;

/// argmin's More–Thuente line search, its first trial bounded in length (see
/// [`minimise_capped`]): when L-BFGS hands it a search direction longer than `first_trial`,
/// its first step is shortened from 1 (the whole direction) to `first_trial` long.
#[derive(Clone)]
struct FirstTrialCapped {
    search: MoreThuenteLineSearch<Vec<f64>, Vec<f64>, f64>,
    first_trial: f64,
}

impl LineSearch<Vec<f64>, f64> for FirstTrialCapped {
    fn search_direction(&mut self, direction: Vec<f64>) {
        let length = direction.iter().map(|v| v * v).sum::<f64>().sqrt();
        let step = if length > self.first_trial {
            self.first_trial / length
        } else {
            1.0
        };
        // Positive and finite unless the direction is not (the search then refuses it).
        let _ = self.search.initial_step_length(step);
        self.search.search_direction(direction);
    }

    fn initial_step_length(&mut self, step: f64) -> std::result::Result<(), argmin::core::Error> {
        self.search.initial_step_length(step)
    }
}

impl<P> Solver<P, St> for FirstTrialCapped
where
    MoreThuenteLineSearch<Vec<f64>, Vec<f64>, f64>: Solver<P, St>,
{
    fn name(&self) -> &str {
        "More-Thuente, first trial capped"
    }

    fn init(&mut self, problem: &mut Problem<P>, state: St) -> SolverStep {
        self.search.init(problem, state)
    }

    fn next_iter(&mut self, problem: &mut Problem<P>, state: St) -> SolverStep {
        self.search.next_iter(problem, state)
    }

    fn terminate(&mut self, state: &St) -> argmin::core::TerminationStatus {
        self.search.terminate(state)
    }
}

/// What a solver's step returns in argmin.
type SolverStep = std::result::Result<(St, Option<argmin::core::KV>), argmin::core::Error>;
type St = IterState<Vec<f64>, Vec<f64>, (), (), (), f64>;

/// Why training ends before its first iteration, if it does: nothing to train, a start that
/// already meets the gradient tolerance, or no iteration budget.
fn stop_before_start(theta0: &[f64], g0: &[f64], options: &TrainOptions) -> Option<StopReason> {
    if theta0.is_empty() {
        Some(StopReason::NothingToTrain)
    } else if max_abs(g0) < options.grad_tol {
        Some(StopReason::GradientTolerance)
    } else if options.max_iters == 0 {
        Some(StopReason::MaxIterations)
    } else {
        None
    }
}

/// A point the solver moved to: parameters, objective, gradient.
type Point = (Vec<f64>, f64, Vec<f64>);

/// One L-BFGS iteration from `state`. Returns the point to accept, if the solver reached one no
/// worse than `best_f`, and the reason the solver must be restarted, if it must (a failed or
/// terminated line search, or a worse point).
fn step<O: Objective>(
    solver: &mut Lbfgs,
    problem: &mut Problem<Op<'_, O>>,
    state: &mut St,
    obj: &O,
    cache: &Mutex<Option<Evaluated>>,
    guard: &Guard<'_>,
    best_f: f64,
) -> (Option<Point>, Option<String>) {
    let mut new_state = match solver.next_iter(problem, state.clone()) {
        Err(e) => return (None, Some(e.to_string())),
        Ok((new_state, _)) => new_state,
    };
    new_state.increment_iter();
    let terminated = new_state.terminated();
    let outcome = match new_state.get_param().cloned() {
        None => (
            None,
            Some(format!("{:?}", new_state.get_termination_reason())),
        ),
        Some(param) => {
            let (f, g) = eval_cached(obj, cache, guard, &param)
                .ok()
                .flatten()
                .unwrap_or((f64::INFINITY, Vec::new()));
            if !f.is_finite() || f > best_f {
                (None, Some("line search returned a worse point".into()))
            } else {
                let failure =
                    terminated.then(|| format!("{:?}", new_state.get_termination_reason()));
                (Some((param, f, g)), failure)
            }
        }
    };
    *state = new_state;
    outcome
}

/// The record of a training run in progress: the history, the best point so far (with its
/// objective and gradient) and the time spent in callbacks (not counted in the records'
/// seconds).
struct Run {
    start: Instant,
    paused: f64,
    history: Vec<IterationRecord>,
    best: Vec<f64>,
    best_f: f64,
    best_g: Vec<f64>,
}

impl Run {
    /// Records an accepted point, shows it to `on_iter` and returns why training stops there,
    /// if it does (callback, gradient tolerance, relative decrease).
    fn accept(
        &mut self,
        param: Vec<f64>,
        f: f64,
        g: Vec<f64>,
        evaluations: usize,
        options: &TrainOptions,
        on_iter: &mut impl FnMut(&IterationRecord, &[f64]) -> Control,
    ) -> Option<StopReason> {
        let rel = (self.best_f - f) / self.best_f.abs().max(f.abs()).max(1.0);
        self.best = param;
        self.best_f = f;
        let record = IterationRecord {
            iteration: self.history.len(),
            objective: f,
            seconds: self.start.elapsed().as_secs_f64() - self.paused,
            gradient_norm: max_abs(&g),
            evaluations,
        };
        self.best_g = g;
        self.history.push(record.clone());
        let t = Instant::now();
        let control = on_iter(&record, &self.best);
        self.paused += t.elapsed().as_secs_f64();
        if control == Control::Stop {
            Some(StopReason::Callback)
        } else if record.gradient_norm < options.grad_tol {
            Some(StopReason::GradientTolerance)
        } else if rel < options.rel_tol {
            Some(StopReason::RelativeTolerance)
        } else {
            None
        }
    }

    /// The outcome: the best point, the history and why training stopped.
    fn finish(self, reason: StopReason) -> Outcome {
        Outcome {
            theta: self.best,
            history: self.history,
            reason,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// No deadline, no interrupt.
    fn none() -> Limits {
        Limits::default()
    }

    struct Rosenbrock;
    impl Objective for Rosenbrock {
        fn eval(&self, t: &[f64], g: &mut [f64]) -> Result<f64> {
            let (x, y) = (t[0], t[1]);
            g[0] = -2.0 * (1.0 - x) - 400.0 * x * (y - x * x);
            g[1] = 200.0 * (y - x * x);
            Ok((1.0 - x).powi(2) + 100.0 * (y - x * x).powi(2))
        }
    }

    /// `weight`·‖θ‖²: a bowl whose gradient's size `weight` sets.
    struct Bowl {
        weight: f64,
    }
    impl Objective for Bowl {
        fn eval(&self, t: &[f64], g: &mut [f64]) -> Result<f64> {
            for (gi, ti) in g.iter_mut().zip(t) {
                *gi = 2.0 * self.weight * ti;
            }
            Ok(self.weight * t.iter().map(|v| v * v).sum::<f64>())
        }
    }

    /// What a run did, in order: an evaluation at a point, or the acceptance of an iterate.
    enum Step {
        Evaluated(f64),
        Accepted(f64),
    }

    /// A one-dimensional bowl that logs every point it is evaluated at.
    struct LoggedBowl<'a> {
        bowl: Bowl,
        log: &'a Mutex<Vec<Step>>,
    }
    impl Objective for LoggedBowl<'_> {
        fn eval(&self, t: &[f64], g: &mut [f64]) -> Result<f64> {
            crate::pool::lock(self.log).push(Step::Evaluated(t[0]));
            self.bowl.eval(t, g)
        }
    }

    /// The longest first trial of any line search of a run from 1000 on 10⁻³ θ², as far from
    /// the iterate the search starts at. Uncapped, the first search tries 999 and extrapolates
    /// to 659; the second, with the secant's exact curvature, tries the minimum 0 at once.
    fn longest_first_trial(first_trial: f64) -> f64 {
        let log = Mutex::new(Vec::new());
        let obj = LoggedBowl {
            bowl: Bowl { weight: 1e-3 },
            log: &log,
        };
        let opts = TrainOptions::default().with_max_iters(5);
        minimise_capped(
            &obj,
            vec![1000.0],
            &opts,
            &none(),
            first_trial,
            |_, theta| {
                crate::pool::lock(&log).push(Step::Accepted(theta[0]));
                Control::Continue
            },
        )
        .expect("runs");
        let (mut from, mut first, mut longest) = (1000.0, true, 0.0f64);
        // The start's own evaluation comes first; each search begins after an acceptance.
        for step in &log.into_inner().expect("log")[1..] {
            match *step {
                Step::Evaluated(at) if first => {
                    longest = longest.max((at - from).abs());
                    first = false;
                }
                Step::Evaluated(_) => {}
                Step::Accepted(at) => (from, first) = (at, true),
            }
        }
        longest
    }

    #[test]
    fn a_capped_search_tries_no_farther_than_its_cap_first() {
        // Uncapped, L-BFGS's second search starts with the secant's whole step, 659 long.
        assert!(longest_first_trial(f64::INFINITY) > 600.0);
        let capped = longest_first_trial(1.0);
        assert!(
            capped <= 1.0 + 1e-9,
            "first trial {capped} beyond the cap 1"
        );
    }

    #[test]
    fn first_step_has_unit_length_whatever_the_objectives_scale() {
        // From (3, 4) the unit step along −g lands on (2.4, 3.2), which meets the strong Wolfe
        // conditions on ‖θ‖², so the line search accepts it as it is (L-BFGS-B's first step).
        // The step −g itself, whatever its scale, would land elsewhere.
        for weight in [1.0, 1e-3, 1e4] {
            let mut first = None;
            minimise(
                &Bowl { weight },
                vec![3.0, 4.0],
                &TrainOptions::default().with_max_iters(1),
                &none(),
                |_, theta| {
                    first.get_or_insert_with(|| theta.to_vec());
                    Control::Continue
                },
            )
            .expect("runs");
            let first = first.expect("one iteration accepted");
            assert!(
                (first[0] - 2.4).abs() < 1e-12 && (first[1] - 3.2).abs() < 1e-12,
                "weight {weight}: first iterate {first:?}"
            );
        }
    }

    #[test]
    fn minimises_rosenbrock_monotonically() {
        let opts = TrainOptions::default()
            .with_grad_tol(1e-8)
            .with_rel_tol(0.0);
        let out = minimise(&Rosenbrock, vec![-1.2, 1.0], &opts, &none(), |_, _| {
            Control::Continue
        })
        .expect("runs");
        assert!(
            (out.theta[0] - 1.0).abs() < 1e-5 && (out.theta[1] - 1.0).abs() < 1e-5,
            "{:?}",
            out.theta
        );
        for w in out.history.windows(2) {
            assert!(w[1].objective <= w[0].objective);
        }
        assert!(out.history.len() < 200);
    }

    /// Rosenbrock that records every point it is evaluated at.
    struct Recording(Mutex<Vec<Vec<f64>>>);
    impl Objective for Recording {
        fn eval(&self, t: &[f64], g: &mut [f64]) -> Result<f64> {
            self.0.lock().expect("not poisoned").push(t.to_vec());
            Rosenbrock.eval(t, g)
        }
    }

    #[test]
    fn no_point_is_evaluated_twice_in_a_row() {
        let obj = Recording(Mutex::new(Vec::new()));
        let opts = TrainOptions::default().with_max_iters(30);
        let out = minimise(&obj, vec![-1.2, 1.0], &opts, &none(), |_, _| {
            Control::Continue
        })
        .expect("runs");
        let points = obj.0.into_inner().expect("not poisoned");
        for w in points.windows(2) {
            assert_ne!(w[0], w[1], "the same point was evaluated twice in a row");
        }
        // One evaluation per iteration plus the line search's extra trials, not two per iteration.
        let iterations = out.history.len() - 1;
        assert!(
            points.len() < 2 * iterations,
            "{} evaluations for {iterations} iterations",
            points.len()
        );
        // The history counts them: one at the start, never fewer than one per iteration, and
        // at the last iteration (the budget's) every evaluation made.
        assert_eq!(out.history[0].evaluations, 1);
        for w in out.history.windows(2) {
            assert!(w[1].evaluations > w[0].evaluations, "{w:?}");
        }
        assert_eq!(out.history[iterations].evaluations, points.len());
    }

    /// x² shifted, undefined (an error, like a non-PD kernel) left of −0.5.
    struct Walled;
    impl Objective for Walled {
        fn eval(&self, t: &[f64], g: &mut [f64]) -> Result<f64> {
            if t[0] < -0.5 {
                return Err(Error::NotPositiveDefinite {
                    space: "wall".into(),
                    jitter: 1e-2,
                });
            }
            g[0] = 2.0 * (t[0] + 0.4);
            Ok((t[0] + 0.4).powi(2))
        }
    }

    #[test]
    fn failed_evaluations_are_backtracked_not_fatal() {
        let opts = TrainOptions::default().with_grad_tol(1e-9);
        let out =
            minimise(&Walled, vec![3.0], &opts, &none(), |_, _| Control::Continue).expect("runs");
        assert!((out.theta[0] + 0.4).abs() < 1e-6, "{:?}", out.theta);
        // The initial point must be valid: its failure is the caller's error.
        assert!(minimise(&Walled, vec![-1.0], &opts, &none(), |_, _| {
            Control::Continue
        })
        .is_err());
    }

    #[test]
    fn callback_stops_and_budget_holds() {
        let opts = TrainOptions::default();
        let mut calls = 0;
        let out = minimise(&Rosenbrock, vec![-1.2, 1.0], &opts, &none(), |r, _| {
            calls += 1;
            if r.iteration == 3 {
                Control::Stop
            } else {
                Control::Continue
            }
        })
        .expect("runs");
        assert_eq!(calls, 3);
        assert_eq!(out.reason, StopReason::Callback);
        assert_eq!(out.history.len(), 4);
        let out = minimise(
            &Rosenbrock,
            vec![-1.2, 1.0],
            &opts.with_max_iters(5),
            &none(),
            |_, _| Control::Continue,
        )
        .expect("runs");
        assert_eq!(out.reason, StopReason::MaxIterations);
        assert_eq!(out.history.last().map(|r| r.iteration), Some(5));
    }

    /// f(x) = −x₀: unbounded below, so More–Thuente extrapolates along every descent direction
    /// (hundreds of evaluations before the step overflows, without a cap).
    struct Unbounded(Mutex<usize>);
    impl Objective for Unbounded {
        fn eval(&self, t: &[f64], g: &mut [f64]) -> Result<f64> {
            *self.0.lock().expect("not poisoned") += 1;
            g[0] = -1.0;
            Ok(-t[0])
        }
    }

    #[test]
    fn every_line_search_is_capped() {
        for cap in [1, 5, TrainOptions::DEFAULT_LINE_SEARCH_EVALUATIONS] {
            let obj = Unbounded(Mutex::new(0));
            let opts = TrainOptions::default()
                .with_max_iters(50)
                .with_max_line_search_evaluations(cap);
            let out =
                minimise(&obj, vec![0.0], &opts, &none(), |_, _| Control::Continue).expect("runs");
            let evaluations = obj.0.into_inner().expect("not poisoned");
            // Every loop round is one line search; at most two rounds in a row accept nothing.
            let rounds = 2 * out.history.len() + 2;
            assert!(
                evaluations <= 1 + rounds * cap,
                "cap {cap}: {evaluations} evaluations in {} iterations ({:?})",
                out.history.len() - 1,
                out.reason
            );
        }
        // A line search without a cap of ours makes far more evaluations than the default cap.
        let obj = Unbounded(Mutex::new(0));
        let opts = TrainOptions::default()
            .with_max_iters(1)
            .with_max_line_search_evaluations(usize::MAX);
        let _ = minimise(&obj, vec![0.0], &opts, &none(), |_, _| Control::Continue);
        let evaluations = obj.0.into_inner().expect("not poisoned");
        assert!(
            evaluations > 10 * TrainOptions::DEFAULT_LINE_SEARCH_EVALUATIONS,
            "{evaluations}"
        );
    }

    #[test]
    fn the_evaluation_budget_stops_training_at_the_best_point() {
        let obj = Recording(Mutex::new(Vec::new()));
        let opts = TrainOptions::default().with_max_evaluations(Some(12));
        let out = minimise(&obj, vec![-1.2, 1.0], &opts, &none(), |_, _| {
            Control::Continue
        })
        .expect("runs");
        assert_eq!(out.reason, StopReason::EvaluationLimit);
        let points = obj.0.into_inner().expect("not poisoned");
        assert!(points.len() <= 12, "{} evaluations", points.len());
        assert!(out.history.len() > 2);
        // The best point is the last accepted one, and it is the one returned.
        let mut g = [0.0; 2];
        let f = Rosenbrock.eval(&out.theta, &mut g).expect("evaluates");
        assert_eq!(f, out.history.last().expect("history").objective);
    }

    #[test]
    fn the_deadline_stops_training_and_keeps_the_start() {
        let opts = TrainOptions::default().with_max_seconds(Some(0.0));
        let limits = Limits::start(&opts);
        let obj = Recording(Mutex::new(Vec::new()));
        let out = minimise(&obj, vec![-1.2, 1.0], &opts, &limits, |_, _| {
            Control::Continue
        })
        .expect("runs");
        assert_eq!(out.reason, StopReason::TimeLimit);
        assert_eq!(out.theta, vec![-1.2, 1.0]);
        assert_eq!(out.history.len(), 1);
        // Only the initial point was evaluated.
        assert_eq!(obj.0.into_inner().expect("not poisoned").len(), 1);
        // A deadline far away changes nothing.
        let far = TrainOptions::default().with_max_seconds(Some(1e9));
        let a = minimise(
            &Rosenbrock,
            vec![-1.2, 1.0],
            &far,
            &Limits::start(&far),
            |_, _| Control::Continue,
        )
        .expect("runs");
        let b = minimise(
            &Rosenbrock,
            vec![-1.2, 1.0],
            &TrainOptions::default(),
            &none(),
            |_, _| Control::Continue,
        )
        .expect("runs");
        assert_eq!(a.theta, b.theta);
        assert_eq!(a.reason, b.reason);
        // Shares of no deadline and of an infinite one are no deadline.
        for s in [None, Some(f64::INFINITY), Some(1e300)] {
            let o = TrainOptions::default().with_max_seconds(s);
            assert_eq!(Limits::start(&o).share(0.5).check(), None);
        }
    }

    #[test]
    fn an_interrupt_between_evaluations_keeps_the_best_point() {
        let calls = Arc::new(Mutex::new(0usize));
        let seen = Arc::clone(&calls);
        let interrupt = Interrupt::new(move || {
            let mut c = seen.lock().expect("not poisoned");
            *c += 1;
            *c > 15
        });
        let opts = TrainOptions::default().with_interrupt(interrupt.clone());
        assert_eq!(opts.clone().interrupt, Some(interrupt));
        let mut accepted = Vec::new();
        let out = minimise(
            &Rosenbrock,
            vec![-1.2, 1.0],
            &opts,
            &Limits::start(&opts),
            |_, theta| {
                accepted.push(theta.to_vec());
                Control::Continue
            },
        )
        .expect("runs");
        assert_eq!(out.reason, StopReason::Interrupted);
        assert_eq!(Some(&out.theta), accepted.last());
        assert!(out.history.len() > 2, "{}", out.history.len());
        // Asked once more after it said stop, not again and again.
        assert_eq!(*calls.lock().expect("not poisoned"), 16);
    }

    #[test]
    fn bad_limits_are_refused_and_old_options_still_read() {
        for bad in [
            TrainOptions::default().with_max_seconds(Some(-1.0)),
            TrainOptions::default().with_max_seconds(Some(f64::NAN)),
            TrainOptions::default().with_max_line_search_evaluations(0),
        ] {
            let e = minimise(&Rosenbrock, vec![0.0, 0.0], &bad, &none(), |_, _| {
                Control::Continue
            })
            .err()
            .expect("refused")
            .to_string();
            assert!(e.contains("TrainOptions::max_"), "{e}");
        }
        // Options serialised before the limits existed read with the defaults.
        let old = r#"{"max_iters":5,"grad_tol":1e-5,"rel_tol":0.0,"memory":10,"map_max_iters":3}"#;
        let o: TrainOptions = serde_json::from_str(old).expect("reads");
        assert_eq!(o.max_seconds, None);
        assert_eq!(o.max_evaluations, None);
        assert_eq!(
            o.max_line_search_evaluations,
            TrainOptions::DEFAULT_LINE_SEARCH_EVALUATIONS
        );
        // The stop reasons are stored in model files by name.
        let json = serde_json::to_string(&StopReason::TimeLimit).expect("json");
        assert_eq!(json, "\"TimeLimit\"");
    }
}
