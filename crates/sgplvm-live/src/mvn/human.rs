//! The human model's angles as MVN frames, and MVN frames back into the human model's angles
//! through the importer's per-frame fit ([`sgplvm_capture::PoseFitter`]): what `sgplvm
//! replay --as mvn` sends and what `sgplvm teleop --input mvn` takes.
//!
//! A frame's segments are the human model's links at the frame's angles — `T8` its root, each
//! arm's `…Shoulder` (clavicle), `…UpperArm`, `…ForeArm` and `…Hand` the links after the
//! sternoclavicular, shoulder, elbow and wrist joints, at those joints — turned, as MVN's are,
//! so that every segment's orientation is the identity in MVN's null pose (the T-pose: both
//! arms abducted 90°, nothing else bent).

use nalgebra::{Isometry3, Rotation3};
use sgplvm_capture::{
    CalibrationProgress, FrameFit, HumanArms, PoseFitter, StreamCalibration,
    StreamCalibrationOptions, Twist,
};
use sgplvm_robots::{Robot, Side};

use super::body::WorldPose;
use super::datagram::MvnPose;
use super::MvnError;

/// The human model's link of each MVN arm segment (left arm; the right's say `right`).
const LINKS: [(&str, &str); 4] = [
    ("Shoulder", "clavicle"),
    ("UpperArm", "upper_arm"),
    ("ForeArm", "forearm"),
    ("Hand", "hand_segment"),
];

/// The human model, and its links' orientations in the null pose.
pub struct HumanSegments {
    robot: Robot,
    /// Per segment name, its link and the link's rotation in the T-pose.
    segments: Vec<(String, String, Rotation3<f64>)>,
}

impl HumanSegments {
    /// The shipped human model's segments.
    pub fn new() -> Result<HumanSegments, MvnError> {
        let robot = Robot::builtin("human").map_err(|e| MvnError::Segment {
            name: "human".into(),
            message: e.to_string(),
        })?;
        let names = robot.joint_names();
        let mut t_pose = vec![0.0; robot.dof()];
        for n in ["jLeftShoulder_abduction", "jRightShoulder_abduction"] {
            if let Some(i) = names.iter().position(|x| x == n) {
                t_pose[i] = std::f64::consts::FRAC_PI_2;
            }
        }
        let mut segments = Vec::new();
        for (side, prefix) in [("Left", "left"), ("Right", "right")] {
            for (segment, link) in LINKS {
                let link = format!("{prefix}_{link}");
                let rest =
                    robot
                        .forward_kinematics(&t_pose, &link)
                        .map_err(|e| MvnError::Segment {
                            name: link.clone(),
                            message: e.to_string(),
                        })?;
                segments.push((
                    format!("{side}{segment}"),
                    link,
                    Rotation3::from(rest.rotation),
                ));
            }
        }
        Ok(HumanSegments { robot, segments })
    }

    /// The segments' world poses at the human model's angles `q` (its joint order): `T8` at
    /// the origin with the body's axes, the arms' segments as the module docs say (MVN names).
    pub fn world_poses(&self, q: &[f64]) -> Result<Vec<(&str, WorldPose)>, MvnError> {
        let bad = |e: sgplvm_robots::RobotError| MvnError::Segment {
            name: "human".into(),
            message: e.to_string(),
        };
        let mut poses: Vec<(&str, WorldPose)> = vec![(
            "T8",
            WorldPose {
                position: nalgebra::Vector3::zeros(),
                rotation: Rotation3::identity(),
            },
        )];
        for (segment, link, rest) in &self.segments {
            let pose: Isometry3<f64> = self.robot.forward_kinematics(q, link).map_err(bad)?;
            poses.push((
                segment.as_str(),
                WorldPose {
                    position: pose.translation.vector,
                    rotation: Rotation3::from(pose.rotation) * rest.inverse(),
                },
            ));
        }
        Ok(poses)
    }

    /// The frame of the human model's angles `q` (its joint order): [`Self::world_poses`].
    pub fn frame(&self, q: &[f64], sample: u32, time_ms: u32) -> Result<MvnPose, MvnError> {
        MvnPose::from_world_poses(sample, time_ms, 0, self.world_poses(q)?)
    }
}

/// The stream's fit: the person calibrated on the first frames ([`StreamCalibration`]: the
/// calibration offered whose rest pose is the stream's, else MVN's null pose as the
/// specification defines it), then each frame's arms fitted as the importer fits a file's.
pub struct MvnFit {
    model: Option<HumanArms>,
    calibration: StreamCalibration,
    fitter: Option<PoseFitter>,
}

/// What the stream's person is called in reports.
const SOURCE: &str = "the Xsens MVN stream";

impl MvnFit {
    /// A fit not calibrated yet, calibrated as `options` say.
    pub fn new(options: StreamCalibrationOptions) -> MvnFit {
        MvnFit {
            model: None,
            calibration: StreamCalibration::new(options, Twist::NullPose, SOURCE)
                .hand_end_unmeasured(),
            fitter: None,
        }
    }

    /// Where the person's calibration stands.
    pub fn progress(&self) -> CalibrationProgress {
        self.calibration.progress()
    }

    /// The fitter, once calibrated (its calibration is the person's).
    pub fn fitter(&self) -> Option<&PoseFitter> {
        self.fitter.as_ref()
    }

    /// The human model's 18 angles (left arm, then right) of `pose`, with the fit's residuals;
    /// `None` while the person is being calibrated.
    pub fn angles(&mut self, pose: &MvnPose) -> Result<Option<FrameFit>, MvnError> {
        let human = |message: String| MvnError::Segment {
            name: "human".into(),
            message,
        };
        let arms = [pose.arm_pose(Side::Left)?, pose.arm_pose(Side::Right)?];
        if self.fitter.is_none() {
            let rest = [
                pose.rest_arm_pose(Side::Left)?,
                pose.rest_arm_pose(Side::Right)?,
            ];
            if self.model.is_none() {
                let robot = Robot::builtin("human").map_err(|e| human(e.to_string()))?;
                self.model = Some(HumanArms::new(&robot).map_err(|e| human(e.to_string()))?);
            }
            let model = self
                .model
                .as_ref()
                .ok_or_else(|| human("no model".into()))?;
            self.fitter = self
                .calibration
                .offer(
                    model,
                    f64::from(pose.time_code_ms) * 1e-3,
                    [&rest[0], &rest[1]],
                    [true, true],
                    "Xsens MVN stream",
                    Some(1.0),
                    [&arms[0], &arms[1]],
                )
                .map_err(|e| MvnError::Calibration(e.to_string()))?;
        }
        let Some(fitter) = self.fitter.as_mut() else {
            return Ok(None);
        };
        let fits = fitter.fit([&arms[0], &arms[1]]);
        Ok(Some((PoseFitter::angles(&fits), fits)))
    }
}

impl Default for MvnFit {
    fn default() -> Self {
        MvnFit::new(StreamCalibrationOptions::default())
    }
}

/// `n` poses spread across the human model's joint ranges (kept 10 % inside each limit), the
/// same for every test that round-trips the model's angles (through MVN, through TF).
#[cfg(test)]
pub(crate) fn poses_across_ranges(n: usize) -> Vec<Vec<f64>> {
    let limits = Robot::builtin("human").unwrap().joint_limits();
    (1..=n)
        .map(|k| {
            limits
                .iter()
                .enumerate()
                .map(|(j, &(lo, hi))| {
                    let s = 0.5 + 0.4 * ((k * 7 + j * 3) as f64).sin();
                    lo + s * (hi - lo) * 0.8 + 0.1 * (hi - lo)
                })
                .collect()
        })
        .collect()
}
