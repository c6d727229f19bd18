//! The robotic half of sgplvm: URDF bodies, kinematics, MCAP demonstrations and the
//! demonstration generator. Knows nothing of statistics.

#![deny(clippy::unwrap_used)]

pub mod anatomy;
pub mod capture;
pub mod dataset;
pub mod joint_state;

pub mod error;
pub mod files;
pub mod kinematics;
pub mod limits;
pub mod models;
pub mod names;
pub mod panics;
pub mod physics;
pub mod retarget;
pub mod safety;
pub mod scene;
pub mod series;
pub mod urdf;

pub use anatomy::{Anatomy, AnatomyError, AnatomySpec};
pub use error::{RobotError, RobotResult};
pub use kinematics::{Chain, IkOptions, IkSolution, IkTarget};
pub use models::{Arm, Side};
pub use physics::{replay, replay_urdf, PhysicsError, ReplayOptions, ReplayReport, Trajectory};
pub use urdf::{JointInfo, JointKind, Robot};
pub mod generator;
