use std::sync::{Arc, Mutex};

use super::*;
use crate::error::Error;

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
    let out = minimise(&Walled, vec![3.0], &opts, &none(), |_, _| Control::Continue).expect("runs");
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
