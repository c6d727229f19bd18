//! A person's calibration, as one value: what the per-frame fit needs besides each frame.
//!
//! The fit turns a captured arm pose into the human model's angles; two things about the
//! capture it cannot read off a single frame:
//!
//! * **the rest pose** — what the capture's segments look like with no rotation (a file's zero
//!   channels, MVN's null pose, a TF tree's identity rotations): the places of the
//!   sternoclavicular joint, shoulder, elbow, wrist and hand's end in the upper torso's body
//!   axes (x forward, y left, z up), which also give the person's **segment lengths**;
//! * **each upper arm's twist reference** — which way the human model's upper arm and hand
//!   face when the capture's segments are at rest ([`ArmCalibration::upper_arm_frame`],
//!   [`ArmCalibration::hand_frame`]). A bent rest elbow, or an upper arm away from the
//!   shoulder's gimbal point, tells it ([`Twist::RestPose`]). A straight arm straight out to
//!   the side (a T-pose with flat clavicles, the line of bones some rigs rest in) does not: then
//!   the elbow's hinge as the motion bends it tells it ([`Twist::ElbowHinge`], over a file's
//!   frames or a few seconds of a stream), MVN's specification defines it (every segment the
//!   identity in its T-pose, palms down: [`Twist::NullPose`]), or, with no motion to tell,
//!   it is taken as palms down ([`Twist::Assumed`]).
//!
//! A calibration is made once — by `import` from a file, live from a stream, or read from a
//! file — and every fit of that person goes through it ([`crate::PoseFitter::new`]): imported
//! files store it with each capture's source ([`crate::CaptureSource::calibration`]), model
//! files carry the sources of their training data, and the live node fits a stream through the
//! calibration its model's data was imported with when the stream's rest pose is that
//! calibration's ([`Calibration::check_rest`]). So the same motion gives the same human angles
//! whether it comes as a file or as a stream.

use std::path::Path;

use nalgebra::{Matrix3, Rotation3, Vector3};
use serde::{Deserialize, Serialize};

use crate::fit::{mirror_rotation, mirror_vector, ArmTarget, HumanArms};
use crate::skeleton::ArmPose;
use crate::CaptureError;
use sgplvm_robots::Side;

/// The layout version of a [`Calibration`] this library writes and reads.
pub const CALIBRATION_VERSION: u32 = 1;

/// Largest difference of a rest point, as a fraction of the arm's length (upper arm plus
/// forearm), for a stream's rest pose to be a calibration's ([`Calibration::check_rest`]): 2 %
/// (1 cm on a person's arm) passes a suit's single-precision stream of the same skeleton and
/// tells two people apart by their proportions.
pub const REST_MATCH_FRACTION: f64 = 0.02;

/// How an upper arm's twist reference was told.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Twist {
    /// The rest pose tells it: the elbow bent at rest, or the upper arm away from the
    /// shoulder's gimbal point.
    RestPose,
    /// The rest pose leaves it untold; the elbow's hinge, as the motion bends it, told it.
    ElbowHinge {
        /// Frames in which the elbow was bent enough to count (more than 6°).
        frames: usize,
    },
    /// The rest pose leaves it untold; the stream's specification defines it: Xsens MVN's null
    /// pose has every segment's orientation the identity in its T-pose, palms down.
    NullPose,
    /// The rest pose leaves it untold and no motion showed it: taken as the arm reached by
    /// abduction alone (palms down).
    Assumed,
}

impl Twist {
    /// A sentence for reports.
    pub fn describe(&self) -> String {
        match self {
            Twist::RestPose => "told by the rest pose".to_string(),
            Twist::ElbowHinge { frames } => {
                format!("from the elbow's hinge over {frames} frames of motion")
            }
            Twist::NullPose => "MVN's null pose (T-pose, palms down) as specified".to_string(),
            Twist::Assumed => "untold: palms down assumed (no bent elbow seen)".to_string(),
        }
    }
}

/// One arm at rest, in the upper torso's body axes (x forward, y left, z up), in the capture's
/// length units, relative to the torso joint.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct RestPoints {
    /// The sternoclavicular joint (the shoulder itself without a clavicle segment).
    pub clavicle: [f64; 3],
    /// The shoulder joint centre.
    pub shoulder: [f64; 3],
    /// The elbow.
    pub elbow: [f64; 3],
    /// The wrist.
    pub wrist: [f64; 3],
    /// The hand's end (a finger base, an End Site, or one forearm past the wrist).
    pub hand_end: [f64; 3],
}

impl RestPoints {
    /// The rest points of `pose`.
    pub fn of(pose: &ArmPose) -> RestPoints {
        let a = |v: &Vector3<f64>| [v.x, v.y, v.z];
        RestPoints {
            clavicle: a(&pose.clavicle),
            shoulder: a(&pose.shoulder),
            elbow: a(&pose.elbow),
            wrist: a(&pose.wrist),
            hand_end: a(&pose.hand_tip),
        }
    }

    /// The points in order: clavicle, shoulder, elbow, wrist, hand end.
    pub fn points(&self) -> [Vector3<f64>; 5] {
        [
            self.clavicle,
            self.shoulder,
            self.elbow,
            self.wrist,
            self.hand_end,
        ]
        .map(Vector3::from)
    }

    /// Segment lengths, capture units: clavicle, upper arm, forearm, hand.
    pub fn segment_lengths(&self) -> [f64; 4] {
        let p = self.points();
        [0, 1, 2, 3].map(|k| (p[k + 1] - p[k]).norm())
    }

    /// Upper arm plus forearm, capture units.
    pub fn arm_length(&self) -> f64 {
        let s = self.segment_lengths();
        s[1] + s[2]
    }
}

/// One arm's calibration.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ArmCalibration {
    /// Whether the capture has a clavicle segment for this arm.
    pub has_clavicle: bool,
    /// The arm at rest.
    pub rest: RestPoints,
    /// Segment lengths at rest, capture units: clavicle, upper arm, forearm, hand.
    pub segment_lengths: [f64; 4],
    /// The twist reference: the human model's upper-arm frame at the capture's rest pose (the
    /// left arm's convention; rows of the rotation matrix).
    pub upper_arm_frame: [[f64; 3]; 3],
    /// The human model's hand frame at the capture's rest pose (as above).
    pub hand_frame: [[f64; 3]; 3],
    /// How the twist reference was told.
    pub twist: Twist,
}

impl ArmCalibration {
    /// [`ArmCalibration::upper_arm_frame`] as a rotation.
    pub fn upper_arm_rotation(&self) -> Rotation3<f64> {
        rotation(&self.upper_arm_frame)
    }

    /// [`ArmCalibration::hand_frame`] as a rotation.
    pub fn hand_rotation(&self) -> Rotation3<f64> {
        rotation(&self.hand_frame)
    }
}

/// A person's calibration (module docs).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Calibration {
    /// Layout version ([`CALIBRATION_VERSION`]).
    pub version: u32,
    /// What it was made from (`import of FILE`, `live: 4.0 s of /tf`, …).
    pub made_from: String,
    /// The naming scheme that found the arms (or `map file`, `Xsens MVN stream`).
    pub skeleton: String,
    /// Metres per capture length unit, where known.
    pub metres_per_unit: Option<f64>,
    /// Left arm, then right.
    pub arms: [ArmCalibration; 2],
}

/// Rows of a rotation matrix as a rotation (re-orthonormalised: a file's decimals round).
fn rotation(rows: &[[f64; 3]; 3]) -> Rotation3<f64> {
    let m = Matrix3::from_fn(|i, j| rows[i][j]);
    Rotation3::from_matrix(&m)
}

/// A rotation's rows.
fn rows(r: &Rotation3<f64>) -> [[f64; 3]; 3] {
    let m = r.matrix();
    [0, 1, 2].map(|i| [m[(i, 0)], m[(i, 1)], m[(i, 2)]])
}

/// A unit vector from `a` to `b`, or `fallback` where they coincide.
pub(crate) fn direction(
    a: &Vector3<f64>,
    b: &Vector3<f64>,
    fallback: Vector3<f64>,
) -> Vector3<f64> {
    (b - a).try_normalize(1e-12).unwrap_or(fallback)
}

/// `v` in the left arm's convention.
pub(crate) fn mirrored(side: Side, v: Vector3<f64>) -> Vector3<f64> {
    match side {
        Side::Left => v,
        Side::Right => mirror_vector(v),
    }
}

/// Turns a captured arm pose into the fit's target (left arm's convention), the arm's rest
/// frames `upper_rest` and `hand_rest` taken as its twist reference.
pub(crate) fn arm_target(
    pose: &ArmPose,
    side: Side,
    has_clavicle: bool,
    upper_rest: &Rotation3<f64>,
    hand_rest: &Rotation3<f64>,
) -> ArmTarget {
    let m = |v: Vector3<f64>| mirrored(side, v);
    let mr = |r: &Rotation3<f64>| match side {
        Side::Left => *r,
        Side::Right => mirror_rotation(r),
    };
    let down = -Vector3::z();
    let upper = m(direction(&pose.shoulder, &pose.elbow, down));
    ArmTarget {
        clavicle: (has_clavicle && (pose.shoulder - pose.clavicle).norm() > 1e-9)
            .then(|| m(direction(&pose.clavicle, &pose.shoulder, Vector3::y()))),
        upper_arm: upper,
        forearm: m(direction(&pose.elbow, &pose.wrist, upper)),
        upper_arm_frame: mr(&pose.upper_arm_turn) * upper_rest,
        hand_frame: mr(&pose.hand_turn) * hand_rest,
    }
}

/// Where each elbow bends the forearm as the motion shows it: the forearm's part across the
/// upper arm, taken back through the upper arm's turn from its rest into the upper arm's rest
/// orientation (body axes, the arm's own side), summed over the frames in which the elbow is
/// bent by more than 6° (so the more bent weigh more). What tells an upper arm's twist where
/// the rest pose does not ([`Twist::ElbowHinge`]); fed a file's frames by `import` and a
/// stream's first seconds by the live node.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct HingeEstimate {
    sum: [Vector3<f64>; 2],
    total: [f64; 2],
    frames: [usize; 2],
}

/// How much of the forearm must lie across the upper arm for a frame to count (sin 6°).
const BENT: f64 = 0.1;

impl HingeEstimate {
    /// No frames yet.
    pub fn new() -> HingeEstimate {
        HingeEstimate::default()
    }

    /// Adds one frame's arm poses (left, right).
    pub fn add(&mut self, poses: [&ArmPose; 2]) {
        for (s, pose) in poses.iter().enumerate() {
            let Some((_, bend)) = elbow_bend(pose) else {
                continue;
            };
            if bend.norm() > BENT {
                self.sum[s] += pose.upper_arm_turn.inverse() * bend;
                self.total[s] += bend.norm();
                self.frames[s] += 1;
            }
        }
    }

    /// Adds the frames `other` saw (another take of the same person).
    pub fn merge(&mut self, other: &HingeEstimate) {
        for s in 0..2 {
            self.sum[s] += other.sum[s];
            self.total[s] += other.total[s];
            self.frames[s] += other.frames[s];
        }
    }

    /// Frames of arm `side` in which the elbow was bent enough to count.
    pub fn bent_frames(&self, side: Side) -> usize {
        self.frames[side_index(side)]
    }

    /// The hinge's direction for arm `side` (body axes, its own side), or `None` if the elbow
    /// never bent far enough or bent no consistent way (the sum less than half the summed
    /// lengths).
    pub fn direction(&self, side: Side) -> Option<Vector3<f64>> {
        let s = side_index(side);
        (self.total[s] > 0.0 && self.sum[s].norm() > 0.5 * self.total[s])
            .then(|| self.sum[s].normalize())
    }
}

/// The upper arm's direction of `pose` and the forearm's direction's part across it (its length
/// the sine of the elbow's bend); `None` where a segment has no length.
pub(crate) fn elbow_bend(pose: &ArmPose) -> Option<(Vector3<f64>, Vector3<f64>)> {
    let u = (pose.elbow - pose.shoulder).try_normalize(1e-12)?;
    let w = (pose.wrist - pose.elbow).try_normalize(1e-12)?;
    Some((u, w - u * w.dot(&u)))
}

fn side_index(side: Side) -> usize {
    usize::from(side == Side::Right)
}

/// What a calibration is made from besides the rest pose: where the rest leaves an upper
/// arm's twist untold, the motion's hinge if there is one, else the twist `untold` says
/// ([`Twist::NullPose`] for a specification's null pose, [`Twist::Assumed`] otherwise).
#[derive(Debug, Clone, Copy)]
pub struct UntoldTwist<'a> {
    /// The elbow's hinge in the motion seen.
    pub hinge: Option<&'a HingeEstimate>,
    /// What an untold twist is taken as without a hinge.
    pub otherwise: Twist,
}

impl Calibration {
    /// Whether the rest poses (left, right) leave each upper arm's twist untold, so that a
    /// calibration needs motion ([`HingeEstimate`]) or a specification to tell it.
    pub fn untold(model: &HumanArms, rest: [&ArmPose; 2], has_clavicle: [bool; 2]) -> [bool; 2] {
        [Side::Left, Side::Right].map(|side| {
            let s = side_index(side);
            let t = arm_target(
                rest[s],
                side,
                has_clavicle[s],
                &Rotation3::identity(),
                &Rotation3::identity(),
            );
            model.rest_twist_untold(t.clavicle, t.upper_arm, t.forearm)
        })
    }

    /// The calibration of a capture whose arms rest as `rest` (left, right; body axes).
    /// `has_clavicle` says whether each arm's capture has a clavicle segment; `untold`, how an
    /// untold twist is told.
    pub fn from_rest(
        model: &HumanArms,
        rest: [&ArmPose; 2],
        has_clavicle: [bool; 2],
        untold: UntoldTwist<'_>,
        made_from: &str,
        skeleton: &str,
        metres_per_unit: Option<f64>,
    ) -> Calibration {
        let needs = Calibration::untold(model, rest, has_clavicle);
        let arms = [Side::Left, Side::Right].map(|side| {
            let s = side_index(side);
            let pose = rest[s];
            let t = arm_target(
                pose,
                side,
                has_clavicle[s],
                &Rotation3::identity(),
                &Rotation3::identity(),
            );
            let m = |v: Vector3<f64>| mirrored(side, v);
            let hand = m(direction(&pose.wrist, &pose.hand_tip, m(t.forearm)));
            let (hinge, twist) = if needs[s] {
                match untold.hinge.and_then(|h| Some((h.direction(side)?, h))) {
                    Some((d, h)) => (
                        Some(m(d)),
                        Twist::ElbowHinge {
                            frames: h.bent_frames(side),
                        },
                    ),
                    None => (None, untold.otherwise),
                }
            } else {
                (None, Twist::RestPose)
            };
            let frames = model.rest_frames(t.clavicle, t.upper_arm, t.forearm, hand, hinge);
            let rest = RestPoints::of(pose);
            ArmCalibration {
                has_clavicle: has_clavicle[s],
                segment_lengths: rest.segment_lengths(),
                rest,
                upper_arm_frame: rows(&frames.upper_arm),
                hand_frame: rows(&frames.hand),
                twist,
            }
        });
        Calibration {
            version: CALIBRATION_VERSION,
            made_from: made_from.to_string(),
            skeleton: skeleton.to_string(),
            metres_per_unit,
            arms,
        }
    }

    /// Segment lengths in metres (clavicle, upper arm, forearm, hand) of arm `side`, where the
    /// units are known.
    pub fn segment_lengths_m(&self, side: Side) -> Option<[f64; 4]> {
        let m = self.metres_per_unit?;
        Some(self.arms[side_index(side)].segment_lengths.map(|l| l * m))
    }

    /// Whether a source whose arms rest as `rest` (left, right; body axes, the source's units)
    /// is this calibration's: every rest point within [`REST_MATCH_FRACTION`] of the arm's
    /// length, both compared in arm lengths (units apart), and the clavicle segments alike.
    /// `Err` says what differs, for the message that the calibration is not used.
    pub fn check_rest(
        &self,
        rest: [&ArmPose; 2],
        has_clavicle: [bool; 2],
        hand_end: HandEnd,
    ) -> Result<(), String> {
        let names = [
            "sternoclavicular joint",
            "shoulder",
            "elbow",
            "wrist",
            "hand's end",
        ];
        for side in [Side::Left, Side::Right] {
            let s = side_index(side);
            let arm = &self.arms[s];
            if arm.has_clavicle != has_clavicle[s] {
                return Err(format!(
                    "the {} arm {} a clavicle segment here and {} in the calibration",
                    side.as_str(),
                    if has_clavicle[s] { "has" } else { "has no" },
                    if arm.has_clavicle { "one" } else { "none" },
                ));
            }
            let here = RestPoints::of(rest[s]);
            let (lc, lh) = (arm.rest.arm_length(), here.arm_length());
            if !(lc > 0.0 && lh > 0.0) {
                return Err(format!("the {} arm has no length at rest", side.as_str()));
            }
            for ((c, h), name) in arm.rest.points().iter().zip(here.points()).zip(names) {
                if name == "hand's end" && hand_end == HandEnd::Unmeasured {
                    continue;
                }
                let off = (c / lc - h / lh).norm();
                if off > REST_MATCH_FRACTION {
                    return Err(format!(
                        "the {} arm's {name} rests {:.1} % of the arm's length from the calibration's (at most {:.0} %)",
                        side.as_str(),
                        100.0 * off,
                        100.0 * REST_MATCH_FRACTION
                    ));
                }
            }
        }
        Ok(())
    }

    /// A sentence for reports: what it was made from and how each twist was told.
    pub fn describe(&self) -> String {
        let [l, r] = &self.arms;
        if l.twist == r.twist {
            format!("{} (twist {})", self.made_from, l.twist.describe())
        } else {
            format!(
                "{} (left twist {}, right twist {})",
                self.made_from,
                l.twist.describe(),
                r.twist.describe()
            )
        }
    }

    /// Reads a calibration from `path`: a JSON calibration (as [`Calibration::write`] writes
    /// it), or the first of those an imported demonstration file's capture sources carry.
    pub fn read(path: &Path) -> Result<Vec<Calibration>, CaptureError> {
        let file = path.display().to_string();
        let bad = |message: String| CaptureError::Calibration {
            file: file.clone(),
            message,
        };
        let bytes = std::fs::read(path).map_err(|e| bad(format!("cannot read it: {e}")))?;
        if bytes.starts_with(b"\x89MCAP") {
            let found: Vec<Calibration> = crate::read_capture_sources(path)?
                .into_iter()
                .filter_map(|s| s.calibration)
                .collect();
            if found.is_empty() {
                return Err(bad(
                    "holds no calibration: its capture sources were imported before calibrations were stored (import the capture again)".into(),
                ));
            }
            return Ok(found);
        }
        let text = String::from_utf8(bytes)
            .map_err(|_| bad("neither an MCAP file nor JSON text".into()))?;
        let value: serde_json::Value = serde_json::from_str(&text)
            .map_err(|e| bad(format!("not JSON ({e}); expected a calibration")))?;
        let version = value.get("version").and_then(serde_json::Value::as_u64);
        if version != Some(u64::from(CALIBRATION_VERSION)) {
            return Err(bad(format!(
                "calibration version {}; this library reads version {CALIBRATION_VERSION}",
                version.map_or("missing".to_string(), |v| v.to_string())
            )));
        }
        let calibration: Calibration =
            serde_json::from_value(value).map_err(|e| bad(format!("not a calibration: {e}")))?;
        calibration.validate().map_err(bad)?;
        Ok(vec![calibration])
    }

    /// Checks the values a file could get wrong: finite points, rotation matrices.
    pub fn validate(&self) -> Result<(), String> {
        for (arm, side) in self.arms.iter().zip(["left", "right"]) {
            let finite = arm
                .rest
                .points()
                .iter()
                .flat_map(|p| p.iter().copied().collect::<Vec<_>>())
                .chain(arm.upper_arm_frame.iter().flatten().copied())
                .chain(arm.hand_frame.iter().flatten().copied())
                .all(f64::is_finite);
            if !finite {
                return Err(format!(
                    "the {side} arm holds a value that is not a finite number"
                ));
            }
            for (what, m) in [
                ("upper_arm_frame", &arm.upper_arm_frame),
                ("hand_frame", &arm.hand_frame),
            ] {
                let m = Matrix3::from_fn(|i, j| m[i][j]);
                if (m * m.transpose() - Matrix3::identity()).amax() > 1e-6 || m.determinant() < 0.0
                {
                    return Err(format!(
                        "the {side} arm's `{what}` is not a rotation matrix"
                    ));
                }
            }
        }
        Ok(())
    }

    /// Writes the calibration as JSON to `path` (whole or not at all).
    pub fn write(&self, path: &Path) -> Result<(), CaptureError> {
        let file = path.display().to_string();
        let text = serde_json::to_string_pretty(self).map_err(|e| CaptureError::Calibration {
            file: file.clone(),
            message: format!("cannot encode it: {e}"),
        })?;
        let tmp = sgplvm_robots::files::temporary_path(path);
        std::fs::write(&tmp, text)
            .and_then(|()| std::fs::rename(&tmp, path))
            .map_err(|e| {
                let _ = std::fs::remove_file(&tmp);
                CaptureError::Calibration {
                    file,
                    message: format!("cannot write it: {e}"),
                }
            })
    }
}

/// Whether a source's rest pose measures where each hand ends (a file's End Site or a hand's
/// child joint does; an MVN stream's segments end at the wrist, and its hand's end is only
/// put a forearm's length beyond it): an unmeasured end is not compared with a calibration's.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum HandEnd {
    /// The rest pose says where the hand ends.
    Measured,
    /// It does not.
    Unmeasured,
}

/// Of `candidates`, the one whose rest pose is that of a source resting as `rest`, nearest
/// first; `Err` lists why each was not.
pub fn choose<'a>(
    candidates: &'a [Calibration],
    rest: [&ArmPose; 2],
    has_clavicle: [bool; 2],
    hand_end: HandEnd,
) -> Result<&'a Calibration, Vec<String>> {
    let mut why = Vec::new();
    for c in candidates {
        match c.check_rest(rest, has_clavicle, hand_end) {
            Ok(()) => return Ok(c),
            Err(e) => why.push(format!("{}: {e}", c.made_from)),
        }
    }
    Err(why)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pose(upper: Vector3<f64>, fore: Vector3<f64>) -> ArmPose {
        let clavicle = Vector3::new(0.0, 0.02, 0.2);
        let shoulder = clavicle + Vector3::new(0.0, 0.15, 0.0);
        let elbow = shoulder + 0.28 * upper;
        let wrist = elbow + 0.25 * fore;
        ArmPose {
            clavicle,
            shoulder,
            elbow,
            wrist,
            hand_tip: wrist + 0.1 * fore,
            upper_arm_turn: Rotation3::identity(),
            hand_turn: Rotation3::identity(),
        }
    }

    fn mirror(p: &ArmPose) -> ArmPose {
        ArmPose {
            clavicle: mirror_vector(p.clavicle),
            shoulder: mirror_vector(p.shoulder),
            elbow: mirror_vector(p.elbow),
            wrist: mirror_vector(p.wrist),
            hand_tip: mirror_vector(p.hand_tip),
            ..*p
        }
    }

    fn model() -> HumanArms {
        HumanArms::new(&sgplvm_robots::Robot::builtin("human").unwrap()).unwrap()
    }

    #[test]
    fn a_t_pose_leaves_the_twist_untold_and_a_hinge_tells_it() {
        let h = model();
        let left = pose(Vector3::y(), Vector3::y());
        let right = mirror(&left);
        assert_eq!(
            Calibration::untold(&h, [&left, &right], [true, true]),
            [true, true]
        );
        let none = UntoldTwist {
            hinge: None,
            otherwise: Twist::Assumed,
        };
        let c = Calibration::from_rest(&h, [&left, &right], [true, true], none, "test", "t", None);
        assert_eq!(c.arms[0].twist, Twist::Assumed);
        // Elbows bending upwards in the motion (palms forward): the hinge tells the twist.
        let mut hinge = HingeEstimate::new();
        let bent = pose(Vector3::y(), Vector3::new(0.0, 0.7, 0.7).normalize());
        hinge.add([&bent, &mirror(&bent)]);
        let told = UntoldTwist {
            hinge: Some(&hinge),
            otherwise: Twist::Assumed,
        };
        let c2 = Calibration::from_rest(&h, [&left, &right], [true, true], told, "test", "t", None);
        assert_eq!(c2.arms[1].twist, Twist::ElbowHinge { frames: 1 });
        // Palms down (the elbow bends forward) against elbows bending upwards: a quarter turn
        // of the upper arm apart.
        let turn = c.arms[0].upper_arm_rotation().inverse() * c2.arms[0].upper_arm_rotation();
        assert!(
            (turn.angle() - std::f64::consts::FRAC_PI_2).abs() < 1e-9,
            "{}",
            turn.angle()
        );
    }

    #[test]
    fn a_crooked_line_of_bones_leaves_the_twist_untold_and_a_t_pose_tells_it() {
        // Character Creator's CMU conversions rest in a line of bones with the upper arm 5.3°
        // off the clavicle's line (the twist taken from it pinned the forearms' pronation to
        // its limit in every frame); the CMU T-poses lie 9° and further.
        let h = model();
        let off = |deg: f64| {
            let a = deg.to_radians();
            let upper = Vector3::new(0.0, a.cos(), a.sin());
            let left = pose(upper, upper);
            let right = mirror(&left);
            Calibration::untold(&h, [&left, &right], [true, true])
        };
        assert_eq!(off(5.3), [true, true]);
        assert_eq!(off(9.0), [false, false]);
    }

    #[test]
    fn a_bent_rest_elbow_tells_the_twist() {
        let h = model();
        let left = pose(-Vector3::z(), Vector3::x());
        let right = mirror(&left);
        assert_eq!(
            Calibration::untold(&h, [&left, &right], [true, true]),
            [false, false]
        );
        let c = Calibration::from_rest(
            &h,
            [&left, &right],
            [true, true],
            UntoldTwist {
                hinge: None,
                otherwise: Twist::Assumed,
            },
            "test",
            "t",
            Some(1.0),
        );
        assert_eq!(c.arms[0].twist, Twist::RestPose);
        let l = c.segment_lengths_m(Side::Left).unwrap();
        assert!(
            (l[1] - 0.28).abs() < 1e-12 && (l[2] - 0.25).abs() < 1e-12,
            "{l:?}"
        );
    }

    #[test]
    fn rest_poses_match_in_any_units_and_not_across_proportions() {
        let h = model();
        let left = pose(-Vector3::z(), Vector3::x());
        let right = mirror(&left);
        let untold = UntoldTwist {
            hinge: None,
            otherwise: Twist::Assumed,
        };
        let c = Calibration::from_rest(&h, [&left, &right], [true, true], untold, "t", "t", None);
        let scale = |p: &ArmPose, k: f64| ArmPose {
            clavicle: p.clavicle * k,
            shoulder: p.shoulder * k,
            elbow: p.elbow * k,
            wrist: p.wrist * k,
            hand_tip: p.hand_tip * k,
            ..*p
        };
        // The same person in centimetres.
        let (l, r) = (scale(&left, 100.0), scale(&right, 100.0));
        assert!(c
            .check_rest([&l, &r], [true, true], HandEnd::Measured)
            .is_ok());
        // A forearm 15 % longer: another person.
        let mut other = left;
        other.wrist = other.elbow + 0.29 * Vector3::x();
        other.hand_tip = other.wrist + 0.1 * Vector3::x();
        let e = c
            .check_rest([&other, &right], [true, true], HandEnd::Measured)
            .unwrap_err();
        assert!(e.contains("left arm's"), "{e}");
        let e = c
            .check_rest([&left, &right], [false, true], HandEnd::Measured)
            .unwrap_err();
        assert!(e.contains("clavicle"), "{e}");
    }

    #[test]
    fn a_calibration_round_trips_through_json_and_bad_files_are_named() {
        let h = model();
        let left = pose(Vector3::y(), Vector3::y());
        let right = mirror(&left);
        let untold = UntoldTwist {
            hinge: None,
            otherwise: Twist::NullPose,
        };
        let c = Calibration::from_rest(
            &h,
            [&left, &right],
            [true, true],
            untold,
            "t",
            "t",
            Some(0.01),
        );
        let dir = std::env::temp_dir().join(format!("sgplvm-cal-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("person.json");
        c.write(&path).unwrap();
        assert_eq!(Calibration::read(&path).unwrap(), vec![c.clone()]);
        let mut text: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
        text["version"] = 99.into();
        std::fs::write(&path, text.to_string()).unwrap();
        let e = Calibration::read(&path).unwrap_err().to_string();
        assert!(e.contains("person.json") && e.contains("version 99"), "{e}");
        text["version"] = 1.into();
        text["arms"][0]["hand_frame"][0][0] = 3.0.into();
        std::fs::write(&path, text.to_string()).unwrap();
        let e = Calibration::read(&path).unwrap_err().to_string();
        assert!(e.contains("hand_frame") && e.contains("rotation"), "{e}");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
