//! Physics replay: drive a robot's URDF model through a joint trajectory in
//! [rapier](https://rapier.rs) and report how well it follows, which joint limits it crosses
//! and which of its links collide — the check the paper ran in Gazebo, without ROS.
//!
//! The model is loaded with `rapier3d-urdf` as one multibody (reduced coordinates) whose root
//! link (the torso) is fixed to the world. Every movable joint gets a PD motor (rapier's
//! implicit, acceleration-based joint motor) that follows the trajectory: the 40 Hz reference
//! frames are interpolated linearly to the physics rate (1 kHz by default), the motor's target
//! position is the reference at the end of each step and its target velocity the slope of the
//! current reference segment. Gravity pulls along −z of the root frame.
//!
//! Self-collisions are watched between every pair of links that are not neighbours in the
//! kinematic tree (see [`ReplayOptions::ignored_pairs`] for the exact rule); contacts push the
//! links apart as they would on the real robot unless [`ReplayOptions::contact_response`] is off.
//!
//! # Example
//! ```
//! use sgplvm_robots::physics::{replay, ReplayOptions, Trajectory};
//!
//! let urdf = r#"<robot name="pendulum">
//!   <link name="base"><collision><geometry><box size="0.1 0.1 0.1"/></geometry></collision></link>
//!   <link name="arm">
//!     <inertial><origin xyz="0 0 -0.2"/><mass value="1"/>
//!       <inertia ixx="0.01" iyy="0.01" izz="0.001" ixy="0" ixz="0" iyz="0"/></inertial>
//!   </link>
//!   <joint name="shoulder" type="revolute">
//!     <parent link="base"/><child link="arm"/><axis xyz="0 1 0"/>
//!     <limit lower="-1" upper="1" effort="10" velocity="3"/>
//!   </joint>
//! </robot>"#;
//! let trajectory = Trajectory::new(
//!     vec!["shoulder".into()],
//!     vec![0.0, 0.5, 1.0],
//!     vec![0.0, 0.3, 0.6],
//! )?;
//! let report = replay(urdf, "pendulum.urdf", &trajectory, &ReplayOptions::default())?;
//! assert_eq!(report.physics_steps, 1000);
//! assert!(report.joints[0].max_error < 0.05);
//! # Ok::<(), sgplvm_robots::physics::PhysicsError>(())
//! ```

use std::collections::{HashMap, HashSet};
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::Path;
use std::time::Instant;

use rapier3d::dynamics::{
    JointAxis, MassProperties, MultibodyIndex, MultibodyJointHandle, RigidBodyBuilder,
    RigidBodyHandle, RigidBodyType,
};
use rapier3d::geometry::{ColliderBuilder, SolverFlags};
use rapier3d::math::{Real, Vector};
use rapier3d::pipeline::{ActiveHooks, PairFilterContext, PhysicsHooks, PhysicsWorld};
use rapier3d_urdf::urdf_rs;
use rapier3d_urdf::{UrdfLoaderOptions, UrdfMultibodyOptions, UrdfRobot};
use serde::Serialize;

/// Density (kg/m³, about that of water) given to the collision shapes of a link that declares
/// no mass, so that every moving link has an inertia.
const DEFAULT_DENSITY: Real = 1000.0;
/// Mass (kg) of a moving link that declares neither a mass nor a collision shape.
const PLACEHOLDER_MASS: Real = 1e-3;
/// Principal inertia (kg·m²) of such a placeholder link.
const PLACEHOLDER_INERTIA: Real = 1e-6;
/// Standard gravity, m/s².
const GRAVITY: Real = 9.81;

/// What went wrong while setting up or running a replay. Every message names the file, the
/// joint or the frame at fault and what was expected.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum PhysicsError {
    /// The URDF was refused by the robot-model parser (see [`crate::urdf::Robot`]).
    #[error(transparent)]
    Robot(#[from] crate::error::RobotError),
    /// The URDF text could not be read.
    #[error("{file}: cannot read the URDF: {message}")]
    Urdf {
        /// File name used in messages.
        file: String,
        /// The parser's reason.
        message: String,
    },
    /// The URDF parsed but describes something the replay cannot simulate.
    #[error("{file}: {element}: {message}")]
    Model {
        /// File name used in messages.
        file: String,
        /// The element at fault, e.g. `<joint name="elbow">`.
        element: String,
        /// What was found and what was expected.
        message: String,
    },
    /// The trajectory's shape or times are wrong.
    #[error("trajectory: {message}")]
    Trajectory {
        /// What was found and what was expected.
        message: String,
    },
    /// A trajectory position is NaN or infinite.
    #[error("trajectory frame {frame} (t = {time} s), joint \"{joint}\": position is {value}; expected a finite number")]
    NonFinitePosition {
        /// 0-based frame index.
        frame: usize,
        /// Time of that frame, seconds.
        time: f64,
        /// The joint's column name.
        joint: String,
        /// The offending value.
        value: f64,
    },
    /// A trajectory column names no movable joint of the model.
    #[error("trajectory column \"{joint}\" names no movable joint of {file} (its movable joints: {known})")]
    UnknownJoint {
        /// File name of the model.
        file: String,
        /// The unknown column name.
        joint: String,
        /// The model's movable joints, comma-separated.
        known: String,
    },
    /// A movable joint of the model has no column in the trajectory.
    #[error("{file}: movable joint \"{joint}\" has no column in the trajectory (expected one column per movable joint; set ReplayOptions::allow_missing_joints to hold it still)")]
    MissingJoint {
        /// File name of the model.
        file: String,
        /// The joint without a column.
        joint: String,
    },
    /// A replay option is out of its range.
    #[error("replay option {field} = {value}: expected {expected}")]
    InvalidOption {
        /// The option's field name.
        field: &'static str,
        /// The value given.
        value: String,
        /// The accepted range.
        expected: &'static str,
    },
    /// The simulation produced non-finite joint positions.
    #[error("{file}: the simulation diverged at t = {time} s (joint \"{joint}\" is at {value}); expected finite positions — lower the stiffness or raise the physics rate")]
    Diverged {
        /// File name of the model.
        file: String,
        /// Simulated time, seconds.
        time: f64,
        /// The first joint found non-finite.
        joint: String,
        /// Its value.
        value: f64,
    },
    /// The physics engine itself failed (it panicked on this model); the model is unusual.
    #[error("{file}: the physics engine failed on this model: {message}")]
    Engine {
        /// File name of the model.
        file: String,
        /// The engine's panic message.
        message: String,
    },
}

/// How a trajectory is replayed. `ReplayOptions::default()` gives the issue's setting: 1 kHz
/// physics, gravity on, critically damped PD motors, limits enforced, contacts solved.
#[derive(Debug, Clone, PartialEq)]
pub struct ReplayOptions {
    /// Physics steps per second (default 1000).
    pub physics_rate_hz: f64,
    /// Proportional gain of the joint motors, in 1/s² (rapier's acceleration-based motor model:
    /// the commanded acceleration is `stiffness × position error + damping × velocity error`,
    /// whatever the link's inertia). Default 40 000, a 200 rad/s (32 Hz) servo bandwidth.
    pub stiffness: f64,
    /// Derivative gain of the joint motors, in 1/s (default 400: critical damping for the
    /// default stiffness).
    pub damping: f64,
    /// Seconds the robot holds the first frame before the trajectory starts, so that it has
    /// settled under gravity (default 0.5). Nothing is measured while settling.
    pub settle_seconds: f64,
    /// Whether gravity (9.81 m/s² along −z of the fixed root link) acts (default true).
    pub gravity: bool,
    /// A joint counts as beyond its limit when it is more than this far past it, in rad (or m
    /// for prismatic joints); default 0.001.
    pub limit_tolerance: f64,
    /// A joint counts as too fast when its speed exceeds the URDF `<limit velocity>` by more
    /// than this, in rad/s (or m/s); default 0.01. Joints whose URDF velocity limit is 0 or
    /// missing are not checked.
    pub velocity_tolerance: f64,
    /// Whether the URDF joint limits are enforced by the simulator (default true, as on the
    /// robot). With false, a commanded excursion is followed and shows as a measured violation.
    pub enforce_limits: bool,
    /// Whether colliding links push each other apart (default true). With false, collisions
    /// are only detected and reported.
    pub contact_response: bool,
    /// Two links whose shapes are closer than this (metres; negative values demand that much
    /// penetration) count as colliding. Default 0.0: touching or penetrating.
    pub contact_distance: f64,
    /// Events of the same kind (the same link pair, or the same joint and limit check)
    /// separated by less than this many seconds are merged into one (default 0.02 s: contact
    /// that flickers on and off from one 1 ms step to the next is one collision).
    pub merge_gap_seconds: f64,
    /// Whether the motors also track the reference velocity (default true). With false they
    /// are pure position servos with velocity damping toward zero.
    pub velocity_feedforward: bool,
    /// Whether a movable joint without a trajectory column is allowed (held at 0, or at the
    /// nearest limit when 0 is outside them). Default false: a missing joint is an error.
    pub allow_missing_joints: bool,
    /// Extra link pairs never checked for collision, in either order. Links that are
    /// neighbours in the kinematic tree are always skipped: a pair is skipped when every link
    /// on the tree path between them has no collision shape, or when every joint on that path
    /// is fixed.
    pub ignored_pairs: Vec<(String, String)>,
    /// Reflected rotor inertia added to every joint, kg·m² (default 1e-4). Keeps the dynamics
    /// well posed when a URDF gives a link no inertia about its joint axis.
    pub armature: f64,
    /// Solver iterations (rapier substeps) per physics step (default 1: at 1 kHz more
    /// iterations cost proportionally more time and changed tracking errors by < 1e-3 rad
    /// on the shipped robots).
    pub solver_iterations: usize,
    /// Refuse trajectories that would need more physics steps than this (default 10 000 000,
    /// about 2.8 h of motion at 1 kHz).
    pub max_steps: usize,
    /// Whether to return the simulated joint positions at the trajectory's frame times in
    /// [`ReplayReport::simulated`] (default false).
    pub record_simulated: bool,
}

impl Default for ReplayOptions {
    fn default() -> Self {
        ReplayOptions {
            physics_rate_hz: 1000.0,
            stiffness: 40_000.0,
            damping: 400.0,
            settle_seconds: 0.5,
            gravity: true,
            limit_tolerance: 1e-3,
            velocity_tolerance: 0.01,
            enforce_limits: true,
            contact_response: true,
            contact_distance: 0.0,
            merge_gap_seconds: 0.02,
            velocity_feedforward: true,
            allow_missing_joints: false,
            ignored_pairs: Vec::new(),
            armature: 1e-4,
            solver_iterations: 1,
            max_steps: 10_000_000,
            record_simulated: false,
        }
    }
}

impl ReplayOptions {
    /// Checks every option's range; [`replay`] calls it first.
    pub fn validate(&self) -> Result<(), PhysicsError> {
        fn bad(field: &'static str, value: impl ToString, expected: &'static str) -> PhysicsError {
            PhysicsError::InvalidOption {
                field,
                value: value.to_string(),
                expected,
            }
        }
        if !(self.physics_rate_hz.is_finite() && self.physics_rate_hz >= 1.0) {
            return Err(bad(
                "physics_rate_hz",
                self.physics_rate_hz,
                "a finite rate of at least 1 Hz",
            ));
        }
        let non_negative = [
            ("stiffness", self.stiffness, "a finite gain >= 0"),
            ("damping", self.damping, "a finite gain >= 0"),
            (
                "settle_seconds",
                self.settle_seconds,
                "a finite duration >= 0",
            ),
            (
                "limit_tolerance",
                self.limit_tolerance,
                "a finite tolerance >= 0",
            ),
            (
                "velocity_tolerance",
                self.velocity_tolerance,
                "a finite tolerance >= 0",
            ),
            (
                "merge_gap_seconds",
                self.merge_gap_seconds,
                "a finite duration >= 0",
            ),
            ("armature", self.armature, "a finite inertia >= 0"),
        ];
        for (field, value, expected) in non_negative {
            if !(value.is_finite() && value >= 0.0) {
                return Err(bad(field, value, expected));
            }
        }
        if self.stiffness == 0.0 && self.damping == 0.0 {
            return Err(bad(
                "stiffness",
                0.0,
                "a positive stiffness or damping (both are 0: the motors would do nothing)",
            ));
        }
        if !self.contact_distance.is_finite() {
            return Err(bad(
                "contact_distance",
                self.contact_distance,
                "a finite distance in metres",
            ));
        }
        if self.solver_iterations == 0 {
            return Err(bad("solver_iterations", 0, "at least 1"));
        }
        Ok(())
    }
}

/// A joint trajectory: one row of positions per time, columns named after the model's joints.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Trajectory {
    /// Column names: the URDF names of the joints, in the order of the columns.
    pub joint_names: Vec<String>,
    /// Frame times in seconds, strictly increasing (40 Hz for the paper's data).
    pub times: Vec<f64>,
    /// Positions (rad, or m for prismatic joints), row-major: frame `i`, joint `j` at
    /// `positions[i * joint_names.len() + j]`.
    pub positions: Vec<f64>,
}

impl Trajectory {
    /// Builds a trajectory and checks it (see [`Trajectory::validate`]).
    pub fn new(
        joint_names: Vec<String>,
        times: Vec<f64>,
        positions: Vec<f64>,
    ) -> Result<Self, PhysicsError> {
        let trajectory = Trajectory {
            joint_names,
            times,
            positions,
        };
        trajectory.validate()?;
        Ok(trajectory)
    }

    /// Number of frames (rows).
    pub fn frames(&self) -> usize {
        self.times.len()
    }

    /// The positions of frame `i`, in column order, or `None` past the end.
    pub fn row(&self, i: usize) -> Option<&[f64]> {
        let n = self.joint_names.len();
        self.positions.get(i * n..(i + 1) * n)
    }

    /// Checks that there is at least one named, distinct column, at least two frames with
    /// finite strictly increasing times, one position per frame and column, all finite.
    pub fn validate(&self) -> Result<(), PhysicsError> {
        let n = self.joint_names.len();
        if n == 0 {
            return Err(PhysicsError::Trajectory {
                message: "no joint columns; expected at least one joint name".into(),
            });
        }
        let mut seen = HashMap::new();
        for (j, name) in self.joint_names.iter().enumerate() {
            if name.trim().is_empty() {
                return Err(PhysicsError::Trajectory {
                    message: format!("column {j} has an empty joint name"),
                });
            }
            if let Some(first) = seen.insert(name.as_str(), j) {
                return Err(PhysicsError::Trajectory {
                    message: format!(
                        "joint \"{name}\" names both column {first} and column {j}; expected each joint once"
                    ),
                });
            }
        }
        let frames = self.times.len();
        if frames < 2 {
            return Err(PhysicsError::Trajectory {
                message: format!("{frames} frame(s); expected at least 2 to define a motion"),
            });
        }
        for (i, t) in self.times.iter().enumerate() {
            if !t.is_finite() {
                return Err(PhysicsError::Trajectory {
                    message: format!("frame {i} has time {t}; expected a finite time in seconds"),
                });
            }
            if i > 0 && *t <= self.times[i - 1] {
                return Err(PhysicsError::Trajectory {
                    message: format!(
                        "frame {i} has time {t} s, not after frame {} at {} s; expected strictly increasing times",
                        i - 1,
                        self.times[i - 1]
                    ),
                });
            }
        }
        if self.positions.len() != frames * n {
            let rows = if self.positions.len().is_multiple_of(n) {
                format!(" ({} rows of {n})", self.positions.len() / n)
            } else {
                format!(" (not a whole number of rows of {n})")
            };
            return Err(PhysicsError::Trajectory {
                message: format!(
                    "{} position values{rows}; expected {frames} frames × {n} joint columns = {}",
                    self.positions.len(),
                    frames * n
                ),
            });
        }
        for (k, value) in self.positions.iter().enumerate() {
            if !value.is_finite() {
                let (frame, j) = (k / n, k % n);
                return Err(PhysicsError::NonFinitePosition {
                    frame,
                    time: self.times[frame],
                    joint: self.joint_names[j].clone(),
                    value: *value,
                });
            }
        }
        Ok(())
    }
}

/// Tracking quality of one joint over every physics step.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct JointTracking {
    /// The joint's URDF name.
    pub name: String,
    /// Root mean square of (reference − simulated position), rad (m for prismatic joints).
    pub rms_error: f64,
    /// Largest absolute error.
    pub max_error: f64,
    /// When the largest error happened, seconds (trajectory time).
    pub max_error_time: f64,
}

/// A stretch of time during which a joint was beyond one of its limits.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LimitViolation {
    /// When the excursion began, seconds (trajectory time).
    pub time: f64,
    /// The last physics step still beyond the limit, seconds.
    pub end_time: f64,
    /// The joint's URDF name.
    pub joint: String,
    /// The largest distance beyond the limit, rad (m for prismatic joints).
    pub amount: f64,
    /// The limit that was crossed (the lower or the upper one).
    pub limit: f64,
    /// True when the reference itself went beyond the limit; false when the simulated joint
    /// did (e.g. dragged by gravity or a collision, or with limits not enforced).
    pub commanded: bool,
}

/// A stretch of time during which two links of the robot touched or penetrated.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Collision {
    /// When the contact began, seconds (trajectory time).
    pub time: f64,
    /// The last physics step still in contact, seconds.
    pub end_time: f64,
    /// One link's URDF name (the pair is in URDF link order).
    pub link_a: String,
    /// The other link's URDF name.
    pub link_b: String,
    /// The deepest penetration seen, metres (0 for a touch).
    pub max_penetration: f64,
}

/// Everything a replay measured.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ReplayReport {
    /// Simulated time, seconds (last minus first frame time).
    pub duration: f64,
    /// Physics steps taken.
    pub physics_steps: usize,
    /// Wall-clock time of the trajectory's physics steps (settling excluded), seconds.
    pub wall_seconds: f64,
    /// Tracking per movable joint, in the order of the trajectory's columns (joints held
    /// still because they had no column follow).
    pub joints: Vec<JointTracking>,
    /// Limit excursions, ordered by start time.
    pub limit_violations: Vec<LimitViolation>,
    /// Stretches of time during which a joint moved faster than its URDF velocity limit,
    /// ordered by start time; `amount` and `limit` are speeds (rad/s or m/s, `limit` signed
    /// like the velocity), `commanded` as for position limits (the reference's slope, or the
    /// simulated joint's velocity).
    pub velocity_violations: Vec<LimitViolation>,
    /// Self-collisions, ordered by start time; consecutive steps in contact form one event.
    pub collisions: Vec<Collision>,
    /// Things the model loader worked around (mesh shapes skipped, floating roots fixed ...).
    pub warnings: Vec<String>,
    /// The simulated positions at the trajectory's frame times, same columns as
    /// [`ReplayReport::joints`], when [`ReplayOptions::record_simulated`] is set.
    pub simulated: Option<Trajectory>,
}

/// Replays `trajectory` on the robot described by the URDF text `urdf_xml` (`source` is the
/// file name used in messages). The text is read by [`crate::urdf::Robot::from_urdf_str`], which
/// copes with the quirks of real URDFs; see the module documentation for the control and the
/// rules.
pub fn replay(
    urdf_xml: &str,
    source: &str,
    trajectory: &Trajectory,
    options: &ReplayOptions,
) -> Result<ReplayReport, PhysicsError> {
    let robot = crate::urdf::Robot::from_urdf_str(urdf_xml, source)?;
    replay_urdf(robot.urdf(), source, trajectory, options)
}

/// Like [`replay`], for a URDF already parsed by urdf-rs (e.g. [`crate::urdf::Robot::urdf`]).
pub fn replay_urdf(
    robot: &urdf_rs::Robot,
    source: &str,
    trajectory: &Trajectory,
    options: &ReplayOptions,
) -> Result<ReplayReport, PhysicsError> {
    options.validate()?;
    trajectory.validate()?;
    let model = prepare_model(robot, source)?;
    // rapier asserts a few invariants of its own; anything we did not foresee becomes an
    // error value instead of tearing down the caller.
    match catch_unwind(AssertUnwindSafe(|| {
        simulate(&model, source, trajectory, options)
    })) {
        Ok(result) => result,
        Err(panic) => {
            let message = panic
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| panic.downcast_ref::<String>().cloned())
                .unwrap_or_else(|| "unknown panic".to_string());
            Err(PhysicsError::Engine {
                file: source.to_string(),
                message,
            })
        }
    }
}

/// How a movable joint's coordinate is driven.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Dof {
    /// Revolute or continuous: rapier's `AngX`, coordinate 3.
    Angular,
    /// Prismatic: rapier's `LinX`, coordinate 0.
    Linear,
}

impl Dof {
    fn axis(self) -> JointAxis {
        match self {
            Dof::Angular => JointAxis::AngX,
            Dof::Linear => JointAxis::LinX,
        }
    }
    fn coord(self) -> usize {
        match self {
            Dof::Angular => 3,
            Dof::Linear => 0,
        }
    }
}

/// A checked, simulation-ready copy of the URDF.
struct PreparedModel {
    /// The URDF with floating roots fixed and zero-range revolute joints made continuous.
    robot: urdf_rs::Robot,
    /// For each link: whether it carries a collision shape rapier will build.
    has_shape: Vec<bool>,
    /// Link pairs (by URDF link index) never checked, as a dense symmetric matrix.
    neighbours: Vec<bool>,
    warnings: Vec<String>,
}

fn element_of_joint(joint: &urdf_rs::Joint) -> String {
    format!("<joint name=\"{}\">", joint.name)
}

fn element_of_link(link: &urdf_rs::Link) -> String {
    format!("<link name=\"{}\">", link.name)
}

/// Checks the URDF tree and numbers, fixes what a fixed-base replay needs fixed.
fn prepare_model(robot: &urdf_rs::Robot, file: &str) -> Result<PreparedModel, PhysicsError> {
    let model_err = |element: String, message: String| PhysicsError::Model {
        file: file.to_string(),
        element,
        message,
    };
    let mut robot = robot.clone();
    let mut warnings = Vec::new();
    let n_links = robot.links.len();
    if n_links == 0 {
        return Err(model_err(
            "<robot>".into(),
            "no <link>; expected at least one".into(),
        ));
    }
    let mut link_index = HashMap::new();
    for (i, link) in robot.links.iter().enumerate() {
        if link_index.insert(link.name.clone(), i).is_some() {
            return Err(model_err(
                element_of_link(link),
                "declared twice; expected unique link names".into(),
            ));
        }
    }
    let finite3 = |v: &[f64; 3]| v.iter().all(|x| x.is_finite());
    // Geometry and inertia sanity: parry builds shapes from whatever numbers it gets.
    for link in &mut robot.links {
        let element = element_of_link(link);
        let inertial = &link.inertial;
        let i = &inertial.inertia;
        let values = [i.ixx, i.ixy, i.ixz, i.iyy, i.iyz, i.izz];
        let valid = inertial.mass.value.is_finite()
            && inertial.mass.value >= 0.0
            && values.iter().all(|v| v.is_finite())
            && finite3(&inertial.origin.xyz.0)
            && finite3(&inertial.origin.rpy.0);
        if !valid {
            return Err(model_err(
                element + " <inertial>",
                "expected a finite mass >= 0 and finite inertia and origin".into(),
            ));
        }
        let mut kept = Vec::new();
        for collision in link.collision.drain(..) {
            let ok_pose = finite3(&collision.origin.xyz.0) && finite3(&collision.origin.rpy.0);
            let ok_size = |v: f64| v.is_finite() && v >= 0.0;
            let ok_shape = match &collision.geometry {
                urdf_rs::Geometry::Box { size } => size.0.iter().all(|v| ok_size(*v)),
                urdf_rs::Geometry::Cylinder { radius, length }
                | urdf_rs::Geometry::Capsule { radius, length } => {
                    ok_size(*radius) && ok_size(*length)
                }
                urdf_rs::Geometry::Sphere { radius } => ok_size(*radius),
                urdf_rs::Geometry::Mesh { filename, .. } => {
                    warnings.push(format!(
                        "{file}: {element}: collision mesh \"{filename}\" skipped (only boxes, cylinders, capsules and spheres are simulated)"
                    ));
                    continue;
                }
            };
            if !(ok_pose && ok_shape) {
                return Err(model_err(
                    element + " <collision>",
                    "expected finite, non-negative shape sizes and a finite origin".into(),
                ));
            }
            kept.push(collision);
        }
        link.collision = kept;
    }
    let mut parent_of = vec![None; n_links];
    for (j, joint) in robot.joints.iter_mut().enumerate() {
        let element = element_of_joint(joint);
        let parent = *link_index.get(&joint.parent.link).ok_or_else(|| {
            model_err(
                element.clone(),
                format!(
                    "unknown parent link \"{}\"; expected a declared <link>",
                    joint.parent.link
                ),
            )
        })?;
        let child = *link_index.get(&joint.child.link).ok_or_else(|| {
            model_err(
                element.clone(),
                format!(
                    "unknown child link \"{}\"; expected a declared <link>",
                    joint.child.link
                ),
            )
        })?;
        if parent_of[child].is_some() {
            return Err(model_err(
                element,
                format!(
                    "link \"{}\" is the child of a second joint; a URDF must be a tree",
                    joint.child.link
                ),
            ));
        }
        parent_of[child] = Some((j, parent));
        if !finite3(&joint.origin.xyz.0) || !finite3(&joint.origin.rpy.0) {
            return Err(model_err(element, "expected a finite <origin>".into()));
        }
        match joint.joint_type {
            urdf_rs::JointType::Floating | urdf_rs::JointType::Planar => {
                warnings.push(format!(
                    "{file}: {element}: {:?} joint fixed (the replay fixes the robot's base to the world)",
                    joint.joint_type
                ));
                joint.joint_type = urdf_rs::JointType::Fixed;
            }
            urdf_rs::JointType::Spherical => {
                return Err(model_err(
                    element,
                    "spherical joints cannot follow a one-column trajectory; expected revolute, continuous, prismatic or fixed".into(),
                ));
            }
            urdf_rs::JointType::Revolute
            | urdf_rs::JointType::Continuous
            | urdf_rs::JointType::Prismatic => {
                let axis = joint.axis.xyz.0;
                let norm = axis.iter().map(|a| a * a).sum::<f64>().sqrt();
                if !(finite3(&axis) && norm > 1e-9) {
                    return Err(model_err(
                        element + " <axis>",
                        format!("{axis:?}; expected a finite, non-zero axis"),
                    ));
                }
                let (lower, upper) = (joint.limit.lower, joint.limit.upper);
                if joint.joint_type != urdf_rs::JointType::Continuous {
                    if !(lower.is_finite() && upper.is_finite() && lower <= upper) {
                        return Err(model_err(
                            element + " <limit>",
                            format!("lower = {lower}, upper = {upper}; expected finite limits with lower <= upper"),
                        ));
                    }
                    if joint.joint_type == urdf_rs::JointType::Revolute
                        && lower == 0.0
                        && upper == 0.0
                    {
                        warnings.push(format!(
                            "{file}: {element}: revolute joint with both limits 0 treated as unlimited"
                        ));
                        joint.joint_type = urdf_rs::JointType::Continuous;
                    }
                }
            }
            urdf_rs::JointType::Fixed => {}
        }
    }
    // No cycles: walking up from any link must end at a root within n_links steps.
    for start in 0..n_links {
        let mut link = start;
        for _ in 0..=n_links {
            match parent_of[link] {
                Some((_, parent)) => link = parent,
                None => break,
            }
        }
        if parent_of[link].is_some() {
            return Err(model_err(
                element_of_link(&robot.links[start]),
                "lies on a cycle of joints; a URDF must be a tree".into(),
            ));
        }
    }
    let has_shape: Vec<bool> = robot
        .links
        .iter()
        .map(|l| !l.collision.is_empty())
        .collect();
    let neighbours = neighbour_matrix(&robot, &parent_of, &has_shape);
    Ok(PreparedModel {
        robot,
        has_shape,
        neighbours,
        warnings,
    })
}

/// The chain of (joint, link) steps from `link` up to its root, `link` first.
fn ancestry(link: usize, parent_of: &[Option<(usize, usize)>]) -> Vec<usize> {
    let mut chain = vec![link];
    let mut current = link;
    while let Some((_, parent)) = parent_of[current] {
        chain.push(parent);
        current = parent;
    }
    chain
}

/// Which link pairs are neighbours (never collision-checked): every intermediate link on the
/// tree path has no shape, or every joint on the path is fixed.
fn neighbour_matrix(
    robot: &urdf_rs::Robot,
    parent_of: &[Option<(usize, usize)>],
    has_shape: &[bool],
) -> Vec<bool> {
    let n = robot.links.len();
    let mut matrix = vec![false; n * n];
    let chains: Vec<Vec<usize>> = (0..n).map(|l| ancestry(l, parent_of)).collect();
    for a in 0..n {
        matrix[a * n + a] = true;
        for b in (a + 1)..n {
            let (ca, cb) = (&chains[a], &chains[b]);
            // Lowest common ancestor: the first link of a's chain that is in b's chain.
            let Some((ia, ib)) = ca
                .iter()
                .enumerate()
                .find_map(|(ia, l)| cb.iter().position(|m| m == l).map(|ib| (ia, ib)))
            else {
                continue; // different trees: not neighbours
            };
            // Links strictly between a and b on the path (the common ancestor included when it
            // is neither end).
            let mut between: Vec<usize> = ca.get(1..ia).unwrap_or(&[]).to_vec();
            between.extend_from_slice(cb.get(1..ib).unwrap_or(&[]));
            if ia > 0 && ib > 0 {
                between.push(ca[ia]);
            }
            let shapeless_between = between.iter().all(|&l| !has_shape[l]);
            // Joints on the path: the parent joint of every link below the common ancestor.
            let all_fixed = ca[..ia]
                .iter()
                .chain(cb[..ib].iter())
                .all(|&l| match parent_of[l] {
                    Some((j, _)) => robot.joints[j].joint_type == urdf_rs::JointType::Fixed,
                    None => true,
                });
            if shapeless_between || all_fixed {
                matrix[a * n + b] = true;
                matrix[b * n + a] = true;
            }
        }
    }
    matrix
}

/// Contact filter: neighbours and ignored pairs produce no contacts; the others are detected,
/// and solved when contact response is on.
struct SelfCollisionFilter {
    n_links: usize,
    skip: Vec<bool>,
    response: bool,
}

impl PhysicsHooks for SelfCollisionFilter {
    fn filter_contact_pair(&self, context: &PairFilterContext) -> Option<SolverFlags> {
        let link = |h| {
            context
                .colliders
                .get(h)
                .map(|c| c.user_data as usize)
                .filter(|&l| l < self.n_links)
        };
        if let (Some(a), Some(b)) = (link(context.collider1), link(context.collider2)) {
            if self.skip[a * self.n_links + b] {
                return None;
            }
        }
        Some(if self.response {
            SolverFlags::COMPUTE_RIGID_IMPULSES
        } else {
            SolverFlags::empty()
        })
    }
}

/// A movable joint in the simulation.
struct DrivenJoint {
    name: String,
    handle: MultibodyJointHandle,
    body: RigidBodyHandle,
    dof: Dof,
    /// (lower, upper), or None for continuous joints.
    limits: Option<(f64, f64)>,
    /// The URDF velocity limit, when positive.
    velocity_limit: Option<f64>,
    /// Trajectory column, or None when held still.
    column: Option<usize>,
    /// Held position for joints without a column.
    hold: f64,
}

/// An open limit or collision event.
struct OpenEvent {
    start: f64,
    end: f64,
    amount: f64,
    limit: f64,
    last_step: usize,
}

fn simulate(
    model: &PreparedModel,
    file: &str,
    trajectory: &Trajectory,
    options: &ReplayOptions,
) -> Result<ReplayReport, PhysicsError> {
    let robot = &model.robot;
    let n_links = robot.links.len();
    let mut warnings = model.warnings.clone();

    // Load into rapier.
    let loader_options = UrdfLoaderOptions {
        make_roots_fixed: true,
        enable_joint_collisions: false,
        collider_blueprint: ColliderBuilder::default()
            .density(0.0)
            .active_hooks(ActiveHooks::FILTER_CONTACT_PAIRS),
        rigid_body_blueprint: RigidBodyBuilder::dynamic().can_sleep(false),
        ..UrdfLoaderOptions::default()
    };
    let mut urdf_robot = UrdfRobot::from_robot(robot, loader_options, Path::new("."));
    for link in &mut urdf_robot.links {
        let source = &robot.links[link.urdf_link_index];
        for collider in &mut link.colliders {
            collider.collider.user_data = link.urdf_link_index as u128;
        }
        let is_moving = link.body.body_type() == RigidBodyType::Dynamic;
        if is_moving && source.inertial.mass.value == 0.0 {
            if link.colliders.is_empty() {
                link.body.set_additional_mass_properties(
                    MassProperties::new(
                        Vector::ZERO,
                        PLACEHOLDER_MASS,
                        Vector::splat(PLACEHOLDER_INERTIA),
                    ),
                    false,
                );
            } else {
                warnings.push(format!(
                    "{file}: <link name=\"{}\"> declares no mass; its collision shapes were given a density of {DEFAULT_DENSITY} kg/m³",
                    source.name
                ));
                for collider in &mut link.colliders {
                    collider.collider.set_density(DEFAULT_DENSITY);
                }
            }
        }
    }
    // Every branch leaving a fixed link gets its own shapeless copy of that link as root, so
    // that each arm is a multibody of its own. The dynamics are the same (a fixed link
    // couples nothing) and rapier's multibody cost grows with the square of the degrees of
    // freedom, so two 7-joint arms step about twice as fast as one 14-joint tree.
    let mut branches_seen = vec![false; urdf_robot.links.len()];
    for j in 0..urdf_robot.joints.len() {
        let parent = urdf_robot.joints[j].link1;
        if urdf_robot.links[parent].body.body_type() != RigidBodyType::Fixed {
            continue;
        }
        if !branches_seen[parent] {
            branches_seen[parent] = true;
            continue;
        }
        let twin = rapier3d_urdf::UrdfLink {
            body: urdf_robot.links[parent].body.clone(),
            colliders: Vec::new(),
            urdf_link_index: urdf_robot.links[parent].urdf_link_index,
        };
        urdf_robot.links.push(twin);
        urdf_robot.joints[j].link1 = urdf_robot.links.len() - 1;
    }
    // Which URDF joint each rapier joint came from (the squeeze of empty links may merge).
    let sources: Vec<usize> = urdf_robot
        .joints
        .iter()
        .map(|j| j.source_urdf_joint_index())
        .collect();

    let mut world = PhysicsWorld::new();
    world.gravity = if options.gravity {
        Vector::new(0.0, 0.0, -GRAVITY)
    } else {
        Vector::ZERO
    };
    world.integration_parameters.dt = (1.0 / options.physics_rate_hz) as Real;
    world.integration_parameters.num_solver_iterations = options.solver_iterations;
    let handles = urdf_robot.insert_using_multibody_joints(
        &mut world.bodies,
        &mut world.colliders,
        &mut world.multibody_joints,
        UrdfMultibodyOptions::empty(),
    );

    // The movable joints, in URDF order.
    let mut driven: Vec<DrivenJoint> = Vec::new();
    for (handle, &source) in handles.joints.iter().zip(&sources) {
        let joint = &robot.joints[source];
        let dof = match joint.joint_type {
            urdf_rs::JointType::Revolute | urdf_rs::JointType::Continuous => Dof::Angular,
            urdf_rs::JointType::Prismatic => Dof::Linear,
            _ => continue,
        };
        let Some(mb_handle) = handle.joint else {
            return Err(PhysicsError::Model {
                file: file.to_string(),
                element: element_of_joint(joint),
                message: "could not be added to the robot's multibody; expected a tree of joints"
                    .into(),
            });
        };
        let limits = match joint.joint_type {
            urdf_rs::JointType::Continuous => None,
            _ => Some((joint.limit.lower, joint.limit.upper)),
        };
        driven.push(DrivenJoint {
            name: joint.name.clone(),
            handle: mb_handle,
            body: handle.link2,
            dof,
            limits,
            velocity_limit: (joint.limit.velocity.is_finite() && joint.limit.velocity > 0.0)
                .then_some(joint.limit.velocity),
            column: None,
            hold: limits.map_or(0.0, |(lo, hi)| 0.0f64.clamp(lo, hi)),
        });
    }
    driven.sort_by_key(|d| robot.joints.iter().position(|j| j.name == d.name));

    // Match trajectory columns to joints by name.
    let by_name: HashMap<String, usize> = driven
        .iter()
        .enumerate()
        .map(|(i, d)| (d.name.clone(), i))
        .collect();
    for (column, name) in trajectory.joint_names.iter().enumerate() {
        let Some(&i) = by_name.get(name.as_str()) else {
            let known: Vec<&str> = driven.iter().map(|d| d.name.as_str()).collect();
            return Err(PhysicsError::UnknownJoint {
                file: file.to_string(),
                joint: name.clone(),
                known: if known.is_empty() {
                    "none".to_string()
                } else {
                    known.join(", ")
                },
            });
        };
        driven[i].column = Some(column);
    }
    if let Some(missing) = driven.iter().find(|d| d.column.is_none()) {
        if !options.allow_missing_joints {
            return Err(PhysicsError::MissingJoint {
                file: file.to_string(),
                joint: missing.name.clone(),
            });
        }
    }
    for d in &mut driven {
        if !options.enforce_limits {
            if let Some((mb, link_id)) = world.multibody_joints.get_mut(d.handle) {
                if let Some(link) = mb.link_mut(link_id) {
                    link.joint.data.limit_axes.remove(d.dof.axis().into());
                }
            }
        }
    }
    // Report order: trajectory columns first, then held joints.
    driven.sort_by_key(|d| d.column.unwrap_or(usize::MAX));

    // Armature and the initial configuration (the first frame, at rest).
    let first = trajectory.row(0).unwrap_or(&[]);
    let initial: Vec<f64> = driven
        .iter()
        .map(|d| d.column.map_or(d.hold, |c| first[c]))
        .collect();
    // (multibody, link id, first dof) of every driven joint.
    let placement: Vec<Option<(MultibodyIndex, usize)>> = driven
        .iter()
        .map(|d| {
            world
                .multibody_joints
                .rigid_body_link(d.body)
                .map(|l| (l.multibody, l.id))
        })
        .collect();
    let multibody_indices: HashSet<MultibodyIndex> =
        placement.iter().flatten().map(|(m, _)| *m).collect();
    for index in multibody_indices {
        let Some(mb) = world.multibody_joints.get_multibody_mut(index) else {
            continue;
        };
        mb.armature_mut().fill(options.armature as Real);
        let mut displacement: Vec<Real> = vec![0.0; mb.ndofs()];
        for (place, q0) in placement.iter().zip(&initial) {
            let Some((_, link_id)) = place.filter(|(m, _)| *m == index) else {
                continue;
            };
            if let Some(link) = mb.link(link_id) {
                if let Some(slot) = displacement.get_mut(link.assembly_id()) {
                    *slot = *q0 as Real;
                }
            }
        }
        mb.apply_displacements(&displacement);
        mb.forward_kinematics(&world.bodies, false);
        mb.update_rigid_bodies(&mut world.bodies, true);
    }

    // Contact filter.
    let mut skip = model.neighbours.clone();
    let link_index: HashMap<&str, usize> = robot
        .links
        .iter()
        .enumerate()
        .map(|(i, l)| (l.name.as_str(), i))
        .collect();
    for (a, b) in &options.ignored_pairs {
        match (link_index.get(a.as_str()), link_index.get(b.as_str())) {
            (Some(&ia), Some(&ib)) => {
                skip[ia * n_links + ib] = true;
                skip[ib * n_links + ia] = true;
            }
            _ => {
                return Err(PhysicsError::InvalidOption {
                    field: "ignored_pairs",
                    value: format!("(\"{a}\", \"{b}\")"),
                    expected: "pairs of link names declared in the URDF",
                })
            }
        }
    }
    let hooks = SelfCollisionFilter {
        n_links,
        skip,
        response: options.contact_response,
    };
    if !model.has_shape.iter().any(|&s| s) {
        warnings.push(format!(
            "{file}: no link has a collision shape; self-collisions cannot be detected"
        ));
    }

    // The replay loop.
    let t0 = trajectory.times[0];
    let t_end = trajectory.times[trajectory.frames() - 1];
    let duration = t_end - t0;
    let rate = options.physics_rate_hz;
    let steps_f = (duration * rate).round().max(1.0);
    let settle_steps = (options.settle_seconds * rate).round();
    if steps_f + settle_steps > options.max_steps as f64 {
        return Err(PhysicsError::Trajectory {
            message: format!(
                "{duration} s at {rate} Hz (after {} s of settling) needs {} physics steps; expected at most max_steps = {}",
                options.settle_seconds,
                steps_f + settle_steps,
                options.max_steps
            ),
        });
    }
    let steps = steps_f as usize;
    let settle_steps = settle_steps as usize;
    let n_cols = trajectory.joint_names.len();
    let (stiffness, damping) = (options.stiffness as Real, options.damping as Real);
    let tol = options.limit_tolerance;
    let merge_gap = (options.merge_gap_seconds * rate).round() as usize;

    let mut sum_sq = vec![0.0f64; driven.len()];
    let mut max_err = vec![0.0f64; driven.len()];
    let mut max_err_time = vec![t0; driven.len()];
    let mut reference = vec![0.0f64; driven.len()];
    let mut velocity = vec![0.0f64; driven.len()];
    let mut actual = vec![0.0f64; driven.len()];
    let mut open_limits: HashMap<(usize, bool), OpenEvent> = HashMap::new();
    let mut open_speeds: HashMap<(usize, bool), OpenEvent> = HashMap::new();
    let mut velocity_violations = Vec::new();
    let mut slope = vec![0.0f64; driven.len()];
    let mut limit_violations = Vec::new();
    let mut open_contacts: HashMap<(usize, usize), OpenEvent> = HashMap::new();
    let mut collisions = Vec::new();
    let mut simulated = options
        .record_simulated
        .then(|| Vec::with_capacity(trajectory.frames() * driven.len()));
    let mut next_frame = 1usize;
    let mut segment = 0usize;

    // Settle on the first frame.
    for _ in 0..settle_steps {
        for (d, q0) in driven.iter().zip(&initial) {
            if let Some((mb, link_id)) = world.multibody_joints.get_mut(d.handle) {
                if let Some(link) = mb.link_mut(link_id) {
                    link.joint
                        .data
                        .set_motor(d.dof.axis(), *q0 as Real, 0.0, stiffness, damping);
                }
            }
        }
        world.step_with_events(&hooks, &());
    }
    if let Some(sim) = simulated.as_mut() {
        for d in &driven {
            sim.push(joint_position(&world, d));
        }
    }
    let started = Instant::now();
    for step in 1..=steps {
        let t = (t0 + step as f64 / rate).min(t_end);
        while segment + 2 < trajectory.frames() && trajectory.times[segment + 1] < t {
            segment += 1;
        }
        let (ta, tb) = (trajectory.times[segment], trajectory.times[segment + 1]);
        let w = ((t - ta) / (tb - ta)).clamp(0.0, 1.0);
        let row_a = &trajectory.positions[segment * n_cols..(segment + 1) * n_cols];
        let row_b = &trajectory.positions[(segment + 1) * n_cols..(segment + 2) * n_cols];
        for (i, d) in driven.iter().enumerate() {
            let (q, v) = match d.column {
                Some(c) => (
                    row_a[c] + w * (row_b[c] - row_a[c]),
                    (row_b[c] - row_a[c]) / (tb - ta),
                ),
                None => (d.hold, 0.0),
            };
            reference[i] = q;
            slope[i] = v;
            velocity[i] = if options.velocity_feedforward { v } else { 0.0 };
            if let Some((mb, link_id)) = world.multibody_joints.get_mut(d.handle) {
                if let Some(link) = mb.link_mut(link_id) {
                    link.joint.data.set_motor(
                        d.dof.axis(),
                        q as Real,
                        velocity[i] as Real,
                        stiffness,
                        damping,
                    );
                }
            }
        }

        world.step_with_events(&hooks, &());

        for (i, d) in driven.iter().enumerate() {
            let q = joint_position(&world, d);
            if !q.is_finite() {
                return Err(PhysicsError::Diverged {
                    file: file.to_string(),
                    time: t,
                    joint: d.name.clone(),
                    value: q,
                });
            }
            actual[i] = q;
            let e = (reference[i] - q).abs();
            sum_sq[i] += e * e;
            if e > max_err[i] {
                max_err[i] = e;
                max_err_time[i] = t;
            }
            if let Some((lo, hi)) = d.limits {
                for (commanded, value) in [(true, reference[i]), (false, q)] {
                    let (beyond, limit) = if value > hi {
                        (value - hi, hi)
                    } else {
                        (lo - value, lo)
                    };
                    if beyond > tol {
                        extend_event(&mut open_limits, (i, commanded), t, step, beyond, limit);
                    }
                }
            }
            if let Some(max_speed) = d.velocity_limit {
                let measured = joint_velocity(&world, d);
                for (commanded, value) in [(true, slope[i]), (false, measured)] {
                    let beyond = value.abs() - max_speed;
                    if beyond > options.velocity_tolerance {
                        let limit = max_speed.copysign(value);
                        extend_event(&mut open_speeds, (i, commanded), t, step, beyond, limit);
                    }
                }
            }
        }
        close_events(&mut open_speeds, step, merge_gap, |(i, commanded), e| {
            velocity_violations.push(LimitViolation {
                time: e.start,
                end_time: e.end,
                joint: driven[i].name.clone(),
                amount: e.amount,
                limit: e.limit,
                commanded,
            })
        });
        close_events(&mut open_limits, step, merge_gap, |(i, commanded), e| {
            limit_violations.push(LimitViolation {
                time: e.start,
                end_time: e.end,
                joint: driven[i].name.clone(),
                amount: e.amount,
                limit: e.limit,
                commanded,
            })
        });

        for pair in world.narrow_phase.contact_pairs() {
            let Some((_, contact)) = pair.find_deepest_contact() else {
                continue;
            };
            if (contact.dist as f64) > options.contact_distance {
                continue;
            }
            let link_of = |h| world.colliders.get(h).map(|c| c.user_data as usize);
            let (Some(a), Some(b)) = (link_of(pair.collider1), link_of(pair.collider2)) else {
                continue;
            };
            if a == b || a >= n_links || b >= n_links || hooks.skip[a * n_links + b] {
                continue;
            }
            let key = (a.min(b), a.max(b));
            let depth = (-contact.dist as f64).max(0.0);
            let event = open_contacts.entry(key).or_insert(OpenEvent {
                start: t,
                end: t,
                amount: 0.0,
                limit: 0.0,
                last_step: step,
            });
            event.end = t;
            event.last_step = step;
            event.amount = event.amount.max(depth);
        }
        close_events(&mut open_contacts, step, merge_gap, |(a, b), e| {
            collisions.push(Collision {
                time: e.start,
                end_time: e.end,
                link_a: robot.links[a].name.clone(),
                link_b: robot.links[b].name.clone(),
                max_penetration: e.amount,
            })
        });

        if let Some(sim) = simulated.as_mut() {
            while next_frame < trajectory.frames() && trajectory.times[next_frame] <= t + 0.5 / rate
            {
                sim.extend_from_slice(&actual);
                next_frame += 1;
            }
        }
    }
    let wall_seconds = started.elapsed().as_secs_f64();
    // Close whatever is still open at the end.
    close_events(&mut open_speeds, usize::MAX, 0, |(i, commanded), e| {
        velocity_violations.push(LimitViolation {
            time: e.start,
            end_time: e.end,
            joint: driven[i].name.clone(),
            amount: e.amount,
            limit: e.limit,
            commanded,
        })
    });
    close_events(&mut open_limits, usize::MAX, 0, |(i, commanded), e| {
        limit_violations.push(LimitViolation {
            time: e.start,
            end_time: e.end,
            joint: driven[i].name.clone(),
            amount: e.amount,
            limit: e.limit,
            commanded,
        })
    });
    close_events(&mut open_contacts, usize::MAX, 0, |(a, b), e| {
        collisions.push(Collision {
            time: e.start,
            end_time: e.end,
            link_a: robot.links[a].name.clone(),
            link_b: robot.links[b].name.clone(),
            max_penetration: e.amount,
        })
    });
    let by_time = |x: &LimitViolation, y: &LimitViolation| {
        x.time
            .total_cmp(&y.time)
            .then_with(|| x.joint.cmp(&y.joint))
            .then_with(|| y.commanded.cmp(&x.commanded))
    };
    limit_violations.sort_by(by_time);
    velocity_violations.sort_by(by_time);
    collisions.sort_by(|x, y| {
        x.time
            .total_cmp(&y.time)
            .then_with(|| x.link_a.cmp(&y.link_a))
            .then_with(|| x.link_b.cmp(&y.link_b))
    });

    let joints = driven
        .iter()
        .enumerate()
        .map(|(i, d)| JointTracking {
            name: d.name.clone(),
            rms_error: (sum_sq[i] / steps as f64).sqrt(),
            max_error: max_err[i],
            max_error_time: max_err_time[i],
        })
        .collect();
    let simulated = simulated.map(|mut positions| {
        // A frame the loop could not reach (only possible through rounding) repeats the last.
        while positions.len() < trajectory.frames() * driven.len() {
            positions.extend_from_slice(&actual);
        }
        Trajectory {
            joint_names: driven.iter().map(|d| d.name.clone()).collect(),
            times: trajectory.times.clone(),
            positions,
        }
    });
    Ok(ReplayReport {
        duration,
        physics_steps: steps,
        wall_seconds,
        joints,
        limit_violations,
        velocity_violations,
        collisions,
        warnings,
        simulated,
    })
}

/// The simulated position of a driven joint (NaN if rapier lost it, caught as divergence).
fn joint_position(world: &PhysicsWorld, d: &DrivenJoint) -> f64 {
    world
        .multibody_joints
        .get(d.handle)
        .and_then(|(mb, link_id)| mb.link(link_id))
        .map_or(f64::NAN, |link| link.joint().coords()[d.dof.coord()] as f64)
}

/// The simulated velocity of a driven joint.
fn joint_velocity(world: &PhysicsWorld, d: &DrivenJoint) -> f64 {
    world
        .multibody_joints
        .get(d.handle)
        .and_then(|(mb, link_id)| mb.link(link_id).map(|link| mb.joint_velocity(link)))
        .and_then(|v| v.get(0).copied())
        .map_or(0.0, |v| v as f64)
}

/// Opens or extends the event `key` at step `step` (time `t`) with excess `beyond` over `limit`.
fn extend_event<K: Eq + std::hash::Hash>(
    open: &mut HashMap<K, OpenEvent>,
    key: K,
    t: f64,
    step: usize,
    beyond: f64,
    limit: f64,
) {
    let event = open.entry(key).or_insert(OpenEvent {
        start: t,
        end: t,
        amount: 0.0,
        limit,
        last_step: step,
    });
    event.end = t;
    event.last_step = step;
    if beyond > event.amount {
        event.amount = beyond;
        event.limit = limit;
    }
}

/// Moves every event not extended during the last `gap` steps before `step` (inclusive of
/// `step`) from `open` to `emit`.
fn close_events<K: Copy + Eq + std::hash::Hash>(
    open: &mut HashMap<K, OpenEvent>,
    step: usize,
    gap: usize,
    mut emit: impl FnMut(K, OpenEvent),
) {
    if open.is_empty() {
        return;
    }
    let done: Vec<K> = open
        .iter()
        .filter(|(_, e)| step - e.last_step > gap)
        .map(|(k, _)| *k)
        .collect();
    for key in done {
        if let Some(event) = open.remove(&key) {
            emit(key, event);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// base ─rev→ a (shapeless) ─rev→ b (shape); base ─fixed→ c (shape) ─rev→ d (shape);
    /// d ─fixed→ e (shape).
    const TREE: &str = r#"<robot name="tree">
      <link name="base"><collision><geometry><box size="1 1 1"/></geometry></collision></link>
      <link name="a"/>
      <link name="b"><collision><geometry><sphere radius="0.1"/></geometry></collision></link>
      <link name="c"><collision><geometry><sphere radius="0.1"/></geometry></collision></link>
      <link name="d"><collision><geometry><sphere radius="0.1"/></geometry></collision></link>
      <link name="e"><collision><geometry><sphere radius="0.1"/></geometry></collision></link>
      <joint name="j_a" type="revolute"><parent link="base"/><child link="a"/>
        <axis xyz="1 0 0"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
      <joint name="j_b" type="revolute"><parent link="a"/><child link="b"/>
        <axis xyz="0 1 0"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
      <joint name="j_c" type="fixed"><parent link="base"/><child link="c"/></joint>
      <joint name="j_d" type="continuous"><parent link="c"/><child link="d"/><axis xyz="0 0 1"/></joint>
      <joint name="j_e" type="fixed"><parent link="d"/><child link="e"/></joint>
    </robot>"#;

    fn neighbours(xml: &str) -> (Vec<String>, Vec<bool>) {
        let robot = urdf_rs::read_from_string(xml).unwrap();
        let model = prepare_model(&robot, "tree.urdf").unwrap();
        let names = model.robot.links.iter().map(|l| l.name.clone()).collect();
        (names, model.neighbours)
    }

    #[test]
    fn neighbours_are_tree_adjacent_through_shapeless_links_or_fixed_joints() {
        let (names, m) = neighbours(TREE);
        let n = names.len();
        let idx = |s: &str| names.iter().position(|x| x == s).unwrap();
        let near = |a: &str, b: &str| m[idx(a) * n + idx(b)];
        // Direct parent/child.
        assert!(near("base", "a") && near("a", "b") && near("c", "d") && near("d", "e"));
        // Through the shapeless link a.
        assert!(near("base", "b") && near("b", "base"));
        // All-fixed path.
        assert!(near("base", "c"));
        // c (with a shape) sits between base and d, and the path has a moving joint.
        assert!(!near("base", "d") && !near("base", "e"));
        // Across the base: b and c, b and d are not neighbours.
        assert!(!near("b", "c") && !near("b", "d") && !near("c", "e"));
        // Symmetric.
        for i in 0..n {
            for j in 0..n {
                assert_eq!(m[i * n + j], m[j * n + i]);
            }
        }
    }

    #[test]
    fn model_preparation_fixes_floating_roots_and_zero_range_joints() {
        let xml = TREE
            .replace(
                r#"<link name="base">"#,
                r#"<link name="world"/><joint name="float" type="floating"><parent link="world"/><child link="base"/></joint><link name="base">"#,
            )
            .replace(
                r#"<axis xyz="0 1 0"/><limit lower="-1" upper="1""#,
                r#"<axis xyz="0 1 0"/><limit lower="0" upper="0""#,
            );
        let robot = urdf_rs::read_from_string(&xml).unwrap();
        let model = prepare_model(&robot, "tree.urdf").unwrap();
        let kind = |name: &str| {
            model
                .robot
                .joints
                .iter()
                .find(|j| j.name == name)
                .map(|j| j.joint_type.clone())
                .unwrap()
        };
        assert_eq!(kind("float"), urdf_rs::JointType::Fixed);
        assert_eq!(kind("j_b"), urdf_rs::JointType::Continuous);
        assert_eq!(kind("j_a"), urdf_rs::JointType::Revolute);
        assert_eq!(model.warnings.len(), 2, "{:?}", model.warnings);
    }

    #[test]
    fn model_preparation_rejects_loops_and_bad_numbers() {
        // b ─→ base closes the loop base → a → b → base.
        let mut robot = urdf_rs::read_from_string(TREE).unwrap();
        let mut back = robot.joints[0].clone();
        back.name = "j_back".into();
        back.parent.link = "b".into();
        back.child.link = "base".into();
        robot.joints.push(back);
        let err = prepare_model(&robot, "t.urdf").err().unwrap().to_string();
        assert!(err.contains("cycle"), "{err}");

        let mut robot = urdf_rs::read_from_string(TREE).unwrap();
        // c becomes the child of two joints.
        let mut extra = robot.joints[2].clone();
        extra.name = "j_c2".into();
        extra.parent.link = "b".into();
        robot.joints.push(extra);
        let err = prepare_model(&robot, "t.urdf").err().unwrap().to_string();
        assert!(
            err.contains("<joint name=\"j_c2\">") && err.contains("tree"),
            "{err}"
        );

        let mut robot = urdf_rs::read_from_string(TREE).unwrap();
        robot.links[2].collision[0].geometry = urdf_rs::Geometry::Sphere { radius: -0.1 };
        let err = prepare_model(&robot, "t.urdf").err().unwrap().to_string();
        assert!(err.contains("<link name=\"b\"> <collision>"), "{err}");

        let mut robot = urdf_rs::read_from_string(TREE).unwrap();
        robot.joints[0].axis.xyz = urdf_rs::Vec3([0.0, 0.0, 0.0]);
        let err = prepare_model(&robot, "t.urdf").err().unwrap().to_string();
        assert!(err.contains("<joint name=\"j_a\"> <axis>"), "{err}");
    }

    #[test]
    fn options_are_range_checked() {
        assert!(ReplayOptions::default().validate().is_ok());
        let cases = [
            ReplayOptions {
                physics_rate_hz: 0.0,
                ..Default::default()
            },
            ReplayOptions {
                stiffness: -1.0,
                ..Default::default()
            },
            ReplayOptions {
                stiffness: 0.0,
                damping: 0.0,
                ..Default::default()
            },
            ReplayOptions {
                settle_seconds: f64::INFINITY,
                ..Default::default()
            },
            ReplayOptions {
                limit_tolerance: f64::NAN,
                ..Default::default()
            },
            ReplayOptions {
                solver_iterations: 0,
                ..Default::default()
            },
        ];
        for options in cases {
            assert!(
                matches!(options.validate(), Err(PhysicsError::InvalidOption { .. })),
                "{options:?}"
            );
        }
    }

    #[test]
    fn events_close_when_not_extended() {
        let mut open = HashMap::new();
        let event = |step| OpenEvent {
            start: 0.1,
            end: 0.2,
            amount: 0.5,
            limit: 1.0,
            last_step: step,
        };
        open.insert(1usize, event(7));
        open.insert(2usize, event(8));
        let mut closed = Vec::new();
        close_events(&mut open, 8, 0, |k, e| closed.push((k, e.last_step)));
        assert_eq!(closed, vec![(1, 7)]);
        assert!(open.contains_key(&2) && open.len() == 1);
        // With a gap of 3 steps, an event last extended at step 8 stays open through step 11.
        close_events(&mut open, 11, 3, |k, e| closed.push((k, e.last_step)));
        assert_eq!(closed.len(), 1);
        close_events(&mut open, 12, 3, |k, e| closed.push((k, e.last_step)));
        assert_eq!(closed, vec![(1, 7), (2, 8)]);
    }

    #[test]
    fn public_types_are_send_and_sync() {
        fn check<T: Send + Sync>() {}
        check::<ReplayOptions>();
        check::<Trajectory>();
        check::<ReplayReport>();
        check::<PhysicsError>();
    }
}
