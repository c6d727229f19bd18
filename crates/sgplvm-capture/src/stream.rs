//! The per-frame fit of a capture, one frame at a time: each arm's calibration from its rest
//! pose, then every frame's arm poses (shoulder, elbow, wrist, hand in the upper torso's body
//! axes) turned into the human model's 18 angles, each arm continuing from its previous
//! frame's angles, with how far the model lands from the capture. `sgplvm import` runs it over
//! a file's frames; the live sources (Xsens MVN, TF skeletons) over a stream's: one fit for
//! both.

use nalgebra::{Rotation3, Vector3};

use crate::fit::{mirror_rotation, mirror_vector, ArmAngles, ArmTarget, HumanArms, RestFrames};
use crate::skeleton::ArmPose;
use crate::{ELBOW_ANGLE_LIMIT_DEG, WORST_RESIDUAL_LIMIT_M};
use sgplvm_robots::Side;

/// One arm's calibration: its rest frames in the left arm's convention.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct ArmCalibration {
    pub(super) rest: RestFrames,
}

/// A unit vector from `a` to `b`, or `fallback` where they coincide.
pub(super) fn direction(
    a: &Vector3<f64>,
    b: &Vector3<f64>,
    fallback: Vector3<f64>,
) -> Vector3<f64> {
    (b - a).try_normalize(1e-12).unwrap_or(fallback)
}

/// `v` in the left arm's convention.
pub(super) fn mirrored(side: Side, v: Vector3<f64>) -> Vector3<f64> {
    match side {
        Side::Left => v,
        Side::Right => mirror_vector(v),
    }
}

/// Turns a captured arm pose into the fit's target (left arm's convention).
pub(super) fn arm_target(
    pose: &ArmPose,
    side: Side,
    has_clavicle: bool,
    cal: &ArmCalibration,
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
        upper_arm_frame: mr(&pose.upper_arm_turn) * cal.rest.upper_arm,
        hand_frame: mr(&pose.hand_turn) * cal.rest.hand,
    }
}

/// One arm's fit of one frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ArmFitResult {
    /// The model's 9 angles of the arm, within limits.
    pub angles: ArmAngles,
    /// Which of them sit at a limit.
    pub clamped: [bool; 9],
    /// The model's elbow's distance to the scaled capture's, metres.
    pub elbow_m: f64,
    /// The model's wrist's distance to the scaled capture's, metres.
    pub wrist_m: f64,
    /// The elbow angle's difference from the capture's, degrees.
    pub elbow_angle_deg: f64,
}

impl ArmFitResult {
    /// Whether the frame is beyond what a faithful fit stays within (3 cm, 2°).
    pub fn beyond(&self) -> bool {
        self.elbow_m > WORST_RESIDUAL_LIMIT_M
            || self.wrist_m > WORST_RESIDUAL_LIMIT_M
            || self.elbow_angle_deg > ELBOW_ANGLE_LIMIT_DEG
    }
}

/// The fit of a stream of arm poses (module docs).
#[derive(Debug, Clone)]
pub struct PoseFitter {
    model: HumanArms,
    calibration: [ArmCalibration; 2],
    has_clavicle: [bool; 2],
    prev: [Option<ArmAngles>; 2],
}

impl PoseFitter {
    /// A fitter calibrated on the rest poses of both arms (left, right). `has_clavicle` says
    /// whether each arm's capture has a clavicle segment; `hinge`, for an arm whose rest pose
    /// leaves the shoulder's twist untold ([`HumanArms::rest_twist_untold`]), the direction a
    /// bent elbow takes the forearm in the upper arm's rest orientation (body axes, the arm's
    /// own side) as the motion shows it, if known.
    pub fn new(
        model: HumanArms,
        rest: [&ArmPose; 2],
        has_clavicle: [bool; 2],
        hinge: &dyn Fn(Side) -> Option<Vector3<f64>>,
    ) -> PoseFitter {
        let calibration = [Side::Left, Side::Right].map(|side| {
            let s = usize::from(side == Side::Right);
            let pose = rest[s];
            let provisional = ArmCalibration {
                rest: RestFrames {
                    upper_arm: Rotation3::identity(),
                    hand: Rotation3::identity(),
                },
            };
            let t = arm_target(pose, side, has_clavicle[s], &provisional);
            let m = |v: Vector3<f64>| mirrored(side, v);
            let hand = m(direction(&pose.wrist, &pose.hand_tip, m(t.forearm)));
            let hinge = if model.rest_twist_untold(t.clavicle, t.upper_arm, t.forearm) {
                hinge(side).map(m)
            } else {
                None
            };
            ArmCalibration {
                rest: model.rest_frames(t.clavicle, t.upper_arm, t.forearm, hand, hinge),
            }
        });
        PoseFitter {
            model,
            calibration,
            has_clavicle,
            prev: [None, None],
        }
    }

    /// The human model's fit.
    pub fn model(&self) -> &HumanArms {
        &self.model
    }

    /// Forgets the previous frame (the next one is fitted on its own, as a first frame).
    pub fn reset(&mut self) {
        self.prev = [None, None];
    }

    /// One frame of both arms (left, right): the model's angles and the residuals, each arm
    /// continuing from its previous frame's angles.
    pub fn fit(&mut self, poses: [&ArmPose; 2]) -> [ArmFitResult; 2] {
        [Side::Left, Side::Right].map(|side| {
            let s = usize::from(side == Side::Right);
            let t = arm_target(poses[s], side, self.has_clavicle[s], &self.calibration[s]);
            let fit = self.model.fit(side, &t, self.prev[s].as_ref());
            self.prev[s] = Some(fit.angles);
            let points = self.model.target_points(&t);
            let (ep, wp) = (mirrored(side, points.elbow), mirrored(side, points.wrist));
            let (e, w) = self.model.elbow_and_wrist(side, &fit.angles);
            ArmFitResult {
                angles: fit.angles,
                clamped: fit.clamped,
                elbow_m: (e - ep).norm(),
                wrist_m: (w - wp).norm(),
                elbow_angle_deg: (fit.capture_elbow_angle - fit.angles[5]).abs().to_degrees(),
            }
        })
    }

    /// One frame's 18 angles (left arm, then right) from [`PoseFitter::fit`]'s results.
    pub fn angles(results: &[ArmFitResult; 2]) -> [f64; 18] {
        let mut q = [0.0; 18];
        for (s, r) in results.iter().enumerate() {
            q[9 * s..9 * s + 9].copy_from_slice(&r.angles);
        }
        q
    }
}
