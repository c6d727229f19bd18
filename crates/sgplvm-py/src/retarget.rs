//! `sgplvm.retarget`: robot commands for a human's motion from Python, numpy or MCAP in, with
//! the options of `sgplvm retarget`.

use std::path::PathBuf;

use numpy::ndarray::Array2;
use numpy::{PyArray2, PyReadonlyArray1, PyReadonlyArray2};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use sgplvm_robots::anatomy::Anatomy;
use sgplvm_robots::dataset::{BodyData, Dataset};
use sgplvm_robots::retarget::file::{read_human, retarget_files, TestChoice};
use sgplvm_robots::retarget::split::SplitOptions;
use sgplvm_robots::retarget::{retarget, Match, Redundancy, RetargetError, RetargetOptions};
use sgplvm_robots::Robot;

use crate::guard::guarded;
use crate::robots::PyRobot;

fn retarget_error(e: RetargetError) -> PyErr {
    PyValueError::new_err(e.to_string())
}

/// The options of `sgplvm retarget` from Python's names.
fn options(mode: &str, redundancy: &str, velocity_limits: bool) -> PyResult<RetargetOptions> {
    let mode = Match::parse(mode).ok_or_else(|| {
        PyValueError::new_err(format!(
            "match is {mode:?}; expected \"arms\", \"hands\", \"hands+elbows\" or \"poses\""
        ))
    })?;
    let redundancy = match redundancy {
        "continuous" => Redundancy::Continuous,
        "canonical" => Redundancy::Canonical,
        other => {
            return Err(PyValueError::new_err(format!(
                "redundancy is {other:?}; expected \"continuous\" or \"canonical\""
            )))
        }
    };
    Ok(RetargetOptions {
        mode,
        redundancy,
        velocity_limits,
        ..RetargetOptions::default()
    })
}

/// Each robot by name with its anatomy (a `Robot` or a built-in name).
fn anatomies(robots: &Bound<'_, PyDict>) -> PyResult<Vec<(String, Anatomy)>> {
    let mut out = Vec::new();
    for (name, robot) in robots.iter() {
        let name: String = name.extract()?;
        let anatomy = match robot.extract::<PyRef<'_, PyRobot>>() {
            Ok(r) => r.native_anatomy()?.clone(),
            Err(_) => {
                let builtin: String = robot.extract().map_err(|_| {
                    PyValueError::new_err(format!(
                        "robots[{name:?}]: expected a sgplvm.Robot or a built-in robot's name"
                    ))
                })?;
                Anatomy::builtin(&builtin).map_err(crate::robots::anatomy_error)?
            }
        };
        out.push((name, anatomy));
    }
    if out.is_empty() {
        return Err(PyValueError::new_err("robots: no robot to retarget to"));
    }
    Ok(out)
}

/// Retargets human frames (the human model's 18 joint angles) onto robots: `human` (n, 18)
/// with `times_ns` (n,), or the demonstrations of `demos` (MCAP paths). With `out`, writes the
/// demonstrations split for training (as `sgplvm retarget` does) and returns its report;
/// without, returns per robot its joint names, commands (n, joints) and reach report.
#[pyfunction]
#[pyo3(signature = (robots, mode, redundancy, velocity_limits, human=None, times_ns=None, demos=None, out=None, block_seconds=4.0, test_every=4, test_files=None, guard_seconds=0.5, train_subsample=12, test_subsample=3, test_people=None))]
#[allow(clippy::too_many_arguments)] // the Python signature, keyword arguments included
pub fn retarget_native<'py>(
    py: Python<'py>,
    robots: &Bound<'py, PyDict>,
    mode: &str,
    redundancy: &str,
    velocity_limits: bool,
    human: Option<PyReadonlyArray2<'py, f64>>,
    times_ns: Option<PyReadonlyArray1<'py, i64>>,
    demos: Option<Vec<PathBuf>>,
    out: Option<PathBuf>,
    block_seconds: f64,
    test_every: usize,
    test_files: Option<Vec<String>>,
    guard_seconds: f64,
    train_subsample: usize,
    test_subsample: usize,
    test_people: Option<Vec<String>>,
) -> PyResult<Bound<'py, PyAny>> {
    guarded(|| {
        let options = options(mode, redundancy, velocity_limits)?;
        let robots = anatomies(robots)?;
        if let Some(out) = out {
            let demos = demos.ok_or_else(|| {
                PyValueError::new_err(
                    "out= writes demonstrations: give the human as demos= (MCAP files)",
                )
            })?;
            let split = SplitOptions {
                block_s: block_seconds,
                guard_s: guarded_seconds(guard_seconds)?,
                train_subsample,
                test_subsample,
                ..SplitOptions::default()
            };
            let test = match (test_files, test_people) {
                (Some(_), Some(_)) => {
                    return Err(PyValueError::new_err(
                        "test_files= and test_people= both choose the test motions: give one",
                    ))
                }
                (Some(files), None) => TestChoice::Files(files),
                (None, Some(people)) => TestChoice::People(people),
                (None, None) => TestChoice::EveryNthBlock(test_every),
            };
            let done = py
                .detach(|| retarget_files(&demos, &robots, &options, &split, &test, &out))
                .map_err(retarget_error)?;
            let json =
                serde_json::to_string(&done).map_err(|e| PyValueError::new_err(e.to_string()))?;
            return py.import("json")?.call_method1("loads", (json,));
        }
        let dataset = match (demos, human) {
            (Some(d), None) => read_human(&d).map_err(retarget_error)?.0,
            (None, Some(h)) => human_dataset(h.as_array(), times_ns)?,
            _ => {
                return Err(PyValueError::new_err(
                    "give the human either as human= (an (n, 18) array, with times_ns=) or as demos= (MCAP files)",
                ))
            }
        };
        let results = py
            .detach(|| retarget(&dataset, &robots, &options))
            .map_err(retarget_error)?;
        let dict = PyDict::new(py);
        for r in results {
            let body = PyDict::new(py);
            body.set_item("joint_names", r.body.joint_names.clone())?;
            let p = &r.body.positions;
            let array = Array2::from_shape_fn((p.nrows(), p.ncols()), |(i, j)| p[(i, j)]);
            body.set_item("positions", PyArray2::from_owned_array(py, array))?;
            let json = serde_json::to_string(&r.report)
                .map_err(|e| PyValueError::new_err(e.to_string()))?;
            body.set_item("report", py.import("json")?.call_method1("loads", (json,))?)?;
            dict.set_item(r.body.name.clone(), body)?;
        }
        Ok(dict.into_any())
    })
}

/// Refuses a negative or non-finite guard.
fn guarded_seconds(s: f64) -> PyResult<f64> {
    if s.is_finite() && s >= 0.0 {
        Ok(s)
    } else {
        Err(PyValueError::new_err(format!(
            "guard_seconds is {s}; expected seconds ≥ 0"
        )))
    }
}

/// A dataset of the human's frames alone.
fn human_dataset(
    h: numpy::ndarray::ArrayView2<'_, f64>,
    times_ns: Option<PyReadonlyArray1<'_, i64>>,
) -> PyResult<Dataset> {
    let names = Robot::builtin("human")
        .map_err(crate::robots::robot_error)?
        .joint_names();
    if h.ncols() != names.len() {
        return Err(PyValueError::new_err(format!(
            "human: expected (frames, {}) joint angles of the human model, got {:?}",
            names.len(),
            h.shape()
        )));
    }
    if let Some((i, j)) = h
        .indexed_iter()
        .find(|(_, v)| !v.is_finite())
        .map(|(ij, _)| ij)
    {
        return Err(PyValueError::new_err(format!(
            "human: frame {i}, joint {} is not a finite number",
            names[j]
        )));
    }
    let times: Vec<i64> = match times_ns {
        Some(t) => t.as_array().to_vec(),
        None => return Err(PyValueError::new_err(
            "times_ns: the frames' times (int64 nanoseconds) are needed for the velocity limits",
        )),
    };
    if times.len() != h.nrows() || times.windows(2).any(|w| w[1] <= w[0]) {
        return Err(PyValueError::new_err(format!(
            "times_ns: expected {} increasing times, one per frame",
            h.nrows()
        )));
    }
    let positions = nalgebra::DMatrix::from_fn(h.nrows(), h.ncols(), |i, j| h[(i, j)]);
    let human = BodyData {
        name: "human".into(),
        topic: "/human/joint_states".into(),
        joint_names: names,
        positions,
    };
    Ok(Dataset::unlabelled(times, human, Vec::new()))
}
