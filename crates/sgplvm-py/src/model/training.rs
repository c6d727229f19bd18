//! A training run with the GIL released: Python's signal handlers checked between objective
//! evaluations (Ctrl-C stops it, keeping the model trained so far), and the Python callbacks
//! called with the GIL held, their exceptions raised once training has returned.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, PoisonError};
use std::time::{Duration, Instant};

use pyo3::exceptions::PyKeyboardInterrupt;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use sgplvm_core::{
    Control, Interrupt, IterationRecord, SelectionCallback, SharedGplvm, TrainOptions,
    ValidationRecord,
};

use super::model_error;

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
pub(super) fn train_detached(
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
    settle(py, Some(&outcome.raised), &outcome.signal, result)
}

/// What a training run with the GIL released comes to: the exception a callback raised (in
/// `raised`), if one did; else the trained value with the exception a signal handler raised
/// during it (in `signal`) or just after it ([`late_signal`]), if one did. A signal's exception
/// wins over a training error: the user pressed Ctrl-C.
pub(crate) fn settle<T>(
    py: Python<'_>,
    raised: Option<&Mutex<Option<PyErr>>>,
    signal: &Mutex<Option<PyErr>>,
    result: sgplvm_core::Result<T>,
) -> PyResult<(T, Option<PyErr>)> {
    let take = |m: &Mutex<Option<PyErr>>| m.lock().unwrap_or_else(PoisonError::into_inner).take();
    if let Some(e) = raised.and_then(take) {
        return Err(e);
    }
    match (result, take(signal).or_else(|| late_signal(py))) {
        (Ok(value), signal) => Ok((value, signal)),
        (Err(_), Some(e)) => Err(e),
        (Err(e), None) => Err(model_error(e)),
    }
}

/// A trained `model` (a model or regression) as a Python result: the model, or — when a signal
/// handler raised during its training — that exception, carrying the model as its
/// `_sgplvm_native` attribute (the Python wrapper keeps it: the best parameters reached before
/// the interrupt).
pub(crate) fn finish_training<T>(py: Python<'_>, model: T, signal: Option<PyErr>) -> PyResult<T>
where
    T: pyo3::PyClass + Into<pyo3::PyClassInitializer<T>>,
{
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
