//! Early stopping on held-out frames: the iteration budget chosen on a validation split of the
//! training frames, never on the test set.
//!
//! Trained to convergence, the marginal likelihood keeps improving while the error on motions
//! the model has not seen rises again after a few iterations (docs/fidelity.md: the noise
//! collapses and the latent points bend to fit every training frame). So:
//!
//! 1. **Selection run.** The model is trained on the frames *not* held out; after every
//!    iteration (and at the start) it predicts every output space from the held-out human
//!    frames. The validation error is the mean over output spaces of each space's mean squared
//!    error (original units). Training stops after [`Validation::patience`] iterations without
//!    a lower validation error, or at the budget.
//! 2. **Final run.** The model is trained again on *all* frames, for the iteration at which the
//!    validation error was lowest (0: the initial model).
//!
//! The returned model records both in its [`Selection`] (stored in the model file). For a
//! transfer, the selection run trains the new robot's kernel on the held-out model's frames
//! (the latent points are frozen, so this is a GP regression from them) and predicts the
//! held-out frames from their latent points.

use std::time::Instant;

use faer::{Mat, MatRef};
use serde::{Deserialize, Serialize};

use crate::config::ModelConfig;
use crate::error::{Error, Result};
use crate::kernel::KernelParams;
use crate::model::{Callback, SharedGplvm, Space};
use crate::objective::Mode;
use crate::regression::{fit_kernel, GpRegression};
use crate::train::{Control, IterationRecord, Limits, StopReason, TrainOptions};

/// The share of the time left that a selection run may use under
/// [`TrainOptions::max_seconds`]; the final training gets the rest.
const SELECTION_SHARE: f64 = 0.5;

/// Frames held out of training to choose the iteration budget (see the module docs).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Validation {
    /// Rows (frames) of the training data held out; distinct, in range, at least one, and
    /// leaving more than Q frames to train on.
    pub rows: Vec<usize>,
    /// Iterations without a lower validation error after which the selection run stops.
    pub patience: usize,
}

impl Validation {
    /// Iterations the selection run goes on without a better validation error, by default.
    /// On the shipped data the best iteration is 0–20 in 17 of 18 cases (docs/fidelity.md).
    pub const DEFAULT_PATIENCE: usize = 50;

    /// Holds out `rows`, with the default patience.
    pub fn new(rows: Vec<usize>) -> Self {
        Self {
            rows,
            patience: Self::DEFAULT_PATIENCE,
        }
    }

    /// Every third of nine equal blocks of `n` rows held out (rows 2/9–3/9, 5/9–6/9 and
    /// 8/9–1 of the way through): for rows in time order, three stretches of motion the model
    /// does not see. With the default patience.
    pub fn blocks(n: usize) -> Self {
        Self::new((0..n).filter(|&r| (r * 9 / n) % 3 == 2).collect())
    }

    /// Sets the patience.
    pub fn with_patience(mut self, patience: usize) -> Self {
        self.patience = patience;
        self
    }

    /// The frames to train on and the held-out frames (both ascending) of `n` frames.
    pub(crate) fn split(&self, n: usize, latent_dim: usize) -> Result<(Vec<usize>, Vec<usize>)> {
        let bad = |reason: String| Error::InvalidValue {
            what: "validation rows".into(),
            reason,
        };
        let mut held = vec![false; n];
        for &r in &self.rows {
            if r >= n {
                return Err(bad(format!(
                    "row {r} is out of range; the data has {n} rows"
                )));
            }
            if std::mem::replace(&mut held[r], true) {
                return Err(bad(format!("row {r} is given twice")));
            }
        }
        let (out, fit): (Vec<usize>, Vec<usize>) = (0..n).partition(|&i| held[i]);
        if out.is_empty() {
            return Err(bad("no row is held out; expected at least one".into()));
        }
        if fit.len() <= latent_dim {
            return Err(bad(format!(
                "{} of {n} rows are held out, leaving {} to train on; expected more than the \
                 latent dimension {latent_dim}",
                out.len(),
                fit.len()
            )));
        }
        Ok((fit, out))
    }
}

/// One iteration of a selection run.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ValidationRecord {
    /// Iteration of the selection run (0 = the initial model).
    pub iteration: usize,
    /// Objective on the frames trained on.
    pub objective: f64,
    /// Mean over output spaces of the held-out frames' mean squared error (original units).
    pub validation_mse: f64,
}

/// How a model's iteration budget was chosen on held-out frames.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Selection {
    /// Frames the selection run trained on.
    pub fit_frames: usize,
    /// Frames held out.
    pub validation_frames: usize,
    /// The patience the selection run used.
    pub patience: usize,
    /// The selection run, iteration 0 first (iterations whose model could not predict are
    /// left out).
    pub curve: Vec<ValidationRecord>,
    /// The iteration with the lowest validation error: the budget of the final training on
    /// all frames.
    pub best_iteration: usize,
    /// Seconds the selection run took (validation predictions included).
    pub seconds: f64,
}

impl Selection {
    /// Whether the held-out error chose the budget: the selection run went on past its best
    /// iteration (patience ran out, or a callback ended it), rather than ending there at the
    /// iteration cap or the time limit.
    pub fn chose_the_budget(&self) -> bool {
        self.curve
            .last()
            .is_some_and(|r| r.iteration > self.best_iteration)
    }

    /// The stop reason of a final training on all frames for this budget, which stopped for
    /// `reason`: [`StopReason::ValidatedBudget`] where it ran out of the budget this selection
    /// chose (its `max_iters`), else `reason`.
    pub(crate) fn final_stop_reason(&self, reason: Option<StopReason>) -> Option<StopReason> {
        match reason {
            Some(StopReason::MaxIterations) if self.chose_the_budget() => {
                Some(StopReason::ValidatedBudget)
            }
            other => other,
        }
    }
}

/// Callback of a selection run: sees every iteration's validation error (iteration 0, the
/// initial model, first; not finite when that model could not predict) and may end the run
/// early with [`Control::Stop`] — the budget is then the best iteration seen so far.
pub type SelectionCallback<'c> = &'c mut dyn FnMut(&ValidationRecord) -> Control;

/// Tracks the validation error of a selection run and when to stop it.
struct Tracker<'c> {
    curve: Vec<ValidationRecord>,
    best: Option<(usize, f64)>,
    patience: usize,
    observer: Option<SelectionCallback<'c>>,
}

impl<'c> Tracker<'c> {
    fn new(patience: usize, observer: Option<SelectionCallback<'c>>) -> Self {
        Self {
            curve: Vec::new(),
            best: None,
            patience,
            observer,
        }
    }

    /// Records iteration `iteration`'s validation error (skipped when not finite), tells the
    /// observer, and says whether the run should go on.
    fn record(&mut self, iteration: usize, objective: f64, validation_mse: f64) -> Control {
        let record = ValidationRecord {
            iteration,
            objective,
            validation_mse,
        };
        let observed = match self.observer.as_mut() {
            Some(observer) => observer(&record),
            None => Control::Continue,
        };
        if validation_mse.is_finite() && objective.is_finite() {
            self.curve.push(record);
            if self.best.is_none_or(|(_, m)| validation_mse < m) {
                self.best = Some((iteration, validation_mse));
            }
        }
        match self.best {
            _ if observed == Control::Stop => Control::Stop,
            Some((b, _)) if iteration >= b + self.patience => Control::Stop,
            _ => Control::Continue,
        }
    }

    fn finish(self, fit_frames: usize, validation_frames: usize, start: Instant) -> Selection {
        Selection {
            fit_frames,
            validation_frames,
            patience: self.patience,
            curve: self.curve,
            best_iteration: self.best.map_or(0, |(b, _)| b),
            seconds: start.elapsed().as_secs_f64(),
        }
    }
}

/// The rows `rows` of `m`.
pub(crate) fn take_rows(m: MatRef<'_, f64>, rows: &[usize]) -> Mat<f64> {
    Mat::from_fn(rows.len(), m.ncols(), |i, j| m[(rows[i], j)])
}

/// Mean squared difference of two matrices of the same shape.
fn mse(a: MatRef<'_, f64>, b: MatRef<'_, f64>) -> f64 {
    let mut sum = 0.0;
    for j in 0..a.ncols() {
        for i in 0..a.nrows() {
            sum += (a[(i, j)] - b[(i, j)]).powi(2);
        }
    }
    sum / (a.nrows() * a.ncols()).max(1) as f64
}

/// The selection run of a transfer: the kernel of the new robot's `space` (preprocessed `data`,
/// its rows those of latent points `x`) trained from its starting point on the rows not held
/// out by `validation`, its GP posterior mean at the held-out rows' latent points scored after
/// every iteration (within half of `limits`).
pub(crate) fn select_kernel_budget(
    x: MatRef<'_, f64>,
    space: &Space,
    data: MatRef<'_, f64>,
    validation: &Validation,
    options: &TrainOptions,
    limits: &Limits,
) -> Result<Selection> {
    select_kernel_budget_observed(x, space, data, validation, options, limits, None)
}

/// [`select_kernel_budget`] with `observer` seeing every iteration's validation error.
fn select_kernel_budget_observed(
    x: MatRef<'_, f64>,
    space: &Space,
    data: MatRef<'_, f64>,
    validation: &Validation,
    options: &TrainOptions,
    limits: &Limits,
    observer: Option<SelectionCallback<'_>>,
) -> Result<Selection> {
    let (fit, held) = validation.split(x.nrows(), x.ncols())?;
    let start = Instant::now();
    let x_fit = take_rows(x, &fit);
    let x_held = take_rows(x, &held);
    let y_fit = take_rows(space.data.as_ref(), &fit);
    let desired = take_rows(data, &held);
    let name = space.name.as_str();
    // (objective on the fit rows, validation error) at `kernel`.
    let score = |kernel: &KernelParams| -> (f64, f64) {
        let zero = vec![0.0; y_fit.ncols()];
        let gp =
            GpRegression::with_kernel(x_fit.as_ref(), zero, y_fit.as_ref(), kernel.clone(), name);
        match gp.and_then(|gp| Ok((gp.objective(), gp.predict(x_held.as_ref())?))) {
            Ok((objective, mut p)) => {
                space.unscale(&mut p);
                (objective, mse(p.as_ref(), desired.as_ref()))
            }
            Err(_) => (f64::NAN, f64::NAN),
        }
    };
    let mut tracker = Tracker::new(validation.patience, observer);
    let (objective0, error0) = score(&space.kernel);
    if tracker.record(0, objective0, error0) == Control::Continue && options.max_iters > 0 {
        fit_kernel(
            x_fit.as_ref(),
            y_fit.as_ref(),
            space.kernel.clone(),
            options,
            &limits.share(SELECTION_SHARE),
            name,
            |rec, kernel| tracker.record(rec.iteration, rec.objective, score(kernel).1),
        )?;
    }
    Ok(tracker.finish(fit.len(), held.len(), start))
}

impl SharedGplvm {
    /// [`SharedGplvm::fit`] with its iteration budget chosen on held-out frames (see the
    /// `validation` module): a selection run on the other frames, then the model trained on
    /// all frames for the best iteration. `options.max_iters` bounds both runs; under
    /// `options.max_seconds` the selection run may use half of the time and the final run the
    /// rest. `callback` sees the final run. The model's [`SharedGplvm::selection`] says what
    /// was chosen.
    pub fn fit_validated(
        config: &ModelConfig,
        spaces: &[(&str, MatRef<'_, f64>)],
        input: &str,
        options: &TrainOptions,
        validation: &Validation,
        callback: Option<Callback<'_>>,
    ) -> Result<Self> {
        Self::fit_validated_observed(config, spaces, input, options, validation, None, callback)
    }

    /// [`SharedGplvm::fit_validated`] with `on_selection` seeing every iteration of the
    /// selection run (its validation error: the values of the returned model's selection
    /// curve) and able to end that run early, as a tuner that stops poor runs does.
    pub fn fit_validated_observed(
        config: &ModelConfig,
        spaces: &[(&str, MatRef<'_, f64>)],
        input: &str,
        options: &TrainOptions,
        validation: &Validation,
        on_selection: Option<SelectionCallback<'_>>,
        callback: Option<Callback<'_>>,
    ) -> Result<Self> {
        options.check_for(config)?;
        let limits = Limits::start(options);
        // Checks every space (shapes, names, values) before the split indexes into them.
        let all = Self::initial(config, spaces, input)?;
        let (fit, held) = validation.split(all.n(), config.latent_dim)?;
        let start = Instant::now();
        let fit_data: Vec<Mat<f64>> = spaces.iter().map(|(_, m)| take_rows(*m, &fit)).collect();
        let fit_spaces: Vec<(&str, MatRef<'_, f64>)> = spaces
            .iter()
            .zip(&fit_data)
            .map(|((name, _), m)| (*name, m.as_ref()))
            .collect();
        let input_index = spaces.iter().position(|(n, _)| *n == input).unwrap_or(0);
        let human = take_rows(spaces[input_index].1, &held);
        let outputs: Vec<(&str, Mat<f64>)> = spaces
            .iter()
            .enumerate()
            .filter(|&(i, _)| i != input_index)
            .map(|(_, (name, m))| (*name, take_rows(*m, &held)))
            .collect();
        let error = |model: &SharedGplvm| -> f64 {
            let mut total = 0.0;
            for (name, desired) in &outputs {
                match model.predict(human.as_ref(), name, false) {
                    Ok(p) => total += mse(p.mean.as_ref(), desired.as_ref()),
                    Err(_) => return f64::NAN,
                }
            }
            total / outputs.len() as f64
        };
        let mut tracker = Tracker::new(validation.patience, on_selection);
        let seed_model = Self::initial(config, &fit_spaces, input)?;
        // Scored and dropped before the other runs: its buffers would add a third to the peak
        // memory of the final run.
        let go_on = {
            let mut initial = seed_model.clone();
            initial.train(
                Mode::Full,
                &options.clone().with_max_iters(0),
                &limits,
                None,
            )?;
            let objective0 = initial.history.first().map_or(f64::NAN, |r| r.objective);
            tracker.record(0, objective0, error(&initial))
        };
        if go_on == Control::Continue && options.max_iters > 0 {
            let mut selection = seed_model;
            selection.train(
                Mode::Full,
                options,
                &limits.share(SELECTION_SHARE),
                Some(&mut |rec: &IterationRecord, snapshot: &SharedGplvm| {
                    tracker.record(rec.iteration, rec.objective, error(snapshot))
                }),
            )?;
        }
        let chosen = tracker.finish(fit.len(), held.len(), start);
        let mut model = all;
        model.train(
            Mode::Full,
            &options.clone().with_max_iters(chosen.best_iteration),
            &limits,
            callback,
        )?;
        model.stop_reason = chosen.final_stop_reason(model.stop_reason.take());
        model.selection = Some(chosen);
        Ok(model)
    }

    /// [`SharedGplvm::transfer`] (or, with `seed`, [`SharedGplvm::transfer_seeded`]) with its
    /// iteration budget chosen on held-out frames: the new robot's kernel trained on the other
    /// frames (latent points frozen), its predictions of the held-out frames from their latent
    /// points scored after every iteration; then the transfer on all frames for the best
    /// iteration. `callback` sees the final run.
    pub fn transfer_validated(
        &self,
        name: &str,
        data: MatRef<'_, f64>,
        seed: Option<u64>,
        options: &TrainOptions,
        validation: &Validation,
        callback: Option<Callback<'_>>,
    ) -> Result<Self> {
        self.transfer_validated_observed(name, data, seed, options, validation, None, callback)
    }

    /// [`SharedGplvm::transfer_validated`] with `on_selection` seeing every iteration of the
    /// selection run and able to end it early (as in
    /// [`SharedGplvm::fit_validated_observed`]).
    #[allow(clippy::too_many_arguments)]
    pub fn transfer_validated_observed(
        &self,
        name: &str,
        data: MatRef<'_, f64>,
        seed: Option<u64>,
        options: &TrainOptions,
        validation: &Validation,
        on_selection: Option<SelectionCallback<'_>>,
        callback: Option<Callback<'_>>,
    ) -> Result<Self> {
        options.check()?;
        if self.sparse.is_some() {
            // The selection runs are exact GP regressions on the training frames (O(N³)).
            return Err(Error::InvalidValue {
                what: "validation".into(),
                reason: "choosing a sparse model's transfer budget on held-out frames is not \
                         supported yet; transfer without validation (--validation none)"
                    .into(),
            });
        }
        let limits = Limits::start(options);
        let space = self.transfer_space(name, data, seed)?;
        let chosen = select_kernel_budget_observed(
            self.x.as_ref(),
            &space,
            data,
            validation,
            options,
            &limits,
            on_selection,
        )?;
        let budget = options.clone().with_max_iters(chosen.best_iteration);
        let mut model = self.transfer_impl(name, data, seed, &budget, &limits, callback)?;
        model.stop_reason = chosen.final_stop_reason(model.stop_reason.take());
        model.selection = Some(chosen);
        Ok(model)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_support::*;

    /// Every third frame of `n` held out.
    fn every_third(n: usize) -> Validation {
        Validation::new((0..n).filter(|i| i % 3 == 1).collect())
    }

    /// A final run that ran out of the budget the held-out frames chose says so (issue 38),
    /// in the model, its file and in words; one whose budget was the caller's cap does not.
    #[test]
    fn the_stop_reason_names_the_validated_budget() {
        let n = 45;
        let (h, r, _, _) = demo(n, 3);
        let spaces = [("human", h.as_ref()), ("walkman", r.as_ref())];
        let config = ModelConfig::default().with_latent_dim(2);
        let validation = every_third(n).with_patience(4);
        let m =
            SharedGplvm::fit_validated(&config, &spaces, "human", &quick(40), &validation, None)
                .expect("fit");
        let s = m.selection().expect("selection");
        // Patience ran out after the best iteration: the held-out error chose the budget.
        assert!(s.chose_the_budget(), "{:?}", s.curve.last());
        assert!(
            s.best_iteration > 0 && s.best_iteration < 40,
            "{}",
            s.best_iteration
        );
        assert_eq!(m.stop_reason(), Some(&StopReason::ValidatedBudget));
        assert_eq!(
            m.history().last().map(|r| r.iteration),
            Some(s.best_iteration)
        );
        assert_eq!(
            m.stop_reason().map(StopReason::name),
            Some("validated_budget")
        );
        assert_eq!(
            m.stop_reason().map(ToString::to_string).as_deref(),
            Some("validated budget reached")
        );
        let back = SharedGplvm::from_bytes(&m.to_bytes()).expect("round trip");
        assert_eq!(back.stop_reason(), Some(&StopReason::ValidatedBudget));
        // A budget of 0 iterations: the selection run has nothing after its only point, so the
        // cap, not the held-out frames, decided.
        let capped =
            SharedGplvm::fit_validated(&config, &spaces, "human", &quick(0), &validation, None)
                .expect("fit");
        assert!(!capped.selection().expect("selection").chose_the_budget());
        assert_ne!(capped.stop_reason(), Some(&StopReason::ValidatedBudget));
    }

    #[test]
    fn bad_splits_are_refused_naming_the_row() {
        let (h, r, _, _) = demo(20, 1);
        let spaces = [("human", h.as_ref()), ("walkman", r.as_ref())];
        let config = ModelConfig::default().with_latent_dim(2);
        for (rows, expected) in [
            (vec![3, 20], "row 20 is out of range; the data has 20 rows"),
            (vec![4, 4], "row 4 is given twice"),
            (vec![], "no row is held out"),
            ((0..18).collect(), "leaving 2 to train on"),
        ] {
            let e = SharedGplvm::fit_validated(
                &config,
                &spaces,
                "human",
                &quick(5),
                &Validation::new(rows),
                None,
            )
            .expect_err("refused")
            .to_string();
            assert!(e.contains(expected), "{e}");
        }
    }

    /// The selection curve is what a model trained for k iterations on the other frames
    /// predicts for the held-out frames, the budget is its minimum, the run stops `patience`
    /// iterations after it, and the returned model is `fit` on all frames for that budget.
    #[test]
    fn fit_validated_is_early_stopping_then_retraining() {
        for bc in BackConstraint::ALL {
            let n = 45;
            let (h, r, _, _) = demo(n, 3);
            let spaces = [("human", h.as_ref()), ("walkman", r.as_ref())];
            let config = ModelConfig::default()
                .with_latent_dim(2)
                .with_back_constraint(bc);
            let validation = every_third(n).with_patience(4);
            let options = quick(40);
            let m =
                SharedGplvm::fit_validated(&config, &spaces, "human", &options, &validation, None)
                    .expect("fit");
            let s = m.selection().expect("selection recorded").clone();
            assert_eq!((s.fit_frames, s.validation_frames), (30, 15));
            let best = s
                .curve
                .iter()
                .min_by(|a, b| a.validation_mse.total_cmp(&b.validation_mse))
                .expect("curve");
            assert_eq!(best.iteration, s.best_iteration, "{bc:?}");
            let last = s.curve.last().expect("curve").iteration;
            assert!(last <= s.best_iteration + 4, "{bc:?}: ran to {last}");
            // Recompute points of the curve independently: the start, and for input back
            // constraints the last one too (training snapshots of models with an input map
            // warm-start the map, the model stopped there fits it from a cold start, and on this
            // small problem the two optima differ).
            let fit_rows: Vec<usize> = (0..n).filter(|i| i % 3 != 1).collect();
            let held: Vec<usize> = (0..n).filter(|i| i % 3 == 1).collect();
            let (hf, rf) = (
                take_rows(h.as_ref(), &fit_rows),
                take_rows(r.as_ref(), &fit_rows),
            );
            let (hv, rv) = (take_rows(h.as_ref(), &held), take_rows(r.as_ref(), &held));
            let checked = match bc {
                BackConstraint::Input => vec![&s.curve[0], s.curve.last().expect("curve")],
                _ => vec![&s.curve[0]],
            };
            for rec in checked {
                let k = SharedGplvm::fit(
                    &config,
                    &[("human", hf.as_ref()), ("walkman", rf.as_ref())],
                    "human",
                    &options.clone().with_max_iters(rec.iteration),
                    None,
                )
                .expect("fit");
                let p = k.predict(hv.as_ref(), "walkman", false).expect("predict");
                let want = mse(p.mean.as_ref(), rv.as_ref());
                assert!(
                    (rec.validation_mse - want).abs() <= 1e-12 * want,
                    "{bc:?} iteration {}: {} vs {want}",
                    rec.iteration,
                    rec.validation_mse
                );
            }
            let plain = SharedGplvm::fit(
                &config,
                &spaces,
                "human",
                &options.clone().with_max_iters(s.best_iteration),
                None,
            )
            .expect("fit");
            assert_eq!(m.params(), plain.params(), "{bc:?}");
            assert_eq!(m.history().len(), plain.history().len());
            // The selection survives a round trip through the model file.
            let back = SharedGplvm::from_bytes(&m.to_bytes()).expect("load");
            assert_eq!(back.selection(), Some(&s));
            assert!(m.training_seconds() >= s.seconds);
        }
    }

    /// The selection observer hears exactly the curve the model records, and stopping it
    /// ends the selection run there: the budget is the best iteration seen so far, and the
    /// model is the plain fit for that budget.
    #[test]
    fn the_selection_observer_hears_the_curve_and_can_end_the_run() {
        let n = 45;
        let (h, r, r2, _) = demo(n, 3);
        let spaces = [("human", h.as_ref()), ("walkman", r.as_ref())];
        let config = ModelConfig::default().with_latent_dim(2);
        let validation = every_third(n).with_patience(6);
        let options = quick(40);
        let mut heard = Vec::new();
        let m = SharedGplvm::fit_validated_observed(
            &config,
            &spaces,
            "human",
            &options,
            &validation,
            Some(&mut |rec: &ValidationRecord| {
                heard.push(rec.clone());
                Control::Continue
            }),
            None,
        )
        .expect("fit");
        let s = m.selection().expect("selection").clone();
        assert!(heard.len() > 2);
        assert_eq!(heard, s.curve);
        let plain =
            SharedGplvm::fit_validated(&config, &spaces, "human", &options, &validation, None)
                .expect("fit");
        assert_eq!(plain.params(), m.params());

        let stop_at = 2;
        let mut last = None;
        let stopped = SharedGplvm::fit_validated_observed(
            &config,
            &spaces,
            "human",
            &options,
            &validation,
            Some(&mut |rec: &ValidationRecord| {
                last = Some(rec.iteration);
                if rec.iteration >= stop_at {
                    Control::Stop
                } else {
                    Control::Continue
                }
            }),
            None,
        )
        .expect("fit");
        let st = stopped.selection().expect("selection");
        assert_eq!(last, Some(stop_at));
        assert_eq!(st.curve[..], s.curve[..=stop_at]);
        let best = st
            .curve
            .iter()
            .min_by(|a, b| a.validation_mse.total_cmp(&b.validation_mse))
            .expect("curve")
            .iteration;
        assert_eq!(st.best_iteration, best);
        let budget = SharedGplvm::fit(
            &config,
            &spaces,
            "human",
            &options.clone().with_max_iters(best),
            None,
        )
        .expect("fit");
        assert_eq!(stopped.params(), budget.params());

        // A transfer's selection run is heard the same way.
        let mut heard = Vec::new();
        let t = m
            .transfer_validated_observed(
                "coman",
                r2.as_ref(),
                None,
                &options,
                &validation,
                Some(&mut |rec: &ValidationRecord| {
                    heard.push(rec.clone());
                    Control::Continue
                }),
                None,
            )
            .expect("transfer");
        assert_eq!(heard, t.selection().expect("selection").curve);
    }

    #[test]
    fn blocks_hold_out_a_third_in_three_stretches() {
        assert_eq!(Validation::blocks(9).rows, vec![2, 5, 8]);
        let v = Validation::blocks(90);
        assert_eq!(v.rows.len(), 30);
        assert_eq!(v.rows[..10], (20..30).collect::<Vec<_>>()[..]);
        assert_eq!(v.rows[20..], (80..90).collect::<Vec<_>>()[..]);
        assert!(Validation::blocks(0).rows.is_empty());
    }

    #[test]
    fn patience_zero_keeps_the_initial_model() {
        let n = 30;
        let (h, r, _, _) = demo(n, 5);
        let config = ModelConfig::default().with_latent_dim(2);
        let m = SharedGplvm::fit_validated(
            &config,
            &[("human", h.as_ref()), ("walkman", r.as_ref())],
            "human",
            &quick(50),
            &every_third(n).with_patience(0),
            None,
        )
        .expect("fit");
        let s = m.selection().expect("selection");
        assert_eq!((s.best_iteration, s.curve.len()), (0, 1));
        assert_eq!(m.history().len(), 1);
    }

    /// The transfer's selection scores the GP posterior mean from the fit frames' latent
    /// points, recomputed here with a dense solve at the starting kernel; the transfer is then
    /// `transfer_seeded` for the chosen budget.
    #[test]
    fn transfer_validated_scores_held_out_latent_points() {
        use faer::linalg::solvers::DenseSolveCore;
        let n = 45;
        let (h, _, r2, _) = demo(n, 7);
        let source = fit(BackConstraint::Input, n, 15, 0);
        let validation = every_third(n).with_patience(5);
        let t = source
            .transfer_validated("coman", r2.as_ref(), Some(3), &quick(60), &validation, None)
            .expect("transfer");
        let s = t.selection().expect("selection").clone();
        let plain = source
            .transfer_seeded(
                "coman",
                r2.as_ref(),
                3,
                &quick(60).with_max_iters(s.best_iteration),
                None,
            )
            .expect("transfer");
        assert_eq!(t.params(), plain.params());
        assert_eq!(
            t.predict(h.as_ref(), "coman", false).expect("p"),
            plain.predict(h.as_ref(), "coman", false).expect("p")
        );
        // The same training without the selection ran out of its iteration budget; with it,
        // that budget was the validated one.
        if plain.stop_reason() == Some(&StopReason::MaxIterations) && s.chose_the_budget() {
            assert_eq!(t.stop_reason(), Some(&StopReason::ValidatedBudget));
        } else {
            assert_eq!(t.stop_reason(), plain.stop_reason());
        }
        // Iteration 0: the starting kernel, dense posterior mean.
        let space = source
            .transfer_space("coman", r2.as_ref(), Some(3))
            .expect("space");
        let k = &space.kernel;
        let x = source.latent_points();
        let fit_rows: Vec<usize> = (0..n).filter(|i| i % 3 != 1).collect();
        let held: Vec<usize> = (0..n).filter(|i| i % 3 == 1).collect();
        let kx = |i: usize, j: usize| {
            let d2: f64 = (0..x.ncols())
                .map(|t| ((x[(i, t)] - x[(j, t)]) / k.lengthscale[t]).powi(2))
                .sum();
            k.variance * (-0.5 * d2).exp()
        };
        let m = fit_rows.len();
        let kff = Mat::from_fn(m, m, |a, b| {
            kx(fit_rows[a], fit_rows[b]) + if a == b { k.noise } else { 0.0 }
        });
        let inv = kff.as_ref().partial_piv_lu().inverse();
        let y = Mat::from_fn(m, space.data.ncols(), |a, j| space.data[(fit_rows[a], j)]);
        let alpha = &inv * &y;
        let mut sum = 0.0;
        for &v in &held {
            for j in 0..y.ncols() {
                let mean: f64 = (0..m).map(|a| kx(v, fit_rows[a]) * alpha[(a, j)]).sum();
                let pred = mean * space.scale[j] + space.offset[j];
                sum += (pred - r2[(v, j)]).powi(2);
            }
        }
        let want = sum / (held.len() * y.ncols()) as f64;
        let got = s.curve[0].validation_mse;
        assert!((got - want).abs() < 1e-9 * want, "{got} vs {want}");
        // The bad-split check holds for transfers too.
        assert!(source
            .transfer_validated(
                "coman",
                r2.as_ref(),
                None,
                &quick(5),
                &Validation::new(vec![n]),
                None
            )
            .is_err());
    }
}
