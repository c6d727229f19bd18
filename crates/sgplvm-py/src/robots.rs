//! `sgplvm.Robot`: URDF bodies and their forward kinematics.

use crate::guard::guarded;
use numpy::ndarray::Array2;
use numpy::PyArray2;
use pyo3::exceptions::{PyOSError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyAnyMethods;
use sgplvm_robots::anatomy::{Anatomy, AnatomyError, AnatomySpec, ArmSpec, CommandJoints, Mount};
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
    /// The robot's anatomy, or why it has none (a single arm, say: FK still works).
    anatomy: Result<Anatomy, String>,
}

pub(crate) fn anatomy_error(e: AnatomyError) -> PyErr {
    match e {
        AnatomyError::Robot(r) => robot_error(r),
        other => PyValueError::new_err(other.to_string()),
    }
}

impl PyRobot {
    /// The robot's anatomy, or a `ValueError` saying why it has none.
    pub(crate) fn native_anatomy(&self) -> PyResult<&Anatomy> {
        self.anatomy
            .as_ref()
            .map_err(|e| PyValueError::new_err(e.clone()))
    }
}

/// The anatomy settings of `from_urdf`'s keyword arguments.
fn spec_of(
    arms: Option<std::collections::HashMap<String, (String, String)>>,
    hold: Option<std::collections::HashMap<String, f64>>,
    up: Option<(f64, f64, f64)>,
    forward: Option<(f64, f64, f64)>,
    mount_roll_deg: Option<f64>,
    command_joints: Option<&Bound<'_, PyAny>>,
) -> PyResult<AnatomySpec> {
    let mut spec = AnatomySpec::default();
    for (side, (from, to)) in arms.unwrap_or_default() {
        let arm = Some(ArmSpec { from, to });
        match side.as_str() {
            "left" => spec.left = arm,
            "right" => spec.right = arm,
            other => {
                return Err(PyValueError::new_err(format!(
                    "arms: key {other:?}; expected \"left\" and \"right\""
                )))
            }
        }
    }
    for (name, value) in hold.unwrap_or_default() {
        if !value.is_finite() {
            return Err(PyValueError::new_err(format!(
                "hold[{name:?}] is {value}; expected a finite number"
            )));
        }
        spec.hold.insert(name, value);
    }
    spec.up = up.map(|(x, y, z)| nalgebra::Vector3::new(x, y, z));
    spec.forward = forward.map(|(x, y, z)| nalgebra::Vector3::new(x, y, z));
    if let Some(deg) = mount_roll_deg {
        if !Mount::valid_roll(deg) {
            return Err(PyValueError::new_err(format!(
                "mount_roll_deg is {deg}; expected degrees within ±180 (0: the person's arm as it is)"
            )));
        }
        spec.mount_roll_deg = Some(deg);
    }
    if let Some(c) = command_joints {
        spec.command_joints = match c.extract::<String>() {
            Ok(text) => CommandJoints::parse(&text),
            Err(_) => CommandJoints::List(c.extract::<Vec<String>>().map_err(|_| {
                PyValueError::new_err(
                    "command_joints: expected \"arms\", \"all\" or a list of joint names",
                )
            })?),
        };
    }
    Ok(spec)
}

#[pymethods]
impl PyRobot {
    /// One of the shipped bodies: "walkman", "coman", "centauro" or "human".
    #[staticmethod]
    fn builtin(name: &str) -> PyResult<Self> {
        guarded(|| {
            let robot = Robot::builtin(name).map_err(robot_error)?;
            let anatomy = Anatomy::of(robot.clone()).map_err(|e| e.to_string());
            Ok(PyRobot {
                robot,
                chain: None,
                anatomy,
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

    /// Loads a URDF file as its maker publishes it; with `base` and `tip`, the body is
    /// restricted to the chain between them. The robot's anatomy (its arms, held joints, body
    /// frame, reach and neutral posture) is found from the URDF and the description file beside
    /// it (`ROBOT.anatomy.json`), or as `arms` ({"left": (FROM_LINK, TO_LINK), "right": …}; one
    /// side alone for a single-arm robot),
    /// `hold` ({joint: value}), `up`, `forward` (directions in the torso link's frame),
    /// `mount_roll_deg` (degrees the person's arm is turned outward about the forward axis;
    /// default 0, or 90 for an arm that cannot hang, as on a table) and `command_joints`
    /// ("arms", "all" or joint names) say.
    #[staticmethod]
    #[pyo3(signature = (path, base=None, tip=None, *, arms=None, hold=None, up=None, forward=None, mount_roll_deg=None, command_joints=None))]
    #[allow(clippy::too_many_arguments)] // the Python signature, keyword arguments included
    fn from_urdf(
        path: std::path::PathBuf,
        base: Option<&str>,
        tip: Option<&str>,
        arms: Option<std::collections::HashMap<String, (String, String)>>,
        hold: Option<std::collections::HashMap<String, f64>>,
        up: Option<(f64, f64, f64)>,
        forward: Option<(f64, f64, f64)>,
        mount_roll_deg: Option<f64>,
        command_joints: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Self> {
        guarded(|| {
            let spec = spec_of(arms, hold, up, forward, mount_roll_deg, command_joints)?;
            let robot = Robot::from_urdf_file(&path).map_err(robot_error)?;
            let anatomy = match Anatomy::load(&path, &spec) {
                Ok(a) => Ok(a),
                // What the user said must hold; a robot found to have no two arms still has
                // its forward kinematics.
                Err(e) if !spec.is_empty() => return Err(anatomy_error(e)),
                Err(e) => Err(e.to_string()),
            };
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
            Ok(PyRobot {
                robot,
                chain,
                anatomy,
            })
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

    /// What sgplvm makes of the robot: arms, held joints, body frame, reach, neutral posture
    /// and notes, as a dict (what `sgplvm robot --json` prints).
    #[getter(anatomy)]
    fn anatomy_report<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let report = self.native_anatomy()?.report();
        let json =
            serde_json::to_string(&report).map_err(|e| PyValueError::new_err(e.to_string()))?;
        py.import("json")?.call_method1("loads", (json,))
    }

    /// The anatomy in a few lines of text (what `sgplvm robot` prints).
    fn summary(&self) -> PyResult<String> {
        Ok(self.native_anatomy()?.summary())
    }

    /// The joints the robot's commands name (the arm joints unless `command_joints` said
    /// otherwise).
    #[getter]
    fn command_joint_names(&self) -> PyResult<Vec<String>> {
        Ok(self.native_anatomy()?.command_joint_names())
    }

    /// The joints outside the arms and the values they are held at.
    #[getter]
    fn held_joints(&self) -> PyResult<Vec<(String, f64)>> {
        Ok(self.native_anatomy()?.held_joints())
    }

    /// Every joint's value (URDF order) with the arms at their neutral posture and the rest
    /// held.
    #[getter]
    fn hold_configuration(&self) -> PyResult<Vec<f64>> {
        Ok(self.native_anatomy()?.hold_configuration().to_vec())
    }

    /// The description file's text (JSON) that keeps this anatomy: write it beside the URDF as
    /// `ROBOT.anatomy.json` and every command reads it.
    fn description(&self) -> PyResult<String> {
        Ok(self.native_anatomy()?.to_file().to_json())
    }

    fn __repr__(&self) -> String {
        format!(
            "Robot({:?}, {} joints)",
            self.robot.name(),
            self.joint_names().len()
        )
    }
}
