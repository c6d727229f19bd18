//! A scene's TF tree: the frame every body is placed in, the TF topics, and the transforms
//! published on them — once, each body's placement in the world and its fixed joints
//! (`/tf_static`); at every frame, every movable joint at the frame's values (`/tf`).

use super::body::BodyChannel;
use super::msgs::Transform;

/// The frame every body is placed in.
pub const WORLD_FRAME: &str = "world";

/// Topic of the static transforms.
pub const TF_STATIC_TOPIC: &str = "/tf_static";

/// Topic of the moving transforms.
pub const TF_TOPIC: &str = "/tf";

/// The fixed transforms of `bodies`, for `/tf_static`: each body's root link placed in
/// [`WORLD_FRAME`], then each of its fixed joints.
pub(super) fn static_transforms(bodies: &[BodyChannel]) -> Vec<Transform<'_>> {
    let mut transforms = Vec::new();
    for body in bodies {
        let robot = &body.body.robot;
        transforms.push(Transform {
            parent: WORLD_FRAME,
            child: &body.frames[robot.root],
            pose: body.body.placement,
        });
        for joint in robot.joints() {
            if joint.q_index.is_none() {
                transforms.push(Transform {
                    parent: &body.frames[joint.parent],
                    child: &body.frames[joint.child],
                    pose: joint.transform(0.0),
                });
            }
        }
    }
    transforms
}

/// The moving transforms of `bodies` at one frame, for `/tf`: each body's configuration set
/// from its joint values `joints[b]` (columns that are not joints of its robot skipped), then
/// every movable joint of every body.
pub(super) fn moving_transforms<'a>(
    bodies: &'a mut [BodyChannel],
    joints: &[&[f64]],
) -> Vec<Transform<'a>> {
    let mut transforms = Vec::new();
    for (body, values) in bodies.iter_mut().zip(joints) {
        for (qi, &v) in body.q_index.iter().zip(values.iter()) {
            if let Some(qi) = *qi {
                body.q[qi] = v;
            }
        }
    }
    let bodies: &'a [BodyChannel] = bodies;
    for body in bodies {
        for joint in body.body.robot.joints() {
            if let Some(qi) = joint.q_index {
                transforms.push(Transform {
                    parent: &body.frames[joint.parent],
                    child: &body.frames[joint.child],
                    pose: joint.transform(body.q[qi]),
                });
            }
        }
    }
    transforms
}
