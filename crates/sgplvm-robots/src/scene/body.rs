//! A body of a scene ([`SceneBody`]): its robot, where it stands, its joint-state topic, its
//! prefixed description; the checks of a scene's bodies before their channels are laid out
//! (unique names, known joints), and a body being encoded ([`BodyChannel`]: where its columns
//! go in its robot's configuration, its channels and frame names).

use std::path::PathBuf;

use nalgebra::{Isometry3, Translation3};

use super::SceneOptions;
use crate::joint_state::{JointStateError, Result};
use crate::urdf::{file_uri, MeshSearch, Robot};

/// One body of a scene: its kinematic model, where it stands, and the topic and joint order
/// of its joint states.
#[derive(Debug, Clone)]
pub struct SceneBody {
    /// Name of the body: the prefix of its frames (`<name>/<link>`) and of its description topic.
    pub name: String,
    /// The kinematic model.
    pub robot: Robot,
    /// Pose of the body's root link in [`WORLD_FRAME`](super::WORLD_FRAME).
    pub placement: Isometry3<f64>,
    /// Topic of its joint states, e.g. `/coman/joint_command`.
    pub joint_topic: String,
    /// Where its mesh files are found: each one found is written into the description as an
    /// absolute `file://` URI (which Foxglove desktop loads); the others, and all of them
    /// when `None` (the built-in bodies, which have no meshes), are left as the URDF gives them.
    pub meshes: Option<MeshSearch>,
    /// The configuration (the robot's joint order) of the joints its joint states do not name,
    /// e.g. a robot's waist and legs held still while its arms are commanded; `None`, or a
    /// configuration of another length: the robot's neutral configuration.
    pub rest: Option<Vec<f64>>,
}

impl SceneBody {
    /// A built-in body (see [`Robot::builtin`]) named after itself, its root link at
    /// `position` (metres, in [`WORLD_FRAME`](super::WORLD_FRAME)).
    pub fn builtin(name: &str, joint_topic: &str, position: [f64; 3]) -> Result<Self> {
        let robot = Robot::builtin(name).map_err(|e| JointStateError::InvalidInput {
            what: format!("body `{name}`"),
            detail: e.to_string(),
        })?;
        Ok(SceneBody {
            name: name.to_string(),
            robot,
            placement: Isometry3::from_parts(
                Translation3::new(position[0], position[1], position[2]),
                nalgebra::UnitQuaternion::identity(),
            ),
            joint_topic: joint_topic.to_string(),
            meshes: None,
            rest: None,
        })
    }

    /// Topic of the body's description: `/<name>/robot_description`.
    pub fn description_topic(&self) -> String {
        format!("/{}/robot_description", self.name)
    }

    /// The body's URDF with every link renamed `<name>/<link>` (joints keep their names) and
    /// every mesh [`SceneBody::meshes`] finds named by its absolute `file://` URI, as written
    /// on the description topic.
    pub fn prefixed_urdf(&self) -> Result<String> {
        let mut urdf = self.robot.urdf().clone();
        let p = |s: &mut String| *s = format!("{}/{s}", self.name);
        urdf.links.iter_mut().for_each(|l| p(&mut l.name));
        if let Some(search) = &self.meshes {
            for filename in mesh_filenames(&mut urdf) {
                if let Ok(uri) = search.resolve_file_uri(filename) {
                    *filename = uri;
                }
            }
        }
        for j in &mut urdf.joints {
            p(&mut j.parent.link);
            p(&mut j.child.link);
        }
        urdf_rs::write_to_string(&urdf).map_err(|e| JointStateError::InvalidInput {
            what: format!("body `{}`", self.name),
            detail: format!("cannot write its URDF: {e}"),
        })
    }

    /// Frame name of link `link` of this body.
    pub(super) fn frame(&self, link: usize) -> String {
        format!("{}/{}", self.name, self.robot.links[link])
    }

    /// Every mesh file of the body that [`SceneBody::meshes`] finds (visual and collision),
    /// each under the URI its URDF gives and under its `file://` URI, the names a viewer may
    /// ask for: the files a live view may serve. Empty without a search.
    pub fn mesh_files(&self) -> Vec<(String, PathBuf)> {
        let Some(search) = &self.meshes else {
            return Vec::new();
        };
        let mut urdf = self.robot.urdf().clone();
        let mut files: Vec<(String, PathBuf)> = Vec::new();
        for filename in mesh_filenames(&mut urdf) {
            if let Ok(path) = search.resolve(filename) {
                for uri in [filename.clone(), file_uri(&path)] {
                    if !files.iter().any(|(u, _)| *u == uri) {
                        files.push((uri, path.clone()));
                    }
                }
            }
        }
        files
    }
}

/// The `filename` of every `<mesh>` of `urdf`, visual and collision, in file order.
fn mesh_filenames(urdf: &mut urdf_rs::Robot) -> impl Iterator<Item = &mut String> {
    urdf.links.iter_mut().flat_map(|link| {
        let visual = link.visual.iter_mut().map(|v| &mut v.geometry);
        let collision = link.collision.iter_mut().map(|c| &mut c.geometry);
        visual.chain(collision).filter_map(|g| match g {
            urdf_rs::Geometry::Mesh { filename, .. } => Some(filename),
            _ => None,
        })
    })
}
/// A body with its joint names and, per name, the joint's index in its robot's configuration.
pub(super) type PreparedBody = (SceneBody, Vec<String>, Vec<Option<usize>>);

/// Checks the bodies of a scene (unique names without `/`; with TF, every joint a movable joint
/// of the body's robot) and finds each joint in its robot's configuration.
pub(super) fn prepare_bodies(
    bodies: Vec<(SceneBody, Vec<String>)>,
    options: &SceneOptions,
) -> Result<Vec<PreparedBody>> {
    let mut prepared: Vec<PreparedBody> = Vec::with_capacity(bodies.len());
    for (i, (body, names)) in bodies.into_iter().enumerate() {
        if prepared.iter().any(|b| b.0.name == body.name)
            || body.name.is_empty()
            || body.name.contains('/')
        {
            return Err(JointStateError::InvalidInput {
                what: format!("body {i} `{}`", body.name),
                detail: "expected a unique, non-empty body name without `/`".into(),
            });
        }
        let mut q_index = Vec::with_capacity(names.len());
        for n in &names {
            let qi = body.robot.joint_index(n);
            if qi.is_none() && options.tf {
                return Err(JointStateError::InvalidInput {
                    what: format!("topic `{}`", body.joint_topic),
                    detail: format!(
                        "joint `{n}` is not a movable joint of robot `{}` (expected one of {:?})",
                        body.robot.name(),
                        body.robot.joint_names()
                    ),
                });
            }
            q_index.push(qi);
        }
        prepared.push((body, names, q_index));
    }
    Ok(prepared)
}

/// A body being written: its model, where its columns go in the robot's configuration, its
/// channel and the scratch configuration.
pub(super) struct BodyChannel {
    pub(super) body: SceneBody,
    pub(super) names: Vec<String>,
    /// For each column of the joint states, its index in the robot's configuration (if any).
    pub(super) q_index: Vec<Option<usize>>,
    pub(super) q: Vec<f64>,
    pub(super) channel: u16,
    pub(super) description_channel: Option<u16>,
    /// Frame names of every link, `<body>/<link>`.
    pub(super) frames: Vec<String>,
}

impl BodyChannel {
    /// A body on its channels, at the robot's neutral configuration.
    pub(super) fn new(
        body: SceneBody,
        names: Vec<String>,
        q_index: Vec<Option<usize>>,
        channel: u16,
        description_channel: Option<u16>,
    ) -> BodyChannel {
        BodyChannel {
            q: {
                let neutral = body.robot.neutral_configuration();
                body.rest
                    .clone()
                    .filter(|rest| rest.len() == neutral.len())
                    .unwrap_or(neutral)
            },
            frames: (0..body.robot.links.len()).map(|l| body.frame(l)).collect(),
            body,
            names,
            q_index,
            channel,
            description_channel,
        }
    }
}
