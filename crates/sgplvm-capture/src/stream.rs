//! The per-frame fit of a capture, one frame at a time, through the person's
//! [`Calibration`]: every frame's arm poses (shoulder, elbow, wrist, hand in the upper torso's body
//! axes) turned into the human model's 18 angles, each arm continuing from its previous
//! frame's angles, with how far the model lands from the capture. `sgplvm import` runs it over
//! a file's frames; the live sources (Xsens MVN, TF skeletons) over a stream's: one fit for
//! both.

use nalgebra::Rotation3;

use crate::calibration::{arm_target, mirrored, Calibration};
use crate::fit::{ArmAngles, HumanArms};
use crate::skeleton::ArmPose;
use crate::{ELBOW_ANGLE_LIMIT_DEG, WORST_RESIDUAL_LIMIT_M};
use sgplvm_robots::Side;

/// One frame's fit: the human model's 18 angles (left arm, then right) and each arm's result.
pub type FrameFit = ([f64; 18], [ArmFitResult; 2]);

/// One arm's fit of one frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ArmFitResult {
    /// The model's 9 angles of the arm, within limits.
    pub angles: ArmAngles,
    /// Which of them sit at a limit: held there by the fit, or on it within [`AT_LIMIT_RAD`]
    /// (a capture already within the limits, such as a stream made from imported angles,
    /// reads as its file did).
    pub clamped: [bool; 9],
    /// The model's elbow's distance to the scaled capture's, metres.
    pub elbow_m: f64,
    /// The model's wrist's distance to the scaled capture's, metres.
    pub wrist_m: f64,
    /// The elbow angle's difference from the capture's, degrees.
    pub elbow_angle_deg: f64,
}

/// How near a limit an angle counts as at it, radians: an Xsens MVN stream's single
/// precision.
pub const AT_LIMIT_RAD: f64 = 1e-4;

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
    calibration: Calibration,
    /// Per arm, the twist reference (the human model's upper-arm and hand frames at rest).
    rest_frames: [(Rotation3<f64>, Rotation3<f64>); 2],
    prev: [Option<ArmAngles>; 2],
}

impl PoseFitter {
    /// A fitter of the person `calibration` describes.
    pub fn new(model: HumanArms, calibration: &Calibration) -> PoseFitter {
        PoseFitter {
            model,
            rest_frames: [0, 1].map(|s| {
                let arm = &calibration.arms[s];
                (arm.upper_arm_rotation(), arm.hand_rotation())
            }),
            calibration: calibration.clone(),
            prev: [None, None],
        }
    }

    /// The calibration frames are fitted through.
    pub fn calibration(&self) -> &Calibration {
        &self.calibration
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
            let (upper_rest, hand_rest) = &self.rest_frames[s];
            let has_clavicle = self.calibration.arms[s].has_clavicle;
            let t = arm_target(poses[s], side, has_clavicle, upper_rest, hand_rest);
            let fit = self.model.fit(side, &t, self.prev[s].as_ref());
            self.prev[s] = Some(fit.angles);
            let points = self.model.target_points(&t);
            let (ep, wp) = (mirrored(side, points.elbow), mirrored(side, points.wrist));
            let (e, w) = self.model.elbow_and_wrist(side, &fit.angles);
            let limits = self.model.limits(side);
            let clamped = std::array::from_fn(|k| {
                let (lo, hi) = limits[k];
                let v = fit.angles[k];
                fit.clamped[k] || (v - lo).abs() < AT_LIMIT_RAD || (v - hi).abs() < AT_LIMIT_RAD
            });
            ArmFitResult {
                angles: fit.angles,
                clamped,
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
