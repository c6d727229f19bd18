//! `sgplvm.Robot`: URDF bodies and their forward kinematics.

use crate::guard::guarded;
use numpy::ndarray::Array2;
use numpy::PyArray2;
use pyo3::exceptions::{PyOSError, PyValueError};
use pyo3::prelude::*;
use sgplvm_robots::{Chain, Robot, RobotError};

pub(crate) fn robot_error(e: RobotError) -> PyErr {
    match e {
        RobotError::Io { .. } => PyOSError::new_err(e.to_string()),
        other => PyValueError::new_err(other.to_string()),
    }
}

/// A robot (or human) body from a URDF: joint names, limits and forward kinematics.
///
/// `q` vectors are in `joint_names` order; poses are 4×4 homogeneous matrices in the root frame
/// (or, for a robot restricted to a chain, in the chain's base frame).
#[pyclass(module = "sgplvm._sgplvm", name = "Robot", frozen)]
pub struct PyRobot {
    robot: Robot,
    chain: Option<Chain>,
}

#[pymethods]
impl PyRobot {
    /// One of the shipped bodies: "walkman", "coman", "centauro" or "human".
    #[staticmethod]
    fn builtin(name: &str) -> PyResult<Self> {
        guarded(|| {
            Ok(PyRobot {
                robot: Robot::builtin(name).map_err(robot_error)?,
                chain: None,
            })
        })
    }

    /// Names accepted by `Robot.builtin`.
    #[staticmethod]
    fn builtin_names() -> Vec<&'static str> {
        Robot::builtin_names().to_vec()
    }

    /// The URDF text of a shipped body.
    #[staticmethod]
    fn builtin_urdf(name: &str) -> PyResult<&'static str> {
        Robot::builtin_urdf(name).ok_or_else(|| {
            PyValueError::new_err(format!(
                "unknown robot {name:?}; expected one of {:?}",
                Robot::builtin_names()
            ))
        })
    }

    /// Loads a URDF file; with `base` and `tip`, the body is restricted to the chain between them.
    #[staticmethod]
    #[pyo3(signature = (path, base=None, tip=None))]
    fn from_urdf(
        path: std::path::PathBuf,
        base: Option<&str>,
        tip: Option<&str>,
    ) -> PyResult<Self> {
        guarded(|| {
            let robot = Robot::from_urdf_file(&path).map_err(robot_error)?;
            let chain = match (base, tip) {
                (None, None) => None,
                (Some(base), Some(tip)) => Some(robot.chain(base, tip).map_err(robot_error)?),
                (None, Some(tip)) => {
                    Some(robot.chain(robot.root_link(), tip).map_err(robot_error)?)
                }
                (Some(_), None) => {
                    return Err(PyValueError::new_err(
                        "from_urdf: `base` needs a `tip` link as well",
                    ))
                }
            };
            Ok(PyRobot { robot, chain })
        })
    }

    /// The robot's name.
    #[getter]
    fn name(&self) -> &str {
        self.robot.name()
    }

    /// Movable joint names, in the order of `q` (for the shipped bodies: left arm, then right,
    /// shoulder to wrist).
    #[getter]
    fn joint_names(&self) -> Vec<String> {
        match &self.chain {
            Some(chain) => chain.joint_names().to_vec(),
            None => self.robot.joint_names(),
        }
    }

    /// (lower, upper) limit of every joint, in `joint_names` order.
    #[getter]
    fn joint_limits(&self) -> Vec<(f64, f64)> {
        match &self.chain {
            Some(chain) => chain.limits().to_vec(),
            None => self.robot.joint_limits(),
        }
    }

    /// All link names.
    #[getter]
    fn link_names(&self) -> Vec<String> {
        self.robot.link_names()
    }

    /// Pose (4×4) of `link` for configuration `q`; for a chain, `link` may be omitted (the tip).
    #[pyo3(signature = (q, link=None))]
    fn forward_kinematics<'py>(
        &self,
        py: Python<'py>,
        q: Vec<f64>,
        link: Option<&str>,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        guarded(|| {
            let pose = match (&self.chain, link) {
            (Some(chain), Some(other)) if other != chain.tip() => {
                return Err(PyValueError::new_err(format!(
                    "link {other:?}: this robot is restricted to the chain {} → {}; expected the tip link",
                    chain.base(),
                    chain.tip()
                )))
            }
            (Some(chain), _) => chain.try_forward(&q).map_err(robot_error)?,
            (None, Some(link)) => self.robot.forward_kinematics(&q, link).map_err(robot_error)?,
            (None, None) => return Err(PyValueError::new_err("forward_kinematics: name the link")),
        };
            let m = pose.to_homogeneous();
            Ok(PyArray2::from_owned_array(
                py,
                Array2::from_shape_fn((4, 4), |(i, j)| m[(i, j)]),
            ))
        })
    }

    fn __repr__(&self) -> String {
        format!(
            "Robot({:?}, {} joints)",
            self.robot.name(),
            self.joint_names().len()
        )
    }
}
