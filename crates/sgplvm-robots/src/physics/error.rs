//! The errors of a replay: a value for every way the model, the trajectory, the options or
//! the engine can refuse, each naming the file, joint or frame at fault and what was expected.

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
    /// Trajectory columns name no movable joint of the model.
    #[error(
        "{} of the trajectory name no movable joint of {file}: {}; its {}: {}",
        crate::names::count(columns.len(), "column"),
        crate::names::few(columns, crate::names::SHOWN),
        crate::names::count(known.len(), "movable joint"),
        if known.is_empty() { "none".to_string() } else { crate::names::few(known, crate::names::SHOWN) }
    )]
    UnknownJoint {
        /// File name of the model.
        file: String,
        /// The first unknown column name.
        joint: String,
        /// Every unknown column name, in trajectory order (`joint` first).
        columns: Vec<String>,
        /// The model's movable joints.
        known: Vec<String>,
    },
    /// Movable joints of the model have no column in the trajectory.
    #[error(
        "{} of the {} of {file} {} no column in the trajectory: {} (expected one column per \
         movable joint; ReplayOptions::allow_missing_joints holds the others still)",
        joints.len(),
        crate::names::count(*movable, "movable joint"),
        if joints.len() == 1 { "has" } else { "have" },
        crate::names::few(joints, crate::names::SHOWN)
    )]
    MissingJoint {
        /// File name of the model.
        file: String,
        /// The first joint without a column.
        joint: String,
        /// Every joint without a column, in the model's order (`joint` first).
        joints: Vec<String>,
        /// Movable joints of the model.
        movable: usize,
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
