//! Which joints of a capture's skeleton are the arms, and where the arms are in each frame,
//! expressed in the upper torso's frame.
//!
//! The arms are found by name ([`SCHEMES`]: CMU/cgspeed and Mixamo `LeftShoulder/LeftArm/
//! LeftForeArm/LeftHand`, Xsens MVN `LeftShoulder/LeftUpperArm/...`, Xsens BVH exports and
//! SMPL `LeftCollar/LeftShoulder/LeftElbow/LeftWrist`, MakeHuman `lcollar/lshoulder/lelbow/lhand`
//! and its game rig's `Clavicle_L/UpArm_L/LoArm_L/Hand_L`, Poser/DAZ `lCollar/lShldr/...` (Genesis
//! 3 and 8 `lShldrBend/lForearmBend`), Unreal and 3ds Max `clavicle_l/upperarm_l/lowerarm_l/
//! hand_l`, Rigify `shoulder.L/upper_arm.L/...` (and `DEF-upper_arm.L`)), namespace prefixes
//! (`mixamorig:`, a TF frame's `actor1/`) and case, `_`, `.`, `-` and spaces aside; or by an
//! explicit [`ArmMap`] (`--map FILE`). Twist bones between an arm's joints (Genesis'
//! `lShldrTwist`) belong to the segment above them.
//!
//! The upper torso is the joint the clavicles hang from. Its body axes (x forward, y left,
//! z up, those of the human model's `T8`) come from the skeleton's geometry, whatever its zero
//! pose looks like ([`crate::axes`]): left from the right clavicle's root to the left one's,
//! up from the pelvis to the neck along the spine. They are fixed in the torso, so walking,
//! turning and bending of the whole body do not reach the arms.

use std::collections::{BTreeMap, VecDeque};

use nalgebra::{Rotation3, Vector3};

use crate::axes::body_axes;
use crate::bvh::{Bvh, BvhJoint, Channel};
use crate::calibration::HandEnd;
use crate::CaptureError;
use sgplvm_robots::Side;

mod hand;
mod names;
use hand::hand_tip;
use names::{base_name, name_forms, sided};
pub use names::{normalise, ArmMap, Scheme, SCHEMES};

/// The four arm segments.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Role {
    Clavicle,
    UpperArm,
    Forearm,
    Hand,
}

impl Role {
    const ALL: [Role; 4] = [Role::Clavicle, Role::UpperArm, Role::Forearm, Role::Hand];

    /// The map keys of this role: the model's joint group and the segment name.
    fn keys(self, side: Side) -> (String, String) {
        let s = match side {
            Side::Left => "Left",
            Side::Right => "Right",
        };
        let (joint, segment) = match self {
            Role::Clavicle => ("C7Shoulder", "clavicle"),
            Role::UpperArm => ("Shoulder", "upper_arm"),
            Role::Forearm => ("Elbow", "forearm"),
            Role::Hand => ("Wrist", "hand"),
        };
        (
            format!("j{s}{joint}"),
            format!("{}_{segment}", side.as_str()),
        )
    }
}

/// The joints of one arm in the capture.
#[derive(Debug, Clone, PartialEq)]
pub struct ArmJoints {
    /// The clavicle segment's joint (sternoclavicular joint), if the skeleton has one.
    pub clavicle: Option<usize>,
    /// The upper arm's joint (at the shoulder).
    pub upper_arm: usize,
    /// The forearm's joint (at the elbow).
    pub forearm: usize,
    /// The hand's joint (at the wrist).
    pub hand: usize,
    /// Where the hand ends, in the hand's frame (the middle finger's base, else a finger's
    /// base near the wrist, the End Site, or the mean of its children); `None` if the hand has
    /// none of them.
    pub hand_tip: Option<Vector3<f64>>,
    /// Whether the skeleton says where the hand ends (a finger or an End Site), or
    /// `hand_tip` is a guess (the mean of children that are no fingers, such as an Xsens
    /// prop; none). A ROS 2 TF tree carries no End Sites: where a file's hand ends at one, the
    /// same motion's tree guesses.
    pub hand_end: HandEnd,
}

/// The arms of a capture's skeleton and the body axes of its upper torso.
#[derive(Debug, Clone, PartialEq)]
pub struct Skeleton {
    /// Which naming scheme matched (or `"map file"`).
    pub scheme: String,
    /// The upper torso joint (the clavicles' parent).
    pub torso: usize,
    /// Left and right arm.
    pub arms: [ArmJoints; 2],
    /// Body axes as columns (forward, left, up) in the torso's frame.
    pub axes: Rotation3<f64>,
    /// Which joints gave the body axes (for reports).
    pub axes_from: String,
    /// Upper arm plus forearm length at rest, in the file's units.
    pub arm_length: f64,
    /// Where an arm was found without a clavicle although its upper arm hangs from a joint
    /// named like one: which, said to the user.
    pub clavicle_note: Option<String>,
}

/// Where one arm is in one frame, in body axes (x forward, y left, z up), file units,
/// relative to the torso joint.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ArmPose {
    /// The sternoclavicular joint (the shoulder itself where there is no clavicle).
    pub clavicle: Vector3<f64>,
    /// The shoulder joint centre.
    pub shoulder: Vector3<f64>,
    /// The elbow.
    pub elbow: Vector3<f64>,
    /// The wrist.
    pub wrist: Vector3<f64>,
    /// The hand's end.
    pub hand_tip: Vector3<f64>,
    /// Orientation of the upper-arm segment relative to its rest orientation, body axes.
    pub upper_arm_turn: Rotation3<f64>,
    /// Orientation of the hand segment relative to its rest orientation, body axes.
    pub hand_turn: Rotation3<f64>,
}

impl Skeleton {
    /// Finds the arms by name (or by `map`) and the torso's body axes.
    pub fn identify(bvh: &Bvh, map: Option<&ArmMap>, file: &str) -> Result<Skeleton, CaptureError> {
        let (scheme, arms) = match map {
            Some(m) => (
                "map file".to_string(),
                [
                    arm_from_map(bvh, m, Side::Left, file)?,
                    arm_from_map(bvh, m, Side::Right, file)?,
                ],
            ),
            None => find_arms(bvh).ok_or_else(|| CaptureError::NoArms {
                file: file.to_string(),
                segments: nearest_the_root_first(bvh),
            })?,
        };
        let top = |a: &ArmJoints| a.clavicle.unwrap_or(a.upper_arm);
        let torso = common_parent(bvh, top(&arms[0]), top(&arms[1])).ok_or_else(|| CaptureError::Skeleton {
            file: file.to_string(),
            message: format!(
                "the arms `{}` and `{}` hang from no common joint; expected both on the upper torso",
                bvh.joints[top(&arms[0])].name,
                bvh.joints[top(&arms[1])].name
            ),
        })?;
        // From joint to joint at rest, over any twist bones between them (DAZ's Genesis 3 and 8
        // put `lShldrTwist` between `lShldrBend` and `lForearmBend`, Rigify `upper_arm.L.001`).
        let rest_length = |from: usize, to: usize| {
            bvh.rest_position(from, to)
                .map_or(0.0, |v: Vector3<f64>| v.norm())
        };
        let arm_length = rest_length(arms[0].upper_arm, arms[0].forearm)
            + rest_length(arms[0].forearm, arms[0].hand);
        if arm_length.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
            return Err(CaptureError::Skeleton {
                file: file.to_string(),
                message: format!(
                    "the left arm `{}` has zero length in the rest pose",
                    bvh.joints[arms[0].upper_arm].name
                ),
            });
        }
        let axes = body_axes(bvh, torso, &arms, arm_length, file)?;
        let clavicle_note = match map {
            Some(_) => None,
            None => clavicles_left_out(bvh, &arms),
        };
        Ok(Skeleton {
            clavicle_note,
            scheme,
            torso,
            arms,
            axes: axes.rotation,
            axes_from: axes.found_from,
            arm_length,
        })
    }

    /// The map (as `--map` takes it) that names each arm's segments as the other side's: what
    /// imports a skeleton whose Left and Right are the person's right and left as the person's.
    pub fn swapped_map(&self, bvh: &Bvh) -> ArmMap {
        let mut map = BTreeMap::new();
        for (side, other) in [(Side::Left, Side::Right), (Side::Right, Side::Left)] {
            let arm = &self.arms[side_index(other)];
            let joints = [
                arm.clavicle,
                Some(arm.upper_arm),
                Some(arm.forearm),
                Some(arm.hand),
            ];
            for (role, joint) in Role::ALL.into_iter().zip(joints) {
                if let Some(j) = joint {
                    map.insert(role.keys(side).0, bvh.joints[j].name.clone());
                }
            }
        }
        ArmMap(map)
    }

    /// The pose of arm `side` in frame `values` (one frame's channels).
    pub fn arm_pose(&self, bvh: &Bvh, values: &[f64], side: Side) -> ArmPose {
        self.arm_pose_with(bvh, &|k| bvh.joints[k].local(values), side)
    }

    /// The pose of arm `side` where `local` gives each joint's transform in its parent's frame
    /// (translation, rotation): a file's frame ([`Skeleton::arm_pose`]) or a live source's, such
    /// as a ROS 2 TF tree's transforms, composed down from the torso the same way.
    pub fn arm_pose_with(
        &self,
        bvh: &Bvh,
        local: &dyn Fn(usize) -> (Vector3<f64>, Rotation3<f64>),
        side: Side,
    ) -> ArmPose {
        let arm = &self.arms[side_index(side)];
        let to_body = self.axes.inverse();
        // Torso-relative transforms down the arm, joint by joint.
        let mut pos = Vector3::zeros();
        let mut rot = Rotation3::identity();
        let at = |j: usize, pos: &mut Vector3<f64>, rot: &mut Rotation3<f64>, from: usize| {
            if let Some(path) = bvh.path(from, j) {
                for k in path {
                    let (t, r) = local(k);
                    *pos += *rot * t;
                    *rot *= r;
                }
            }
        };
        let top = arm.clavicle.unwrap_or(arm.upper_arm);
        at(top, &mut pos, &mut rot, self.torso);
        let clavicle = pos;
        at(arm.upper_arm, &mut pos, &mut rot, top);
        let shoulder = pos;
        // The upper arm's orientation is that of the bone the elbow hangs from: the upper arm
        // itself, or the last of the twist bones that carry part of its twist (DAZ's
        // `lShldrTwist`, Rigify's `upper_arm.L.001`).
        let upper_end = bvh.joints[arm.forearm].parent.unwrap_or(arm.upper_arm);
        at(upper_end, &mut pos, &mut rot, arm.upper_arm);
        let upper_rot = rot;
        at(arm.forearm, &mut pos, &mut rot, upper_end);
        let elbow = pos;
        at(arm.hand, &mut pos, &mut rot, arm.forearm);
        let wrist = pos;
        let hand_rot = rot;
        let hand_tip = match arm.hand_tip {
            Some(t) => wrist + hand_rot * t,
            None => wrist + (wrist - elbow),
        };
        let body = |v: Vector3<f64>| to_body * v;
        // Relative to the rest pose, in body axes: R_body⁻¹ R R_body.
        let turn = |r: Rotation3<f64>| to_body * r * self.axes;
        ArmPose {
            clavicle: body(clavicle),
            shoulder: body(shoulder),
            elbow: body(elbow),
            wrist: body(wrist),
            hand_tip: body(hand_tip),
            upper_arm_turn: turn(upper_rot),
            hand_turn: turn(hand_rot),
        }
    }

    /// The pose of arm `side` with every channel at zero (the file's rest pose).
    pub fn rest_pose(&self, bvh: &Bvh, side: Side) -> ArmPose {
        let zero = vec![0.0; bvh.channels];
        let mut rest = self.arm_pose(bvh, &zero, side);
        // Position channels replace offsets: at zero they would put every joint at its
        // parent; the rest places them as the motion does (`Bvh::rest_translation`).
        let arm = &self.arms[side_index(side)];
        let to_body = self.axes.inverse();
        let p = |j: usize| {
            to_body
                * bvh
                    .rest_position(self.torso, j)
                    .unwrap_or_else(Vector3::zeros)
        };
        rest.clavicle = p(arm.clavicle.unwrap_or(arm.upper_arm));
        rest.shoulder = p(arm.upper_arm);
        rest.elbow = p(arm.forearm);
        rest.wrist = p(arm.hand);
        rest.hand_tip = match arm.hand_tip {
            Some(t) => rest.wrist + to_body * t,
            None => rest.wrist + (rest.wrist - rest.elbow),
        };
        rest
    }
}

/// One frame of a tree of named frames (a ROS 2 TF tree, a suit's segment hierarchy).
#[derive(Debug, Clone, PartialEq)]
pub struct TreeFrame {
    /// The frame's name.
    pub name: String,
    /// Its parent's name (`None` for a root).
    pub parent: Option<String>,
    /// Its origin in its parent's frame at rest (its newest translation).
    pub offset: Vector3<f64>,
}

/// A tree of named frames as the skeleton a BVH file would declare, with no frames: every
/// frame a joint (parents before children, roots first, each level in `frames`' order), its
/// offset the translation to its parent, three rotation channels on every frame with a parent
/// (none on a root). Frames on a loop or under a parent not in `frames` are left out. So a
/// live tree goes through [`Skeleton::identify`] and [`Skeleton::arm_pose_with`] as a file's
/// skeleton does.
pub fn tree_skeleton(frames: &[TreeFrame]) -> Bvh {
    let mut children: BTreeMap<&str, Vec<&TreeFrame>> = BTreeMap::new();
    let mut queue: VecDeque<&TreeFrame> = VecDeque::new();
    let known: std::collections::BTreeSet<&str> = frames.iter().map(|f| f.name.as_str()).collect();
    for f in frames {
        match f.parent.as_deref() {
            Some(p) if known.contains(p) => children.entry(p).or_default().push(f),
            _ => queue.push_back(f),
        }
    }
    let mut joints: Vec<BvhJoint> = Vec::new();
    let mut index: BTreeMap<&str, usize> = BTreeMap::new();
    let mut channels = 0;
    while let Some(f) = queue.pop_front() {
        if index.contains_key(f.name.as_str()) {
            continue;
        }
        let parent = f.parent.as_deref().and_then(|p| index.get(p).copied());
        let (offset, chans) = match parent {
            Some(_) => (
                f.offset,
                vec![Channel::Zrotation, Channel::Yrotation, Channel::Xrotation],
            ),
            None => (Vector3::zeros(), Vec::new()),
        };
        index.insert(&f.name, joints.len());
        joints.push(BvhJoint {
            name: f.name.clone(),
            parent,
            offset,
            first_channel: channels,
            channels: chans.clone(),
            end_site: None,
            line: 0,
        });
        channels += chans.len();
        queue.extend(children.get(f.name.as_str()).into_iter().flatten().copied());
    }
    Bvh {
        joints,
        frame_time: 0.025,
        channels,
        values: Vec::new(),
        frame_lines_left_out: 0,
    }
}

/// 0 for the left arm, 1 for the right.
pub(crate) fn side_index(side: Side) -> usize {
    match side {
        Side::Left => 0,
        Side::Right => 1,
    }
}

/// The nearest joint above both `a` and `b`.
fn common_parent(bvh: &Bvh, a: usize, b: usize) -> Option<usize> {
    let mut above_a = Vec::new();
    let mut cur = bvh.joints[a].parent;
    while let Some(p) = cur {
        above_a.push(p);
        cur = bvh.joints[p].parent;
    }
    let mut cur = bvh.joints[b].parent;
    while let Some(p) = cur {
        if above_a.contains(&p) {
            return Some(p);
        }
        cur = bvh.joints[p].parent;
    }
    None
}

/// Tries every scheme; the first whose segments exist on both sides and chain up properly
/// (clavicle above upper arm above forearm above hand) wins.
fn find_arms(bvh: &Bvh) -> Option<(String, [ArmJoints; 2])> {
    // Whole names first, then their word-boundary ends (a whole name wins over an end). Of
    // two whole names alike but for leading underscores, the one without them: MakeHuman's
    // exports put a helper joint `__Clavicle_L` on the spine above the clavicle `Clavicle_L`.
    let mut by_name: BTreeMap<String, usize> = BTreeMap::new();
    let forms: Vec<Vec<String>> = bvh.joints.iter().map(|j| name_forms(&j.name)).collect();
    let helper = |i: usize| base_name(&bvh.joints[i].name).starts_with('_');
    for helpers in [false, true] {
        for (i, f) in forms
            .iter()
            .enumerate()
            .filter(|(i, _)| helper(*i) == helpers)
        {
            by_name.entry(f[0].clone()).or_insert(i);
        }
    }
    for (i, f) in forms.iter().enumerate() {
        for end in &f[1..] {
            by_name.entry(end.clone()).or_insert(i);
        }
    }
    let find = |bases: &[&str], side: Side| -> Option<usize> {
        bases
            .iter()
            .flat_map(|b| sided(b, side))
            .find_map(|n| by_name.get(&n).copied())
    };
    // First with the clavicles found, then without (a skeleton may lack them).
    for need_clavicle in [true, false] {
        if let Some(found) = find_arms_with(bvh, &find, need_clavicle) {
            return Some(found);
        }
    }
    None
}

/// Where an arm was found without a clavicle although its upper arm hangs from a joint named
/// like one (GAMES-105's `lTorso_Clavicle`, whose scheme calls the clavicle `Collar`): that
/// joint's turn is then the shoulder's — said, so that the user can name it with `--map`.
fn clavicles_left_out(bvh: &Bvh, arms: &[ArmJoints; 2]) -> Option<String> {
    let named: Vec<String> = arms
        .iter()
        .filter(|a| a.clavicle.is_none())
        .filter_map(|a| bvh.joints[a.upper_arm].parent)
        .map(|p| format!("`{}`", bvh.joints[p].name))
        .filter(|n| {
            let n = normalise(n);
            n.contains("clavicle") || n.contains("collar")
        })
        .collect();
    (!named.is_empty()).then(|| {
        format!(
            "no clavicle segment was found, though the upper arms hang from {}, named like one: its turn is taken as the shoulder's (a map naming it jLeftC7Shoulder / jRightC7Shoulder fits it as the clavicle)",
            named.join(" and ")
        )
    })
}

/// [`find_arms`] over the schemes with lookup `find`, requiring the clavicles or not.
fn find_arms_with(
    bvh: &Bvh,
    find: &dyn Fn(&[&str], Side) -> Option<usize>,
    need_clavicle: bool,
) -> Option<(String, [ArmJoints; 2])> {
    'scheme: for scheme in SCHEMES {
        let mut arms = Vec::with_capacity(2);
        for side in [Side::Left, Side::Right] {
            let (Some(upper), Some(fore), Some(hand)) = (
                find(scheme.upper_arm, side),
                find(scheme.forearm, side),
                find(scheme.hand, side),
            ) else {
                continue 'scheme;
            };
            let clavicle =
                find(scheme.clavicle, side).filter(|&c| c != upper && bvh.path(c, upper).is_some());
            if bvh.path(upper, fore).is_none()
                || bvh.path(fore, hand).is_none()
                || (need_clavicle && clavicle.is_none())
            {
                continue 'scheme;
            }
            arms.push(ArmJoints::of(bvh, clavicle, upper, fore, hand));
        }
        let [l, r]: [ArmJoints; 2] = arms.try_into().ok()?;
        if l.upper_arm == r.upper_arm {
            continue;
        }
        return Some((scheme.name.to_string(), [l, r]));
    }
    None
}

/// Every joint's name, nearest the root first (file order within a depth): the arms sit a few
/// joints from the root, a face's or a hand's many bones deep below it, so a list cut short
/// still shows the arms (MakeHuman's rig declares 90 face bones before its collars).
fn nearest_the_root_first(bvh: &Bvh) -> Vec<String> {
    let mut depth = vec![0usize; bvh.joints.len()];
    for (i, joint) in bvh.joints.iter().enumerate() {
        // A parent is declared before its children.
        depth[i] = joint.parent.map_or(0, |p| depth[p] + 1);
    }
    let mut order: Vec<usize> = (0..bvh.joints.len()).collect();
    order.sort_by_key(|&i| depth[i]);
    order
        .into_iter()
        .map(|i| bvh.joints[i].name.clone())
        .collect()
}

/// The arm of `side` as `map` names it.
fn arm_from_map(
    bvh: &Bvh,
    map: &ArmMap,
    side: Side,
    file: &str,
) -> Result<ArmJoints, CaptureError> {
    for key in map.0.keys() {
        if !ArmMap::known_keys().contains(key) {
            return Err(CaptureError::Map {
                file: file.to_string(),
                message: format!(
                    "unknown key `{key}`; expected some of {}",
                    ArmMap::known_keys().join(", ")
                ),
            });
        }
    }
    let lookup = |role: Role, required: bool| -> Result<Option<usize>, CaptureError> {
        let (joint_key, segment_key) = role.keys(side);
        match map.get(side, role) {
            Some(name) => bvh.joint(name).map(Some).ok_or_else(|| CaptureError::Map {
                file: file.to_string(),
                message: format!(
                    "`{joint_key}` names segment `{name}`, which the capture does not have; its segments are: {}",
                    bvh.joints.iter().map(|j| j.name.as_str()).collect::<Vec<_>>().join(", ")
                ),
            }),
            None if required => Err(CaptureError::Map {
                file: file.to_string(),
                message: format!("no `{joint_key}` (or `{segment_key}`): every arm needs its upper arm, forearm and hand"),
            }),
            None => Ok(None),
        }
    };
    let clavicle = lookup(Role::Clavicle, false)?;
    let (Some(upper), Some(fore), Some(hand)) = (
        lookup(Role::UpperArm, true)?,
        lookup(Role::Forearm, true)?,
        lookup(Role::Hand, true)?,
    ) else {
        unreachable!("required roles are present or an error");
    };
    let chained = clavicle.is_none_or(|c| bvh.path(c, upper).is_some())
        && bvh.path(upper, fore).is_some()
        && bvh.path(fore, hand).is_some();
    if !chained {
        return Err(CaptureError::Map {
            file: file.to_string(),
            message: format!("the {} arm's segments do not hang from each other (clavicle → upper arm → forearm → hand)", side.as_str()),
        });
    }
    Ok(ArmJoints::of(bvh, clavicle, upper, fore, hand))
}

impl ArmJoints {
    /// The arm of `bvh` with these joints, and where its hand ends ([`hand_tip`]).
    fn of(
        bvh: &Bvh,
        clavicle: Option<usize>,
        upper_arm: usize,
        forearm: usize,
        hand: usize,
    ) -> Self {
        let tip = hand_tip(bvh, hand);
        ArmJoints {
            clavicle,
            upper_arm,
            forearm,
            hand,
            hand_tip: tip.map(|(at, _)| at),
            hand_end: tip.map_or(HandEnd::Unmeasured, |(_, end)| end),
        }
    }
}

#[cfg(test)]
mod tests;
