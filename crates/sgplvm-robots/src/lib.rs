//! The robotic half of sgplvm: URDF bodies, kinematics, MCAP demonstrations and the
//! demonstration generator. Knows nothing of statistics.

pub mod joint_state;
pub mod dataset;
