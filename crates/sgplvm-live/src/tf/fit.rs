//! A TF tree through the importer's own steps: the tree as the skeleton a BVH file would
//! declare ([`skeleton_of`], the capture crate's [`tree_skeleton`]: each frame a joint, its
//! offset the translation to its parent), the arms found by the importer's naming schemes or
//! map ([`Skeleton::identify`]), the person calibrated on the tree's rest pose
//! ([`Skeleton::rest_pose`]: every rotation the identity, as a BVH's zero channels) through
//! [`StreamCalibration`] — the calibration of the models' training data where the rest pose is
//! its, else the stream's own (watching the motion a few seconds where the rest pose leaves a
//! twist untold) — and each complete set of transforms fitted by [`PoseFitter`] through
//! [`Skeleton::arm_pose_with`], the per-frame transforms composed down from the torso exactly
//! as a file's channels are.

use std::collections::BTreeSet;

use nalgebra::Rotation3;
use sgplvm_capture::{
    tree_skeleton, ArmMap, ArmPose, Bvh, CaptureError, FrameFit, HandEnd, HumanArms, PoseFitter,
    Skeleton, StreamCalibration, StreamCalibrationOptions, TreeFrame, Twist,
};
use sgplvm_robots::{Robot, Side};

use super::buffer::TfBuffer;

/// The name the importer's messages give the "file" of a TF skeleton.
pub const SOURCE: &str = "/tf";

/// The TF tree as a BVH skeleton with no frames ([`tree_skeleton`]): every frame a joint, its
/// offset its newest translation.
pub fn skeleton_of(buffer: &TfBuffer) -> Bvh {
    let frames: Vec<TreeFrame> = buffer
        .frame_names()
        .into_iter()
        .map(|name| TreeFrame {
            parent: buffer.parent(&name).map(str::to_string),
            offset: buffer
                .latest(&name)
                .map(|t| t.translation.vector)
                .unwrap_or_else(nalgebra::Vector3::zeros),
            name,
        })
        .collect();
    tree_skeleton(&frames)
}

/// Why a frame set was not fitted.
#[derive(Debug, Clone, PartialEq)]
pub enum SetNotFitted {
    /// Needed frames missing at the set's stamp.
    Missing(Vec<String>),
    /// The person's calibration given is not the stream's (the message says why).
    Calibration(String),
}

/// The arms found in a TF tree, and the fit of its person.
pub struct Fitted {
    bvh: Bvh,
    skeleton: Skeleton,
    model: HumanArms,
    rest: [ArmPose; 2],
    has_clavicle: [bool; 2],
    calibration: StreamCalibration,
    fitter: Option<PoseFitter>,
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

    /// Where the person's calibration stands.
    pub fn calibration(&self) -> &StreamCalibration {
        &self.calibration
    }

    /// The fitter, once calibrated.
    pub fn fitter(&self) -> Option<&PoseFitter> {
        self.fitter.as_ref()
    }

    /// The human model's 18 angles (left arm, then right) of the transforms at `stamp`, with
    /// the fit's residuals; `None` while the person is being calibrated.
    pub fn fit(
        &mut self,
        buffer: &TfBuffer,
        stamp: i64,
        tolerance_ns: i64,
    ) -> Result<Option<FrameFit>, SetNotFitted> {
        let missing = buffer.missing(self.needed.iter().map(String::as_str), stamp, tolerance_ns);
        if !missing.is_empty() {
            return Err(SetNotFitted::Missing(missing));
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
        if self.fitter.is_none() {
            self.fitter = self
                .calibration
                .offer(
                    &self.model,
                    stamp as f64 * 1e-9,
                    [&self.rest[0], &self.rest[1]],
                    self.has_clavicle,
                    &self.skeleton.scheme,
                    None,
                    [&poses[0], &poses[1]],
                )
                .map_err(|e| SetNotFitted::Calibration(e.to_string()))?;
        }
        let Some(fitter) = self.fitter.as_mut() else {
            return Ok(None);
        };
        let fits = fitter.fit([&poses[0], &poses[1]]);
        Ok(Some((PoseFitter::angles(&fits), fits)))
    }
}

/// Finds the arms in the frames received so far (`map`: as `sgplvm import --map`); the person
/// is calibrated as `options` says on the first set fitted. The error of a tree whose names no
/// scheme knows lists every frame found.
pub fn identify(
    buffer: &TfBuffer,
    map: Option<&ArmMap>,
    options: StreamCalibrationOptions,
) -> Result<Fitted, CaptureError> {
    let bvh = skeleton_of(buffer);
    let skeleton = Skeleton::identify(&bvh, map, SOURCE).map_err(|e| flat_hint(&bvh, e))?;
    let rest = [Side::Left, Side::Right].map(|side| skeleton.rest_pose(&bvh, side));
    let has_clavicle = [0, 1].map(|s| skeleton.arms[s].clavicle.is_some());
    let model = HumanArms::new(&Robot::builtin("human")?)?;
    let mut needed = BTreeSet::new();
    for arm in &skeleton.arms {
        for j in bvh.path(skeleton.torso, arm.hand).unwrap_or_default() {
            needed.insert(bvh.joints[j].name.clone());
        }
    }
    Ok(Fitted {
        needed: needed.into_iter().collect(),
        calibration: {
            let c = StreamCalibration::new(options, Twist::Assumed, SOURCE);
            // A tree carries no End Sites: a hand without a finger frame ends where it guesses.
            if skeleton
                .arms
                .iter()
                .all(|a| a.hand_end == HandEnd::Measured)
            {
                c
            } else {
                c.hand_end_unmeasured()
            }
        },
        bvh,
        skeleton,
        model,
        rest,
        has_clavicle,
        fitter: None,
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
