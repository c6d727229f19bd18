//! L-BFGS training driver around argmin 0.11 (More–Thuente line search, `Vec<f64>` parameters).
//!
//! The solver's own loop is driven here (`Solver::init` then `Solver::next_iter`) so that every
//! iteration can be recorded, timed and shown to a callback that may stop training.

use std::sync::Mutex;
use std::time::Instant;

use argmin::core::{CostFunction, Gradient, IterState, Problem, Solver, State};
use argmin::solver::linesearch::MoreThuenteLineSearch;
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
    /// L-BFGS history size m.
    pub memory: usize,
    /// Iteration budget of the GP regression human → latent fitted after training for models
    /// without input back constraints.
    pub map_max_iters: usize,
}

impl Default for TrainOptions {
    fn default() -> Self {
        Self {
            max_iters: 1000,
            grad_tol: 1e-5,
            rel_tol: 2.2e-9,
            memory: 10,
            map_max_iters: 300,
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
        Ok(())
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

/// Evaluates `obj` at `theta` through a one-entry cache: the line search asks for the cost and
/// the gradient of the same point separately, and the training loop asks once more for the
/// point the solver accepted — one evaluation serves all three.
fn eval_cached<O: Objective>(
    obj: &O,
    cache: &Mutex<Option<Evaluated>>,
    theta: &[f64],
) -> Option<(f64, Vec<f64>)> {
    let mut guard = crate::pool::lock(cache);
    if let Some((t, result)) = guard.as_ref() {
        if t.as_slice() == theta {
            return result.clone();
        }
    }
    let mut grad = vec![0.0; theta.len()];
    let result = match obj.eval(theta, &mut grad) {
        Ok(f) if f.is_finite() && grad.iter().all(|g| g.is_finite()) => Some((f, grad)),
        _ => None,
    };
    *guard = Some((theta.to_vec(), result.clone()));
    result
}

struct Op<'a, O: Objective> {
    obj: &'a O,
    scale: f64,
    cache: &'a Mutex<Option<Evaluated>>,
}

impl<O: Objective> Op<'_, O> {
    /// Scaled objective and gradient as the solver sees them.
    fn eval(&self, theta: &[f64]) -> (f64, Vec<f64>) {
        match eval_cached(self.obj, self.cache, theta) {
            Some((f, g)) => (
                f * self.scale,
                g.into_iter().map(|g| g * self.scale).collect(),
            ),
            None => (FAILED_COST, vec![0.0; theta.len()]),
        }
    }
}

impl<O: Objective> CostFunction for Op<'_, O> {
    type Param = Vec<f64>;
    type Output = f64;
    fn cost(&self, p: &Vec<f64>) -> std::result::Result<f64, argmin::core::Error> {
        Ok(self.eval(p).0)
    }
}

impl<O: Objective> Gradient for Op<'_, O> {
    type Param = Vec<f64>;
    type Gradient = Vec<f64>;
    fn gradient(&self, p: &Vec<f64>) -> std::result::Result<Vec<f64>, argmin::core::Error> {
        Ok(self.eval(p).1)
    }
}

/// Outcome of [`minimise`].
pub(crate) struct Outcome {
    pub theta: Vec<f64>,
    pub history: Vec<IterationRecord>,
    pub reason: StopReason,
}

fn max_abs(g: &[f64]) -> f64 {
    g.iter().fold(0.0, |m, v| m.max(v.abs()))
}

/// Minimises `obj` from `theta0` with L-BFGS. `scale` (> 0) multiplies the objective seen by
/// the solver (the model uses 1/(N·ΣD) so that step sizes are O(1)); records keep the true
/// objective. `on_iter` sees every accepted iteration and the current vector.
pub(crate) fn minimise<O: Objective>(
    obj: &O,
    theta0: Vec<f64>,
    scale: f64,
    options: &TrainOptions,
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
    let mut run = Run {
        start,
        paused: 0.0,
        history: vec![IterationRecord {
            iteration: 0,
            objective: f0,
            seconds: start.elapsed().as_secs_f64(),
            gradient_norm: max_abs(&g0),
        }],
        best: theta0,
        best_f: f0,
    };
    if let Some(reason) = stop_before_start(&run.best, &g0, options) {
        return Ok(run.finish(reason));
    }
    // A fresh problem and L-BFGS (empty memory) started at `theta`. The problem is recreated
    // too: argmin 0.11's L-BFGS does not hand the problem back after a failed line search.
    let fresh = |theta: Vec<f64>| -> Result<(Problem<Op<'_, O>>, Lbfgs, St)> {
        let mut problem = Problem::new(Op {
            obj,
            scale,
            cache: &cache,
        });
        let mut solver: Lbfgs = LBFGS::new(MoreThuenteLineSearch::new(), options.memory);
        let (state, _) = solver
            .init(&mut problem, IterState::new().param(theta))
            .map_err(|e| Error::InvalidValue {
                what: "L-BFGS initialisation".into(),
                reason: e.to_string(),
            })?;
        Ok((problem, solver, state))
    };
    let (mut problem, mut solver, mut state) = fresh(run.best.clone())?;
    // After a failed line search the solver is restarted once from the best point with an
    // empty memory (steepest descent step); a second failure in a row ends training.
    let mut restarted = false;
    loop {
        if run.history.len() > options.max_iters {
            return Ok(run.finish(StopReason::MaxIterations));
        }
        let (accepted, failure) = step(
            &mut solver,
            &mut problem,
            &mut state,
            obj,
            &cache,
            run.best_f,
        );
        if let Some((param, f, g)) = accepted {
            restarted = false;
            if let Some(reason) = run.accept(param, f, &g, options, &mut on_iter) {
                return Ok(run.finish(reason));
            }
        }
        if let Some(msg) = failure {
            if restarted {
                return Ok(run.finish(StopReason::LineSearch(msg)));
            }
            restarted = true;
            (problem, solver, state) = fresh(run.best.clone())?;
        }
    }
}

type Lbfgs = LBFGS<MoreThuenteLineSearch<Vec<f64>, Vec<f64>, f64>, Vec<f64>, Vec<f64>, f64>;
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
            let (f, g) = eval_cached(obj, cache, &param).unwrap_or((f64::INFINITY, Vec::new()));
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

/// The record of a training run in progress: the history, the best point so far and the time
/// spent in callbacks (not counted in the records' seconds).
struct Run {
    start: Instant,
    paused: f64,
    history: Vec<IterationRecord>,
    best: Vec<f64>,
    best_f: f64,
}

impl Run {
    /// Records an accepted point, shows it to `on_iter` and returns why training stops there,
    /// if it does (callback, gradient tolerance, relative decrease).
    fn accept(
        &mut self,
        param: Vec<f64>,
        f: f64,
        g: &[f64],
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
            gradient_norm: max_abs(g),
        };
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

    struct Rosenbrock;
    impl Objective for Rosenbrock {
        fn eval(&self, t: &[f64], g: &mut [f64]) -> Result<f64> {
            let (x, y) = (t[0], t[1]);
            g[0] = -2.0 * (1.0 - x) - 400.0 * x * (y - x * x);
            g[1] = 200.0 * (y - x * x);
            Ok((1.0 - x).powi(2) + 100.0 * (y - x * x).powi(2))
        }
    }

    #[test]
    fn minimises_rosenbrock_monotonically() {
        let opts = TrainOptions::default()
            .with_grad_tol(1e-8)
            .with_rel_tol(0.0);
        let out = minimise(&Rosenbrock, vec![-1.2, 1.0], 1.0, &opts, |_, _| {
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
        let out =
            minimise(&obj, vec![-1.2, 1.0], 1.0, &opts, |_, _| Control::Continue).expect("runs");
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
        let out = minimise(&Walled, vec![3.0], 1.0, &opts, |_, _| Control::Continue).expect("runs");
        assert!((out.theta[0] + 0.4).abs() < 1e-6, "{:?}", out.theta);
        // The initial point must be valid: its failure is the caller's error.
        assert!(minimise(&Walled, vec![-1.0], 1.0, &opts, |_, _| Control::Continue).is_err());
    }

    #[test]
    fn callback_stops_and_budget_holds() {
        let opts = TrainOptions::default();
        let mut calls = 0;
        let out = minimise(&Rosenbrock, vec![-1.2, 1.0], 1.0, &opts, |r, _| {
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
            1.0,
            &opts.with_max_iters(5),
            |_, _| Control::Continue,
        )
        .expect("runs");
        assert_eq!(out.reason, StopReason::MaxIterations);
        assert_eq!(out.history.last().map(|r| r.iteration), Some(5));
    }
}
