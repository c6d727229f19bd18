//! The robotic half of sgplvm: bodies from URDF (the shipped robots, the human model, and any
//! maker's robot with its [`anatomy`]: arms, held joints, body frame, reach), kinematics and
//! differential IK ([`kinematics`]), retargeting a person's arm postures onto a robot
//! ([`retarget`]), the live safety step ([`safety`]), physics replay ([`physics`]), MCAP
//! demonstrations and scenes ([`dataset`], [`joint_state`], [`scene`]) and the demonstration
//! generator ([`generator`]). Knows nothing of statistics, nor of motion capture (the
//! `sgplvm-capture` crate turns captures into the human model's angles).

#![deny(clippy::unwrap_used)]

pub mod anatomy;
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
pub use urdf::{JointInfo, JointKind, JointRecord, Robot, RobotIdentity};
pub mod generator;
