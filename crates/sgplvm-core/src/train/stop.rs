//! Why training stops: the [`StopReason`]s, the rules that end a run before its first
//! iteration and after an accepted one, the limits from outside the iterations (the deadline
//! and the [`Interrupt`], `Limits`) and the guard that counts a run's objective evaluations and
//! refuses the next one when a limit is reached.

use std::fmt;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use serde::{Deserialize, Serialize};

use super::{Control, TrainOptions};

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

/// Counts a run's objective evaluations and refuses the next one when a limit is reached: the
/// line search's cap (the line search then fails), the run's cap, the deadline or the
/// interrupt (training then stops, for the reason kept here).
pub(super) struct Guard<'a> {
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
pub(super) struct Refused;

impl<'a> Guard<'a> {
    pub(super) fn new(options: &'a TrainOptions, limits: &'a Limits) -> Self {
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
    pub(super) fn admit(&self) -> std::result::Result<(), Refused> {
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
    pub(super) fn evaluations(&self) -> usize {
        crate::pool::lock(&self.state).total
    }

    /// Starts counting the evaluations of a new line search.
    pub(super) fn new_line_search(&self) {
        crate::pool::lock(&self.state).in_line_search = 0;
    }

    /// Why training must stop now, if it must (a limit reached during an evaluation, or now).
    pub(super) fn stop(&self) -> Option<StopReason> {
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

/// The largest absolute component of `g` (the gradient's size the tolerance is checked on).
pub(super) fn max_abs(g: &[f64]) -> f64 {
    g.iter().fold(0.0, |m, v| m.max(v.abs()))
}

/// Why training ends before its first iteration, if it does: nothing to train, a start that
/// already meets the gradient tolerance, or no iteration budget.
pub(super) fn stop_before_start(
    theta0: &[f64],
    g0: &[f64],
    options: &TrainOptions,
) -> Option<StopReason> {
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

/// Why training stops after an accepted iteration, if it does: the callback said so
/// (`control`), the gradient's largest component is below the tolerance, or the relative
/// decrease `rel` is.
pub(super) fn stop_after_iteration(
    control: Control,
    gradient_norm: f64,
    rel: f64,
    options: &TrainOptions,
) -> Option<StopReason> {
    if control == Control::Stop {
        Some(StopReason::Callback)
    } else if gradient_norm < options.grad_tol {
        Some(StopReason::GradientTolerance)
    } else if rel < options.rel_tol {
        Some(StopReason::RelativeTolerance)
    } else {
        None
    }
}
