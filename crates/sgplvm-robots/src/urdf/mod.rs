//! URDF loading: validation with precise messages, normalisation of real-world quirks, parsing
//! with urdf-rs and building of the kinematic tree ([`Robot`]).
//!
//! Loading goes in three steps:
//! 1. the XML is read into an element tree with positions (roxmltree) and every element the
//!    kinematics or a physics engine uses is checked (numbers, attribute counts, joint types,
//!    required links); a problem is reported with the file, the LINE, the element and what was
//!    expected;
//! 2. what the file breaks of the URDF specification where its meaning is clear is repaired as
//!    ROS's parser reads it, and every repair is kept with its lines ([`UrdfRepair`],
//!    [`Robot::repairs`]): a `<material>` without a name, a `<texture>` without a file, a
//!    `<limit>` without `velocity` or `effort`, `velocity="0"` on a joint that can move (read as
//!    no limit given), a `<limit>` whose lower is above its upper (read the other way round,
//!    as InMoov's head roll means it), an `<axis>` without `xyz`, a repeat of an element ROS
//!    reads once (the first kept), a shape of size zero and an `<inertial>` beyond any robot's
//!    (left out); what the specification defaults but urdf-rs 0.9
//!    insists on is filled in silently. The repaired text (every line where it was) is parsed by
//!    urdf-rs, so that the same [`urdf_rs::Robot`] can be handed to rapier's URDF loader;
//! 3. the joints are assembled into a tree: unknown links, a link with two parents, cycles and
//!    several roots are errors.
//!
//! Quirks that load: joints without `<origin>`, origins without `rpy` or `xyz`, numbers such as
//! `0.` or `1.6E-4`, a floating root joint (held at its origin: the base is fixed),
//! `<gazebo>`, `<sensor>`, `<transmission>` and other foreign blocks (ignored), revolute joints
//! whose lower and upper limits are equal (kept in the configuration with that one value allowed,
//! never part of an arm: [`JointInfo::can_move`]),
//! mesh files that do not exist (meshes are never opened).
//!
//! `mod.rs` holds the robot model and its queries (joint order, limits, forward kinematics);
//! `parse.rs` loads a text: the depth guard, the XML parser, then the three steps — `check.rs`
//! (1, and the pose convention and the size limits), `repair.rs` and urdf-rs (2), `tree.rs`
//! (3). `meshes.rs` finds the mesh files a URDF names ([`MeshSearch`]: relative paths,
//! `file://` and `package://` URIs) for the physics replay and the scene files.

mod check;
mod identity;
mod meshes;
mod parse;
mod repair;
mod tree;

pub use check::{
    pose_from_xyz_rpy, MAX_GYRATION_M, MAX_INERTIA, MAX_LENGTH_M, MAX_MASS_KG, MIN_MASS_KG,
};
pub use identity::{JointRecord, RobotIdentity, IDENTITY_TOLERANCE};
pub use meshes::{file_uri, MeshMiss, MeshSearch, ANCESTOR_LEVELS, PACKAGE_SEARCH_DEPTH};
pub use parse::MAX_DEPTH;
pub use repair::UrdfRepair;

use std::collections::HashMap;
use std::path::Path;

use nalgebra::{Isometry3, Translation3, Unit, UnitQuaternion, Vector3};

use crate::error::{RobotError, RobotResult};
use parse::parse;

/// The kind of a URDF joint, as far as kinematics is concerned.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum JointKind {
    /// Rotation about the axis, within limits.
    Revolute,
    /// Rotation about the axis without limits.
    Continuous,
    /// Translation along the axis, within limits.
    Prismatic,
    /// Rigid connection.
    Fixed,
    /// A free 6-DoF joint; held at its origin (the robot's base is fixed in this crate).
    Floating,
    /// A planar 3-DoF joint; held at its origin.
    Planar,
}

impl JointKind {
    /// Whether the joint contributes one coordinate to the configuration vector `q`.
    pub fn is_movable(self) -> bool {
        matches!(
            self,
            JointKind::Revolute | JointKind::Continuous | JointKind::Prismatic
        )
    }

    fn parse(s: &str) -> Option<JointKind> {
        Some(match s {
            "revolute" => JointKind::Revolute,
            "continuous" => JointKind::Continuous,
            "prismatic" => JointKind::Prismatic,
            "fixed" => JointKind::Fixed,
            "floating" => JointKind::Floating,
            "planar" => JointKind::Planar,
            _ => return None,
        })
    }
}

/// One joint of a [`Robot`], in the form the kinematics uses.
#[derive(Debug, Clone, PartialEq)]
pub struct JointInfo {
    /// The joint's name in the URDF.
    pub name: String,
    /// Its type.
    pub kind: JointKind,
    /// Index of the parent link in [`Robot::link_names`].
    pub parent: usize,
    /// Index of the child link in [`Robot::link_names`].
    pub child: usize,
    /// Pose of the joint frame in the parent link frame (`<origin>`).
    pub origin: Isometry3<f64>,
    /// Unit axis in the joint frame (`<axis>`, default x).
    pub axis: Unit<Vector3<f64>>,
    /// `(lower, upper)`; `(-inf, inf)` for continuous joints, `(0, 0)` for fixed ones.
    pub limits: (f64, f64),
    /// Velocity limit (`<limit velocity>`), 0 when absent.
    pub velocity: f64,
    /// Effort limit (`<limit effort>`), 0 when absent.
    pub effort: f64,
    /// Position of this joint in the configuration vector, for movable joints.
    pub q_index: Option<usize>,
}

impl JointInfo {
    /// Whether the joint can move: movable by its type, and not a revolute or prismatic joint
    /// whose lower and upper limits are equal (one value allowed, as Toyota's HSR's
    /// `wrist_ft_sensor_frame_joint`: a sensor frame's joint, never commanded).
    pub fn can_move(&self) -> bool {
        self.kind.is_movable()
            && !(self.kind != JointKind::Continuous && self.limits.0 == self.limits.1)
    }

    /// The joint's local transform (origin then motion) for coordinate `q`.
    pub fn transform(&self, q: f64) -> Isometry3<f64> {
        match self.kind {
            JointKind::Revolute | JointKind::Continuous => {
                self.origin * UnitQuaternion::from_axis_angle(&self.axis, q)
            }
            JointKind::Prismatic => self.origin * Translation3::from(self.axis.into_inner() * q),
            _ => self.origin,
        }
    }
}

/// A parsed URDF: links, joints and the kinematic tree they form.
///
/// The configuration vector `q` holds one value per movable joint (revolute, continuous,
/// prismatic) in the order of [`Robot::joint_names`]: the order of the joints in the file.
/// The built-in models are written left arm then right arm, shoulder to wrist.
#[derive(Debug, Clone)]
pub struct Robot {
    pub(crate) name: String,
    pub(crate) source: String,
    pub(crate) links: Vec<String>,
    pub(crate) link_index: HashMap<String, usize>,
    pub(crate) joints: Vec<JointInfo>,
    /// For each link, the joint whose child it is (None for the root).
    pub(crate) parent_joint: Vec<Option<usize>>,
    pub(crate) root: usize,
    /// Joint indices of the movable joints, in q order.
    pub(crate) movable: Vec<usize>,
    pub(crate) urdf: urdf_rs::Robot,
    /// What the file breaks of the URDF specification and loading repaired.
    pub(crate) repairs: Vec<UrdfRepair>,
}

impl Robot {
    /// Loads a URDF file. Errors name the file.
    pub fn from_urdf_file(path: &Path) -> RobotResult<Robot> {
        let file = path.display().to_string();
        let xml = std::fs::read_to_string(path).map_err(|source| RobotError::Io {
            file: file.clone(),
            source,
        })?;
        Robot::from_urdf_str(&xml, &file)
    }

    /// Parses URDF text; `source` is the file name used in error messages.
    pub fn from_urdf_str(xml: &str, source: &str) -> RobotResult<Robot> {
        parse(xml, source)
    }

    /// What the file breaks of the URDF specification where its meaning is clear, and what
    /// loading made of it (as ROS's parser reads it), each with the lines it was found at.
    pub fn repairs(&self) -> &[UrdfRepair] {
        &self.repairs
    }

    /// The robot's name (`<robot name>`).
    pub fn name(&self) -> &str {
        &self.name
    }

    /// The file name (or `builtin:<name>`) the robot was loaded from.
    pub fn source(&self) -> &str {
        &self.source
    }

    /// Names of the movable joints, in configuration order.
    pub fn joint_names(&self) -> Vec<String> {
        self.movable
            .iter()
            .map(|&j| self.joints[j].name.clone())
            .collect()
    }

    /// `(lower, upper)` of each movable joint, in configuration order.
    pub fn joint_limits(&self) -> Vec<(f64, f64)> {
        self.movable
            .iter()
            .map(|&j| self.joints[j].limits)
            .collect()
    }

    /// Velocity limit of each movable joint (0 when the file gives none), in configuration order.
    pub fn velocity_limits(&self) -> Vec<f64> {
        self.movable
            .iter()
            .map(|&j| self.joints[j].velocity)
            .collect()
    }

    /// Number of movable joints (length of `q`).
    pub fn dof(&self) -> usize {
        self.movable.len()
    }

    /// Position of a movable joint in the configuration vector.
    pub fn joint_index(&self, name: &str) -> Option<usize> {
        self.movable
            .iter()
            .position(|&j| self.joints[j].name == name)
    }

    /// Names of all links, in file order.
    pub fn link_names(&self) -> Vec<String> {
        self.links.clone()
    }

    /// The root link (the one link that is no joint's child).
    pub fn root_link(&self) -> &str {
        &self.links[self.root]
    }

    /// Every joint (movable or not), in file order.
    pub fn joints(&self) -> &[JointInfo] {
        &self.joints
    }

    /// The description as urdf-rs parsed it (normalised), e.g. for `rapier3d_urdf`.
    pub fn urdf(&self) -> &urdf_rs::Robot {
        &self.urdf
    }

    /// The configuration closest to all-zeros that respects the joint limits.
    pub fn neutral_configuration(&self) -> Vec<f64> {
        self.joint_limits()
            .iter()
            .map(|&(lo, hi)| 0.0_f64.clamp(lo, hi))
            .collect()
    }

    pub(crate) fn link_id(&self, link: &str) -> RobotResult<usize> {
        self.link_index
            .get(link)
            .copied()
            .ok_or_else(|| RobotError::NoSuchLink {
                robot: self.name.clone(),
                link: link.to_string(),
            })
    }

    /// Joints from the root down to `link` (root-most first).
    pub(crate) fn path_to(&self, link: usize) -> Vec<usize> {
        let mut path = Vec::new();
        let mut cur = link;
        while let Some(j) = self.parent_joint[cur] {
            path.push(j);
            cur = self.joints[j].parent;
        }
        path.reverse();
        path
    }

    /// Pose of `link` in the root frame for configuration `q` (in [`Robot::joint_names`] order).
    pub fn forward_kinematics(&self, q: &[f64], link: &str) -> RobotResult<Isometry3<f64>> {
        self.check_q(q, "forward_kinematics")?;
        let id = self.link_id(link)?;
        Ok(self.pose_of(q, id))
    }

    /// Poses of `link` for many configurations, `qs` row-major `n × dof`.
    pub fn forward_kinematics_batch(
        &self,
        qs: &[f64],
        link: &str,
    ) -> RobotResult<Vec<Isometry3<f64>>> {
        let dof = self.dof();
        if dof == 0 || !qs.len().is_multiple_of(dof) {
            return Err(RobotError::WrongDof {
                what: format!(
                    "forward_kinematics_batch (a multiple of {dof} values, robot \"{}\")",
                    self.name
                ),
                expected: dof,
                got: qs.len(),
            });
        }
        let id = self.link_id(link)?;
        Ok(qs.chunks_exact(dof).map(|q| self.pose_of(q, id)).collect())
    }

    /// Poses of every link in the root frame, in [`Robot::link_names`] order.
    pub fn all_link_poses(&self, q: &[f64]) -> RobotResult<Vec<Isometry3<f64>>> {
        self.check_q(q, "all_link_poses")?;
        Ok((0..self.links.len()).map(|l| self.pose_of(q, l)).collect())
    }

    fn pose_of(&self, q: &[f64], link: usize) -> Isometry3<f64> {
        let mut pose = Isometry3::identity();
        for j in self.path_to(link) {
            let joint = &self.joints[j];
            let v = joint.q_index.map_or(0.0, |i| q[i]);
            pose *= joint.transform(v);
        }
        pose
    }

    pub(crate) fn check_q(&self, q: &[f64], what: &str) -> RobotResult<()> {
        if q.len() != self.dof() {
            return Err(RobotError::WrongDof {
                what: format!("{what} (robot \"{}\")", self.name),
                expected: self.dof(),
                got: q.len(),
            });
        }
        Ok(())
    }
}
