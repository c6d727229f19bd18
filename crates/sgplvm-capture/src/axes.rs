//! The upper torso's body axes (x forward, y left, z up, those of the human model's `T8`),
//! found from the skeleton's geometry, not from what its zero pose looks like.
//!
//! A BVH file fixes each joint's offset in its parent's frame; what every rotation channel at
//! zero looks like depends on the rig. Where the joints' axes are the world's, it is the pose
//! the skeleton was drawn in (a T- or A-pose); where every bone lies along its joint's local
//! x (Maya and MotionBuilder rigs, often with six channels on every joint) it is a line of
//! bones no person takes, the clavicles pointing up the spine. So the axes come from points
//! whose place in the torso's frame the offsets fix by themselves:
//!
//! * **left**, from the right arm's first joint below the torso to the left arm's: the roots
//!   of the clavicles, which hang from the torso joint and so are fixed in its frame. Where
//!   they are closer together than [`MIN_SPAN`] arm lengths (CMU's clavicles both start at
//!   the torso joint itself) the next joints down each arm are taken, placed by the offsets
//!   with the joints above them at zero rotation, and so on down to the shoulders.
//! * **up**, from the pelvis (the highest joint above the torso that more than one chain
//!   hangs from: spine and legs; the root where none does) to the neck, along the spine's
//!   offsets: the spine's own line, whichever local axis its bones lie along. The offset of
//!   a root above the pelvis (a floor joint's height in some files) plays no part. Without a
//!   neck or head joint, up ends between the shoulders. Where the spine's zero pose folds
//!   (two bones turned by more than 60°, as where the pelvis' bone lies along its y and those
//!   above along their x), the line starts above the fold.
//! * forward = left × up, left first made square to up.
//!
//! The axes are fixed in the torso's frame: every frame takes them along with the torso's
//! own rotation, so walking, turning and bending stay out of the arms.

use nalgebra::{Matrix3, Rotation3, Vector3};

use crate::bvh::Bvh;
use crate::skeleton::{normalise, ArmJoints};
use crate::CaptureError;

/// Fewest arm lengths (upper arm plus forearm) apart that two joints must be for the line
/// between them to give the left axis: closer roots of the clavicles would let a millimetre
/// of asymmetry turn the axes by degrees.
pub const MIN_SPAN: f64 = 0.05;

/// Body axes as the columns (forward, left, up) of a rotation in the torso's frame, and how
/// they were found.
#[derive(Debug, Clone, PartialEq)]
pub struct BodyAxes {
    /// Columns forward, left, up, in the torso's frame.
    pub rotation: Rotation3<f64>,
    /// Which joints gave left and up, for reports.
    pub found_from: String,
}

/// The body axes of the torso joint `torso` from which `arms` hang (see the module
/// documentation); `arm_length` (file units) sets how far apart the left points must be.
pub fn body_axes(
    bvh: &Bvh,
    torso: usize,
    arms: &[ArmJoints; 2],
    arm_length: f64,
    file: &str,
) -> Result<BodyAxes, CaptureError> {
    let name = |j: usize| bvh.joints[j].name.as_str();
    // Places with every joint between at zero rotation, from the pelvis: the differences
    // below are the torso frame's (the root's, as before, wherever the pelvis is the root).
    let pelvis = pelvis(bvh, torso);
    let at = |j: usize| bvh.rest_position(pelvis, j).unwrap_or_else(Vector3::zeros);
    let shoulders = [arms[0].upper_arm, arms[1].upper_arm];
    let Some((left_joints, fixed)) = left_joints(bvh, torso, arms, arm_length) else {
        return Err(CaptureError::Skeleton {
            file: file.to_string(),
            message: format!(
                "cannot tell the torso's axes: the arms `{}` and `{}` start at the same place (less than {MIN_SPAN} arm lengths apart down to the shoulders)",
                name(shoulders[0]),
                name(shoulders[1])
            ),
        });
    };
    let left = at(left_joints[0]) - at(left_joints[1]);
    let neck = (torso + 1..bvh.joints.len())
        .filter(|&j| bvh.path(torso, j).is_some())
        .find(|&j| {
            let n = normalise(&bvh.joints[j].name);
            n.contains("neck") || n.contains("head")
        });
    let top = match neck {
        Some(n) => at(n),
        None => 0.5 * (at(shoulders[0]) + at(shoulders[1])),
    };
    let bottom = spine_start(bvh, pelvis, neck.unwrap_or(torso));
    let up = top - at(bottom);
    let top_name = match neck {
        Some(n) => format!("`{}`", name(n)),
        None => format!(
            "between `{}` and `{}`",
            name(shoulders[0]),
            name(shoulders[1])
        ),
    };
    let rotation = square_axes(left, up).ok_or_else(|| CaptureError::Skeleton {
        file: file.to_string(),
        message: format!(
            "cannot tell the torso's axes: the line from `{}` to `{}` (left) runs along the spine from `{}` to {top_name} (up), or the spine has no length",
            name(left_joints[1]),
            name(left_joints[0]),
            name(bottom),
        ),
    })?;
    let left_how = if fixed {
        format!("fixed in `{}`", name(torso))
    } else {
        "the joints above them at zero rotation".to_string()
    };
    Ok(BodyAxes {
        rotation,
        found_from: format!(
            "left from `{}` to `{}` ({left_how}), up from `{}` to {top_name} along the spine",
            name(left_joints[1]),
            name(left_joints[0]),
            name(bottom),
        ),
    })
}

/// The joints (left, right) at the same depth below `torso` on the two arms' chains that are
/// the first at least [`MIN_SPAN`] arm lengths apart, and whether their places are fixed in
/// the torso (no joint with rotation channels between them and it).
fn left_joints(
    bvh: &Bvh,
    torso: usize,
    arms: &[ArmJoints; 2],
    arm_length: f64,
) -> Option<([usize; 2], bool)> {
    let chain = |a: &ArmJoints| bvh.path(torso, a.upper_arm).unwrap_or_default();
    let (l, r) = (chain(&arms[0]), chain(&arms[1]));
    let at = |j: usize| bvh.rest_position(torso, j).unwrap_or_else(Vector3::zeros);
    let turns = |j: &usize| bvh.joints[*j].channels.iter().any(|c| c.is_rotation());
    (0..l.len().min(r.len()))
        .find(|&k| (at(l[k]) - at(r[k])).norm() >= MIN_SPAN * arm_length)
        .map(|k| {
            let fixed = !l[..k].iter().chain(&r[..k]).any(turns);
            ([l[k], r[k]], fixed)
        })
}

/// The highest joint above `torso` that more than one chain hangs from (where the legs and
/// the spine part); the root if there is none.
fn pelvis(bvh: &Bvh, torso: usize) -> usize {
    let mut above = Vec::new();
    let mut cur = bvh.joints[torso].parent;
    while let Some(p) = cur {
        above.push(p);
        cur = bvh.joints[p].parent;
    }
    above
        .iter()
        .rev()
        .find(|&&j| bvh.children(j).nth(1).is_some())
        .or(above.last())
        .copied()
        .unwrap_or(torso)
}

/// The spine folds at zero rotation where two of its bones on the way up turn by more than
/// this (radians): no person's spine does, so the offsets below the fold do not tell up.
const SPINE_FOLD: f64 = std::f64::consts::FRAC_PI_3;

/// Where the spine's line from `pelvis` up to `top` starts: the pelvis, or the joint above the
/// highest fold of the spine's zero pose ([`SPINE_FOLD`]). Rokoko Studio lays the pelvis'
/// first bone along its y and every bone above it along its own x: summed at zero rotation,
/// the line from the pelvis leans 17° towards a shoulder, while the bones above the fold are
/// the spine's own line in the torso's frame.
fn spine_start(bvh: &Bvh, pelvis: usize, top: usize) -> usize {
    let path = bvh.path(pelvis, top).unwrap_or_default();
    let mut start = pelvis;
    let mut below: Option<Vector3<f64>> = None;
    for &j in &path {
        let bone = bvh.rest_translation(j);
        if bone.norm() < 1e-9 {
            continue;
        }
        if let Some(b) = below {
            if b.angle(&bone) > SPINE_FOLD {
                start = bvh.joints[j].parent.unwrap_or(pelvis);
            }
        }
        below = Some(bone);
    }
    start
}

/// Body axes (forward, left, up) as the columns of a rotation, from a left and an up vector.
fn square_axes(left: Vector3<f64>, up: Vector3<f64>) -> Option<Rotation3<f64>> {
    let up = up.try_normalize(1e-9)?;
    let left = (left - up * left.dot(&up)).try_normalize(1e-9)?;
    let forward = left.cross(&up);
    Some(Rotation3::from_matrix_unchecked(Matrix3::from_columns(&[
        forward, left, up,
    ])))
}
