//! The first stage of a replay: the URDF (as urdf-rs parsed it) checked for what the
//! simulator needs — one tree of uniquely named links, finite numbers, collision shapes, axes
//! and limits — and adjusted for a fixed-base replay (floating roots fixed, zero-range
//! revolute joints held, or made continuous where the trajectory commands them). Collision
//! meshes are taken out of the URDF and made convex hulls (`hulls`). It also decides which
//! link pairs are neighbours and never collision-checked.

use std::collections::HashMap;

use rapier3d_urdf::urdf_rs;

use super::hulls::{self, MeshCollision, MeshHull, UncheckedMesh};
use super::PhysicsError;
use crate::kinematics::adjacency::neighbour_matrix;
use crate::urdf::{MeshSearch, MAX_INERTIA, MAX_LENGTH_M, MAX_MASS_KG};

/// A checked, simulation-ready copy of the URDF.
pub(super) struct PreparedModel {
    /// The URDF with floating roots fixed, held joints welded and commanded zero-range revolute
    /// joints made continuous;
    /// every collision mesh replaced by a zero-size box (which rapier3d-urdf skips, and which
    /// keeps the link from being squeezed away as empty).
    pub(super) robot: urdf_rs::Robot,
    /// For each link: whether it carries a collision shape the replay will build (a
    /// primitive, or a mesh's hull).
    pub(super) has_shape: Vec<bool>,
    /// Link pairs (by URDF link index) never checked, as a dense symmetric matrix.
    pub(super) neighbours: Vec<bool>,
    /// For each link, its parent joint and parent link (URDF indices), `None` for a root.
    pub(super) parent_of: ParentOf,
    /// What was worked around (fixed floating joints ...).
    pub(super) warnings: Vec<String>,
    /// The collision meshes made convex hulls.
    pub(super) hulls: Vec<MeshHull>,
    /// The collision meshes left out, with why.
    pub(super) unchecked_meshes: Vec<UncheckedMesh>,
    /// Seconds spent finding, reading and hulling the meshes.
    pub(super) mesh_seconds: f64,
    /// The joints held still by their controllers (welded where they are held), in URDF order.
    pub(super) held: Vec<(String, f64)>,
    /// For each link: whether the nearest movable joint above it is a held one (a finger, the
    /// head, a torso lift): a part the trajectory does not command.
    pub(super) held_part: Vec<bool>,
}

/// `<joint name="...">`, as error messages name a joint.
pub(super) fn element_of_joint(joint: &urdf_rs::Joint) -> String {
    format!("<joint name=\"{}\">", joint.name)
}

fn element_of_link(link: &urdf_rs::Link) -> String {
    format!("<link name=\"{}\">", link.name)
}

/// Builds the [`PhysicsError::Model`] errors of one file.
struct ModelErr<'a> {
    file: &'a str,
}

impl ModelErr<'_> {
    fn at(&self, element: String, message: String) -> PhysicsError {
        PhysicsError::Model {
            file: self.file.to_string(),
            element,
            message,
        }
    }
}

/// Finite and within [`MAX_LENGTH_M`] in size (an offset, or angles).
fn finite3(v: &[f64; 3]) -> bool {
    v.iter().all(|x| x.abs() <= MAX_LENGTH_M)
}

/// For each link, its parent joint and parent link (URDF indices), `None` for a root.
pub(super) type ParentOf = Vec<Option<(usize, usize)>>;

/// Checks the URDF tree and numbers, fixes what a fixed-base replay needs fixed, welds the
/// joints `held` at their values (as a controller holding them would keep them) and makes the
/// collision meshes `meshes` finds convex hulls.
pub(super) fn prepare_model(
    robot: &urdf_rs::Robot,
    file: &str,
    meshes: &MeshSearch,
    held: &[(String, f64)],
) -> Result<PreparedModel, PhysicsError> {
    let err = ModelErr { file };
    let mut robot = robot.clone();
    let mut warnings = Vec::new();
    let link_index = index_links(&robot.links, &err)?;
    let mut mesh_collisions = Vec::new();
    let mut has_shape = vec![false; robot.links.len()];
    for (i, link) in robot.links.iter_mut().enumerate() {
        has_shape[i] = check_link(i, link, &err, &mut mesh_collisions)?;
    }
    let mut parent_of = vec![None; robot.links.len()];
    for (j, joint) in robot.joints.iter_mut().enumerate() {
        let element = element_of_joint(joint);
        let (parent, child) = joint_links(joint, &element, &link_index, &parent_of, &err)?;
        parent_of[child] = Some((j, parent));
        if !finite3(&joint.origin.xyz.0) || !finite3(&joint.origin.rpy.0) {
            return Err(err.at(element, "expected a finite <origin>".into()));
        }
        let is_held = held.iter().any(|(name, _)| *name == joint.name);
        check_joint_type(joint, element, &err, &mut warnings, is_held)?;
    }
    check_acyclic(&robot, &parent_of, &err)?;
    let welded = weld(&mut robot, held)?;
    let held_part = held_parts(&robot, &parent_of, &welded);
    let carried = carried_held_parts(&robot, &parent_of, &held_part);
    let loaded = hulls::load(&mesh_collisions, &robot.links, meshes, &carried);
    for hull in &loaded.hulls {
        has_shape[hull.link] = true;
    }
    let neighbours = neighbour_matrix(
        &parent_of,
        |j| robot.joints[j].joint_type != urdf_rs::JointType::Fixed,
        &has_shape,
    );
    let held = welded
        .iter()
        .map(|&(j, v)| (robot.joints[j].name.clone(), v))
        .collect();
    Ok(PreparedModel {
        robot,
        has_shape,
        neighbours,
        parent_of,
        warnings,
        hulls: loaded.hulls,
        unchecked_meshes: loaded.unchecked,
        mesh_seconds: loaded.seconds,
        held,
        held_part,
    })
}

/// The revolute and prismatic joints whose lower and upper limits are equal and finite (a
/// sensor frame's joint, as Toyota's HSR's `wrist_ft_sensor_frame_joint`), with that value.
pub(super) fn one_valued_joints(robot: &urdf_rs::Robot) -> Vec<(String, f64)> {
    robot
        .joints
        .iter()
        .filter(|j| {
            matches!(
                j.joint_type,
                urdf_rs::JointType::Revolute | urdf_rs::JointType::Prismatic
            ) && j.limit.lower == j.limit.upper
                && j.limit.lower.is_finite()
        })
        .map(|j| (j.name.clone(), j.limit.lower))
        .collect()
}

/// Makes every joint of `held` fixed at its value: its origin becomes the origin moved by the
/// joint's motion there. Returns the welded joints (URDF indices) and values; a name that is
/// no movable joint is an error.
fn weld(
    robot: &mut urdf_rs::Robot,
    held: &[(String, f64)],
) -> Result<Vec<(usize, f64)>, PhysicsError> {
    use nalgebra::{Translation3, Unit, UnitQuaternion, Vector3};
    let mut welded = Vec::new();
    for (name, value) in held {
        let found = robot.joints.iter().position(|j| {
            &j.name == name
                && matches!(
                    j.joint_type,
                    urdf_rs::JointType::Revolute
                        | urdf_rs::JointType::Continuous
                        | urdf_rs::JointType::Prismatic
                )
        });
        let (Some(j), true) = (found, value.is_finite()) else {
            return Err(PhysicsError::InvalidOption {
                field: "held",
                value: format!("(\"{name}\", {value})"),
                expected: "movable joints of the URDF at finite values",
            });
        };
        let joint = &mut robot.joints[j];
        let origin = crate::urdf::pose_from_xyz_rpy(joint.origin.xyz.0, joint.origin.rpy.0);
        let axis =
            Unit::try_new(Vector3::from(joint.axis.xyz.0), 1e-12).unwrap_or_else(Vector3::x_axis);
        let moved = match joint.joint_type {
            urdf_rs::JointType::Prismatic => {
                origin * Translation3::from(axis.into_inner() * *value)
            }
            _ => origin * UnitQuaternion::from_axis_angle(&axis, *value),
        };
        let (roll, pitch, yaw) = moved.rotation.euler_angles();
        let t = moved.translation.vector;
        joint.origin.xyz.0 = [t.x, t.y, t.z];
        joint.origin.rpy.0 = [roll, pitch, yaw];
        joint.joint_type = urdf_rs::JointType::Fixed;
        welded.push((j, *value));
    }
    welded.sort_by_key(|&(j, _)| j);
    Ok(welded)
}

/// For each link, whether it is a part held still that a moving joint further up carries (a
/// hand's fingers on a moving arm; not a torso on a held lift, nor a held head or leg).
fn carried_held_parts(robot: &urdf_rs::Robot, parent_of: &ParentOf, held: &[bool]) -> Vec<bool> {
    (0..robot.links.len())
        .map(|link| {
            let mut at = link;
            while let Some((j, parent)) = parent_of[at] {
                if robot.joints[j].joint_type != urdf_rs::JointType::Fixed {
                    return held[link];
                }
                at = parent;
            }
            false
        })
        .collect()
}

/// For each link, whether the nearest joint above it that moves, or was welded, was welded.
fn held_parts(robot: &urdf_rs::Robot, parent_of: &ParentOf, welded: &[(usize, f64)]) -> Vec<bool> {
    (0..robot.links.len())
        .map(|mut link| {
            while let Some((j, parent)) = parent_of[link] {
                if welded.iter().any(|&(w, _)| w == j) {
                    return true;
                }
                if robot.joints[j].joint_type != urdf_rs::JointType::Fixed {
                    return false;
                }
                link = parent;
            }
            false
        })
        .collect()
}

/// Link name → URDF index; at least one link, names unique.
fn index_links(
    links: &[urdf_rs::Link],
    err: &ModelErr<'_>,
) -> Result<HashMap<String, usize>, PhysicsError> {
    if links.is_empty() {
        return Err(err.at("<robot>".into(), "no <link>; expected at least one".into()));
    }
    let mut link_index = HashMap::new();
    for (i, link) in links.iter().enumerate() {
        if link_index.insert(link.name.clone(), i).is_some() {
            return Err(err.at(
                element_of_link(link),
                "declared twice; expected unique link names".into(),
            ));
        }
    }
    Ok(link_index)
}

/// Geometry and inertia sanity (parry builds shapes from whatever numbers it gets); collision
/// meshes are moved to `meshes` (link `index`), a zero-size box left in their place. Returns
/// whether the link keeps a primitive collision shape.
fn check_link(
    index: usize,
    link: &mut urdf_rs::Link,
    err: &ModelErr<'_>,
    meshes: &mut Vec<MeshCollision>,
) -> Result<bool, PhysicsError> {
    let element = element_of_link(link);
    let inertial = &link.inertial;
    let i = &inertial.inertia;
    let values = [i.ixx, i.ixy, i.ixz, i.iyy, i.iyz, i.izz];
    let valid = inertial.mass.value.is_finite()
        && (0.0..=MAX_MASS_KG).contains(&inertial.mass.value)
        && values.iter().all(|v| v.abs() <= MAX_INERTIA)
        && finite3(&inertial.origin.xyz.0)
        && finite3(&inertial.origin.rpy.0);
    if !valid {
        return Err(err.at(
            element + " <inertial>",
            format!("expected a mass in 0..={MAX_MASS_KG} kg, inertia components of at most {MAX_INERTIA} kg·m² in size and an origin within {MAX_LENGTH_M} m"),
        ));
    }
    let mut primitive = false;
    for collision in &mut link.collision {
        let ok_pose = finite3(&collision.origin.xyz.0) && finite3(&collision.origin.rpy.0);
        let ok_size = |v: f64| v > 0.0 && v <= MAX_LENGTH_M;
        let ok_shape = match &collision.geometry {
            urdf_rs::Geometry::Box { size } => size.0.iter().all(|v| ok_size(*v)),
            urdf_rs::Geometry::Cylinder { radius, length }
            | urdf_rs::Geometry::Capsule { radius, length } => ok_size(*radius) && ok_size(*length),
            urdf_rs::Geometry::Sphere { radius } => ok_size(*radius),
            // The scale is checked with the mesh: a bad one leaves the mesh unchecked.
            urdf_rs::Geometry::Mesh { .. } => true,
        };
        if !(ok_pose && ok_shape) {
            return Err(err.at(
                element + " <collision>",
                format!("expected shape sizes in (0, {MAX_LENGTH_M}] m and an origin within {MAX_LENGTH_M} m"),
            ));
        }
        let placeholder = urdf_rs::Geometry::Box {
            size: urdf_rs::Vec3([0.0; 3]),
        };
        match std::mem::replace(&mut collision.geometry, placeholder) {
            urdf_rs::Geometry::Mesh { filename, scale } => meshes.push(MeshCollision {
                link: index,
                origin: collision.origin.clone(),
                filename,
                scale: scale.map_or([1.0; 3], |s| s.0),
            }),
            geometry => {
                collision.geometry = geometry;
                primitive = true;
            }
        }
    }
    Ok(primitive)
}

/// The (parent, child) link indices of `joint`: both declared, the child of no other joint.
fn joint_links(
    joint: &urdf_rs::Joint,
    element: &str,
    link_index: &HashMap<String, usize>,
    parent_of: &ParentOf,
    err: &ModelErr<'_>,
) -> Result<(usize, usize), PhysicsError> {
    let lookup = |role: &str, name: &str| {
        link_index.get(name).copied().ok_or_else(|| {
            err.at(
                element.to_string(),
                format!("unknown {role} link \"{name}\"; expected a declared <link>"),
            )
        })
    };
    let parent = lookup("parent", &joint.parent.link)?;
    let child = lookup("child", &joint.child.link)?;
    if parent_of[child].is_some() {
        return Err(err.at(
            element.to_string(),
            format!(
                "link \"{}\" is the child of a second joint; a URDF must be a tree",
                joint.child.link
            ),
        ));
    }
    Ok((parent, child))
}

/// What each joint type needs: floating and planar joints are fixed (the base is fixed to
/// the world), spherical ones refused, movable ones need a finite non-zero axis and (unless
/// continuous) finite ordered limits; a revolute joint with both limits 0 that is not held
/// (the trajectory commands it) becomes continuous.
fn check_joint_type(
    joint: &mut urdf_rs::Joint,
    element: String,
    err: &ModelErr<'_>,
    warnings: &mut Vec<String>,
    is_held: bool,
) -> Result<(), PhysicsError> {
    let file = err.file;
    match joint.joint_type {
        urdf_rs::JointType::Floating | urdf_rs::JointType::Planar => {
            warnings.push(format!(
                "{file}: {element}: {:?} joint fixed (the replay fixes the robot's base to the world)",
                joint.joint_type
            ));
            joint.joint_type = urdf_rs::JointType::Fixed;
        }
        urdf_rs::JointType::Spherical => {
            return Err(err.at(
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
                return Err(err.at(
                    element + " <axis>",
                    format!("{axis:?}; expected a finite, non-zero axis"),
                ));
            }
            let (lower, upper) = (joint.limit.lower, joint.limit.upper);
            if joint.joint_type != urdf_rs::JointType::Continuous {
                if !(lower.is_finite() && upper.is_finite() && lower <= upper) {
                    return Err(err.at(
                        element + " <limit>",
                        format!("lower = {lower}, upper = {upper}; expected finite limits with lower <= upper"),
                    ));
                }
                if joint.joint_type == urdf_rs::JointType::Revolute
                    && lower == 0.0
                    && upper == 0.0
                    && !is_held
                {
                    warnings.push(format!(
                        "{file}: {element}: revolute joint with both limits 0, commanded by the trajectory: treated as unlimited"
                    ));
                    joint.joint_type = urdf_rs::JointType::Continuous;
                }
            }
        }
        urdf_rs::JointType::Fixed => {}
    }
    Ok(())
}

/// No cycles: walking up from any link must end at a root within `n_links` steps.
fn check_acyclic(
    robot: &urdf_rs::Robot,
    parent_of: &ParentOf,
    err: &ModelErr<'_>,
) -> Result<(), PhysicsError> {
    let n_links = robot.links.len();
    for start in 0..n_links {
        let mut link = start;
        for _ in 0..=n_links {
            match parent_of[link] {
                Some((_, parent)) => link = parent,
                None => break,
            }
        }
        if parent_of[link].is_some() {
            return Err(err.at(
                element_of_link(&robot.links[start]),
                "lies on a cycle of joints; a URDF must be a tree".into(),
            ));
        }
    }
    Ok(())
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
        let model = prepare_model(&robot, "tree.urdf", &MeshSearch::new(), &[]).unwrap();
        let names = model.robot.links.iter().map(|l| l.name.clone()).collect();
        (names, model.neighbours)
    }

    #[test]
    fn neighbours_are_one_moving_joint_apart_or_joined_through_shapeless_links() {
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
        // One moving joint between two bodies of links joined by fixed joints (MoveIt's
        // adjacency): base + c and d + e.
        assert!(near("base", "d") && near("base", "e") && near("c", "e"));
        // Across the base, two moving joints and shapes between: not neighbours.
        assert!(!near("b", "c") && !near("b", "d") && !near("b", "e"));
        // Symmetric.
        for i in 0..n {
            for j in 0..n {
                assert_eq!(m[i * n + j], m[j * n + i]);
            }
        }
    }

    #[test]
    fn only_parts_held_on_a_moving_joint_are_carried() {
        // Held: j_b (b, on the moving j_a: a finger on an arm) and j_d (d and e, on the fixed
        // base: a torso on a held lift); j_a moves.
        let robot = urdf_rs::read_from_string(TREE).unwrap();
        let held = [("j_b".to_string(), 0.0), ("j_d".to_string(), 0.0)];
        let model = prepare_model(&robot, "tree.urdf", &MeshSearch::new(), &held).unwrap();
        let mut parent_of = vec![None; model.robot.links.len()];
        let index = |name: &str| {
            model
                .robot
                .links
                .iter()
                .position(|l| l.name == name)
                .unwrap()
        };
        for (j, joint) in model.robot.joints.iter().enumerate() {
            parent_of[index(&joint.child.link)] = Some((j, index(&joint.parent.link)));
        }
        let carried = carried_held_parts(&model.robot, &parent_of, &model.held_part);
        let is = |name: &str| carried[index(name)];
        assert!(is("b"));
        assert!(!is("base") && !is("a") && !is("c") && !is("d") && !is("e"));
        assert!(model.held_part[index("d")] && model.held_part[index("e")]);
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
        let model = prepare_model(&robot, "tree.urdf", &MeshSearch::new(), &[]).unwrap();
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
        let err = prepare_model(&robot, "t.urdf", &MeshSearch::new(), &[])
            .err()
            .unwrap()
            .to_string();
        assert!(err.contains("cycle"), "{err}");

        let mut robot = urdf_rs::read_from_string(TREE).unwrap();
        // c becomes the child of two joints.
        let mut extra = robot.joints[2].clone();
        extra.name = "j_c2".into();
        extra.parent.link = "b".into();
        robot.joints.push(extra);
        let err = prepare_model(&robot, "t.urdf", &MeshSearch::new(), &[])
            .err()
            .unwrap()
            .to_string();
        assert!(
            err.contains("<joint name=\"j_c2\">") && err.contains("tree"),
            "{err}"
        );

        let mut robot = urdf_rs::read_from_string(TREE).unwrap();
        robot.links[2].collision[0].geometry = urdf_rs::Geometry::Sphere { radius: -0.1 };
        let err = prepare_model(&robot, "t.urdf", &MeshSearch::new(), &[])
            .err()
            .unwrap()
            .to_string();
        assert!(err.contains("<link name=\"b\"> <collision>"), "{err}");

        let mut robot = urdf_rs::read_from_string(TREE).unwrap();
        robot.joints[0].axis.xyz = urdf_rs::Vec3([0.0, 0.0, 0.0]);
        let err = prepare_model(&robot, "t.urdf", &MeshSearch::new(), &[])
            .err()
            .unwrap()
            .to_string();
        assert!(err.contains("<joint name=\"j_a\"> <axis>"), "{err}");
    }
}
