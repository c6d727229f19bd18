//! Motion capture in: a BVH file becomes the human model's 18 joint angles at the
//! teleoperation rate, with a measure of how faithfully they reproduce the capture.
//!
//! 1. [`bvh`] reads the file (any channel order, 6-channel joints, End Sites).
//! 2. [`skeleton`] finds the arms by their names (or a map file) and expresses every frame in
//!    the upper torso's frame, so the whole body's walking, turning and bending stays out.
//! 3. [`fit`] turns each arm's pose into the model's 9 angles in closed form, segment by
//!    segment, scaled to the model's segment lengths; the model's forward kinematics then checks
//!    the elbow and wrist against the scaled capture ([`FitReport`]).
//! 4. The angles, continuous from frame to frame, are resampled to the rate asked
//!    ([`ImportOptions::rate_hz`], 40 Hz by default) by linear interpolation.
//!
//! [`import_bvh`] runs the four steps on one file; [`captures_to_dataset`] joins imported files
//! into a [`Dataset`] (one segment per file) whose MCAP carries every file's [`CaptureSource`]
//! in its [`CAPTURE_METADATA`] record.

pub mod bvh;
pub mod fit;
pub mod skeleton;
pub mod write;

use std::collections::BTreeMap;
use std::path::Path;

use nalgebra::{DMatrix, Vector3};
use serde::{Deserialize, Serialize};

pub use bvh::{Bvh, BvhError, BvhJoint, Channel};
pub use fit::{ArmAngles, ArmTarget, HumanArms};
pub use skeleton::{ArmMap, ArmPose, Skeleton, SCHEMES};
pub use write::write_bvh;

use crate::dataset::{concatenate, BodyData, Dataset};
use crate::joint_state::{JointStateError, DEFAULT_RATE_HZ};
use crate::series::median;
use crate::{Robot, RobotError, Side};
use fit::{mirror_rotation, mirror_vector, RestFrames};
use skeleton::side_index;

/// Name of the MCAP metadata record holding the [`CaptureSource`] of every imported file
/// (key `json`: a JSON list, one entry per segment).
pub const CAPTURE_METADATA: &str = "sgplvm.capture";

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
    #[error("{file}: cannot tell which segments are the arms; the names of one of these schemes were expected: {}. The file's {} segments are: {}. Name them with --map FILE (a JSON object such as {{\"jLeftShoulder\": \"L_UpperArm\", \"jLeftElbow\": \"L_Forearm\", \"jLeftWrist\": \"L_Hand\", ...}})",
        SCHEMES.iter().map(|s| s.name).collect::<Vec<_>>().join("; "), .segments.len(), list(.segments))]
    NoArms {
        /// The capture file.
        file: String,
        /// Every segment (joint) name of the file.
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
    const ALL: [Units; 5] = [
        Units::Metres,
        Units::Centimetres,
        Units::Millimetres,
        Units::Inches,
        Units::Cmu,
    ];

    /// Metres per file unit.
    pub fn metres(self) -> f64 {
        match self {
            Units::Metres => 1.0,
            Units::Centimetres => 0.01,
            Units::Millimetres => 0.001,
            Units::Inches => 0.0254,
            Units::Cmu => 0.0254 / 0.45,
        }
    }

    /// Short name (`m`, `cm`, `mm`, `in`, `cmu`), as `--units` takes it.
    pub fn name(self) -> &'static str {
        match self {
            Units::Metres => "m",
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

    /// The units in which `arm_length` (upper arm plus forearm, file units) is nearest an
    /// adult's 0.45–0.65 m; `None` if no unit gives a human size.
    pub fn guess(arm_length: f64) -> Option<Units> {
        Units::ALL
            .into_iter()
            .map(|u| (u, ((arm_length * u.metres()) / 0.54).ln().abs()))
            .filter(|(_, d)| *d < 0.35f64)
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

/// One arm's calibration: its rest frames in the left arm's convention.
struct ArmCalibration {
    rest: RestFrames,
}

/// A unit vector from `a` to `b`, or `fallback` where they coincide.
fn direction(a: &Vector3<f64>, b: &Vector3<f64>, fallback: Vector3<f64>) -> Vector3<f64> {
    (b - a).try_normalize(1e-12).unwrap_or(fallback)
}

/// Turns a captured arm pose into the fit's target (left arm's convention).
fn arm_target(pose: &ArmPose, side: Side, has_clavicle: bool, cal: &ArmCalibration) -> ArmTarget {
    let m = |v: Vector3<f64>| match side {
        Side::Left => v,
        Side::Right => mirror_vector(v),
    };
    let mr = |r: &nalgebra::Rotation3<f64>| match side {
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

/// Imports one BVH file (see the module documentation).
pub fn import_bvh(
    path: impl AsRef<Path>,
    options: &ImportOptions,
) -> Result<CapturedMotion, CaptureError> {
    let path = path.as_ref();
    let bvh = Bvh::read(path)?;
    import_parsed(&bvh, &path.display().to_string(), options)
}

/// [`import_bvh`] of an already parsed file; `file` names it in reports and errors.
pub fn import_parsed(
    bvh: &Bvh,
    file: &str,
    options: &ImportOptions,
) -> Result<CapturedMotion, CaptureError> {
    let bad = |message: String| CaptureError::Options {
        file: file.to_string(),
        message,
    };
    if !(options.rate_hz.is_finite() && options.rate_hz > 0.0 && options.rate_hz <= 10_000.0) {
        return Err(bad(format!(
            "rate {} Hz; expected a positive rate up to 10 kHz (40 is the teleoperation rate)",
            options.rate_hz
        )));
    }
    let frames_in_file = bvh.frames();
    if frames_in_file < 2 {
        return Err(bad(format!(
            "{frames_in_file} frame(s); a motion needs at least 2"
        )));
    }
    let skeleton = Skeleton::identify(bvh, options.map.as_ref(), file)?;
    let human = Robot::builtin("human")?;
    let model = HumanArms::new(&human)?;
    let calibration = [Side::Left, Side::Right].map(|side| {
        let rest = skeleton.rest_pose(bvh, side);
        let has_clavicle = skeleton.arms[side_index(side)].clavicle.is_some();
        let provisional = ArmCalibration {
            rest: RestFrames {
                upper_arm: nalgebra::Rotation3::identity(),
                hand: nalgebra::Rotation3::identity(),
            },
        };
        let t = arm_target(&rest, side, has_clavicle, &provisional);
        let hand = match side {
            Side::Left => direction(&rest.wrist, &rest.hand_tip, t.forearm),
            Side::Right => mirror_vector(direction(
                &rest.wrist,
                &rest.hand_tip,
                mirror_vector(t.forearm),
            )),
        };
        ArmCalibration {
            rest: model.rest_frames(t.clavicle, t.upper_arm, t.forearm, hand),
        }
    });
    // The span to import.
    let dt = bvh.frame_time;
    let duration = (frames_in_file - 1) as f64 * dt;
    let from = options.from_s.unwrap_or(0.0);
    let to = options.to_s.unwrap_or(duration).min(duration);
    if !(from.is_finite() && to.is_finite() && from >= 0.0 && from < to) {
        return Err(bad(format!(
            "time range {from} s to {to} s; expected 0 ≤ from < to within the capture's {duration:.2} s"
        )));
    }
    let first = (from / dt - 1e-6).ceil().max(0.0) as usize;
    let last = ((to / dt + 1e-6).floor() as usize).min(frames_in_file - 1);
    if last <= first {
        return Err(bad(format!(
            "the range {from} s to {to} s holds fewer than 2 frames"
        )));
    }
    // Fit every frame.
    let n = last - first + 1;
    let mut angles = DMatrix::<f64>::zeros(n, 18);
    let mut elbow_res = Vec::with_capacity(2 * n);
    let mut wrist_res = Vec::with_capacity(2 * n);
    let mut angle_res = Vec::with_capacity(2 * n);
    let mut beyond = vec![false; n];
    let mut at_limit = [0usize; 18];
    let mut prev: [Option<ArmAngles>; 2] = [None, None];
    for (row, f) in (first..=last).enumerate() {
        let values = bvh.frame(f);
        for side in [Side::Left, Side::Right] {
            let s = side_index(side);
            let pose = skeleton.arm_pose(bvh, values, side);
            let t = arm_target(
                &pose,
                side,
                skeleton.arms[s].clavicle.is_some(),
                &calibration[s],
            );
            let fit = model.fit(side, &t, prev[s].as_ref());
            prev[s] = Some(fit.angles);
            for k in 0..9 {
                angles[(row, 9 * s + k)] = fit.angles[k];
                at_limit[9 * s + k] += usize::from(fit.clamped[k]);
            }
            let points = model.target_points(&t);
            let (ep, wp) = match side {
                Side::Left => (points.elbow, points.wrist),
                Side::Right => (mirror_vector(points.elbow), mirror_vector(points.wrist)),
            };
            let (e, w) = model.elbow_and_wrist(side, &fit.angles);
            let (de, dw) = ((e - ep).norm(), (w - wp).norm());
            let da = (fit.capture_elbow_angle - fit.angles[5]).abs().to_degrees();
            beyond[row] |= de > WORST_RESIDUAL_LIMIT_M
                || dw > WORST_RESIDUAL_LIMIT_M
                || da > ELBOW_ANGLE_LIMIT_DEG;
            elbow_res.push(de);
            wrist_res.push(dw);
            angle_res.push(da);
        }
    }
    // cgspeed's CMU conversions start with a T-pose frame: a first frame that jumps far more
    // than any later frame moves is a calibration pose, not motion.
    let mut start_row = 0;
    if options.from_s.is_none() && n >= 10 {
        let jump = |a: usize, b: usize| {
            (0..18)
                .map(|k| (angles[(a, k)] - angles[(b, k)]).abs())
                .fold(0.0, f64::max)
        };
        let first_jump = jump(0, 1);
        let mut next_second: Vec<f64> = (1..(n - 1).min(1 + bvh.frame_rate().ceil() as usize))
            .map(|r| jump(r, r + 1))
            .collect();
        let typical = median(&mut next_second);
        if first_jump > 0.35 && first_jump > 20.0 * typical {
            start_row = 1;
        }
    }
    let (elbow_res, wrist_res, angle_res, beyond) = if start_row == 1 {
        (
            elbow_res[2..].to_vec(),
            wrist_res[2..].to_vec(),
            angle_res[2..].to_vec(),
            beyond[1..].to_vec(),
        )
    } else {
        (elbow_res, wrist_res, angle_res, beyond)
    };
    let worst = |v: &[f64]| v.iter().copied().fold(0.0, f64::max);
    let t0 = (first + start_row) as f64 * dt;
    let quarter = std::f64::consts::FRAC_PI_2;
    // Per side, frames where flexion or rotation jumped by more than a quarter turn.
    let shoulder_switches = (start_row + 1..n)
        .map(|r| {
            [[2usize, 4], [11, 13]]
                .iter()
                .filter(|pair| {
                    pair.iter()
                        .any(|&k| (angles[(r, k)] - angles[(r - 1, k)]).abs() > quarter)
                })
                .count()
        })
        .sum();
    let fit = FitReport {
        frames: n - start_row,
        elbow_median_m: median(&mut elbow_res.clone()),
        elbow_worst_m: worst(&elbow_res),
        wrist_median_m: median(&mut wrist_res.clone()),
        wrist_worst_m: worst(&wrist_res),
        elbow_angle_median_deg: median(&mut angle_res.clone()),
        elbow_angle_worst_deg: worst(&angle_res),
        frames_beyond: beyond.iter().filter(|b| **b).count(),
        first_beyond_s: beyond.iter().position(|b| *b).map(|r| r as f64 * dt),
        at_limit: model
            .joint_names
            .iter()
            .zip(at_limit)
            .filter(|(_, c)| *c > 0)
            .map(|(name, c)| (name.clone(), c))
            .collect(),
        shoulder_switches,
    };
    // Resample onto the output clock.
    let span = (last - first - start_row) as f64 * dt;
    // A frame time written with few digits (CMU's .0083333) must not lose the last frame.
    let out_n = (span * options.rate_hz + 1e-3).floor() as usize + 1;
    if out_n > MAX_OUTPUT_FRAMES {
        return Err(bad(format!(
            "{:.0} s at {} Hz would be {out_n} frames; at most {MAX_OUTPUT_FRAMES} are written (lower --rate or cut with --from/--to)",
            span, options.rate_hz
        )));
    }
    let mut out = DMatrix::<f64>::zeros(out_n, 18);
    let mut times_ns = Vec::with_capacity(out_n);
    for k in 0..out_n {
        let t = k as f64 / options.rate_hz;
        let x = (t / dt).min((n - 1 - start_row) as f64);
        let i = (x.floor() as usize).min(n - 2 - start_row);
        let a = x - i as f64;
        for side in 0..2 {
            let arm = 9 * side..9 * side + 9;
            // Between two frames where a shoulder switched to its other Euler solution the
            // angles do not lie on a line between the poses: the nearer frame instead.
            let switched = arm.clone().any(|j| {
                (angles[(start_row + i + 1, j)] - angles[(start_row + i, j)]).abs() > quarter
            });
            for j in arm {
                let v0 = angles[(start_row + i, j)];
                let v1 = angles[(start_row + i + 1, j)];
                out[(k, j)] = match (switched, a < 0.5) {
                    (false, _) => v0 + a * (v1 - v0),
                    (true, true) => v0,
                    (true, false) => v1,
                };
            }
        }
        times_ns.push(options.start_time_ns + (t * 1e9).round() as i64);
    }
    let units = options.units.or_else(|| Units::guess(skeleton.arm_length));
    Ok(CapturedMotion {
        times_ns,
        joint_names: model.joint_names.clone(),
        positions: out,
        source: CaptureSource {
            file: file.to_string(),
            skeleton: skeleton.scheme.clone(),
            frame_rate: 1.0 / dt,
            frames_in_file,
            span_s: (t0, t0 + span),
            calibration_frame_dropped: start_row == 1,
            units: units
                .map(|u| u.name().to_string())
                .unwrap_or_else(|| "unknown".into()),
            arm_length: skeleton.arm_length * units.map(Units::metres).unwrap_or(1.0),
            rate_hz: options.rate_hz,
            fit,
        },
    })
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
    let read = crate::joint_state::read_topics(path, &[])?;
    match read
        .metadata
        .get(CAPTURE_METADATA)
        .and_then(|m| m.get("json"))
    {
        None => Ok(Vec::new()),
        Some(json) => serde_json::from_str(json).map_err(|e| {
            CaptureError::Demonstrations(JointStateError::BadDatasetMetadata {
                path: path.to_path_buf(),
                detail: format!(
                    "record `{CAPTURE_METADATA}` is not a list of capture sources: {e}"
                ),
            })
        }),
    }
}

#[cfg(test)]
mod tests;
