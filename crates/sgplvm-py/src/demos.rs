//! Demonstrations from Python: ROS 2 JointState MCAP files, the dataset, physics replay.

use std::collections::BTreeMap;

use numpy::ndarray::Array2;
use numpy::{PyArray1, PyArray2, PyReadonlyArray1, PyReadonlyArray2};
use pyo3::exceptions::{PyOSError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use sgplvm::provenance::demonstration_annotations;
use sgplvm_robots::dataset::{load_demonstrations as load_dataset, BodyData};
use sgplvm_robots::joint_state::{self, Compression, JointStateError, JointStates};
use sgplvm_robots::scene::{write_scene, SceneBody, SceneOptions, SceneSeries};
use sgplvm_robots::{ReplayOptions, Robot, Trajectory};

use crate::guard::guarded;
use crate::robots::robot_error;

fn joint_state_error(e: JointStateError) -> PyErr {
    match e {
        JointStateError::Io { .. } => PyOSError::new_err(e.to_string()),
        other => PyValueError::new_err(other.to_string()),
    }
}

fn matrix<'py>(
    py: Python<'py>,
    rows: usize,
    cols: usize,
    values: &[f64],
) -> Bound<'py, PyArray2<f64>> {
    PyArray2::from_owned_array(
        py,
        Array2::from_shape_fn((rows, cols), |(i, j)| values[i * cols + j]),
    )
}

fn parse_compression(name: &str) -> PyResult<Compression> {
    match name {
        "zstd" => Ok(Compression::Zstd),
        "lz4" => Ok(Compression::Lz4),
        "none" => Ok(Compression::None),
        other => Err(PyValueError::new_err(format!(
            "compression is {other:?}; expected \"zstd\", \"lz4\" or \"none\""
        ))),
    }
}

/// `(times_ns, joint_names, positions)` as numpy arrays.
type JointStatesArrays<'py> = (
    Bound<'py, PyArray1<i64>>,
    Vec<String>,
    Bound<'py, PyArray2<f64>>,
);

/// Reads one `sensor_msgs/msg/JointState` topic of an MCAP file (CDR or JSON encoded).
///
/// Returns `(times_ns, joint_names, positions)`: int64 (n,), list of str, float64 (n, joints).
#[pyfunction]
pub fn read_joint_states<'py>(
    py: Python<'py>,
    path: std::path::PathBuf,
    topic: &str,
) -> PyResult<JointStatesArrays<'py>> {
    guarded(|| {
        let states = py
            .detach(|| joint_state::read_joint_states(&path, topic))
            .map_err(joint_state_error)?;
        let positions = matrix(py, states.len(), states.dof(), &states.positions);
        Ok((
            PyArray1::from_vec(py, states.times_ns),
            states.names,
            positions,
        ))
    })
}

/// Writes one JointState topic (CDR, profile ros2) to an MCAP file, atomically; with `robot`
/// (a built-in body), also its description, `/tf_static` and `/tf` for Foxglove.
#[pyfunction]
#[pyo3(signature = (path, topic, times_ns, names, positions, compression="zstd", robot=None))]
#[allow(clippy::too_many_arguments)] // the Python signature, keyword arguments included
pub fn write_joint_states(
    py: Python<'_>,
    path: std::path::PathBuf,
    topic: &str,
    times_ns: PyReadonlyArray1<'_, i64>,
    names: Vec<String>,
    positions: PyReadonlyArray2<'_, f64>,
    compression: &str,
    robot: Option<&str>,
) -> PyResult<()> {
    guarded(|| {
        let compression = parse_compression(compression)?;
        let times = times_ns.as_array().to_vec();
        let view = positions.as_array();
        if view.nrows() != times.len() || view.ncols() != names.len() {
            return Err(PyValueError::new_err(format!(
                "positions has shape ({}, {}); expected ({}, {}) = (len(times_ns), len(names))",
                view.nrows(),
                view.ncols(),
                times.len(),
                names.len()
            )));
        }
        if let Some(((i, j), v)) = view.indexed_iter().find(|(_, v)| !v.is_finite()) {
            return Err(PyValueError::new_err(format!(
                "positions[{i}, {j}] is {v}; expected finite joint positions"
            )));
        }
        let values: Vec<f64> = view.iter().copied().collect();
        let states = JointStates::new(times, names, values).map_err(joint_state_error)?;
        let body = robot
            .map(|name| SceneBody::builtin(name, topic, [0.0; 3]))
            .transpose()
            .map_err(joint_state_error)?;
        py.detach(|| match &body {
            Some(body) => write_scene(
                &path,
                &[SceneSeries {
                    body,
                    states: &states,
                }],
                &[],
                &SceneOptions {
                    compression,
                    ..SceneOptions::default()
                },
            ),
            None => joint_state::write_joint_states(&path, topic, &states, compression),
        })
        .map_err(joint_state_error)
    })
}

fn body_dict<'py>(py: Python<'py>, body: &BodyData) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    let m = &body.positions;
    d.set_item("topic", &body.topic)?;
    d.set_item("joint_names", body.joint_names.clone())?;
    d.set_item(
        "positions",
        PyArray2::from_owned_array(
            py,
            Array2::from_shape_fn((m.nrows(), m.ncols()), |(i, j)| m[(i, j)]),
        ),
    )?;
    Ok(d)
}

/// Loads a demonstration MCAP as numpy arrays: a dict with `times_ns`, `human`, `robots`
/// (name → {topic, joint_names, positions}), `train` and `test` frame indices, `validation`
/// (positions in `train` to hold out for choosing the iteration budget: the last repetition
/// of every training motion), `train_every_frame` (every frame of the training motions, of which
/// `train` is a subsample: what the sparse and Bayesian models train on) and
/// `validation_every_frame` (positions in it held out, the same motions as `validation`),
/// `segments` (start, end, from_pose, to_pose, repetition), `pose_names` and `provenance`: what
/// `sgplvm train` saves with a model of these demonstrations (the person's calibration, each
/// robot's record from `retarget`), for `model.annotate(demo["provenance"])`.
#[pyfunction]
pub fn load_demonstrations<'py>(
    py: Python<'py>,
    path: std::path::PathBuf,
) -> PyResult<Bound<'py, PyDict>> {
    guarded(|| {
        let ds = py
            .detach(|| load_dataset(&path))
            .map_err(joint_state_error)?;
        let d = PyDict::new(py);
        d.set_item("times_ns", PyArray1::from_slice(py, &ds.times_ns))?;
        d.set_item("human", body_dict(py, &ds.human)?)?;
        let robots = PyDict::new(py);
        for robot in &ds.robots {
            robots.set_item(&robot.name, body_dict(py, robot)?)?;
        }
        d.set_item("robots", robots)?;
        let index = |v: &[usize]| PyArray1::from_vec(py, v.iter().map(|&i| i as i64).collect());
        d.set_item("train", index(&ds.train))?;
        d.set_item("test", index(&ds.test))?;
        d.set_item("validation", index(&ds.validation_split().rows))?;
        let every = ds.with_every_training_frame();
        d.set_item("train_every_frame", index(&every.train))?;
        d.set_item(
            "validation_every_frame",
            index(&every.validation_split().rows),
        )?;
        d.set_item("pose_names", ds.pose_names.clone())?;
        let segments = PyList::empty(py);
        for s in &ds.segments {
            let sd = PyDict::new(py);
            sd.set_item("start", s.start)?;
            sd.set_item("end", s.end)?;
            sd.set_item("from_pose", s.from_pose)?;
            sd.set_item("to_pose", s.to_pose)?;
            sd.set_item("repetition", s.repetition)?;
            sd.set_item("person", s.person.as_deref())?;
            segments.append(sd)?;
        }
        d.set_item("segments", segments)?;
        let robot_names: Vec<String> = ds.robots.iter().map(|r| r.name.clone()).collect();
        let provenance = py
            .detach(|| demonstration_annotations(&path, &robot_names, &BTreeMap::new()))
            .map_err(|e| match e {
                sgplvm::pipeline::PipelineError::Data(e) => joint_state_error(e),
                other => PyValueError::new_err(other.to_string()),
            })?;
        let provenance: serde_json::Map<String, serde_json::Value> = provenance
            .into_iter()
            .map(|(key, value)| (key.to_string(), value))
            .collect();
        let json = py.import("json")?;
        d.set_item(
            "provenance",
            json.call_method1(
                "loads",
                (serde_json::Value::Object(provenance).to_string(),),
            )?,
        )?;
        Ok(d)
    })
}

/// Replays a joint trajectory on a robot in the rapier physics engine (PD position control at
/// 1 kHz, fixed base) and returns the report as a dict: tracking error per joint, joint-limit
/// violations and self-collisions. `robot` is a built-in name or a URDF path.
#[pyfunction]
#[pyo3(signature = (robot, joint_names, times, positions))]
pub fn simulate<'py>(
    py: Python<'py>,
    robot: &str,
    joint_names: Vec<String>,
    times: PyReadonlyArray1<'py, f64>,
    positions: PyReadonlyArray2<'py, f64>,
) -> PyResult<Bound<'py, PyAny>> {
    guarded(|| {
        let (xml, source) = match Robot::builtin_urdf(robot) {
            Some(xml) => (xml.to_string(), format!("builtin:{robot}")),
            None => {
                let path = std::path::Path::new(robot);
                if !path.exists() {
                    return Err(PyValueError::new_err(format!(
                    "robot {robot:?} is neither a built-in name ({:?}) nor an existing URDF file",
                    Robot::builtin_names()
                )));
                }
                Robot::from_urdf_file(path).map_err(robot_error)?;
                let xml = std::fs::read_to_string(path)
                    .map_err(|e| PyOSError::new_err(format!("{robot}: {e}")))?;
                (xml, robot.to_string())
            }
        };
        let view = positions.as_array();
        if view.ncols() != joint_names.len() {
            return Err(PyValueError::new_err(format!(
                "positions has {} columns; expected {} (one per joint name)",
                view.ncols(),
                joint_names.len()
            )));
        }
        let trajectory = Trajectory::new(
            joint_names,
            times.as_array().to_vec(),
            view.iter().copied().collect(),
        )
        .map_err(|e| PyValueError::new_err(e.to_string()))?;
        let report = py
            .detach(|| sgplvm_robots::replay(&xml, &source, &trajectory, &ReplayOptions::default()))
            .map_err(|e| PyValueError::new_err(e.to_string()))?;
        let json =
            serde_json::to_string(&report).map_err(|e| PyValueError::new_err(e.to_string()))?;
        py.import("json")?.call_method1("loads", (json,))
    })
}

/// `(times_ns, joint_names, positions, source_json)` of an imported capture.
type CaptureArrays<'py> = (
    Bound<'py, PyArray1<i64>>,
    Vec<String>,
    Bound<'py, PyArray2<f64>>,
    String,
);

/// Imports a BVH motion capture as the human model's 18 joint angles (see
/// `sgplvm_capture`): `(times_ns, joint_names, positions, source_json)`.
#[pyfunction]
#[pyo3(signature = (path, rate=40.0, map=None, units=None, start=None, end=None))]
pub fn read_bvh<'py>(
    py: Python<'py>,
    path: std::path::PathBuf,
    rate: f64,
    map: Option<std::collections::BTreeMap<String, String>>,
    units: Option<&str>,
    start: Option<f64>,
    end: Option<f64>,
) -> PyResult<CaptureArrays<'py>> {
    use sgplvm_capture::{import_bvh, ArmMap, CaptureError, ImportOptions, Units};
    guarded(|| {
        let units = units
            .map(|u| {
                Units::parse(u).ok_or_else(|| {
                    PyValueError::new_err(format!("units {u:?}; expected {}", Units::choices()))
                })
            })
            .transpose()?;
        let options = ImportOptions {
            rate_hz: rate,
            map: map.map(ArmMap),
            units,
            from_s: start,
            to_s: end,
            ..ImportOptions::default()
        };
        let capture = py
            .detach(|| import_bvh(&path, &options))
            .map_err(|e| match e {
                CaptureError::Bvh(sgplvm_capture::BvhError::Io { .. }) => {
                    PyOSError::new_err(e.to_string())
                }
                other => PyValueError::new_err(other.to_string()),
            })?;
        let m = &capture.positions;
        let positions = PyArray2::from_owned_array(
            py,
            Array2::from_shape_fn((m.nrows(), m.ncols()), |(i, j)| m[(i, j)]),
        );
        let source = serde_json::to_string(&capture.source).map_err(|e| {
            PyValueError::new_err(format!("cannot encode the capture's source: {e}"))
        })?;
        Ok((
            PyArray1::from_vec(py, capture.times_ns),
            capture.joint_names,
            positions,
            source,
        ))
    })
}
