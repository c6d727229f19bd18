//! No Rust panic reaches Python as pyo3's `PanicException` (a `BaseException`, which
//! `except Exception` does not catch): every entry point runs under [`guarded`], which turns a
//! panic into a `RuntimeError` carrying the panic's message. The panic hook installed on import
//! ([`quiet_hook`]) prints nothing for panics inside [`guarded`], whose message the exception
//! carries, so that Python shows the exception alone instead of Rust panic text before it.

use pyo3::exceptions::PyRuntimeError;
use pyo3::prelude::*;

/// Runs `f`; a panic inside it (on this thread or propagated from a worker thread) becomes a
/// `RuntimeError` with the panic's message.
pub(crate) fn guarded<T>(f: impl FnOnce() -> PyResult<T>) -> PyResult<T> {
    match sgplvm_robots::panics::catch(f) {
        Ok(result) => result,
        Err(message) => Err(PyRuntimeError::new_err(format!(
            "internal error in sgplvm (please report it): {}",
            sgplvm_robots::panics::one_line(&message)
        ))),
    }
}

/// Installs the panic hook: quiet inside [`guarded`] (and inside the readers' own caught
/// sections), the previous hook (Rust's default, or another extension's) everywhere else.
pub(crate) fn quiet_hook() {
    let previous = std::panic::take_hook();
    sgplvm_robots::panics::install_hook(Box::new(move |info| previous(info)));
}

/// Panics with `message` inside [`guarded`]: lets the tests check that a panic arrives in
/// Python as a `RuntimeError`.
#[pyfunction(name = "_panic_for_tests")]
pub(crate) fn panic_for_tests(message: &str) -> PyResult<()> {
    guarded(|| panic!("{message}"))
}
