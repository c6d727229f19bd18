//! The second stage of a replay: the prepared URDF loaded into rapier. Every branch leaving
//! a fixed link becomes a multibody of its own (reduced coordinates, root fixed to the
//! world); every movable joint is matched to its trajectory column and gets a motor; the
//! robot starts at rest in the first frame; the self-collision filter skips neighbours and
//! ignored pairs.

use std::collections::{HashMap, HashSet};
use std::path::Path;

use rapier3d::dynamics::{
    JointAxis, MassProperties, MultibodyIndex, MultibodyJointHandle, RigidBodyBuilder,
    RigidBodyHandle, RigidBodyType,
};
use rapier3d::geometry::{ColliderBuilder, SolverFlags};
use rapier3d::math::{Real, Vector};
use rapier3d::pipeline::{ActiveHooks, PairFilterContext, PhysicsHooks, PhysicsWorld};
use rapier3d_urdf::urdf_rs;
use rapier3d_urdf::{
    UrdfCollider, UrdfJointHandle, UrdfLoaderOptions, UrdfMultibodyOptions, UrdfRobot,
};

use super::model::{element_of_joint, PreparedModel};
use super::{PhysicsError, ReplayOptions, Trajectory};
use crate::kinematics::adjacency::{own_closeness, DESIGNED_CLEARANCE_M};

/// Density (kg/m³, about that of water) given to the collision shapes of a link that declares
/// no mass, so that every moving link has an inertia.
const DEFAULT_DENSITY: Real = 1000.0;
/// Mass (kg) of a moving link that declares neither a mass nor a collision shape.
const PLACEHOLDER_MASS: Real = 1e-3;
/// How many massless links the warning names.
const MASSLESS_NAMED: usize = 4;
/// Principal inertia (kg·m²) of such a placeholder link.
const PLACEHOLDER_INERTIA: Real = 1e-6;
/// Standard gravity, m/s².
const GRAVITY: Real = 9.81;

/// How a movable joint's coordinate is driven.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum Dof {
    /// Revolute or continuous: rapier's `AngX`, coordinate 3.
    Angular,
    /// Prismatic: rapier's `LinX`, coordinate 0.
    Linear,
}

impl Dof {
    /// The multibody joint axis the motor acts on.
    pub(super) fn axis(self) -> JointAxis {
        match self {
            Dof::Angular => JointAxis::AngX,
            Dof::Linear => JointAxis::LinX,
        }
    }

    /// The index of the joint's coordinate in rapier's joint coordinates.
    pub(super) fn coord(self) -> usize {
        match self {
            Dof::Angular => 3,
            Dof::Linear => 0,
        }
    }
}

/// A movable joint in the simulation.
pub(super) struct DrivenJoint {
    /// The joint's URDF name.
    pub(super) name: String,
    handle: MultibodyJointHandle,
    body: RigidBodyHandle,
    dof: Dof,
    /// (lower, upper), or None for continuous joints.
    pub(super) limits: Option<(f64, f64)>,
    /// The URDF velocity limit, when positive.
    pub(super) velocity_limit: Option<f64>,
    /// Trajectory column, or None when held still.
    pub(super) column: Option<usize>,
    /// Held position for joints without a column.
    pub(super) hold: f64,
}

impl DrivenJoint {
    /// The simulated position (NaN if rapier lost the joint, caught as divergence).
    pub(super) fn position(&self, world: &PhysicsWorld) -> f64 {
        world
            .multibody_joints
            .get(self.handle)
            .and_then(|(mb, link_id)| mb.link(link_id))
            .map_or(f64::NAN, |link| {
                link.joint().coords()[self.dof.coord()] as f64
            })
    }

    /// Whether the joint slides (prismatic: metres) rather than turns (radians).
    pub(super) fn prismatic(&self) -> bool {
        self.dof == Dof::Linear
    }

    /// The simulated velocity.
    pub(super) fn velocity(&self, world: &PhysicsWorld) -> f64 {
        world
            .multibody_joints
            .get(self.handle)
            .and_then(|(mb, link_id)| mb.link(link_id).map(|link| mb.joint_velocity(link)))
            .and_then(|v| v.get(0).copied())
            .map_or(0.0, |v| v as f64)
    }

    /// Sets the motor's target position and velocity and its gains.
    pub(super) fn set_motor(
        &self,
        world: &mut PhysicsWorld,
        position: Real,
        velocity: Real,
        stiffness: Real,
        damping: Real,
    ) {
        if let Some((mb, link_id)) = world.multibody_joints.get_mut(self.handle) {
            if let Some(link) = mb.link_mut(link_id) {
                link.joint
                    .data
                    .set_motor(self.dof.axis(), position, velocity, stiffness, damping);
            }
        }
    }
}

/// Contact filter: neighbours and ignored pairs produce no contacts; the others are detected,
/// and solved when contact response is on.
pub(super) struct SelfCollisionFilter {
    /// Number of URDF links.
    pub(super) n_links: usize,
    /// Link pairs never checked, as a dense symmetric `n_links × n_links` matrix.
    pub(super) skip: Vec<bool>,
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

/// The simulation, ready to step.
pub(super) struct Scene {
    /// rapier's world holding the robot's multibodies.
    pub(super) world: PhysicsWorld,
    /// The movable joints in report order: trajectory columns first, then held joints.
    pub(super) driven: Vec<DrivenJoint>,
    /// The contact filter passed to every step.
    pub(super) hooks: SelfCollisionFilter,
    /// Every driven joint's position in the first frame (its held position without a column).
    pub(super) initial: Vec<f64>,
    /// The model's warnings and those of loading it.
    pub(super) warnings: Vec<String>,
    /// Link pairs (URDF indices) that are the model's own closeness at the rest posture (every
    /// joint at its hold value): touching there, or within a centimetre with at most two
    /// joints between; never checked, by the rule retargeting's collision model keeps
    /// (`own_closeness`).
    pub(super) overlapping_at_rest: Vec<(usize, usize)>,
}

impl Scene {
    /// Loads `model` into rapier for replaying `trajectory`.
    pub(super) fn build(
        model: &PreparedModel,
        file: &str,
        trajectory: &Trajectory,
        options: &ReplayOptions,
    ) -> Result<Scene, PhysicsError> {
        let robot = &model.robot;
        let mut warnings = model.warnings.clone();
        let (urdf_robot, sources) = load_links(model, file, &mut warnings);
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
        let mut driven = driven_joints(robot, &handles.joints, &sources, file)?;
        assign_columns(&mut driven, trajectory, options, file)?;
        if !options.enforce_limits {
            release_limits(&mut world, &driven);
        }
        // Report order: trajectory columns first, then held joints.
        driven.sort_by_key(|d| d.column.unwrap_or(usize::MAX));
        let mut hooks = collision_filter(model, options)?;
        let rest: Vec<f64> = driven.iter().map(|d| d.hold).collect();
        place(&mut world, &driven, &rest, options.armature);
        let overlapping_at_rest = rest_overlaps(model, &world, &hooks, options.contact_distance);
        for &(a, b) in &overlapping_at_rest {
            hooks.skip[a * hooks.n_links + b] = true;
            hooks.skip[b * hooks.n_links + a] = true;
        }
        let first = trajectory.row(0).unwrap_or(&[]);
        let initial: Vec<f64> = driven
            .iter()
            .map(|d| d.column.map_or(d.hold, |c| first[c]))
            .collect();
        place(&mut world, &driven, &initial, options.armature);
        if !model.has_shape.iter().any(|&s| s) {
            warnings.push(format!(
                "{file}: no link has a collision shape; self-collisions cannot be detected"
            ));
        }
        Ok(Scene {
            world,
            driven,
            hooks,
            initial,
            warnings,
            overlapping_at_rest,
        })
    }
}

/// Every collider's template: massless (the URDF gives the masses) and filtered by
/// [`SelfCollisionFilter`].
fn collider_blueprint() -> ColliderBuilder {
    ColliderBuilder::default()
        .density(0.0)
        .active_hooks(ActiveHooks::FILTER_CONTACT_PAIRS)
}

/// rapier's copy of the URDF links and joints, with the meshes' hulls attached to their links,
/// masses completed and each branch leaving a fixed link rooted on its own twin of that link;
/// plus the URDF joint of each rapier joint.
fn load_links(
    model: &PreparedModel,
    file: &str,
    warnings: &mut Vec<String>,
) -> (UrdfRobot, Vec<usize>) {
    let robot = &model.robot;
    let loader_options = UrdfLoaderOptions {
        make_roots_fixed: true,
        // rapier3d-urdf 0.36 drops an empty root link and fixes its children where they are
        // declared, without its fixed joints' origins: the two arms of a dual-arm station
        // (Franka's FR3 pair: `base` → `left_base`, `right_base`, 0.2 m apart and rolled) were
        // both built at the origin, inside each other. Empty links stay (a fixed one couples
        // nothing; a moving one gets a placeholder mass below).
        squeeze_empty_fixed_links: false,
        enable_joint_collisions: false,
        collider_blueprint: collider_blueprint(),
        rigid_body_blueprint: RigidBodyBuilder::dynamic().can_sleep(false),
        ..UrdfLoaderOptions::default()
    };
    let mut urdf_robot = UrdfRobot::from_robot(robot, loader_options, Path::new("."));
    // Links holding a collision mesh are never squeezed away (its placeholder box keeps them
    // non-empty), and a link's body sits at the URDF link frame: a hull's pose in its link is
    // its collision origin.
    for hull in &model.hulls {
        if let Some(link) = urdf_robot
            .links
            .iter_mut()
            .find(|l| l.urdf_link_index == hull.link)
        {
            let mut builder = collider_blueprint().position(hull.pose);
            builder.shape = hull.shape.clone();
            link.colliders.push(UrdfCollider {
                collider: builder.build(),
                visual: None,
            });
        }
    }
    let mut massless = Vec::new();
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
                massless.push(source.name.clone());
                for collider in &mut link.colliders {
                    collider.collider.set_density(DEFAULT_DENSITY);
                }
            }
        }
    }
    // One line for them all: a URDF without inertias (SDA10F's 16 links) said it 16 times.
    if !massless.is_empty() {
        warnings.push(format!(
            "{file}: no mass declared on {} ({}); their collision shapes were given a density of {DEFAULT_DENSITY} kg/m³",
            crate::names::count(massless.len(), "link"),
            crate::names::few(&massless, MASSLESS_NAMED),
        ));
    }
    split_branches(&mut urdf_robot);
    // Which URDF joint each rapier joint came from (the squeeze of empty links may merge).
    let sources: Vec<usize> = urdf_robot
        .joints
        .iter()
        .map(|j| j.source_urdf_joint_index())
        .collect();
    (urdf_robot, sources)
}

/// Every branch leaving a fixed link gets its own shapeless copy of that link as root, so
/// that each arm is a multibody of its own. The dynamics are the same (a fixed link
/// couples nothing) and rapier's multibody cost grows with the square of the degrees of
/// freedom, so two 7-joint arms step about twice as fast as one 14-joint tree.
fn split_branches(urdf_robot: &mut UrdfRobot) {
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
}

/// The movable joints, in URDF order, not yet matched to columns.
fn driven_joints(
    robot: &urdf_rs::Robot,
    handles: &[UrdfJointHandle<Option<MultibodyJointHandle>>],
    sources: &[usize],
    file: &str,
) -> Result<Vec<DrivenJoint>, PhysicsError> {
    let mut driven: Vec<DrivenJoint> = Vec::new();
    for (handle, &source) in handles.iter().zip(sources) {
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
    Ok(driven)
}

/// Matches trajectory columns to joints by name: every column must name a movable joint, and
/// every movable joint needs a column unless [`ReplayOptions::allow_missing_joints`].
fn assign_columns(
    driven: &mut [DrivenJoint],
    trajectory: &Trajectory,
    options: &ReplayOptions,
    file: &str,
) -> Result<(), PhysicsError> {
    let by_name: HashMap<String, usize> = driven
        .iter()
        .enumerate()
        .map(|(i, d)| (d.name.clone(), i))
        .collect();
    let unknown: Vec<String> = trajectory
        .joint_names
        .iter()
        .filter(|name| !by_name.contains_key(name.as_str()))
        .cloned()
        .collect();
    if let Some(first) = unknown.first() {
        return Err(PhysicsError::UnknownJoint {
            file: file.to_string(),
            joint: first.clone(),
            known: driven.iter().map(|d| d.name.clone()).collect(),
            columns: unknown,
        });
    }
    for (column, name) in trajectory.joint_names.iter().enumerate() {
        if let Some(&i) = by_name.get(name.as_str()) {
            driven[i].column = Some(column);
        }
    }
    let missing: Vec<String> = driven
        .iter()
        .filter(|d| d.column.is_none())
        .map(|d| d.name.clone())
        .collect();
    if let (Some(first), false) = (missing.first(), options.allow_missing_joints) {
        return Err(PhysicsError::MissingJoint {
            file: file.to_string(),
            joint: first.clone(),
            movable: driven.len(),
            joints: missing,
        });
    }
    Ok(())
}

/// Lets the simulated joints pass their URDF limits (see [`ReplayOptions::enforce_limits`]).
fn release_limits(world: &mut PhysicsWorld, driven: &[DrivenJoint]) {
    for d in driven {
        if let Some((mb, link_id)) = world.multibody_joints.get_mut(d.handle) {
            if let Some(link) = mb.link_mut(link_id) {
                link.joint.data.limit_axes.remove(d.dof.axis().into());
            }
        }
    }
}

/// Link pairs the filter checks that are the model's own closeness as the world stands (at
/// rest): within `distance` (touching or penetrating, for 0), or near with few joints between
/// (`own_closeness`, retargeting's rule); each pair once, in URDF order.
fn rest_overlaps(
    model: &PreparedModel,
    world: &PhysicsWorld,
    hooks: &SelfCollisionFilter,
    distance: f64,
) -> Vec<(usize, usize)> {
    let movable = |j: usize| model.robot.joints[j].joint_type != urdf_rs::JointType::Fixed;
    let within = distance.max(DESIGNED_CLEARANCE_M);
    let n = hooks.n_links;
    let placed: Vec<(usize, rapier3d::math::Pose, &dyn rapier3d::geometry::Shape)> = world
        .colliders
        .iter()
        .filter_map(|(_, c)| {
            let link = c.user_data as usize;
            let body = world.bodies.get(c.parent()?)?;
            let pose = *body.position() * *c.position_wrt_parent()?;
            (link < n).then_some((link, pose, c.shape()))
        })
        .collect();
    let mut found: Vec<(usize, usize)> = Vec::new();
    for (i, (a, pa, sa)) in placed.iter().enumerate() {
        for (b, pb, sb) in &placed[i + 1..] {
            let key = ((*a).min(*b), (*a).max(*b));
            if a == b || hooks.skip[a * n + b] || found.contains(&key) {
                continue;
            }
            let contact = rapier3d::parry::query::contact(pa, *sa, pb, *sb, within as Real);
            let own = |d: f64| d <= distance || own_closeness(&model.parent_of, movable, key, d);
            if matches!(contact, Ok(Some(c)) if own(f64::from(c.dist))) {
                found.push(key);
            }
        }
    }
    found.sort_unstable();
    found
}

/// Sets the armature and puts every multibody at rest with each driven joint at `values`
/// (report order).
fn place(world: &mut PhysicsWorld, driven: &[DrivenJoint], values: &[f64], armature: f64) {
    // (multibody, link id) of every driven joint.
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
        mb.armature_mut().fill(armature as Real);
        let mut displacement: Vec<Real> = vec![0.0; mb.ndofs()];
        // Displacements add to the coordinates: from where each joint is to its value.
        for ((d, place), q) in driven.iter().zip(&placement).zip(values) {
            let Some((_, link_id)) = place.filter(|(m, _)| *m == index) else {
                continue;
            };
            if let Some(link) = mb.link(link_id) {
                let now = link.joint().coords()[d.dof.coord()];
                if let Some(slot) = displacement.get_mut(link.assembly_id()) {
                    *slot = *q as Real - now;
                }
            }
        }
        mb.apply_displacements(&displacement);
        mb.forward_kinematics(&world.bodies, false);
        mb.update_rigid_bodies(&mut world.bodies, true);
    }
}

/// The contact filter: the model's neighbours plus [`ReplayOptions::ignored_pairs`].
fn collision_filter(
    model: &PreparedModel,
    options: &ReplayOptions,
) -> Result<SelfCollisionFilter, PhysicsError> {
    let robot = &model.robot;
    let n_links = robot.links.len();
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
    Ok(SelfCollisionFilter {
        n_links,
        skip,
        response: options.contact_response,
    })
}
