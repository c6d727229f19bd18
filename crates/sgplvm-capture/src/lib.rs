//! The human side of sgplvm: motion capture in. A BVH file, or a live stream of a skeleton's
//! segments (an Xsens MVN suit, a ROS 2 TF tree), becomes the human model's 18 joint angles,
//! with a measure of how faithfully they reproduce the capture. Knows nothing of robots but the
//! human model it fits (the robots crate's `human` body) and the demonstration files it writes.
//!
//! 1. [`bvh`] reads the file (any channel order, 6-channel joints, End Sites).
//! 2. [`skeleton`] finds the arms by their names (or a map file) and expresses every frame in
//!    the upper torso's frame, so the whole body's walking, turning and bending stays out; the
//!    torso's body axes come from the skeleton's geometry, whatever its zero pose ([`axes`]).
//! 3. [`fit`] turns each arm's pose into the model's 9 angles in closed form, segment by
//!    segment, scaled to the model's segment lengths; the model's forward kinematics then checks
//!    the elbow and wrist against the scaled capture ([`FitReport`]).
//! 4. The angles, continuous from frame to frame, are resampled to the rate asked
//!    ([`ImportOptions::rate_hz`], 40 Hz by default) by linear interpolation.
//!
//! [`import_bvh`] runs the four steps on one file; [`captures_to_dataset`] joins imported files
//! into a [`Dataset`] (one segment per file) whose MCAP carries every file's [`CaptureSource`]
//! in its [`CAPTURE_METADATA`] record.

#![deny(clippy::unwrap_used)]

pub mod asf;
pub mod axes;
pub mod bvh;
pub mod calibration;
pub mod fit;
pub mod girdle;
pub mod mirror;
pub mod segments;
pub mod skeleton;
pub mod stream;
pub mod stream_calibration;
pub mod write;

mod import;

use std::collections::BTreeMap;
use std::path::Path;

use nalgebra::DMatrix;
use serde::{Deserialize, Serialize};

pub use bvh::{Bvh, BvhError, BvhJoint, Channel};
pub use calibration::{Calibration, HandEnd, HingeEstimate, Twist};
pub use fit::{ArmAngles, ArmTarget, HumanArms};
pub use import::{import_bvh, import_files, import_parsed};
pub use mirror::{ElbowBends, SidesMirrored};
pub use segments::{ArmSegments, WorldPose};
pub use skeleton::{tree_skeleton, ArmMap, ArmPose, Skeleton, TreeFrame, SCHEMES};
pub use stream::{ArmFitResult, FrameFit, PoseFitter};
pub use stream_calibration::{CalibrationProgress, StreamCalibration, StreamCalibrationOptions};
pub use write::write_bvh;

use sgplvm_robots::dataset::{concatenate, BodyData, Dataset};
use sgplvm_robots::joint_state::{JointStateError, DEFAULT_RATE_HZ};
use sgplvm_robots::RobotError;

/// Name of the MCAP metadata record holding the [`CaptureSource`] of every imported file
/// (key `json`: a JSON list, one entry per segment); the robots crate carries it through
/// retargeting unchanged.
pub use sgplvm_robots::dataset::CAPTURE_METADATA;

/// Most frames one import writes (18 angles each).
pub const MAX_OUTPUT_FRAMES: usize = 10_000_000;

/// Median elbow and wrist distance to the scaled capture a faithful import stays within, metres.
pub const MEDIAN_RESIDUAL_LIMIT_M: f64 = 0.01;
/// Largest elbow and wrist distance to the scaled capture a faithful frame stays within, metres.
pub const WORST_RESIDUAL_LIMIT_M: f64 = 0.03;
/// Largest elbow-angle difference a faithful frame stays within, degrees.
pub const ELBOW_ANGLE_LIMIT_DEG: f64 = 2.0;

/// What went wrong importing a capture.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum CaptureError {
    /// The BVH file could not be read or parsed.
    #[error(transparent)]
    Bvh(#[from] BvhError),
    /// No naming scheme identifies both arms.
    #[error("{file}: cannot tell which segments are the arms; the names of one of these schemes were expected: {}. Its {} segments, nearest the root first: {}. Name them with --map FILE (a JSON object such as {{\"jLeftShoulder\": \"L_UpperArm\", \"jLeftElbow\": \"L_Forearm\", \"jLeftWrist\": \"L_Hand\", ...}})",
        SCHEMES.iter().map(|s| s.name).collect::<Vec<_>>().join("; "), .segments.len(), list(.segments))]
    NoArms {
        /// The capture file.
        file: String,
        /// Every segment (joint) name of the file, nearest the root first.
        segments: Vec<String>,
    },
    /// The arms were found but the skeleton cannot be used.
    #[error("{file}: {message}")]
    Skeleton {
        /// The capture file.
        file: String,
        /// What is wrong.
        message: String,
    },
    /// The map file is unreadable or names segments the capture lacks.
    #[error("map file {file}: {message}")]
    Map {
        /// The map file (or the capture, when the map names its segments).
        file: String,
        /// What is wrong.
        message: String,
    },
    /// An option does not fit the capture (a time range outside it, a bad rate).
    #[error("{file}: {message}")]
    Options {
        /// The capture file.
        file: String,
        /// What is wrong.
        message: String,
    },
    /// A calibration file is unreadable, or a calibration is not the capture's.
    #[error("calibration {file}: {message}")]
    Calibration {
        /// The calibration's file (or the capture it was given for).
        file: String,
        /// What is wrong.
        message: String,
    },
    /// The human model could not be loaded.
    #[error("the human model: {0}")]
    Model(#[from] RobotError),
    /// Writing or reading demonstrations failed.
    #[error(transparent)]
    Demonstrations(#[from] JointStateError),
}

/// Up to 60 names joined, with a count of the rest.
fn list(names: &[String]) -> String {
    let shown: Vec<&str> = names.iter().take(60).map(String::as_str).collect();
    if names.len() > shown.len() {
        format!(
            "{} … and {} more",
            shown.join(", "),
            names.len() - shown.len()
        )
    } else {
        shown.join(", ")
    }
}

/// Length units a BVH file may be written in.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Units {
    /// Metres.
    Metres,
    /// Decimetres (MakeHuman's game rig exports).
    Decimetres,
    /// Centimetres (Xsens, Mixamo, most exporters).
    Centimetres,
    /// Millimetres (Vicon, OptiTrack exports).
    Millimetres,
    /// Inches.
    Inches,
    /// The CMU database's units (ASF `length 0.45`: 1/0.45 inch, 5.64 cm).
    Cmu,
}

impl Units {
    const ALL: [Units; 6] = [
        Units::Metres,
        Units::Decimetres,
        Units::Centimetres,
        Units::Millimetres,
        Units::Inches,
        Units::Cmu,
    ];

    /// Metres per file unit.
    pub fn metres(self) -> f64 {
        match self {
            Units::Metres => 1.0,
            Units::Decimetres => 0.1,
            Units::Centimetres => 0.01,
            Units::Millimetres => 0.001,
            Units::Inches => 0.0254,
            Units::Cmu => 0.0254 / 0.45,
        }
    }

    /// Short name (`m`, `dm`, `cm`, `mm`, `in`, `cmu`), as `--units` takes it.
    pub fn name(self) -> &'static str {
        match self {
            Units::Metres => "m",
            Units::Decimetres => "dm",
            Units::Centimetres => "cm",
            Units::Millimetres => "mm",
            Units::Inches => "in",
            Units::Cmu => "cmu",
        }
    }

    /// Parses a short name.
    pub fn parse(s: &str) -> Option<Units> {
        Units::ALL.into_iter().find(|u| u.name() == s)
    }

    /// The short names [`Units::parse`] takes, for messages: `m, dm, cm, mm, in or cmu`.
    pub fn choices() -> String {
        let names: Vec<&str> = Units::ALL.iter().map(|u| u.name()).collect();
        match names.split_last() {
            Some((last, rest)) => format!("{} or {last}", rest.join(", ")),
            None => String::new(),
        }
    }

    /// The units in which `arm_length` (upper arm plus forearm, file units) is nearest an
    /// adult's 0.54 m, within a factor of 3 (a rig scaled up or down, as a Mixamo character
    /// scaled 2.5×, keeps its file's units); `None` if no unit gives a size that near.
    pub fn guess(arm_length: f64) -> Option<Units> {
        Units::ALL
            .into_iter()
            .map(|u| (u, ((arm_length * u.metres()) / 0.54).ln().abs()))
            .filter(|(_, d)| *d < 3f64.ln())
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .map(|(u, _)| u)
    }
}

/// How to import a capture.
#[derive(Debug, Clone, PartialEq)]
pub struct ImportOptions {
    /// Rate of the output frames, Hz (40, the teleoperation rate, by default).
    pub rate_hz: f64,
    /// Explicit arm segments; `None` recognises the naming schemes of [`SCHEMES`].
    pub map: Option<ArmMap>,
    /// The file's length units; `None` guesses them from the arm's length (they only name
    /// sizes in reports: positions are scaled to the model either way).
    pub units: Option<Units>,
    /// First second of the capture to import (0 by default).
    pub from_s: Option<f64>,
    /// Last second of the capture to import (its end by default).
    pub to_s: Option<f64>,
    /// Timestamp of the first output frame, ns.
    pub start_time_ns: i64,
    /// Calibrations to fit through: the one whose rest pose is the capture's (one made from
    /// this skeleton, e.g. by an earlier import or a live session); a capture whose rest pose is
    /// none of theirs is refused. Empty: calibrate on the capture itself.
    pub calibration: Vec<Calibration>,
}

impl Default for ImportOptions {
    fn default() -> Self {
        Self {
            rate_hz: DEFAULT_RATE_HZ,
            map: None,
            units: None,
            from_s: None,
            to_s: None,
            start_time_ns: 1_700_000_000_000_000_000,
            calibration: Vec::new(),
        }
    }
}

/// How faithfully the imported angles reproduce the capture, over every captured frame
/// imported (before resampling): the human model's forward kinematics of the angles against
/// the capture scaled to the model's segment lengths.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FitReport {
    /// Captured frames compared (both arms each).
    pub frames: usize,
    /// Median elbow distance, metres.
    pub elbow_median_m: f64,
    /// Largest elbow distance, metres.
    pub elbow_worst_m: f64,
    /// Median wrist distance, metres.
    pub wrist_median_m: f64,
    /// Largest wrist distance, metres.
    pub wrist_worst_m: f64,
    /// Median difference of the elbow angle (between upper arm and forearm), degrees.
    pub elbow_angle_median_deg: f64,
    /// Largest difference of the elbow angle, degrees.
    pub elbow_angle_worst_deg: f64,
    /// Frames where an elbow or wrist is more than [`WORST_RESIDUAL_LIMIT_M`] away or an elbow
    /// angle more than [`ELBOW_ANGLE_LIMIT_DEG`] off: poses the model cannot take.
    pub frames_beyond: usize,
    /// Time of the first such frame, seconds from the start of the import.
    pub first_beyond_s: Option<f64>,
    /// Per model joint, the captured frames in which the joint was held at a limit.
    pub at_limit: BTreeMap<String, usize>,
    /// Times a shoulder's angles jumped to the other Euler solution of the same pose (by
    /// more than a quarter turn between two captured frames): where the arm passes the
    /// shoulder's gimbal point (abduction ±90°) or its continuing solution leaves the joint
    /// limits. The pose is continuous there, its angles are not.
    pub shoulder_switches: usize,
}

impl FitReport {
    /// Whether the medians and the worst case are within the limits ([`MEDIAN_RESIDUAL_LIMIT_M`],
    /// [`WORST_RESIDUAL_LIMIT_M`], [`ELBOW_ANGLE_LIMIT_DEG`]).
    pub fn within_limits(&self) -> bool {
        self.elbow_median_m <= MEDIAN_RESIDUAL_LIMIT_M
            && self.wrist_median_m <= MEDIAN_RESIDUAL_LIMIT_M
            && self.elbow_worst_m <= WORST_RESIDUAL_LIMIT_M
            && self.wrist_worst_m <= WORST_RESIDUAL_LIMIT_M
            && self.elbow_angle_worst_deg <= ELBOW_ANGLE_LIMIT_DEG
    }
}

/// Where an import came from and how it went.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CaptureSource {
    /// The capture file as given.
    pub file: String,
    /// The naming scheme that identified the arms (or `map file`).
    pub skeleton: String,
    /// Which joints gave the upper torso's body axes ([`axes::BodyAxes::found_from`]; empty in
    /// files imported before it was recorded).
    #[serde(default)]
    pub body_axes: String,
    /// The capture's frame rate, Hz.
    pub frame_rate: f64,
    /// Frames in the file.
    pub frames_in_file: usize,
    /// Seconds of the file imported: from, to.
    pub span_s: (f64, f64),
    /// Whether the file's first frame was left out as a calibration pose (a jump to the
    /// second frame far larger than any later one: cgspeed's CMU files start with a T-pose).
    pub calibration_frame_dropped: bool,
    /// Length units of the file (`cm`, `cmu`, …; `unknown` if none gives a human size).
    pub units: String,
    /// The capture's upper arm plus forearm at rest, metres (file units if unknown).
    pub arm_length: f64,
    /// Rate of the imported frames, Hz.
    pub rate_hz: f64,
    /// The fit's residuals.
    pub fit: FitReport,
    /// The person's calibration the frames were fitted through (absent in files imported
    /// before calibrations were stored).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub calibration: Option<Calibration>,
    /// Who was captured, as the user named them (`sgplvm import --person`): the unit a
    /// leave-people-out split holds out and a model's trust threshold is calibrated over.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub person: Option<String>,
    /// What the import says of the file beside its figures: frame lines past the `Frames:`
    /// count left out, an arm found without its clavicle although a joint is named like one
    /// ([`Skeleton::clavicle_note`]).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub notes: Vec<String>,
    /// Present where most clearly bent elbows bend backwards: the skeleton's Left and Right are
    /// probably the person's right and left ([`mirror`]), with the `--map` that swaps them.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sides_mirrored: Option<SidesMirrored>,
}

/// One imported capture: the human's 18 joint angles at the asked rate.
#[derive(Debug, Clone, PartialEq)]
pub struct CapturedMotion {
    /// Frame times, ns.
    pub times_ns: Vec<i64>,
    /// The human model's joint names (columns).
    pub joint_names: Vec<String>,
    /// Joint angles, frames × 18, radians.
    pub positions: DMatrix<f64>,
    /// Provenance and fit.
    pub source: CaptureSource,
}

/// Seconds left between one imported file and the next in a joined dataset.
pub const GAP_BETWEEN_FILES_S: f64 = 1.0;

/// Joins imported captures into one human-only [`Dataset`] on one clock (each file after the
/// previous one and a [`GAP_BETWEEN_FILES_S`] gap), one unlabelled segment per file, every
/// frame in the training set; and the JSON of their sources for [`CAPTURE_METADATA`].
pub fn captures_to_dataset(captures: &[CapturedMotion]) -> Result<(Dataset, String), CaptureError> {
    let parts: Vec<Dataset> = captures
        .iter()
        .map(|c| {
            let human = BodyData {
                name: "human".into(),
                topic: "/human/joint_states".into(),
                joint_names: c.joint_names.clone(),
                positions: c.positions.clone(),
            };
            Dataset::unlabelled(c.times_ns.clone(), human, Vec::new())
        })
        .collect();
    let dataset = concatenate(&parts, (GAP_BETWEEN_FILES_S * 1e9) as i64)?;
    Ok((dataset, sources_json(captures.iter().map(|c| &c.source))?))
}

/// The JSON list of `sources` stored under [`CAPTURE_METADATA`].
pub fn sources_json<'a>(
    sources: impl Iterator<Item = &'a CaptureSource>,
) -> Result<String, CaptureError> {
    let sources: Vec<&CaptureSource> = sources.collect();
    serde_json::to_string(&sources).map_err(|e| CaptureError::Options {
        file: String::new(),
        message: format!("cannot encode the capture sources: {e}"),
    })
}

/// The [`CaptureSource`]s stored in a demonstration file's [`CAPTURE_METADATA`] record (empty
/// if it has none).
pub fn read_capture_sources(path: impl AsRef<Path>) -> Result<Vec<CaptureSource>, CaptureError> {
    let path = path.as_ref();
    sgplvm_robots::dataset::capture_records(path)?
        .into_iter()
        .map(|record| {
            serde_json::from_value(serde_json::Value::Object(record)).map_err(|e| {
                CaptureError::Demonstrations(JointStateError::BadDatasetMetadata {
                    path: path.to_path_buf(),
                    detail: format!(
                        "record `{CAPTURE_METADATA}` is not a list of capture sources: {e}"
                    ),
                })
            })
        })
        .collect()
}

/// The person calibrations in a list of capture sources (the JSON of a [`CAPTURE_METADATA`]
/// record, as a model file carries its training data's); sources without one are skipped.
pub fn calibrations_in(sources: &serde_json::Value) -> Result<Vec<Calibration>, String> {
    let sources: Vec<CaptureSource> = serde_json::from_value(sources.clone())
        .map_err(|e| format!("not a list of capture sources: {e}"))?;
    let found: Vec<Calibration> = sources.into_iter().filter_map(|s| s.calibration).collect();
    for c in &found {
        c.validate()?;
    }
    Ok(found)
}

#[cfg(test)]
mod tests;
