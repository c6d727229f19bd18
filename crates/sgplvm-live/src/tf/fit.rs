//! A TF tree through the importer's own steps: the tree as the skeleton a BVH file would
//! declare ([`skeleton_of`]: each frame a joint, its offset the translation to its parent),
//! the arms found by the importer's naming schemes or map ([`Skeleton::identify`]), calibrated
//! on the tree's rest pose ([`Skeleton::rest_pose`]: every rotation the identity, as MVN's null
//! pose and a BVH's zero channels) and each complete set of transforms fitted by
//! [`PoseFitter`] through [`Skeleton::arm_pose_with`], the per-frame transforms composed down
//! from the torso exactly as a file's channels are.

use std::collections::{BTreeMap, BTreeSet, VecDeque};

use nalgebra::{Rotation3, Vector3};
use sgplvm_capture::{
    ArmFitResult, ArmMap, Bvh, BvhJoint, CaptureError, Channel, HumanArms, PoseFitter, Skeleton,
};
use sgplvm_robots::{Robot, Side};

use super::buffer::TfBuffer;

/// The name the importer's messages give the "file" of a TF skeleton.
pub const SOURCE: &str = "/tf";

/// The TF tree as a BVH skeleton with no frames: every frame a joint (parents before children,
/// roots first), its offset its newest translation, three rotation channels on every frame
/// with a parent (none on a root). Frames on a loop (no root above them) are left out.
pub fn skeleton_of(buffer: &TfBuffer) -> Bvh {
    let names = buffer.frame_names();
    let mut children: BTreeMap<&str, Vec<&str>> = BTreeMap::new();
    let mut queue: VecDeque<&str> = VecDeque::new();
    for n in &names {
        match buffer.parent(n) {
            Some(p) => children.entry(p).or_default().push(n),
            None => queue.push_back(n),
        }
    }
    let mut joints: Vec<BvhJoint> = Vec::new();
    let mut index: BTreeMap<&str, usize> = BTreeMap::new();
    let mut channels = 0;
    while let Some(n) = queue.pop_front() {
        let parent = buffer.parent(n).and_then(|p| index.get(p).copied());
        let (offset, chans) = match (parent, buffer.latest(n)) {
            (Some(_), Some(t)) => (
                t.translation.vector,
                vec![Channel::Zrotation, Channel::Yrotation, Channel::Xrotation],
            ),
            _ => (Vector3::zeros(), Vec::new()),
        };
        index.insert(n, joints.len());
        joints.push(BvhJoint {
            name: n.to_string(),
            parent,
            offset,
            first_channel: channels,
            channels: chans.clone(),
            end_site: None,
            line: 0,
        });
        channels += chans.len();
        queue.extend(children.get(n).into_iter().flatten().copied());
    }
    Bvh {
        joints,
        frame_time: 0.025,
        channels,
        values: Vec::new(),
    }
}

/// The arms found in a TF tree, the fit calibrated on its rest pose.
pub struct Fitted {
    bvh: Bvh,
    skeleton: Skeleton,
    fitter: PoseFitter,
    /// The frames whose transforms a set needs: every frame from the torso (exclusive) down to
    /// both hands.
    needed: Vec<String>,
}

impl Fitted {
    /// The naming scheme that found the arms (or `map file`).
    pub fn scheme(&self) -> &str {
        &self.skeleton.scheme
    }

    /// The torso frame the arms hang from.
    pub fn torso(&self) -> &str {
        &self.bvh.joints[self.skeleton.torso].name
    }

    /// The frames a complete set must have at one stamp.
    pub fn needed(&self) -> &[String] {
        &self.needed
    }

    /// The human model's 18 angles (left arm, then right) of the transforms at `stamp`, with
    /// the fit's residuals; `Err` names the needed frames missing at that stamp.
    pub fn fit(
        &mut self,
        buffer: &TfBuffer,
        stamp: i64,
        tolerance_ns: i64,
    ) -> Result<([f64; 18], [ArmFitResult; 2]), Vec<String>> {
        let missing = buffer.missing(self.needed.iter().map(String::as_str), stamp, tolerance_ns);
        if !missing.is_empty() {
            return Err(missing);
        }
        let local = |k: usize| {
            let j = &self.bvh.joints[k];
            match buffer.at(&j.name, stamp, tolerance_ns) {
                Some(t) => (t.translation.vector, Rotation3::from(t.rotation)),
                // Not on an arm's chain (never asked for): the rest pose.
                None => (j.offset, Rotation3::identity()),
            }
        };
        let poses = [Side::Left, Side::Right]
            .map(|side| self.skeleton.arm_pose_with(&self.bvh, &local, side));
        let fits = self.fitter.fit([&poses[0], &poses[1]]);
        Ok((PoseFitter::angles(&fits), fits))
    }
}

/// Finds the arms in the frames received so far (`map`: as `sgplvm import --map`) and
/// calibrates the fit on the tree's rest pose. The error of a tree whose names no scheme
/// knows lists every frame found.
pub fn identify(buffer: &TfBuffer, map: Option<&ArmMap>) -> Result<Fitted, CaptureError> {
    let bvh = skeleton_of(buffer);
    let skeleton = Skeleton::identify(&bvh, map, SOURCE).map_err(|e| flat_hint(&bvh, e))?;
    let rest = [Side::Left, Side::Right].map(|side| skeleton.rest_pose(&bvh, side));
    let has_clavicle = [0, 1].map(|s| skeleton.arms[s].clavicle.is_some());
    let model = HumanArms::new(&Robot::builtin("human")?)?;
    // A live stream shows no motion ahead to tell an untold shoulder twist from (the importer
    // looks at the file's elbow hinge): as for MVN, none.
    let fitter = PoseFitter::new(model, [&rest[0], &rest[1]], has_clavicle, &|_| None);
    let mut needed = BTreeSet::new();
    for arm in &skeleton.arms {
        for j in bvh.path(skeleton.torso, arm.hand).unwrap_or_default() {
            needed.insert(bvh.joints[j].name.clone());
        }
    }
    Ok(Fitted {
        needed: needed.into_iter().collect(),
        bvh,
        skeleton,
        fitter,
    })
}

/// A tree whose frames all hang straight from its roots (every segment's pose given in the
/// world, as some drivers publish) has no arm chain for the naming schemes to follow: the
/// error says so, naming the frames.
fn flat_hint(bvh: &Bvh, e: CaptureError) -> CaptureError {
    let CaptureError::NoArms { .. } = e else {
        return e;
    };
    let roots: Vec<&str> = bvh
        .joints
        .iter()
        .filter(|j| j.parent.is_none())
        .map(|j| j.name.as_str())
        .collect();
    let flat = bvh.joints.len() > roots.len() + 3
        && bvh
            .joints
            .iter()
            .all(|j| j.parent.is_none_or(|p| bvh.joints[p].parent.is_none()));
    if !flat {
        return e;
    }
    let text = e.to_string();
    let e = text.strip_prefix(&format!("{SOURCE}: ")).unwrap_or(&text);
    CaptureError::Skeleton {
        file: SOURCE.to_string(),
        message: format!(
            "{e}. Every frame hangs straight from {}: the arms are found along the tree's parent → child chain (clavicle → upper arm → forearm → hand), so publish each segment's transform in its parent segment's frame",
            roots.iter().map(|r| format!("`{r}`")).collect::<Vec<_>>().join(", ")
        ),
    }
}
