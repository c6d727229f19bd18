//! No Rust panic reaches Python as pyo3's `PanicException` (a `BaseException`, which
//! `except Exception` does not catch): every entry point runs under [`guarded`], which turns a
//! panic into a `RuntimeError` carrying the panic's message.

use std::panic::{catch_unwind, AssertUnwindSafe};

use pyo3::exceptions::PyRuntimeError;
use pyo3::prelude::*;

/// Runs `f`; a panic inside it (on this thread or propagated from a worker thread) becomes a
/// `RuntimeError` with the panic's message.
pub(crate) fn guarded<T>(f: impl FnOnce() -> PyResult<T>) -> PyResult<T> {
    match catch_unwind(AssertUnwindSafe(f)) {
        Ok(result) => result,
        Err(payload) => {
            let message = payload
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| payload.downcast_ref::<String>().cloned())
                .unwrap_or_else(|| "a panic without a message".into());
            Err(PyRuntimeError::new_err(format!(
                "internal error in sgplvm (please report it): {message}"
            )))
        }
    }
}

/// Panics with `message` inside [`guarded`]: lets the tests check that a panic arrives in
/// Python as a `RuntimeError`.
#[pyfunction(name = "_panic_for_tests")]
pub(crate) fn panic_for_tests(message: &str) -> PyResult<()> {
    guarded(|| panic!("{message}"))
}
