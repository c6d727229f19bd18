//! The native model class behind `sgplvm.SharedGPLVM` (the Python wrapper in
//! `python/sgplvm/_model.py` converts arguments and adds pickling).

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, PoisonError};
use std::time::{Duration, Instant};

use numpy::ndarray::Array2;
use numpy::{PyArray1, PyArray2, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::exceptions::{PyKeyboardInterrupt, PyMemoryError, PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyDict};
use sgplvm_core::{
    BackConstraint, Control, Interrupt, IterationRecord, KernelParams, LatentParams, Mat,
    ModelConfig, Params, SelectionCallback, SharedGplvm, TrainOptions, Validation,
    ValidationRecord,
};

use crate::guard::guarded;

/// Converts a core error into the Python exception a user expects: `OSError` for files,
/// `MemoryError` for a model too large for memory (refused before allocating), `RuntimeError`
/// for a kernel that cannot be factorised, `ValueError` for the rest.
pub(crate) fn model_error(e: sgplvm_core::Error) -> PyErr {
    match e {
        sgplvm_core::Error::Io { .. } => pyo3::exceptions::PyOSError::new_err(e.to_string()),
        sgplvm_core::Error::NotPositiveDefinite { .. } => PyRuntimeError::new_err(e.to_string()),
        sgplvm_core::Error::TooLarge { .. } | sgplvm_core::Error::TooLargeSparse { .. } => {
            PyMemoryError::new_err(e.to_string())
        }
        _ => PyValueError::new_err(e.to_string()),
    }
}

/// [`model_error`] for reading `source` (a path, or "bytes"/"pickle"): the message names it.
fn read_error(source: &str, e: sgplvm_core::Error) -> PyErr {
    match e {
        sgplvm_core::Error::Io { .. } => model_error(e),
        sgplvm_core::Error::TooLarge { .. } | sgplvm_core::Error::TooLargeSparse { .. } => {
            PyMemoryError::new_err(format!("{source}: {e}"))
        }
        other => PyValueError::new_err(format!("{source}: {other}")),
    }
}

/// A (rows × cols) faer matrix from a 2-D float64 numpy array of any memory order.
pub(crate) fn to_mat(a: &PyReadonlyArray2<'_, f64>) -> Mat<f64> {
    let view = a.as_array();
    Mat::from_fn(view.nrows(), view.ncols(), |i, j| view[[i, j]])
}

/// A 2-D numpy array from a faer matrix.
pub(crate) fn to_numpy<'py>(py: Python<'py>, m: &Mat<f64>) -> Bound<'py, PyArray2<f64>> {
    let array = Array2::from_shape_fn((m.nrows(), m.ncols()), |(i, j)| m[(i, j)]);
    PyArray2::from_owned_array(py, array)
}

/// Python's spelling of a back constraint: `None` (or "none") for free latent points, else the
/// core's names ("input", "output"; see [`BackConstraint`]'s `FromStr`).
fn parse_back_constraint(value: Option<&str>) -> PyResult<BackConstraint> {
    value.map_or(Ok(BackConstraint::None), |name| {
        name.parse().map_err(|_| {
            PyValueError::new_err(format!(
                "back_constraint is {name:?}; expected \"input\", \"output\" or None"
            ))
        })
    })
}

/// The Python value of a back constraint: `None` for free latent points, else its name.
fn back_constraint_name(bc: BackConstraint) -> Option<&'static str> {
    (bc != BackConstraint::None).then(|| bc.name())
}

/// Checks a `back_constraint` argument of any Python type and returns its canonical value
/// ("input", "output" or None); anything else is a ValueError that names what is accepted.
#[pyfunction]
pub(crate) fn canonical_back_constraint(
    value: &Bound<'_, PyAny>,
) -> PyResult<Option<&'static str>> {
    if value.is_none() {
        return Ok(None);
    }
    match value
        .extract::<String>()
        .ok()
        .map(|s| s.parse::<BackConstraint>())
    {
        Some(Ok(bc)) => Ok(back_constraint_name(bc)),
        _ => Err(PyValueError::new_err(format!(
            "back_constraint is {}; expected 'input', 'output' or None",
            value.repr()?
        ))),
    }
}

/// How often, at most, a training looks at Python's signal handlers.
const SIGNAL_CHECK_INTERVAL: Duration = Duration::from_millis(50);

/// An interrupt that runs Python's signal handlers (`PyErr_CheckSignals`, with the GIL) at
/// most every [`SIGNAL_CHECK_INTERVAL`]; the first exception a handler raises (a
/// `KeyboardInterrupt` on Ctrl-C) is kept in `raised` and stops training.
pub(crate) fn signal_interrupt(raised: Arc<Mutex<Option<PyErr>>>) -> Interrupt {
    let last = Mutex::new(Instant::now());
    Interrupt::new(move || {
        let mut raised = raised.lock().unwrap_or_else(PoisonError::into_inner);
        if raised.is_some() {
            return true;
        }
        let mut last = last.lock().unwrap_or_else(PoisonError::into_inner);
        if last.elapsed() < SIGNAL_CHECK_INTERVAL {
            return false;
        }
        *last = Instant::now();
        match Python::attach(|py| py.check_signals()) {
            Ok(()) => false,
            Err(e) => {
                *raised = Some(e);
                true
            }
        }
    })
}

/// The exception of a signal that arrived after training's last look at the signal handlers
/// (a Ctrl-C in its last few milliseconds): run now, so that it is raised carrying the trained
/// model rather than by the interpreter on return, without it.
pub(crate) fn late_signal(py: Python<'_>) -> Option<PyErr> {
    py.check_signals().err()
}

/// A training's model and the exception a signal handler raised during it, if one did.
type Trained = (SharedGplvm, Option<PyErr>);

/// The Python callbacks of one training: `callback(iteration, objective)` for the final run and
/// `validation_callback(record)` (a dict) for the selection run on held-out rows.
#[derive(Default)]
pub(crate) struct PyCallbacks {
    /// Hears each iteration of the final training.
    pub(crate) callback: Option<Py<PyAny>>,
    /// Hears each iteration of the selection run with its validation error.
    pub(crate) validation_callback: Option<Py<PyAny>>,
}

/// Where the Python callbacks of a training report what they raised: `raised` an exception
/// to raise after training, `signal` a `KeyboardInterrupt` to handle like Ctrl-C.
struct Outcome {
    raised: Mutex<Option<PyErr>>,
    abort: AtomicBool,
    signal: Arc<Mutex<Option<PyErr>>>,
}

impl Outcome {
    /// Runs `call` (a callback's call, GIL held): its returning False (not None) stops the
    /// run; an exception stops it too and aborts the whole training (kept in `raised`), except
    /// a `KeyboardInterrupt`, which is handled like Ctrl-C between evaluations (the interrupt
    /// stops training at its next check).
    fn call(&self, call: impl FnOnce(Python<'_>) -> PyResult<Py<PyAny>>) -> Control {
        Python::attach(|py| match call(py) {
            Ok(value) => match value.is_truthy(py) {
                Ok(false) if !value.is_none(py) => Control::Stop,
                Ok(_) => Control::Continue,
                Err(e) => self.fail(e),
            },
            Err(e) if e.is_instance_of::<PyKeyboardInterrupt>(py) => {
                *self.signal.lock().unwrap_or_else(PoisonError::into_inner) = Some(e);
                Control::Continue
            }
            Err(e) => self.fail(e),
        })
    }

    /// Keeps the first exception a callback raised and stops the training.
    fn fail(&self, e: PyErr) -> Control {
        let mut raised = self.raised.lock().unwrap_or_else(PoisonError::into_inner);
        if raised.is_none() {
            *raised = Some(e);
        }
        self.abort.store(true, Ordering::SeqCst);
        Control::Stop
    }
}

/// Runs a training with the GIL released, `options` given an interrupt that checks Python's
/// signal handlers between objective evaluations (so Ctrl-C stops it within about a second).
/// The Python callbacks, if any, are called with the GIL held and may stop their run by
/// returning False (the validation callback: the selection run, whose best iteration so far
/// becomes the budget). An exception in a callback stops training (both runs) and is raised
/// once training has returned; an exception from a signal handler (or a `KeyboardInterrupt`
/// raised in a callback) stops it too and is returned with the model trained so far (its
/// best parameters, stop reason `interrupted`).
fn train_detached(
    py: Python<'_>,
    callbacks: PyCallbacks,
    options: TrainOptions,
    train: impl FnOnce(
            &TrainOptions,
            Option<sgplvm_core::Callback<'_>>,
            Option<SelectionCallback<'_>>,
        ) -> sgplvm_core::Result<SharedGplvm>
        + Send,
) -> PyResult<Trained> {
    let outcome = Arc::new(Outcome {
        raised: Mutex::new(None),
        abort: AtomicBool::new(false),
        signal: Arc::new(Mutex::new(None)),
    });
    let signals = signal_interrupt(Arc::clone(&outcome.signal));
    let aborted = Arc::clone(&outcome);
    let options = options.with_interrupt(Interrupt::new(move || {
        aborted.abort.load(Ordering::SeqCst) || signals.should_stop()
    }));
    let result = py.detach(|| {
        let mut final_run = callbacks.callback.as_ref().map(|cb| {
            |it: &IterationRecord, _: &SharedGplvm| {
                outcome.call(|py| cb.call1(py, (it.iteration, it.objective)))
            }
        });
        let mut selection = callbacks.validation_callback.as_ref().map(|cb| {
            |rec: &ValidationRecord| {
                outcome.call(|py| {
                    let record = PyDict::new(py);
                    record.set_item("iteration", rec.iteration)?;
                    record.set_item("objective", rec.objective)?;
                    record.set_item("validation_mse", rec.validation_mse)?;
                    cb.call1(py, (record,))
                })
            }
        });
        train(
            &options,
            final_run.as_mut().map(|f| f as sgplvm_core::Callback<'_>),
            selection.as_mut().map(|f| f as SelectionCallback<'_>),
        )
    });
    if let Some(e) = outcome
        .raised
        .lock()
        .unwrap_or_else(PoisonError::into_inner)
        .take()
    {
        return Err(e);
    }
    let signal = outcome
        .signal
        .lock()
        .unwrap_or_else(PoisonError::into_inner)
        .take()
        .or_else(|| late_signal(py));
    match (result, signal) {
        (Ok(model), signal) => Ok((model, signal)),
        // A signal's exception wins over a training error: the user pressed Ctrl-C.
        (Err(_), Some(e)) => Err(e),
        (Err(e), None) => Err(model_error(e)),
    }
}

/// `model` as a Python result: the model, or — when a signal handler raised during its
/// training — that exception, carrying the model as its `_sgplvm_native` attribute (the
/// Python wrapper keeps it: the best parameters reached before the interrupt).
fn finish_training(
    py: Python<'_>,
    model: NativeModel,
    signal: Option<PyErr>,
) -> PyResult<NativeModel> {
    match signal {
        None => Ok(model),
        Some(e) => {
            let native = Py::new(py, model)?;
            // An exception type that refuses attributes still propagates, without the model.
            let _ = e.value(py).setattr("_sgplvm_native", native);
            Err(e)
        }
    }
}

/// Posterior mean and, when asked for, variance.
type MeanAndVariance<'py> = (Bound<'py, PyArray2<f64>>, Option<Bound<'py, PyArray2<f64>>>);

/// A trained shared GP-LVM (native part; use `sgplvm.SharedGPLVM`).
#[pyclass(module = "sgplvm._sgplvm", name = "NativeModel", frozen)]
pub struct NativeModel {
    pub(crate) inner: SharedGplvm,
}

#[pymethods]
impl NativeModel {
    /// Fits a model on named spaces (one robot: full model; several: multi-robot). A signal
    /// handler's exception (Ctrl-C) stops training and is raised carrying the model trained so
    /// far as its `_sgplvm_native` attribute.
    #[staticmethod]
    #[pyo3(signature = (spaces, input, latent_dim, back_constraint, seed, scale, max_iters, validation, patience, max_seconds=None, callback=None, column_names=None, inducing=None, validation_callback=None, whiten_back_constraint=false, bayesian=false))]
    #[allow(clippy::too_many_arguments)]
    fn fit(
        py: Python<'_>,
        spaces: Vec<(String, PyReadonlyArray2<'_, f64>)>,
        input: &str,
        latent_dim: usize,
        back_constraint: Option<&str>,
        seed: u64,
        scale: bool,
        max_iters: usize,
        validation: Option<Vec<usize>>,
        patience: usize,
        max_seconds: Option<f64>,
        callback: Option<Py<PyAny>>,
        column_names: Option<Vec<(String, Vec<String>)>>,
        inducing: Option<usize>,
        validation_callback: Option<Py<PyAny>>,
        whiten_back_constraint: bool,
        bayesian: bool,
    ) -> PyResult<Self> {
        guarded(|| {
            let config = ModelConfig::default()
                .with_latent_dim(latent_dim)
                .with_back_constraint(parse_back_constraint(back_constraint)?)
                .with_seed(seed)
                .with_scale(scale)
                .with_inducing(inducing)
                .with_bayesian(bayesian);
            let mats: Vec<(String, Mat<f64>)> =
                spaces.iter().map(|(n, a)| (n.clone(), to_mat(a))).collect();
            let options = TrainOptions::default()
                .with_max_iters(max_iters)
                .with_max_seconds(max_seconds)
                .with_whiten_back_constraint(whiten_back_constraint);
            let input = input.to_string();
            let callbacks = PyCallbacks {
                callback,
                validation_callback,
            };
            let (mut model, signal) =
                train_detached(py, callbacks, options, |options, cb, on_selection| {
                    let views: Vec<(&str, _)> =
                        mats.iter().map(|(n, m)| (n.as_str(), m.as_ref())).collect();
                    match validation {
                        Some(rows) => {
                            let validation = Validation::new(rows).with_patience(patience);
                            SharedGplvm::fit_validated_observed(
                                &config,
                                &views,
                                &input,
                                options,
                                &validation,
                                on_selection,
                                cb,
                            )
                        }
                        None => SharedGplvm::fit(&config, &views, &input, options, cb),
                    }
                })?;
            for (space, names) in column_names.unwrap_or_default() {
                model.set_column_names(&space, names).map_err(model_error)?;
            }
            finish_training(py, NativeModel { inner: model }, signal)
        })
    }

    /// A new model that also predicts for robot `name`, trained only on that robot's kernel.
    /// Ctrl-C as in [`NativeModel::fit`].
    #[pyo3(signature = (name, data, max_iters, validation, patience, max_seconds=None, callback=None, column_names=None, validation_callback=None))]
    #[allow(clippy::too_many_arguments)]
    fn transfer(
        &self,
        py: Python<'_>,
        name: &str,
        data: PyReadonlyArray2<'_, f64>,
        max_iters: usize,
        validation: Option<Vec<usize>>,
        patience: usize,
        max_seconds: Option<f64>,
        callback: Option<Py<PyAny>>,
        column_names: Option<Vec<String>>,
        validation_callback: Option<Py<PyAny>>,
    ) -> PyResult<Self> {
        guarded(|| {
            let data = to_mat(&data);
            let options = TrainOptions::default()
                .with_max_iters(max_iters)
                .with_max_seconds(max_seconds);
            let callbacks = PyCallbacks {
                callback,
                validation_callback,
            };
            let (mut model, signal) = train_detached(
                py,
                callbacks,
                options,
                |options, cb, on_selection| match validation {
                    Some(rows) => {
                        let validation = Validation::new(rows).with_patience(patience);
                        self.inner.transfer_validated_observed(
                            name,
                            data.as_ref(),
                            None,
                            options,
                            &validation,
                            on_selection,
                            cb,
                        )
                    }
                    None => self.inner.transfer(name, data.as_ref(), options, cb),
                },
            )?;
            if let Some(names) = column_names {
                model.set_column_names(name, names).map_err(model_error)?;
            }
            finish_training(py, NativeModel { inner: model }, signal)
        })
    }

    /// Why the last training stopped (`StopReason::name`), if the model was trained.
    #[getter]
    fn stop_reason(&self) -> Option<&'static str> {
        self.inner.stop_reason().map(|r| r.name())
    }

    /// Every third of nine equal blocks of `n` rows: the default validation rows.
    #[staticmethod]
    fn block_validation_rows(n: usize) -> Vec<usize> {
        Validation::blocks(n).rows
    }

    /// How the iteration budget was chosen on held-out frames (JSON), if it was.
    fn selection_json(&self) -> Option<String> {
        self.inner
            .selection()
            .and_then(|s| serde_json::to_string(s).ok())
    }

    /// Posterior mean (and variance, when asked) of `robot` for human frames `h` (n × D_H).
    fn predict<'py>(
        &self,
        py: Python<'py>,
        h: PyReadonlyArray2<'py, f64>,
        robot: &str,
        with_variance: bool,
    ) -> PyResult<MeanAndVariance<'py>> {
        guarded(|| {
            let h = to_mat(&h);
            let prediction = py
                .detach(|| self.inner.predict(h.as_ref(), robot, with_variance))
                .map_err(model_error)?;
            let variance = prediction.variance.as_ref().map(|v| to_numpy(py, v));
            Ok((to_numpy(py, &prediction.mean), variance))
        })
    }

    /// Latent points of human frames (n × Q).
    fn latent<'py>(
        &self,
        py: Python<'py>,
        h: PyReadonlyArray2<'py, f64>,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        guarded(|| {
            let h = to_mat(&h);
            let x = py
                .detach(|| self.inner.latent(h.as_ref()))
                .map_err(model_error)?;
            Ok(to_numpy(py, &x))
        })
    }

    /// Latent points of the training frames (N × Q).
    fn latent_points<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        to_numpy(py, &self.inner.latent_points().to_owned())
    }

    /// Name of the input (human) space.
    #[getter]
    fn input_name(&self) -> String {
        self.inner.input_name().to_string()
    }

    /// Names of the robot spaces.
    #[getter]
    fn output_names(&self) -> Vec<String> {
        self.inner
            .output_names()
            .into_iter()
            .map(str::to_string)
            .collect()
    }

    /// Column (joint) names of a space, if they were given.
    fn column_names(&self, space: &str) -> Option<Vec<String>> {
        self.inner.column_names(space).map(|c| c.to_vec())
    }

    /// Dimension of a space.
    fn space_dim(&self, space: &str) -> Option<usize> {
        self.inner.space_dim(space)
    }

    /// Inducing inputs Z (M×Q) of a sparse model; None for the exact model.
    fn inducing_inputs<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray2<f64>>> {
        self.inner
            .inducing_inputs()
            .map(|z| to_numpy(py, &z.to_owned()))
    }

    /// Variances S (N×Q) of a Bayesian model's q(X); None for point latent positions.
    fn latent_variances<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray2<f64>>> {
        self.inner
            .latent_variances()
            .map(|s| to_numpy(py, &s.to_owned()))
    }

    /// ARD weights α²/ℓ_q² of a space's kernel, one per latent dimension.
    fn ard_weights(&self, space: &str) -> PyResult<Vec<f64>> {
        self.inner.ard_weights(space).map_err(model_error)
    }

    /// Configuration as a dict (latent_dim, back_constraint, seed, scale, inducing, bayesian).
    fn config<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let c = self.inner.config();
        let d = PyDict::new(py);
        d.set_item("latent_dim", c.latent_dim)?;
        d.set_item("back_constraint", back_constraint_name(c.back_constraint))?;
        d.set_item("seed", c.seed)?;
        d.set_item("scale", c.scale)?;
        d.set_item("inducing", c.inducing)?;
        d.set_item("bayesian", c.bayesian)?;
        Ok(d)
    }

    /// Training history: iteration, objective, seconds, gradient norm and evaluations so far
    /// (objective + gradient, the line searches' trials included) per iteration.
    fn history<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let h = self.inner.history();
        let d = PyDict::new(py);
        d.set_item(
            "iteration",
            h.iter().map(|r| r.iteration).collect::<Vec<_>>(),
        )?;
        d.set_item(
            "objective",
            PyArray1::from_vec(py, h.iter().map(|r| r.objective).collect()),
        )?;
        d.set_item(
            "seconds",
            PyArray1::from_vec(py, h.iter().map(|r| r.seconds).collect()),
        )?;
        d.set_item(
            "gradient_norm",
            PyArray1::from_vec(py, h.iter().map(|r| r.gradient_norm).collect()),
        )?;
        d.set_item(
            "evaluations",
            h.iter().map(|r| r.evaluations).collect::<Vec<_>>(),
        )?;
        Ok(d)
    }

    /// Parameters in natural units as nested dicts of numpy arrays and floats.
    fn params<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        guarded(|| params_to_dict(py, &self.inner.params()))
    }

    /// Gradient of the objective, in the structure of `params`.
    fn gradient<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        guarded(|| params_to_dict(py, &self.inner.gradient()))
    }

    /// Negative log marginal likelihood at the current parameters.
    fn objective(&self) -> PyResult<f64> {
        guarded(|| Ok(self.inner.objective()))
    }

    /// A copy of the model with the given parameters.
    fn with_params(&self, params: &Bound<'_, PyDict>) -> PyResult<Self> {
        guarded(|| {
            let current = self.inner.params();
            let p = params_from_dict(params, &current)?;
            let model = self.inner.with_params(&p).map_err(model_error)?;
            Ok(NativeModel { inner: model })
        })
    }

    /// The versioned model file as bytes.
    fn to_bytes<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyBytes>> {
        guarded(|| Ok(PyBytes::new(py, &self.inner.to_bytes())))
    }

    /// Reads a model from bytes (`source` names them in errors).
    #[staticmethod]
    fn from_bytes(py: Python<'_>, bytes: &[u8], source: &str) -> PyResult<Self> {
        guarded(|| {
            py.detach(|| SharedGplvm::from_bytes(bytes))
                .map(|inner| NativeModel { inner })
                .map_err(|e| read_error(source, e))
        })
    }

    /// Writes the model file atomically.
    fn save(&self, py: Python<'_>, path: std::path::PathBuf) -> PyResult<()> {
        guarded(|| py.detach(|| self.inner.save(&path)).map_err(model_error))
    }

    /// Reads a model file.
    #[staticmethod]
    fn load(py: Python<'_>, path: std::path::PathBuf) -> PyResult<Self> {
        guarded(|| {
            py.detach(|| SharedGplvm::load(&path))
                .map(|inner| NativeModel { inner })
                .map_err(|e| read_error(&path.display().to_string(), e))
        })
    }
}

pub(crate) fn kernel_to_dict<'py>(
    py: Python<'py>,
    k: &KernelParams,
) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("variance", k.variance)?;
    d.set_item("lengthscale", PyArray1::from_slice(py, &k.lengthscale))?;
    d.set_item("noise", k.noise)?;
    Ok(d)
}

fn params_to_dict<'py>(py: Python<'py>, p: &Params) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    match &p.latent {
        LatentParams::Free { x } => d.set_item("latent", to_numpy(py, x))?,
        LatentParams::BackConstrained { weights, bandwidth } => {
            let l = PyDict::new(py);
            l.set_item("weights", to_numpy(py, weights))?;
            l.set_item("bandwidth", *bandwidth)?;
            d.set_item("latent", l)?;
        }
    }
    let spaces = PyDict::new(py);
    for (name, k) in &p.spaces {
        spaces.set_item(name, kernel_to_dict(py, k)?)?;
    }
    d.set_item("spaces", spaces)?;
    Ok(d)
}

fn get_item<'py>(d: &Bound<'py, PyDict>, key: &str, context: &str) -> PyResult<Bound<'py, PyAny>> {
    d.get_item(key)?
        .ok_or_else(|| PyValueError::new_err(format!("{context}: missing key {key:?}")))
}

fn matrix_from_any(
    value: &Bound<'_, PyAny>,
    context: &str,
    rows: usize,
    cols: usize,
) -> PyResult<Mat<f64>> {
    let array: PyReadonlyArray2<'_, f64> = value
        .extract()
        .map_err(|_| PyValueError::new_err(format!("{context}: expected a 2-D float64 array")))?;
    if array.shape() != [rows, cols] {
        return Err(PyValueError::new_err(format!(
            "{context}: shape {:?}, expected ({rows}, {cols})",
            array.shape()
        )));
    }
    Ok(to_mat(&array))
}

fn params_from_dict(d: &Bound<'_, PyDict>, current: &Params) -> PyResult<Params> {
    let latent_value = get_item(d, "latent", "params")?;
    let latent = match &current.latent {
        LatentParams::Free { x } => LatentParams::Free {
            x: matrix_from_any(&latent_value, "params['latent']", x.nrows(), x.ncols())?,
        },
        LatentParams::BackConstrained { weights, bandwidth } => {
            let l = latent_value.cast::<PyDict>().map_err(|_| {
                PyValueError::new_err(
                    "params['latent']: expected a dict with 'weights' (back-constrained model)",
                )
            })?;
            let w = get_item(l, "weights", "params['latent']")?;
            let bandwidth = match l.get_item("bandwidth")? {
                Some(b) => b.extract()?,
                None => *bandwidth,
            };
            LatentParams::BackConstrained {
                weights: matrix_from_any(
                    &w,
                    "params['latent']['weights']",
                    weights.nrows(),
                    weights.ncols(),
                )?,
                bandwidth,
            }
        }
    };
    let spaces_value = get_item(d, "spaces", "params")?;
    let spaces_dict = spaces_value
        .cast::<PyDict>()
        .map_err(|_| PyValueError::new_err("params['spaces']: expected a dict of spaces"))?;
    let mut spaces = Vec::with_capacity(current.spaces.len());
    for (name, k) in &current.spaces {
        let context = format!("params['spaces'][{name:?}]");
        let s = get_item(spaces_dict, name, "params['spaces']")?;
        let s = s
            .cast::<PyDict>()
            .map_err(|_| PyValueError::new_err(format!("{context}: expected a dict")))?;
        let lengthscale: Vec<f64> =
            get_item(s, "lengthscale", &context)?
                .extract()
                .map_err(|_| {
                    PyValueError::new_err(format!(
                        "{context}['lengthscale']: expected a sequence of floats"
                    ))
                })?;
        if lengthscale.len() != k.lengthscale.len() {
            return Err(PyValueError::new_err(format!(
                "{context}['lengthscale']: {} values, expected {}",
                lengthscale.len(),
                k.lengthscale.len()
            )));
        }
        spaces.push((
            name.clone(),
            KernelParams {
                variance: get_item(s, "variance", &context)?.extract()?,
                lengthscale,
                noise: get_item(s, "noise", &context)?.extract()?,
            },
        ));
    }
    Ok(Params { latent, spaces })
}

/// One space's negative collapsed variational bound of the sparse model (see
/// `sgplvm_core::sparse_bound`) at latent points `x`, inducing inputs `z`, data `y` and an
/// RBF-ARD kernel; `relative_jitter × variance` is added to K_mm's diagonal.
#[pyfunction]
#[pyo3(signature = (x, z, y, variance, lengthscale, noise, relative_jitter))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn sparse_bound(
    x: PyReadonlyArray2<'_, f64>,
    z: PyReadonlyArray2<'_, f64>,
    y: PyReadonlyArray2<'_, f64>,
    variance: f64,
    lengthscale: Vec<f64>,
    noise: f64,
    relative_jitter: f64,
) -> PyResult<f64> {
    guarded(|| {
        let kernel = KernelParams {
            variance,
            lengthscale,
            noise,
        };
        sgplvm_core::sparse_bound(
            to_mat(&x).as_ref(),
            to_mat(&z).as_ref(),
            to_mat(&y).as_ref(),
            &kernel,
            relative_jitter,
        )
        .map_err(model_error)
    })
}
