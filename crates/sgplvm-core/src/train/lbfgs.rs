//! The L-BFGS loop around argmin 0.11 (More–Thuente line search, `Vec<f64>` parameters):
//! [`minimise`] and [`minimise_capped`] drive the solver iteration by iteration, restart it
//! once after a failed line search, evaluate each point once (a one-entry cache), record the
//! history and keep the best point; the stop rules and limits they apply are in `stop.rs`.

use std::sync::Mutex;
use std::time::Instant;

use argmin::core::{CostFunction, Gradient, IterState, Problem, Solver, State};
use argmin::solver::linesearch::{LineSearch, MoreThuenteLineSearch};
use argmin::solver::quasinewton::LBFGS;

use super::stop::{max_abs, stop_after_iteration, stop_before_start, Guard, Refused};
use super::{Control, IterationRecord, Limits, Objective, StopReason, TrainOptions};
use crate::error::{Error, Result};

/// Cost returned to the line search for a point where the objective cannot be evaluated
/// (non-positive-definite kernel, overflow): large and finite, so More–Thuente backtracks.
const FAILED_COST: f64 = 1e300;

/// Last evaluated point: parameters and, if it could be evaluated, the objective and gradient
/// (unscaled).
type Evaluated = (Vec<f64>, Option<(f64, Vec<f64>)>);

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
        stop_after_iteration(control, record.gradient_norm, rel, options)
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
