//! Direct GP regression `Y = f(X) + ε`, `f ~ GP(0, k)` with the RBF-ARD kernel over the input
//! columns and Gaussian noise (GPy's `GPRegression`), the targets centred. Its hyperparameters
//! maximise the marginal likelihood (the `likelihood` of one space with X as inputs).
//!
//! Two uses: [`GpRegression`], the paper's yardstick — a direct human → robot mapping that the
//! shared model should match on motions it has not seen — and the human → latent input map of
//! models without input back constraints (`input_map`).

use std::sync::Mutex;

use faer::{Accum, Mat, MatRef, Par};

use crate::back_constraint::median_distance;
use crate::error::{Error, Result};
use crate::kernel::{row_major, KernelParams};
use crate::likelihood::{eval_space, SpaceWork, Wanted};
use crate::memory;
use crate::objective::{decode_kernel, encode_kernel, kernel_grad_log};
use crate::pool::{in_pool, lock, ALONE_PARALLEL_FROM};
use crate::predict::{for_each_kernel_block, half_inv_l2, scaled_about_mean};
use crate::preprocess::{check_finite, check_nonempty, mean_col_var, unit_scaled};
use crate::train::{
    minimise, Control, IterationRecord, Limits, Objective, StopReason, TrainOptions,
};

/// The kernel a regression starts from: variance = the targets' mean column variance v, every
/// lengthscale the median pairwise distance of the inputs, noise = v / 100.
pub(crate) fn starting_kernel(x: MatRef<'_, f64>, y: MatRef<'_, f64>) -> KernelParams {
    let v = mean_col_var(y);
    KernelParams {
        variance: v,
        lengthscale: vec![median_distance(x); x.ncols()],
        noise: 0.01 * v,
    }
}

/// The hyperparameters of a regression of centred `y` on `x`, trained by L-BFGS from `start`
/// (`options.max_iters` iterations at most, within `limits`). `what` names the regression in
/// errors; `on_iter` sees every accepted iteration with its kernel and may stop training.
pub(crate) fn fit_kernel(
    x: MatRef<'_, f64>,
    y: MatRef<'_, f64>,
    start: KernelParams,
    options: &TrainOptions,
    limits: &Limits,
    what: &str,
    on_iter: impl FnMut(&IterationRecord, &KernelParams) -> Control,
) -> Result<KernelParams> {
    fit_kernel_why(x, y, start, options, limits, what, on_iter).map(|(k, _)| k)
}

/// [`fit_kernel`], and why training stopped.
fn fit_kernel_why(
    x: MatRef<'_, f64>,
    y: MatRef<'_, f64>,
    start: KernelParams,
    options: &TrainOptions,
    limits: &Limits,
    what: &str,
    mut on_iter: impl FnMut(&IterationRecord, &KernelParams) -> Control,
) -> Result<(KernelParams, StopReason)> {
    let (n, d) = (y.nrows(), y.ncols());
    let obj = RegressionObjective {
        x_rows: row_major(x),
        dx: x.ncols(),
        y: y.to_owned(),
        work: Mutex::new(SpaceWork::new(n, d)),
        what,
    };
    let mut theta0 = Vec::new();
    encode_kernel(&start, &mut theta0);
    let dx = x.ncols();
    let out = minimise(&obj, theta0, options, limits, |rec, theta| {
        on_iter(rec, &decode_kernel(theta, dx))
    })?;
    Ok((decode_kernel(&out.theta, dx), out.reason))
}

/// The regression's negative log marginal likelihood (inputs fixed), θ = log kernel parameters.
struct RegressionObjective<'a> {
    x_rows: Vec<f64>,
    dx: usize,
    y: Mat<f64>,
    work: Mutex<SpaceWork>,
    what: &'a str,
}

impl Objective for RegressionObjective<'_> {
    fn eval(&self, theta: &[f64], grad: &mut [f64]) -> Result<f64> {
        // On the pool from the size at which a space alone spreads its steps over its threads.
        if self.y.nrows() >= ALONE_PARALLEL_FROM {
            in_pool(|| self.eval_here(theta, grad))
        } else {
            self.eval_here(theta, grad)
        }
    }
}

impl RegressionObjective<'_> {
    /// [`Objective::eval`] on the calling thread.
    fn eval_here(&self, theta: &[f64], grad: &mut [f64]) -> Result<f64> {
        let k = decode_kernel(theta, self.dx);
        if !k.is_valid() {
            return Err(Error::InvalidValue {
                what: format!("{} kernel", self.what),
                reason: "overflow".into(),
            });
        }
        let mut w = lock(&self.work);
        let e = eval_space(
            &self.x_rows,
            self.dx,
            self.y.as_ref(),
            &k,
            &mut w,
            1,
            Wanted::KernelGradient,
        )
        .map_err(|e| e.in_space(self.what))?;
        kernel_grad_log(&k, &e, grad);
        Ok(e.nll)
    }
}

/// A trained GP regression from input frames to output frames: the direct mapping the shared
/// model is measured against (the paper chose Q = 5 because the shared model then performed
/// "similar to a GP regression representing a direct human-robot mapping").
///
/// ```
/// use sgplvm_core::{GpRegression, Mat, TrainOptions};
/// let x = Mat::from_fn(40, 2, |i, j| (i as f64 * 0.15 + j as f64).sin());
/// let y = Mat::from_fn(40, 1, |i, _| x[(i, 0)] + 0.5 * x[(i, 1)]);
/// let gp = GpRegression::fit(x.as_ref(), y.as_ref(), &TrainOptions::default())?;
/// let pred = gp.predict(x.as_ref())?;
/// assert!((pred[(3, 0)] - y[(3, 0)]).abs() < 0.05);
/// # Ok::<(), sgplvm_core::Error>(())
/// ```
///
/// Data far from unit scale is standardised as the shared model's spaces are (see
/// [`crate::STANDARD_SCALES`]): inputs and outputs are each divided by a power of two, exactly,
/// so that such data trains like the same data at unit scale; data beyond
/// [`crate::ACCEPTED_SCALES`] is refused with [`Error::DataScale`]. Training is bounded like
/// the shared model's: [`TrainOptions::max_seconds`], the interrupt and the evaluation caps
/// stop it at the best point so far, and [`GpRegression::stop_reason`] says why it stopped.
#[derive(Clone, Debug)]
pub struct GpRegression {
    /// Training inputs divided by `x_unit`, row-major N×D_x.
    x_rows: Vec<f64>,
    /// The power of two the inputs were divided by (1 for data near unit scale).
    x_unit: f64,
    /// Column means of the training outputs (added back in prediction).
    y_mean: Vec<f64>,
    /// The power of two the centred outputs were divided by (1 for data near unit scale).
    y_unit: f64,
    /// Trained hyperparameters (in the standardised units).
    std_kernel: KernelParams,
    /// The same in the units of the data given to `fit`.
    kernel: KernelParams,
    /// Why training stopped (`None` for a regression made with given hyperparameters).
    stop_reason: Option<StopReason>,
    /// K⁻¹(Y − mean), N×D_y.
    alpha: Mat<f64>,
    /// Negative log marginal likelihood at `kernel`.
    objective: f64,
}

impl GpRegression {
    /// Fits a regression of `y` (N×D_y) on `x` (N×D_x): outputs centred, inputs and outputs
    /// far from unit scale standardised, hyperparameters by L-BFGS (`options.max_iters`
    /// iterations at most, within `options.max_seconds` and its interrupt) from
    /// [`GpRegression`]'s starting kernel (variance = the mean output variance, lengthscales =
    /// the median input distance, noise = 1 % of the variance).
    pub fn fit(x: MatRef<'_, f64>, y: MatRef<'_, f64>, options: &TrainOptions) -> Result<Self> {
        options.check()?;
        check_nonempty("regression inputs", x)?;
        check_nonempty("regression outputs", y)?;
        if x.nrows() != y.nrows() {
            return Err(Error::RowCountMismatch {
                space: "regression outputs".into(),
                expected: x.nrows(),
                found: y.nrows(),
            });
        }
        check_finite("regression inputs", x)?;
        check_finite("regression outputs", y)?;
        let (n, d) = (y.nrows(), y.ncols());
        memory::check("GP regression", n, memory::REGRESSION_MATRICES)?;
        let y_mean: Vec<f64> = (0..d)
            .map(|j| (0..n).map(|i| y[(i, j)]).sum::<f64>() / n as f64)
            .collect();
        let yc = Mat::from_fn(n, d, |i, j| y[(i, j)] - y_mean[j]);
        let (xs, x_unit) = unit_scaled("regression inputs", x)?;
        let (ys, y_unit) = unit_scaled("regression outputs", yc.as_ref())?;
        let (kernel, reason) = fit_kernel_why(
            xs.as_ref(),
            ys.as_ref(),
            starting_kernel(xs.as_ref(), ys.as_ref()),
            options,
            &Limits::start(options),
            "regression",
            |_, _| Control::Continue,
        )?;
        let mut fitted = Self::with_kernel(xs.as_ref(), y_mean, ys.as_ref(), kernel, "regression")?;
        let y2 = y_unit * y_unit;
        fitted.kernel = KernelParams {
            variance: fitted.std_kernel.variance * y2,
            lengthscale: fitted
                .std_kernel
                .lengthscale
                .iter()
                .map(|l| l * x_unit)
                .collect(),
            noise: fitted.std_kernel.noise * y2,
        };
        fitted.x_unit = x_unit;
        fitted.y_unit = y_unit;
        fitted.stop_reason = Some(reason);
        Ok(fitted)
    }

    /// The regression of centred `yc` (whose column means were `y_mean`) on `x` with the given
    /// hyperparameters: one factorisation. `what` names it in errors.
    pub(crate) fn with_kernel(
        x: MatRef<'_, f64>,
        y_mean: Vec<f64>,
        yc: MatRef<'_, f64>,
        kernel: KernelParams,
        what: &str,
    ) -> Result<Self> {
        let (n, d) = (yc.nrows(), yc.ncols());
        let x_rows = row_major(x);
        let mut work = SpaceWork::new(n, d);
        let e = eval_space(
            &x_rows,
            x.ncols(),
            yc,
            &kernel,
            &mut work,
            1,
            Wanted::Objective,
        )
        .map_err(|e| e.in_space(what))?;
        Ok(GpRegression {
            x_rows,
            x_unit: 1.0,
            y_mean,
            y_unit: 1.0,
            std_kernel: kernel.clone(),
            kernel,
            stop_reason: None,
            alpha: work.alpha().to_owned(),
            objective: e.nll,
        })
    }

    /// Posterior mean at the input frames in the rows of `x` (n×D_y).
    pub fn predict(&self, x: MatRef<'_, f64>) -> Result<Mat<f64>> {
        let dx = self.std_kernel.lengthscale.len();
        if x.ncols() != dx {
            return Err(Error::DimensionMismatch {
                what: "regression input columns".into(),
                expected: dx,
                found: x.ncols(),
            });
        }
        check_finite("regression inputs", x)?;
        let x_unit = self.x_unit;
        let (train, queries) = scaled_about_mean(
            &self.x_rows,
            dx,
            &half_inv_l2(&self.std_kernel),
            x.nrows(),
            |r, t| x[(r, t)] / x_unit,
        );
        // At unit scale the means are the starting point of the sum, as they always were; a
        // standardised regression sums in its units and then goes back to the user's.
        let standardised = self.y_unit != 1.0;
        let mut mean = Mat::from_fn(x.nrows(), self.y_mean.len(), |_, j| {
            if standardised {
                0.0
            } else {
                self.y_mean[j]
            }
        });
        for_each_kernel_block(queries.as_ref(), train.as_ref(), |r0, kb| {
            faer::linalg::matmul::matmul(
                mean.as_mut().subrows_mut(r0, kb.nrows()),
                Accum::Add,
                kb,
                self.alpha.as_ref(),
                self.std_kernel.variance,
                Par::Seq,
            );
        });
        if standardised {
            for j in 0..mean.ncols() {
                for v in mean.col_as_slice_mut(j) {
                    *v = *v * self.y_unit + self.y_mean[j];
                }
            }
        }
        Ok(mean)
    }

    /// The trained hyperparameters (one lengthscale per input column), in the units of the
    /// data given to [`GpRegression::fit`].
    pub fn kernel(&self) -> &KernelParams {
        &self.kernel
    }

    /// Negative log marginal likelihood of the training outputs at the trained
    /// hyperparameters (of the outputs in the user's units: standardising by `u` adds
    /// `N·D_y·ln u`).
    pub fn objective(&self) -> f64 {
        let (n, d) = (self.alpha.nrows(), self.alpha.ncols());
        self.objective + (n * d) as f64 * self.y_unit.ln()
    }

    /// Why training stopped (converged, iteration budget, `max_seconds`, interrupt, ...);
    /// `None` for a regression made with given hyperparameters.
    pub fn stop_reason(&self) -> Option<&StopReason> {
        self.stop_reason.as_ref()
    }
}

#[cfg(test)]
mod tests {
    use crate::test_support::*;

    /// The regression's mean against the dense formula `k(x*, X) (K + σ²I)⁻¹ (Y − ȳ) + ȳ`, at
    /// its trained hyperparameters.
    #[test]
    fn prediction_matches_the_dense_posterior_mean() {
        use faer::linalg::solvers::DenseSolveCore;
        let (h, r, _, _) = demo(60, 4);
        let gp = GpRegression::fit(h.as_ref(), r.as_ref(), &TrainOptions::default()).unwrap();
        let k = gp.kernel().clone();
        let kx = |a: MatRef<'_, f64>, i: usize, b: MatRef<'_, f64>, j: usize| {
            let d2: f64 = (0..a.ncols())
                .map(|t| ((a[(i, t)] - b[(j, t)]) / k.lengthscale[t]).powi(2))
                .sum();
            k.variance * (-0.5 * d2).exp()
        };
        let n = h.nrows();
        let kk = Mat::from_fn(n, n, |i, j| {
            kx(h.as_ref(), i, h.as_ref(), j) + if i == j { k.noise } else { 0.0 }
        });
        let mean: Vec<f64> = (0..r.ncols())
            .map(|j| (0..n).map(|i| r[(i, j)]).sum::<f64>() / n as f64)
            .collect();
        let yc = Mat::from_fn(n, r.ncols(), |i, j| r[(i, j)] - mean[j]);
        let alpha = kk.llt(faer::Side::Lower).expect("pd").inverse() * &yc;
        let (hq, _, _, _) = demo(25, 9);
        let pred = gp.predict(hq.as_ref()).unwrap();
        for q in 0..hq.nrows() {
            for j in 0..r.ncols() {
                let dense: f64 = (0..n)
                    .map(|i| kx(hq.as_ref(), q, h.as_ref(), i) * alpha[(i, j)])
                    .sum::<f64>()
                    + mean[j];
                assert!(
                    (pred[(q, j)] - dense).abs() < 1e-9,
                    "{} vs {dense}",
                    pred[(q, j)]
                );
            }
        }
        // It learned something: far better than predicting the mean on the training inputs.
        let fitted = gp.predict(h.as_ref()).unwrap();
        let err: f64 = (0..n)
            .map(|i| (fitted[(i, 0)] - r[(i, 0)]).powi(2))
            .sum::<f64>()
            / n as f64;
        let var: f64 = (0..n).map(|i| (r[(i, 0)] - mean[0]).powi(2)).sum::<f64>() / n as f64;
        assert!(err < 0.01 * var, "training MSE {err} vs variance {var}");
    }

    /// Inputs and outputs ×2^±500 (≈ 3·10^∓151) train exactly as at unit scale: the same
    /// hyperparameters in the data's units, the same predictions (inputs scaled) or the same
    /// predictions times the factor (outputs scaled).
    #[test]
    fn data_far_from_unit_scale_is_standardised_exactly() {
        let (h, r, _, _) = demo(40, 5);
        let (h, r) = (unit_scale(&h), unit_scale(&r));
        let (hq, _, _, _) = demo(15, 8);
        let opts = TrainOptions::default().with_max_iters(60);
        let unit = GpRegression::fit(h.as_ref(), r.as_ref(), &opts).unwrap();
        let p1 = unit.predict(hq.as_ref()).unwrap();
        let k1 = unit.kernel().clone();
        let mut by_output_factor = Vec::new();
        for f in [2f64.powi(-500), 2f64.powi(500)] {
            // Inputs scaled: identical hyperparameters (lengthscales ×f) and predictions.
            let gp = GpRegression::fit(times(&h, f).as_ref(), r.as_ref(), &opts).unwrap();
            let k = gp.kernel();
            assert_eq!(k.variance, k1.variance, "×{f:e}");
            assert_eq!(k.noise, k1.noise, "×{f:e}");
            let ls: Vec<f64> = k1.lengthscale.iter().map(|l| l * f).collect();
            assert_eq!(k.lengthscale, ls, "×{f:e}");
            assert_eq!(gp.predict(times(&hq, f).as_ref()).unwrap(), p1, "×{f:e}");
            assert_eq!(gp.stop_reason(), unit.stop_reason());
            // Outputs scaled: variances ×f², predictions ×f.
            let gp = GpRegression::fit(h.as_ref(), times(&r, f).as_ref(), &opts).unwrap();
            assert_eq!(gp.kernel().variance, k1.variance * f * f, "×{f:e}");
            assert_eq!(gp.kernel().lengthscale, k1.lengthscale, "×{f:e}");
            let p = gp.predict(hq.as_ref()).unwrap();
            let back = times(&p, 1.0 / f);
            for i in 0..p.nrows() {
                for j in 0..p.ncols() {
                    assert!((back[(i, j)] - p1[(i, j)]).abs() < 1e-12, "×{f:e}");
                }
            }
            let n_d = (r.nrows() * r.ncols()) as f64;
            let objective = unit.objective() + n_d * f.ln();
            assert!((gp.objective() - objective).abs() < 1e-9 * objective.abs());
            by_output_factor.push(back);
        }
        // The two factors sum in the same standardised units: bit for bit the same.
        assert_eq!(by_output_factor[0], by_output_factor[1]);
    }

    #[test]
    fn data_beyond_the_accepted_scales_is_refused_naming_inputs_or_outputs() {
        let (h, r, _, _) = demo(20, 3);
        let opts = TrainOptions::default().with_max_iters(5);
        for (x, y, what) in [
            (times(&h, 1e-160), r.clone(), "regression inputs"),
            (h.clone(), times(&r, 1e160), "regression outputs"),
        ] {
            let e = GpRegression::fit(x.as_ref(), y.as_ref(), &opts).expect_err("refused");
            assert!(matches!(e, Error::DataScale { .. }), "{e:?}");
            let text = e.to_string();
            assert!(text.starts_with(&format!("space '{what}'")), "{text}");
            assert!(
                text.contains("expected a scale between 1e-153 and 1e153"),
                "{text}"
            );
        }
    }

    /// Training is bounded like the shared model's, and says why it stopped.
    #[test]
    fn max_seconds_and_the_interrupt_stop_training_and_say_so() {
        let (h, r, _, _) = demo(40, 2);
        let opts = TrainOptions::default().with_max_iters(200);
        let full = GpRegression::fit(h.as_ref(), r.as_ref(), &opts).unwrap();
        assert!(
            matches!(
                full.stop_reason(),
                Some(
                    StopReason::GradientTolerance
                        | StopReason::RelativeTolerance
                        | StopReason::MaxIterations
                        | StopReason::LineSearch(_)
                )
            ),
            "{:?}",
            full.stop_reason()
        );
        let timed = GpRegression::fit(
            h.as_ref(),
            r.as_ref(),
            &opts.clone().with_max_seconds(Some(0.0)),
        )
        .unwrap();
        assert_eq!(timed.stop_reason(), Some(&StopReason::TimeLimit));
        let stop = crate::train::Interrupt::new(|| true);
        let stopped =
            GpRegression::fit(h.as_ref(), r.as_ref(), &opts.with_interrupt(stop)).unwrap();
        assert_eq!(stopped.stop_reason(), Some(&StopReason::Interrupted));
        // Stopped at once, they keep the starting kernel: their predictions still exist.
        assert!(stopped.predict(h.as_ref()).is_ok());
        assert_eq!(stopped.kernel(), timed.kernel());
    }

    #[test]
    fn bad_input_is_a_typed_error() {
        let (h, r, _, _) = demo(30, 1);
        let opts = TrainOptions::default();
        assert!(matches!(
            GpRegression::fit(h.as_ref(), r.as_ref().subrows(0, 29), &opts),
            Err(Error::RowCountMismatch { .. })
        ));
        let mut bad = h.clone();
        bad[(3, 2)] = f64::NAN;
        assert!(matches!(
            GpRegression::fit(bad.as_ref(), r.as_ref(), &opts),
            Err(Error::NonFinite { .. })
        ));
        let gp = GpRegression::fit(h.as_ref(), r.as_ref(), &opts.with_max_iters(5)).unwrap();
        assert!(matches!(
            gp.predict(r.as_ref()),
            Err(Error::DimensionMismatch { .. })
        ));
    }
}
