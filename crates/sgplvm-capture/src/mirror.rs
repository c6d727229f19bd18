//! Skeletons whose `Left` and `Right` are the person's right and left. A Kinect v1 / OpenNI
//! recording labels the sides as the camera sees the person, mirrored: its `ShoulderLeft` is
//! the person's right shoulder. Nothing in the names or the rest pose tells; the motion does.
//! The body axes come from the labels (left from the `Right` arm to the `Left` one), so a
//! mirror-labelled person is seen from behind, and an elbow, which bends the forearm to the
//! front of the upper arm, bends it backwards in every frame.
//!
//! The import counts, frame by frame, the elbows that bend clearly forwards or backwards
//! ([`ElbowBends`]) and, where most bend backwards, says so with the `--map` that swaps the
//! sides, in the file's own segment names ([`SidesMirrored`]). It does not swap them itself:
//! the angles are those of the sides as the file names them.

use std::collections::BTreeMap;

use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

use crate::calibration::elbow_bend;
use crate::skeleton::{ArmMap, ArmPose};

/// How much of the forearm must lie across the upper arm for an elbow's bend to be judged
/// (sin 30°).
const CLEARLY_BENT: f64 = 0.5;

/// How far below the horizontal an upper arm must point for the front of the elbow's bend to
/// be told (the sine of the angle, 30°). A hanging arm bends its forearm forwards, or to either
/// side as far as the shoulder turns it (up to 90°), never backwards; a raised one may (an arm
/// out to the side turned outwards, as in a throw, holds the forearm up and back), and one
/// held forwards bends it up, down or sideways. Of 100,000 poses of the human model drawn
/// within natural ranges (flexion −29° to 92°, abduction 0 to 92°, rotation −57° to 69°, elbow
/// 17° to 138°), 30,117 were judged and 1 bent backwards (at 0°, 5 % of 60,268 would).
const LOWERED: f64 = 0.5;

/// Least cosine between the bend and the front (or the back) for it to count as either
/// (within 75° of it): a bend to the side tells neither.
const FRONT_OR_BACK: f64 = 0.25;

/// Fewest judged arm frames for the elbows to say the sides are mirrored.
pub const MIN_JUDGED_FRAMES: usize = 10;

/// Which way the elbows bent over a capture's frames (module docs).
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct ElbowBends {
    judged: usize,
    backwards: usize,
}

impl ElbowBends {
    /// No frames yet.
    pub fn new() -> ElbowBends {
        ElbowBends::default()
    }

    /// Adds one frame's arm poses (left, right; body axes).
    pub fn add(&mut self, poses: [&ArmPose; 2]) {
        for pose in poses {
            if let Some(backwards) = bends_backwards(pose) {
                self.judged += 1;
                self.backwards += usize::from(backwards);
            }
        }
    }

    /// Arm frames (both arms counted) in which an elbow bent clearly forwards or backwards.
    pub fn judged(&self) -> usize {
        self.judged
    }

    /// Of those, the arm frames in which it bent backwards.
    pub fn backwards(&self) -> usize {
        self.backwards
    }

    /// Whether most judged arm frames, of at least [`MIN_JUDGED_FRAMES`], bent backwards.
    pub fn mostly_backwards(&self) -> bool {
        self.judged >= MIN_JUDGED_FRAMES && 2 * self.backwards > self.judged
    }
}

/// Whether the elbow of `pose` (body axes) bends the forearm behind the upper arm
/// (`Some(true)`) or in front of it (`Some(false)`); `None` where that is not told: the elbow
/// nearly straight, the upper arm not lowered ([`LOWERED`]), or the bend to the side.
fn bends_backwards(pose: &ArmPose) -> Option<bool> {
    let (upper, bend) = elbow_bend(pose)?;
    if bend.norm() <= CLEARLY_BENT || upper.z > -LOWERED {
        return None;
    }
    // The body's forward direction square to the upper arm (at least half a unit long, the
    // arm lowered).
    let front = Vector3::x() - upper * upper.x;
    let cosine = bend.normalize().dot(&front.normalize());
    (cosine.abs() >= FRONT_OR_BACK).then_some(cosine < 0.0)
}

/// What the import says of a capture whose elbows mostly bend backwards: its sides are
/// probably mirrored (module docs).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct SidesMirrored {
    /// Arm frames in which an elbow bent clearly forwards or backwards.
    pub judged: usize,
    /// Of those, the arm frames in which it bent backwards.
    pub backwards: usize,
    /// The `--map` that swaps the sides, in the file's segment names (model joint group →
    /// segment).
    pub swapped_map: BTreeMap<String, String>,
}

impl SidesMirrored {
    /// The finding where `bends` mostly bent backwards; `swapped` is the skeleton's arms with
    /// the sides swapped ([`crate::Skeleton::swapped_map`]).
    pub fn of(bends: &ElbowBends, swapped: ArmMap) -> Option<SidesMirrored> {
        bends.mostly_backwards().then(|| SidesMirrored {
            judged: bends.judged(),
            backwards: bends.backwards(),
            swapped_map: swapped.0,
        })
    }

    /// The swapped map as a JSON object, the model's joint groups in their order (clavicle,
    /// shoulder, elbow, wrist; left, then right).
    pub fn map_json(&self) -> String {
        let pairs: Vec<String> = ArmMap::known_keys()
            .iter()
            .filter_map(|key| {
                let segment = self.swapped_map.get(key)?;
                Some(format!(
                    "{}: {}",
                    serde_json::Value::from(key.as_str()),
                    serde_json::Value::from(segment.as_str())
                ))
            })
            .collect();
        format!("{{{}}}", pairs.join(", "))
    }

    /// A sentence for the import's report.
    pub fn describe(&self) -> String {
        format!(
            "the elbows bend backwards in {} of {} arm frames where they clearly bend forwards or backwards: the skeleton's Left and Right are probably the person's right and left (as Kinect v1 / OpenNI recordings label them), the person seen from behind. The angles are those of the sides as the file names them; to swap the sides, import with --map FILE, FILE holding {}",
            self.backwards,
            self.judged,
            self.map_json()
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Rotation3;

    /// An arm (the left one; body axes) with the upper arm along `upper` and the forearm along
    /// `fore`.
    fn arm(upper: Vector3<f64>, fore: Vector3<f64>) -> ArmPose {
        let shoulder = Vector3::new(0.0, 0.2, 0.0);
        let elbow = shoulder + 0.3 * upper.normalize();
        let wrist = elbow + 0.25 * fore.normalize();
        ArmPose {
            clavicle: shoulder,
            shoulder,
            elbow,
            wrist,
            hand_tip: wrist + 0.1 * fore.normalize(),
            upper_arm_turn: Rotation3::identity(),
            hand_turn: Rotation3::identity(),
        }
    }

    #[test]
    fn an_elbow_bending_forwards_or_backwards_is_told_and_unclear_ones_are_not() {
        let down = -Vector3::z();
        // Hanging arm, forearm raised forwards (or backwards: no person's elbow does that).
        assert_eq!(bends_backwards(&arm(down, Vector3::x())), Some(false));
        assert_eq!(bends_backwards(&arm(down, -Vector3::x())), Some(true));
        // Lowered 45° to the side, and forwards.
        let side = Vector3::new(0.0, 1.0, -1.0);
        assert_eq!(bends_backwards(&arm(side, Vector3::x())), Some(false));
        let front = Vector3::new(1.0, 0.0, -1.0);
        assert_eq!(
            bends_backwards(&arm(front, Vector3::new(1.0, 0.0, 1.0))),
            Some(false)
        );
        // Not told: the elbow bent by 10°, the arm out to the side (a throw holds the forearm
        // up and back), raised overhead, a bend to the side (the hand on the belly).
        let little = Vector3::new(0.17, 0.0, -1.0);
        assert_eq!(bends_backwards(&arm(down, little)), None);
        let throw = Vector3::new(-1.0, 0.0, 1.0);
        assert_eq!(bends_backwards(&arm(Vector3::y(), throw)), None);
        assert_eq!(bends_backwards(&arm(Vector3::z(), -Vector3::x())), None);
        assert_eq!(bends_backwards(&arm(down, -Vector3::y())), None);
    }

    #[test]
    fn most_judged_frames_backwards_say_the_sides_are_mirrored() {
        let down = -Vector3::z();
        let forwards = arm(down, Vector3::x());
        let backwards = arm(down, -Vector3::x());
        let mut bends = ElbowBends::new();
        for _ in 0..4 {
            bends.add([&backwards, &backwards]);
        }
        // Too few frames to say.
        assert!(!bends.mostly_backwards());
        bends.add([&backwards, &forwards]);
        assert_eq!((bends.judged(), bends.backwards()), (10, 9));
        assert!(bends.mostly_backwards());
        let map = ArmMap(BTreeMap::from([
            ("jRightShoulder".to_string(), "ShoulderLeft".to_string()),
            ("jLeftShoulder".to_string(), "ShoulderRight".to_string()),
        ]));
        let found = SidesMirrored::of(&bends, map).unwrap();
        assert_eq!(
            found.map_json(),
            r#"{"jLeftShoulder": "ShoulderRight", "jRightShoulder": "ShoulderLeft"}"#
        );
        assert!(found.describe().contains("9 of 10"), "{}", found.describe());
        for _ in 0..10 {
            bends.add([&forwards, &forwards]);
        }
        assert!(SidesMirrored::of(&bends, ArmMap::default()).is_none());
    }
}
