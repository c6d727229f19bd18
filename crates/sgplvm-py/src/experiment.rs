//! The paper's experiment from Python, as the facade crate splits it: the plan of tasks, one
//! task's execution, and the report assembled from the tasks' records. `sgplvm.ray` schedules
//! the tasks on a Ray cluster; the serial `sgplvm experiment` runs the same functions in order.
//!
//! Everything crosses as bytes: the data and the records as JSON (floats round-trip exactly),
//! models as their own bytes, so tasks and results can be pickled and sent anywhere.

use std::path::PathBuf;

use pyo3::exceptions::{PyOSError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyBytes;
use sgplvm::experiment::{
    self, ExperimentConfig, ExperimentData, ExperimentError, Task, TaskResult,
};
use sgplvm::pipeline::{self, PipelineError};
use sgplvm_core::SharedGplvm;

use crate::guard::guarded;

/// `OSError` for files, `ValueError` for everything else (each message names what failed).
fn experiment_error(e: ExperimentError) -> PyErr {
    match e {
        ExperimentError::File(_) => PyOSError::new_err(e.to_string()),
        other => PyValueError::new_err(other.to_string()),
    }
}

fn pipeline_error(e: PipelineError) -> PyErr {
    PyValueError::new_err(e.to_string())
}

/// Reads a JSON argument `what`, naming it and what was expected when it does not parse.
fn from_json<T: serde::de::DeserializeOwned>(
    text: &[u8],
    what: &str,
    expected: &str,
) -> PyResult<T> {
    serde_json::from_slice(text)
        .map_err(|e| PyValueError::new_err(format!("{what}: {e}; expected {expected}")))
}

fn to_json<T: serde::Serialize>(value: &T) -> PyResult<String> {
    serde_json::to_string(value)
        .map_err(|e| PyValueError::new_err(format!("cannot write JSON: {e}")))
}

fn config_from(config: &str) -> PyResult<ExperimentConfig> {
    from_json(config.as_bytes(), "config", "an ExperimentConfig as JSON")
}

fn results_from(results: &str) -> PyResult<experiment::Results> {
    from_json(
        results.as_bytes(),
        "results",
        "the JSON of experiment_assemble",
    )
}

fn data_from(data: &[u8]) -> PyResult<ExperimentData> {
    ExperimentData::from_json(data).map_err(experiment_error)
}

/// The named protocol ("quick" or "paper") as JSON.
#[pyfunction]
pub fn experiment_config(name: &str) -> PyResult<String> {
    match name {
        "quick" => to_json(&ExperimentConfig::quick()),
        "paper" => to_json(&ExperimentConfig::paper()),
        other => Err(PyValueError::new_err(format!(
            "config is {other:?}; expected \"quick\", \"paper\" or a dict of ExperimentConfig fields"
        ))),
    }
}

/// The experiment's data (training/test frames of the human and every robot, the held-out
/// rows) from a demonstrations file, or the shipped/generated default with `None`, as bytes.
/// With `all_frames`, also every training frame at full rate (for a config with `inducing`:
/// the all-frames study of `sgplvm experiment --all-frames`).
/// With `parts`, also the arms' columns and the recombined frames (for a config with `parts`:
/// the study of `sgplvm experiment --parts`).
#[pyfunction]
#[pyo3(signature = (path=None, all_frames=false, parts=false))]
pub fn experiment_data<'py>(
    py: Python<'py>,
    path: Option<PathBuf>,
    all_frames: bool,
    parts: bool,
) -> PyResult<Bound<'py, PyBytes>> {
    guarded(|| {
        let bytes = py
            .detach(|| -> Result<Vec<u8>, PipelineError> {
                let demos = pipeline::load(path.as_deref())?;
                let mut data = demos.experiment_data()?;
                if all_frames {
                    data.all_frames = Some(demos.all_frames_data()?);
                }
                if parts {
                    data.parts = Some(demos.parts_data()?);
                }
                Ok(data.to_json())
            })
            .map_err(pipeline_error)?;
        Ok(PyBytes::new(py, &bytes))
    })
}

/// Every task of the experiment, in serial order, as a JSON list.
#[pyfunction]
pub fn experiment_plan(data: &[u8], config: &str) -> PyResult<String> {
    guarded(|| {
        let data = data_from(data)?;
        to_json(&experiment::plan(&config_from(config)?, &data))
    })
}

/// Performs one task (JSON) given the model bytes of its source task; returns its records
/// (JSON) and, when later tasks start from it, its model's bytes.
#[pyfunction]
#[pyo3(signature = (data, config, task, source=None))]
pub fn experiment_execute<'py>(
    py: Python<'py>,
    data: &[u8],
    config: &str,
    task: &str,
    source: Option<&[u8]>,
) -> PyResult<(String, Option<Bound<'py, PyBytes>>)> {
    guarded(|| {
        let data = data_from(data)?;
        let config = config_from(config)?;
        let task: Task = from_json(task.as_bytes(), "task", "a task of experiment_plan")?;
        let source = source
            .map(|bytes| {
                SharedGplvm::from_bytes(bytes)
                    .map_err(|e| PyValueError::new_err(format!("source model: {e}")))
            })
            .transpose()?;
        let (result, model) = py
            .detach(|| experiment::execute(&task, &data, &config, source.as_ref()))
            .map_err(experiment_error)?;
        let bytes = model.map(|m| PyBytes::new(py, &m.to_bytes()));
        Ok((to_json(&result)?, bytes))
    })
}

/// The results (JSON, as `results.json`) from the records of every task, in any order.
#[pyfunction]
pub fn experiment_assemble(data: &[u8], config: &str, results: Vec<String>) -> PyResult<String> {
    guarded(|| {
        let data = data_from(data)?;
        let config = config_from(config)?;
        let results = results
            .iter()
            .map(|r| {
                from_json::<TaskResult>(
                    r.as_bytes(),
                    "task result",
                    "a record of experiment_execute",
                )
            })
            .collect::<PyResult<Vec<_>>>()?;
        let results = experiment::assemble(&data, &config, results).map_err(experiment_error)?;
        serde_json::to_string_pretty(&results)
            .map_err(|e| PyValueError::new_err(format!("cannot write results: {e}")))
    })
}

/// The serial experiment (what `sgplvm experiment` runs), its results as JSON.
#[pyfunction]
pub fn experiment_run(py: Python<'_>, data: &[u8], config: &str) -> PyResult<String> {
    guarded(|| {
        let data = data_from(data)?;
        let config = config_from(config)?;
        let results = py
            .detach(|| experiment::run(&data, &config, &mut |_| {}))
            .map_err(experiment_error)?;
        serde_json::to_string_pretty(&results)
            .map_err(|e| PyValueError::new_err(format!("cannot write results: {e}")))
    })
}

/// Writes `results.json`, the figures and `report.md` into `out` (each file atomically);
/// returns the paths written.
#[pyfunction]
pub fn experiment_write_outputs(
    py: Python<'_>,
    results: &str,
    out: PathBuf,
) -> PyResult<Vec<String>> {
    guarded(|| {
        let results = results_from(results)?;
        let written = py
            .detach(|| experiment::write_outputs(&results, &out))
            .map_err(experiment_error)?;
        Ok(written.iter().map(|p| p.display().to_string()).collect())
    })
}

/// The report (Markdown) of results (JSON).
#[pyfunction]
pub fn experiment_report(results: &str) -> PyResult<String> {
    guarded(|| {
        let results = results_from(results)?;
        Ok(experiment::report(&results))
    })
}
