//! How a trajectory is replayed: [`ReplayOptions`], its defaults (the paper's setting) and the
//! range check that [`super::replay`] runs before anything is built.

use super::PhysicsError;
use crate::urdf::MeshSearch;

/// How a trajectory is replayed. `ReplayOptions::default()` gives the setting: 1 kHz
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
    /// Joints held still by their controllers, at these values (rad or m): welded there, as an
    /// ideal position controller keeps them — no dynamics of their own, no tracking, no limit
    /// checks; their links move rigidly with their parents, and links held rigid to each other
    /// are not checked against each other. A held joint has no trajectory column. `sgplvm
    /// simulate` holds every joint a URDF robot's anatomy holds (waist, legs, head, fingers) that
    /// the trajectory leaves out.
    pub held: Vec<(String, f64)>,
    /// Extra link pairs never checked for collision, in either order. Links that are
    /// neighbours in the kinematic tree are always skipped: a pair is skipped when every link
    /// on the tree path between them has no collision shape, or when that path holds at most
    /// one joint that is not fixed (links joined by fixed joints are one body, as in MoveIt's
    /// adjacent pairs); so are pairs that are the model's own closeness at rest
    /// ([`ReplayReport::overlapping_at_rest`](crate::physics::ReplayReport::overlapping_at_rest)).
    pub ignored_pairs: Vec<(String, String)>,
    /// Reflected rotor inertia added to every joint, kg·m² (default 1e-4). Keeps the dynamics
    /// well posed when a URDF gives a link no inertia about its joint axis.
    pub armature: f64,
    /// Solver iterations (rapier substeps) per physics step (default 2: with 1, the PR2's
    /// replay of a prediction ran away against its own hulls' contacts at 5.1 s — its shoulder
    /// lift at 35 rad/s — where 2 hold it, as contacts off or 4 kHz do; 2 cost 1.3–1.6× the
    /// time of 1 on the makers' robots, and changed tracking errors by < 1e-3 rad on the
    /// shipped ones).
    pub solver_iterations: usize,
    /// Refuse trajectories that would need more physics steps than this (default 10 000 000,
    /// about 2.8 h of motion at 1 kHz).
    pub max_steps: usize,
    /// Whether to return the simulated joint positions at the trajectory's frame times in
    /// [`ReplayReport::simulated`](super::ReplayReport::simulated) (default false).
    pub record_simulated: bool,
    /// Where the URDF's collision meshes are looked for; each one found becomes a convex hull,
    /// each one missing is listed in [`ReplayReport::unchecked_meshes`](super::ReplayReport::unchecked_meshes).
    /// The default search resolves absolute paths and `file://` URIs only: give it the URDF
    /// file's directory ([`MeshSearch::for_urdf_file`]) and package paths for the rest.
    pub meshes: MeshSearch,
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
            held: Vec::new(),
            ignored_pairs: Vec::new(),
            armature: 1e-4,
            solver_iterations: 2,
            max_steps: 10_000_000,
            record_simulated: false,
            meshes: MeshSearch::new(),
        }
    }
}

impl ReplayOptions {
    /// Checks every option's range; [`replay`](super::replay) calls it first.
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

#[cfg(test)]
mod tests {
    use super::*;

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
}
