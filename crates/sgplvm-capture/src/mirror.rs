//! Skeletons whose `Left` and `Right` are the person's right and left. A Kinect v1 / OpenNI
//! recording labels the sides as the camera sees the person, mirrored: its `ShoulderLeft` is
//! the person's right shoulder. Nothing in the names or the rest pose tells; the motion does.
//! The body axes come from the labels (left from the `Right` arm to the `Left` one), so a
//! mirror-labelled person is seen from behind, and an elbow, which bends the forearm to the
//! front of the upper arm, bends it backwards in every frame.
//!
//! The import counts, frame by frame and arm by arm, the elbows that bend clearly forwards or
//! backwards ([`ElbowBends`]) and, where each arm's bend backwards in nearly every frame it is
//! judged in, over at least a second of them, says so with the `--map` that swaps the
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

/// Least motion (seconds of frames) in which each arm must be judged for the elbows to say the
/// sides are mirrored: a moment of a hand behind the back (upper arm back, forearm towards the
/// midline, judged backwards) lasts less, a mirrored recording's bends last its whole length.
pub const MIN_JUDGED_SECONDS: f64 = 1.0;

/// Least share of each arm's judged frames that must bend backwards for the sides to be said
/// mirrored (a mirror-labelled Kinect recording: 280 of 281 and 261 of 261).
pub const MOSTLY: f64 = 0.9;

/// Which way the elbows bent over a capture's frames, arm by arm (module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct ElbowBends {
    /// Frames per second of the poses added, which sets the least judged frames per arm.
    frame_rate: f64,
    /// Per arm (left, right): frames judged.
    judged: [usize; 2],
    /// Per arm: of those, frames bent backwards.
    backwards: [usize; 2],
}

impl ElbowBends {
    /// No frames yet; the poses will be added at `frame_rate` frames per second (the file's
    /// own frames, which the import judges before it resamples).
    pub fn new(frame_rate: f64) -> ElbowBends {
        ElbowBends {
            frame_rate,
            judged: [0; 2],
            backwards: [0; 2],
        }
    }

    /// Adds one frame's arm poses (left, right; body axes).
    pub fn add(&mut self, poses: [&ArmPose; 2]) {
        for (arm, pose) in poses.iter().enumerate() {
            if let Some(backwards) = bends_backwards(pose) {
                self.judged[arm] += 1;
                self.backwards[arm] += usize::from(backwards);
            }
        }
    }

    /// Arm frames (both arms counted) in which an elbow bent clearly forwards or backwards.
    pub fn judged(&self) -> usize {
        self.judged.iter().sum()
    }

    /// Of those, the arm frames in which it bent backwards.
    pub fn backwards(&self) -> usize {
        self.backwards.iter().sum()
    }

    /// Least judged frames per arm: [`MIN_JUDGED_SECONDS`] of frames (at least one).
    pub fn min_judged(&self) -> usize {
        ((MIN_JUDGED_SECONDS * self.frame_rate).ceil() as usize).max(1)
    }

    /// Whether each arm was judged in at least [`ElbowBends::min_judged`] frames and bent
    /// backwards in at least [`MOSTLY`] of them.
    pub fn mostly_backwards(&self) -> bool {
        (0..2).all(|arm| {
            let judged = self.judged[arm];
            judged >= self.min_judged() && self.backwards[arm] as f64 >= MOSTLY * judged as f64
        })
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

/// What the import says of a capture whose elbows bend backwards, each arm nearly always: its sides are
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
    /// The finding where `bends` bent backwards ([`ElbowBends::mostly_backwards`]); `swapped` is the skeleton's arms with
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
            "the elbows bend backwards in {} of {} arm frames where they clearly bend forwards or backwards (each arm in at least {:.0} % of its own): the skeleton's Left and Right are probably the person's right and left (as Kinect v1 / OpenNI recordings label them), the person seen from behind. The angles are those of the sides as the file names them; to swap the sides, import with --map FILE, FILE holding {}",
            self.backwards,
            self.judged,
            100.0 * MOSTLY,
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
    fn nearly_every_judged_frame_of_each_arm_backwards_for_a_second_says_mirrored() {
        let down = -Vector3::z();
        let forwards = arm(down, Vector3::x());
        let backwards = arm(down, -Vector3::x());
        let straight = arm(down, down);
        // At 30 frames per second: a second is 30 judged frames per arm.
        let mut bends = ElbowBends::new(30.0);
        assert_eq!(bends.min_judged(), 30);
        for _ in 0..29 {
            bends.add([&backwards, &backwards]);
        }
        // Too few frames to say.
        assert!(!bends.mostly_backwards());
        bends.add([&backwards, &backwards]);
        assert!(bends.mostly_backwards());
        // 90 % of each arm's frames still say it, fewer do not.
        for _ in 0..3 {
            bends.add([&forwards, &forwards]);
        }
        assert_eq!((bends.judged(), bends.backwards()), (66, 60));
        let map = ArmMap(BTreeMap::from([
            ("jRightShoulder".to_string(), "ShoulderLeft".to_string()),
            ("jLeftShoulder".to_string(), "ShoulderRight".to_string()),
        ]));
        let found = SidesMirrored::of(&bends, map).unwrap();
        assert_eq!(
            found.map_json(),
            r#"{"jLeftShoulder": "ShoulderRight", "jRightShoulder": "ShoulderLeft"}"#
        );
        assert!(
            found.describe().contains("60 of 66"),
            "{}",
            found.describe()
        );
        bends.add([&straight, &forwards]);
        assert!(SidesMirrored::of(&bends, ArmMap::default()).is_none());
        // One arm alone, however long, does not say it.
        let mut one = ElbowBends::new(30.0);
        for _ in 0..300 {
            one.add([&backwards, &straight]);
        }
        assert!(!one.mostly_backwards());
    }

    #[test]
    fn a_moment_of_a_hand_behind_the_back_does_not_say_mirrored() {
        let down = -Vector3::z();
        // Upper arm 30° back, forearm towards the midline behind the back.
        let behind = arm(
            Vector3::new(-0.5, 0.0, -0.866),
            Vector3::new(-0.3, -1.0, 0.4),
        );
        assert_eq!(bends_backwards(&behind), Some(true));
        let straight = arm(down, Vector3::new(0.05, 0.0, -1.0));
        assert_eq!(bends_backwards(&straight), None);
        // Ten seconds at 30 frames per second, arms straight but for both hands behind the
        // back for half a second: every judged frame bends backwards, over 15 frames an arm.
        let mut bends = ElbowBends::new(30.0);
        for frame in 0..300 {
            let pose = if (100..115).contains(&frame) {
                &behind
            } else {
                &straight
            };
            bends.add([pose, pose]);
        }
        assert_eq!((bends.judged(), bends.backwards()), (30, 30));
        assert!(!bends.mostly_backwards());
    }
}
