//! A robot is more than its URDF: which joints are its arms, which are held still, the body
//! frame its motions are described in, how far each arm reaches and the posture it rests in.
//! [`Anatomy`] holds all of that for one robot, so that no other module knows a maker's link
//! names. Every command that takes a URDF builds one.
//!
//! Most robots have two arms; a single-arm robot (a mobile manipulator, an arm on a table) has
//! one, driven by the person's arm of its side (the right unless its names or the user say
//! otherwise).
//!
//! Where it comes from, in order ([`Found`]):
//! 1. the user: [`AnatomySpec::left`] and [`AnatomySpec::right`] (`--arm left=FROM:TO`), or a description file beside the
//!    URDF (`ROBOT.anatomy.json`, [`AnatomySpec::read`]), which a lab writes once;
//! 2. sgplvm's own convention (links `left_shoulder`, `left_hand`, `right_shoulder`,
//!    `right_hand`: the shipped robots);
//! 3. the URDF's joint names (`left`/`l_`/`_L` … with arm words), else its structure: two serial
//!    chains of revolute joints branching from one link (`discover.rs`).
//!
//! Then, at the hold posture (every joint outside the arms at its hold value, [`AnatomySpec::hold`],
//! default 0 within its limits), from the kinematics alone (`geometry.rs`):
//! - the **shoulder point** of each arm: where its first joints' axes meet (or the point nearest
//!   to them), in the torso link's frame (the links where the two arms branch);
//! - the **body frame** (REP-103: x forward, y left, z up): left from the right shoulder to the
//!   left one, up the root link's z (robots are drawn z up) made square to it, forward = left ×
//!   up; [`AnatomySpec::up`] and [`AnatomySpec::forward`] override;
//! - the **reach**: the largest shoulder-to-hand distance within the joint limits (the
//!   straightened arm), never the zero pose's;
//! - the **neutral posture**: arms hanging slightly forward (the generator's neutral key pose),
//!   found by IK within the limits, or given.
//!
//! An unusable description (a link that does not exist, an arm that is not a chain below its
//! first link, arms sharing movable joints, a hold value outside the limits, a file that
//! contradicts the URDF) is an [`AnatomyError`] naming the file and the link or joint.

mod arm_points;
mod commands;
mod discover;
mod file;
mod geometry;
mod landmarks;
mod mount;
mod summary;
pub mod words;

#[cfg(test)]
mod tests;

use std::collections::BTreeMap;
use std::fmt;
use std::path::{Path, PathBuf};

use nalgebra::{Isometry3, Rotation3, UnitQuaternion, Vector3};
use serde::Serialize;

use crate::kinematics::collision::CollisionModel;
use crate::kinematics::frames::Ancestry;
use crate::kinematics::{ApartProofs, Chain};
use crate::models::Side;
use crate::physics::{mesh_shapes, MeshShapes};

/// The shortest upper arm or forearm an arm may have on its bone line, millimetres: shorter,
/// the bone's direction is undefined ([`AnatomyError::NoBone`]).
pub const MIN_BONE_MM: f64 = 10.0;
use crate::urdf::MeshSearch;
use crate::urdf::Robot;
use crate::RobotError;

pub use commands::CommandColumns;
pub use file::{description_path, AnatomyFile, ANATOMY_FILE_VERSION};
pub use landmarks::ArmLandmarks;
pub use mount::{Mount, MountReason, HANG_MISS_DEG, TABLE_ROLL_DEG};
pub use summary::{AnatomyReport, ArmReport};

/// An arm named by the user: the link it hangs from and its hand link.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, serde::Deserialize)]
pub struct ArmSpec {
    /// The link the arm's first joint hangs from (e.g. the torso link).
    pub from: String,
    /// The hand (or tool) link.
    pub to: String,
}

impl ArmSpec {
    /// Parses `FROM:TO`.
    pub fn parse(text: &str) -> Result<ArmSpec, String> {
        match text.split_once(':') {
            Some((from, to)) if !from.trim().is_empty() && !to.trim().is_empty() => Ok(ArmSpec {
                from: from.trim().to_string(),
                to: to.trim().to_string(),
            }),
            _ => Err(format!(
                "`{text}`: expected FROM_LINK:TO_LINK (the link the arm hangs from and its hand link)"
            )),
        }
    }
}

/// Which joints a robot's commands name (`--command-joints arms|all|LIST`).
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub enum CommandJoints {
    /// The arm joints (the default).
    #[default]
    Arms,
    /// Every movable joint of the URDF, held ones at their hold values.
    All,
    /// These joints, in this order (arm joints and held joints).
    List(Vec<String>),
}

impl CommandJoints {
    /// Parses `arms`, `all` or a comma-separated list of joint names.
    pub fn parse(text: &str) -> CommandJoints {
        match text.trim() {
            "arms" => CommandJoints::Arms,
            "all" => CommandJoints::All,
            list => CommandJoints::List(
                list.split(',')
                    .map(|s| s.trim().to_string())
                    .filter(|s| !s.is_empty())
                    .collect(),
            ),
        }
    }

    /// `arms`, `all` or the names joined by commas.
    pub fn text(&self) -> String {
        match self {
            CommandJoints::Arms => "arms".into(),
            CommandJoints::All => "all".into(),
            CommandJoints::List(l) => l.join(","),
        }
    }
}

/// What a user says about a robot: everything optional; what is not said is found.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct AnatomySpec {
    /// The left and right arm, when named.
    pub left: Option<ArmSpec>,
    /// The right arm, when named.
    pub right: Option<ArmSpec>,
    /// Hold values of joints outside the arms (radians or metres); the rest hold at 0 within
    /// their limits.
    pub hold: BTreeMap<String, f64>,
    /// The body's up direction in the torso link's frame (default: the root link's z).
    pub up: Option<Vector3<f64>>,
    /// The body's forward direction in the torso link's frame (default: left × up).
    pub forward: Option<Vector3<f64>>,
    /// The neutral posture's arm joint values (default: found by IK).
    pub neutral: BTreeMap<String, f64>,
    /// Degrees the person's arm is turned outward about the forward axis before the robot
    /// takes it ([`Mount`]; default: 0 where the arms hang, [`TABLE_ROLL_DEG`] where one
    /// cannot).
    pub mount_roll_deg: Option<f64>,
    /// Which joints commands name.
    pub command_joints: CommandJoints,
    /// The file this spec was read from, for messages (`None`: the command line or code).
    pub source: Option<PathBuf>,
}

impl AnatomySpec {
    /// Whether the user said anything at all.
    pub fn is_empty(&self) -> bool {
        *self == AnatomySpec::default()
    }

    /// The arm of `side`, when named.
    pub fn arm(&self, side: Side) -> Option<&ArmSpec> {
        match side {
            Side::Left => self.left.as_ref(),
            Side::Right => self.right.as_ref(),
        }
    }

    /// Sets `side`'s arm from `SIDE=FROM:TO` (the `--arm` flag).
    pub fn set_arm(&mut self, text: &str) -> Result<(), String> {
        let (side, arm) = text.split_once('=').ok_or_else(|| {
            format!("--arm {text}: expected left=FROM_LINK:TO_LINK or right=FROM_LINK:TO_LINK")
        })?;
        let arm = ArmSpec::parse(arm).map_err(|e| format!("--arm {e}"))?;
        match side.trim() {
            "left" => self.left = Some(arm),
            "right" => self.right = Some(arm),
            other => return Err(format!("--arm {text}: `{other}`; expected left or right")),
        }
        Ok(())
    }

    /// Adds `NAME=VALUE` to the hold values (the `--hold` flag).
    pub fn set_hold(&mut self, text: &str) -> Result<(), String> {
        let (name, value) = text
            .split_once('=')
            .ok_or_else(|| format!("--hold {text}: expected JOINT=VALUE"))?;
        let value: f64 = value
            .trim()
            .parse()
            .ok()
            .filter(|v: &f64| v.is_finite())
            .ok_or_else(|| format!("--hold {text}: `{value}` is not a finite number"))?;
        self.hold.insert(name.trim().to_string(), value);
        Ok(())
    }

    /// `spec` over `self`: what `spec` says wins, hold and neutral values are merged.
    pub fn overridden_by(mut self, spec: AnatomySpec) -> AnatomySpec {
        if spec.left.is_some() {
            self.left = spec.left;
        }
        if spec.right.is_some() {
            self.right = spec.right;
        }
        self.hold.extend(spec.hold);
        self.neutral.extend(spec.neutral);
        if spec.up.is_some() {
            self.up = spec.up;
        }
        if spec.forward.is_some() {
            self.forward = spec.forward;
        }
        if spec.mount_roll_deg.is_some() {
            self.mount_roll_deg = spec.mount_roll_deg;
        }
        if spec.command_joints != CommandJoints::Arms {
            self.command_joints = spec.command_joints;
        }
        self
    }
}

/// How the arms were found.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Found {
    /// Named by the user (on the command line or in code).
    Named,
    /// Named in a description file.
    File(String),
    /// sgplvm's link convention (`left_shoulder`, `left_hand`, …).
    Convention,
    /// The joints' names (left/right and arm words).
    Names,
    /// The tree's structure (two serial chains from one link, sides from the root's y axis; or
    /// one chain: a single arm).
    Structure,
}

impl fmt::Display for Found {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Found::Named => write!(f, "named by you (--arm)"),
            Found::File(p) => write!(f, "named in {p}"),
            Found::Convention => write!(
                f,
                "sgplvm's link convention (left_shoulder, left_hand, right_shoulder, right_hand)"
            ),
            Found::Names => write!(f, "found by their joint names"),
            Found::Structure => write!(
                f,
                "found by the tree's structure (serial chains of revolute joints: two from one link, left the one along +y of the root link; or a single arm)"
            ),
        }
    }
}

/// One arm of an [`Anatomy`].
#[derive(Debug, Clone)]
pub struct AnatomyArm {
    /// Left or right.
    pub side: Side,
    /// The arm's joints, from the link it hangs from to its hand link (poses in that link's
    /// frame).
    pub chain: Chain,
    /// Pose of the chain's base link in the torso link's frame, at the hold posture.
    pub base_in_torso: Isometry3<f64>,
    /// The shoulder point in the torso link's frame.
    pub shoulder: Vector3<f64>,
    /// How far off the shoulder point is from the arm's first joint axes (0 where they meet),
    /// metres.
    pub shoulder_spread_m: f64,
    /// How many of the chain's joints come before the shoulder (0: the shoulder point is fixed
    /// on the link the arm hangs from; TALOS-like arms turn the whole shoulder first).
    pub shoulder_after: usize,
    /// The shoulder point in the frame of chain joint `shoulder_after` (the chain's base frame
    /// when that is 0), so that it moves with the joints before it.
    pub shoulder_local: Vector3<f64>,
    /// The first chain joint of the wrist (the last joints whose axes meet); the chain's length
    /// where no joint follows the elbow (the wrist is then the hand point on the last link).
    pub wrist_after: usize,
    /// The wrist centre in the frame of chain joint `wrist_after` (before its motion), or in
    /// the tip link's frame where `wrist_after` is the chain's length.
    pub wrist_local: Vector3<f64>,
    /// The hand point in the tip link's frame: its origin, or, where the arm's last link
    /// carries the forearm beyond the last joint's axis (Poppy's, ROBOTIS' small humanoids),
    /// twice its centre of mass from there.
    pub hand_local: Vector3<f64>,
    /// The largest shoulder-to-hand distance within the joint limits, metres.
    pub reach: f64,
    /// The arm's joint values (chain order) of that straightened arm.
    pub straight: Vec<f64>,
    /// The shoulder-to-hand distance at the zero configuration (within the limits), metres.
    pub zero_pose_reach: f64,
    /// The neutral posture (chain order).
    pub neutral: Vec<f64>,
    /// The chain joint at the elbow: the one farthest from both the shoulder and the hand on
    /// the straightened arm.
    pub elbow: usize,
}

/// A robot with its arms, held joints, body frame, reach and neutral posture (module docs).
#[derive(Debug, Clone)]
pub struct Anatomy {
    robot: Robot,
    found: Found,
    /// Left then right; one on a single-arm robot.
    arms: Vec<AnatomyArm>,
    torso_link: String,
    /// Rotation from the body frame (x forward, y left, z up) to the torso link's frame.
    body_in_torso: UnitQuaternion<f64>,
    /// The torso link's pose in the root frame at the hold posture.
    torso_in_root: Isometry3<f64>,
    /// How the person's arm is turned before the robot takes it.
    mount: Mount,
    /// Every joint's value with the arms at their neutral posture and the rest held.
    hold: Vec<f64>,
    /// Indices (configuration order) of the joints outside the arms.
    held: Vec<usize>,
    /// Indices (configuration order) of the joints commands name.
    command: Vec<usize>,
    notes: Vec<String>,
    /// Where the URDF's meshes are found (beside it, then the ROS paths).
    meshes: MeshSearch,
    /// The meshes' hulls once read, shared by every collision model of this anatomy (and its
    /// clones): retargeting and its safety step, the live node's robots.
    hulls: HullCache,
    /// The pairs of collision shapes proven kept apart by the joint limits, shared likewise.
    proofs: ApartProofs,
}

/// A mesh (its URI and scale's bits) to its hull and triangles, or why there are none.
type HullMap = std::collections::HashMap<(String, [u64; 3]), Result<MeshShapes, String>>;

/// The hulls read so far, shared between clones.
#[derive(Clone, Default)]
pub(crate) struct HullCache(std::sync::Arc<std::sync::Mutex<HullMap>>);

impl std::fmt::Debug for HullCache {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let n = self.0.lock().map_or(0, |m| m.len());
        write!(f, "HullCache({n} meshes)")
    }
}

impl HullCache {
    /// The hull and triangles of mesh `file` at `scale`, read through `search` the first time.
    fn get(&self, search: &MeshSearch, file: &str, scale: [f64; 3]) -> Result<MeshShapes, String> {
        let key = (file.to_string(), scale.map(f64::to_bits));
        if let Some(found) = self.0.lock().ok().and_then(|m| m.get(&key).cloned()) {
            return found;
        }
        let hull = mesh_shapes(search, file, scale);
        if let Ok(mut m) = self.0.lock() {
            m.insert(key, hull.clone());
        }
        hull
    }
}

/// Why a robot's anatomy cannot be had.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum AnatomyError {
    /// The URDF itself is unusable.
    #[error(transparent)]
    Robot(#[from] RobotError),
    /// No arms could be told from the URDF.
    #[error("{file}: cannot tell the robot's arms: {why}; name them with --arm left=FROM_LINK:TO_LINK --arm right=FROM_LINK:TO_LINK (one of them alone for a single-arm robot; Python: arms={{\"left\": (FROM, TO), ...}}) or in {description}")]
    NoArms {
        /// The URDF.
        file: String,
        /// What was found instead.
        why: String,
        /// The description file a lab can write.
        description: String,
    },
    /// A link named for an arm does not exist.
    #[error("{file}: {what}: no link \"{link}\" in the URDF{hint}")]
    NoSuchLink {
        /// The URDF (or the description file).
        file: String,
        /// Which setting named it (`--arm left`, `arms.left` …).
        what: String,
        /// The name.
        link: String,
        /// Close names, if any.
        hint: String,
    },
    /// A named arm's hand link is not below its first link.
    #[error("{file}: {what}: link \"{to}\" is not below link \"{from}\" in the tree, so they bound no chain (\"{to}\" hangs from {path})")]
    NotAChain {
        /// The URDF.
        file: String,
        /// Which setting named it.
        what: String,
        /// The first link.
        from: String,
        /// The hand link.
        to: String,
        /// The links above `to`, root first.
        path: String,
    },
    /// An arm has too few joints to place its hand.
    #[error("{file}: the {side} arm {from} → {to} has {count} movable joint(s); at least 3 are needed to place a hand")]
    TooFewJoints {
        /// The URDF.
        file: String,
        /// Which arm.
        side: &'static str,
        /// Its first link.
        from: String,
        /// Its hand link.
        to: String,
        /// How many movable joints it has.
        count: usize,
    },
    /// An arm's upper arm or forearm has next to no length on its bone line: not an arm (a
    /// gripper's fingers or a chain of sensor frames taken for one); its directions would be
    /// undefined.
    #[error("{file}: the {side} arm {from} → {to} is no arm: its {bone} is {length_mm:.1} mm long at the neutral posture, where an arm's bones are at least {MIN_BONE_MM} mm; name the arm with --arm {side}=FROM_LINK:TO_LINK")]
    NoBone {
        /// The URDF.
        file: String,
        /// Which arm.
        side: &'static str,
        /// Its first link.
        from: String,
        /// Its hand link.
        to: String,
        /// Which bone, with its ends.
        bone: &'static str,
        /// Its length, millimetres.
        length_mm: f64,
    },
    /// Both arms move the same joints (e.g. both start at the pelvis, below a waist).
    #[error("{file}: the left arm ({} → {}) and the right arm ({} → {}) share the movable joint(s) {}; start both arms below them (e.g. --arm left={}:{}): shared joints are held, not moved by either arm", .arms.lfrom, .arms.lto, .arms.rfrom, .arms.rto, .arms.joints, .arms.below, .arms.lto)]
    SharedJoints {
        /// The URDF.
        file: String,
        /// The two arms and what they share.
        arms: Box<SharedArms>,
    },
    /// A joint named in a setting is unknown or of the wrong kind.
    #[error("{file}: {what}: {message}")]
    Joint {
        /// The URDF or description file.
        file: String,
        /// The setting (`--hold waist_yaw_joint`, `neutral.left_elbow` …).
        what: String,
        /// What is wrong and what was expected.
        message: String,
    },
    /// The geometry cannot give a body frame (shoulders at one point, axes given along each
    /// other …).
    #[error("{file}: body frame: {message}")]
    Frame {
        /// The URDF.
        file: String,
        /// What is wrong.
        message: String,
    },
    /// A description file cannot be read or is malformed.
    #[error("{file}: {message}")]
    File {
        /// The description file.
        file: String,
        /// What is wrong.
        message: String,
    },
}

/// Two named arms that share movable joints ([`AnatomyError::SharedJoints`]).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SharedArms {
    /// Left arm's first link.
    pub lfrom: String,
    /// Left arm's hand.
    pub lto: String,
    /// Right arm's first link.
    pub rfrom: String,
    /// Right arm's hand.
    pub rto: String,
    /// The shared joints.
    pub joints: String,
    /// The link below the shared joints.
    pub below: String,
}

/// Result alias of this module.
pub type AnatomyResult<T> = Result<T, AnatomyError>;

impl Anatomy {
    /// The anatomy of `robot` as `spec` says, found where it does not.
    pub fn new(robot: Robot, spec: &AnatomySpec) -> AnatomyResult<Anatomy> {
        let found_arms = discover::arms(&robot, spec)?;
        geometry::build(robot, found_arms, spec)
    }

    /// [`Anatomy::new`] with nothing said: found from the URDF alone.
    pub fn of(robot: Robot) -> AnatomyResult<Anatomy> {
        Anatomy::new(robot, &AnatomySpec::default())
    }

    /// A built-in robot's anatomy (the convention's arms; nothing held).
    pub fn builtin(name: &str) -> AnatomyResult<Anatomy> {
        Anatomy::of(Robot::builtin(name)?)
    }

    /// Loads `urdf` with the description file beside it (`ROBOT.anatomy.json`, if there is
    /// one) and `spec` over it.
    pub fn load(urdf: &Path, spec: &AnatomySpec) -> AnatomyResult<Anatomy> {
        let robot = Robot::from_urdf_file(urdf)?;
        let beside = description_path(urdf);
        let spec = if beside.is_file() {
            AnatomySpec::read(&beside)?.overridden_by(spec.clone())
        } else {
            spec.clone()
        };
        Anatomy::new(robot, &spec)
    }

    /// The URDF model.
    pub fn robot(&self) -> &Robot {
        &self.robot
    }

    /// How the arms were found.
    pub fn found(&self) -> &Found {
        &self.found
    }

    /// The arms: left then right, or the one arm of a single-arm robot (its side is the
    /// person's arm that drives it).
    pub fn arms(&self) -> &[AnatomyArm] {
        &self.arms
    }

    /// The arm of `side`, `None` on a single-arm robot's other side.
    pub fn arm(&self, side: Side) -> Option<&AnatomyArm> {
        self.arms.iter().find(|a| a.side == side)
    }

    /// The sides of the arms, in [`Anatomy::arms`]' order.
    pub fn sides(&self) -> Vec<Side> {
        self.arms.iter().map(|a| a.side).collect()
    }

    /// The link both arms branch from (a single arm's own base link), whose frame the
    /// shoulders and the body frame are given in.
    pub fn torso_link(&self) -> &str {
        &self.torso_link
    }

    /// Rotation from the body frame (x forward, y left, z up) to the torso link's frame.
    pub fn body_in_torso(&self) -> UnitQuaternion<f64> {
        self.body_in_torso
    }

    /// The torso link's pose in the root link's frame at the hold posture.
    pub fn torso_in_root(&self) -> Isometry3<f64> {
        self.torso_in_root
    }

    /// How the person's arm is turned before this robot takes it: not where the arms hang,
    /// outward about the forward axis where an arm stands on a table ([`Mount`]).
    pub fn mount(&self) -> Mount {
        self.mount
    }

    /// The whole configuration (URDF order) with the arms at their neutral posture and every
    /// other joint at its hold value.
    pub fn hold_configuration(&self) -> &[f64] {
        &self.hold
    }

    /// Names of the joints outside the arms, with their hold values.
    pub fn held_joints(&self) -> Vec<(String, f64)> {
        let names = self.robot.joint_names();
        self.held
            .iter()
            .map(|&i| (names[i].clone(), self.hold[i]))
            .collect()
    }

    /// The arm joints: left arm then right (or the one arm), shoulder to hand.
    pub fn arm_joint_names(&self) -> Vec<String> {
        self.arms
            .iter()
            .flat_map(|a| a.chain.joint_names().iter().cloned())
            .collect()
    }

    /// The joints commands name, in order.
    pub fn command_joint_names(&self) -> Vec<String> {
        let names = self.robot.joint_names();
        self.command.iter().map(|&i| names[i].clone()).collect()
    }

    /// What was noticed on the way (a root frame that is not REP-103, a zero pose that is not
    /// the straightened arm …), one sentence each.
    pub fn notes(&self) -> &[String] {
        &self.notes
    }

    /// The whole configuration for values of some joints (`names`, `values`; the others at
    /// their hold configuration). Unknown names are an error naming them.
    pub fn configuration(&self, names: &[String], values: &[f64]) -> Result<Vec<f64>, String> {
        let mut q = self.hold.clone();
        for (n, &v) in names.iter().zip(values) {
            let i = self.robot.joint_index(n).ok_or_else(|| {
                format!(
                    "joint `{n}` is not a movable joint of robot `{}`",
                    self.robot.name()
                )
            })?;
            q[i] = v;
        }
        Ok(q)
    }

    /// The body frame's axes in the root frame at the hold posture: forward, left, up.
    pub fn body_axes_in_root(&self) -> [Vector3<f64>; 3] {
        let r = Rotation3::from(self.torso_in_root.rotation * self.body_in_torso);
        [0, 1, 2].map(|k| r.matrix().column(k).into_owned())
    }

    /// Where the robot's meshes are found.
    pub fn meshes(&self) -> &MeshSearch {
        &self.meshes
    }

    /// Finds the robot's meshes through `search` (e.g. with the `--package-path` folders).
    pub fn with_meshes(mut self, search: MeshSearch) -> Anatomy {
        self.meshes = search;
        self.hulls = HullCache::default();
        self.proofs = ApartProofs::default();
        self
    }

    /// The visual meshes of the robot's links that are not found where its URDF says (a
    /// viewer draws those links without them): each link's name and why, in file order.
    pub fn visual_meshes_not_found(&self) -> Vec<(String, String)> {
        let mut missing = Vec::new();
        for link in &self.robot.urdf().links {
            for visual in &link.visual {
                if let urdf_rs::Geometry::Mesh { filename, .. } = &visual.geometry {
                    if let Err(e) = self.meshes.resolve(filename) {
                        missing.push((link.name.clone(), e.to_string()));
                    }
                }
            }
        }
        missing
    }

    /// The robot's own collision shapes (meshes as convex hulls where found) and the pairs of
    /// them that can meet when the joints `moving` (configuration indices) move, judged at the
    /// hold posture (pairs nearer than `apart` metres there are the model's own closeness and
    /// left out).
    pub fn collision_model(&self, moving: &[usize], apart: f64) -> CollisionModel {
        let ancestry = Ancestry::of(&self.robot);
        let joints: Vec<usize> = moving.iter().map(|&i| self.robot.movable[i]).collect();
        let search = &self.meshes;
        let loader = |file: &str, scale: [f64; 3]| self.hulls.get(search, file, scale);
        CollisionModel::new(
            &self.robot,
            &ancestry,
            &joints,
            &self.hold,
            apart,
            Some(&loader),
            Some(&self.proofs),
        )
    }

    /// The description file that says what this anatomy is (to write beside the URDF).
    pub fn to_file(&self) -> AnatomyFile {
        AnatomyFile::of(self)
    }
}
