//! Python bindings of sgplvm.
use pyo3::prelude::*;

/// The native part of the `sgplvm` Python package.
#[pymodule]
fn _sgplvm(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
