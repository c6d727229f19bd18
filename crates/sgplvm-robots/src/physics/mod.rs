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
//! Collision shapes are the URDF's boxes, cylinders, capsules and spheres, and the convex
//! hulls of its collision meshes where [`ReplayOptions::meshes`] finds them; a mesh that
//! cannot be found or read is listed in [`ReplayReport::unchecked_meshes`], and
//! [`ReplayReport::self_collision_summary`] says what was not checked.
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
//!
//! # Stages
//! A replay runs in four stages, one file each: [`ReplayOptions`] are range-checked
//! (`options`) and the [`Trajectory`] validated (`trajectory`); the URDF is checked and
//! prepared for a fixed base (`model`, its collision meshes made convex hulls by `hulls`) and
//! loaded into rapier with one motor per movable joint (`build`); the control loop steps the physics (`control`); and what it measured becomes
//! the [`ReplayReport`] (`report`). Every failure is a [`PhysicsError`] (`error`).

mod build;
mod control;
mod error;
mod hulls;
mod model;
mod options;
mod parts_cache;
mod report;
mod trajectory;

use rapier3d_urdf::urdf_rs;

pub use error::PhysicsError;
pub use hulls::{
    decompose_all, mesh_shapes, MeshProblem, MeshShapes, UncheckedMesh, MAX_MESH_BYTES,
};
pub use options::ReplayOptions;
pub use report::{
    Collision, Divergence, JointTracking, LimitViolation, ReferenceJump, ReplayReport,
    JUMP_WINDOW_SECONDS,
};
pub use trajectory::Trajectory;

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
    if let Some((name, value)) = options
        .held
        .iter()
        .find(|(name, _)| trajectory.joint_names.contains(name))
    {
        return Err(PhysicsError::InvalidOption {
            field: "held",
            value: format!("(\"{name}\", {value})"),
            expected: "joints the trajectory has no column for (a held joint is not commanded)",
        });
    }
    // A joint with one value allowed cannot move: where the trajectory does not command it, it
    // is held there as any held joint (no column needed).
    let mut held = options.held.clone();
    for (name, value) in model::one_valued_joints(robot) {
        if !trajectory.joint_names.contains(&name) && !held.iter().any(|(h, _)| *h == name) {
            held.push((name, value));
        }
    }
    let model = model::prepare_model(robot, source, &options.meshes, &held)?;
    // rapier asserts a few invariants of its own; anything we did not foresee becomes an
    // error value instead of tearing down the caller.
    match crate::panics::catch(|| control::simulate(&model, source, trajectory, options)) {
        Ok(result) => result,
        Err(message) => Err(PhysicsError::Engine {
            file: source.to_string(),
            message: crate::panics::one_line(&message),
        }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn public_types_are_send_and_sync() {
        fn check<T: Send + Sync>() {}
        check::<ReplayOptions>();
        check::<Trajectory>();
        check::<ReplayReport>();
        check::<PhysicsError>();
    }
}
