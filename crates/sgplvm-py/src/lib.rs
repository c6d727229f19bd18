//! Python bindings of sgplvm, built by maturin into the native module `sgplvm._sgplvm`; the
//! Python package `sgplvm` (in `python/`) wraps it with argument conversion, pickling and type
//! stubs.

#![deny(clippy::unwrap_used)]

use pyo3::prelude::*;

mod bayesian;
mod demos;
mod experiment;
mod guard;
mod model;
mod parts;
mod regression;
mod retarget;
mod robots;

/// The native part of the `sgplvm` Python package.
#[pymodule]
fn _sgplvm(m: &Bound<'_, PyModule>) -> PyResult<()> {
    guard::quiet_hook();
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add(
        "DEFAULT_PATIENCE",
        sgplvm_core::Validation::DEFAULT_PATIENCE,
    )?;
    m.add_class::<model::NativeModel>()?;
    m.add_class::<parts::NativePartsModel>()?;
    m.add_function(wrap_pyfunction!(parts::arm_columns, m)?)?;
    m.add_function(wrap_pyfunction!(parts::load_any, m)?)?;
    m.add_class::<regression::NativeRegression>()?;
    m.add_class::<robots::PyRobot>()?;
    m.add_function(wrap_pyfunction!(model::canonical_back_constraint, m)?)?;
    m.add_function(wrap_pyfunction!(model::sparse_bound, m)?)?;
    m.add_function(wrap_pyfunction!(bayesian::bayesian_bound, m)?)?;
    m.add_function(wrap_pyfunction!(demos::read_joint_states, m)?)?;
    m.add_function(wrap_pyfunction!(demos::write_joint_states, m)?)?;
    m.add_function(wrap_pyfunction!(demos::load_demonstrations, m)?)?;
    m.add_function(wrap_pyfunction!(demos::read_bvh, m)?)?;
    m.add_function(wrap_pyfunction!(demos::simulate, m)?)?;
    m.add_function(wrap_pyfunction!(retarget::retarget_native, m)?)?;
    m.add_function(wrap_pyfunction!(guard::panic_for_tests, m)?)?;
    m.add_function(wrap_pyfunction!(experiment::experiment_config, m)?)?;
    m.add_function(wrap_pyfunction!(experiment::experiment_data, m)?)?;
    m.add_function(wrap_pyfunction!(experiment::experiment_plan, m)?)?;
    m.add_function(wrap_pyfunction!(experiment::experiment_execute, m)?)?;
    m.add_function(wrap_pyfunction!(experiment::experiment_assemble, m)?)?;
    m.add_function(wrap_pyfunction!(experiment::experiment_run, m)?)?;
    m.add_function(wrap_pyfunction!(experiment::experiment_write_outputs, m)?)?;
    m.add_function(wrap_pyfunction!(experiment::experiment_report, m)?)?;
    Ok(())
}
