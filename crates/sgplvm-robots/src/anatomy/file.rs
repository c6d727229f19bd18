//! The description file a lab writes once beside its URDF (`ROBOT.anatomy.json` for
//! `ROBOT.urdf`), read by every command that loads that URDF:
//!
//! ```json
//! {
//!   "sgplvm_anatomy": 1,
//!   "arms": { "left": "torso_link:left_rubber_hand", "right": "torso_link:right_rubber_hand" },
//!   "hold": { "waist_yaw_joint": 0.0 },
//!   "up": [0, 0, 1],
//!   "forward": [1, 0, 0],
//!   "neutral": { "left_shoulder_pitch_joint": 0.2 },
//!   "mount_roll_deg": 0,
//!   "command_joints": "arms"
//! }
//! ```
//!
//! Every key but the version is optional; `up` and `forward` are directions in the torso
//! link's frame; `mount_roll_deg` turns the person's arm outward about the forward axis
//! (`anatomy::Mount`); `command_joints` is `"arms"`, `"all"` or a list of joint names. Unknown keys
//! and another version are errors naming the file.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

use super::{Anatomy, AnatomyError, AnatomyResult, AnatomySpec, ArmSpec, CommandJoints};

/// The version of the description file format this build reads and writes.
pub const ANATOMY_FILE_VERSION: u32 = 1;

/// The description file beside `urdf`: `ROBOT.anatomy.json` for `ROBOT.urdf`.
pub fn description_path(urdf: &Path) -> PathBuf {
    let stem = urdf
        .file_stem()
        .map_or_else(|| "robot".into(), |s| s.to_string_lossy().into_owned());
    urdf.with_file_name(format!("{stem}.anatomy.json"))
}

/// The description file's contents.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AnatomyFile {
    /// The format's version ([`ANATOMY_FILE_VERSION`]).
    pub sgplvm_anatomy: u32,
    /// `{"left": "FROM:TO", "right": "FROM:TO"}` (one key on a single-arm robot).
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub arms: BTreeMap<String, String>,
    /// Hold values of joints outside the arms.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub hold: BTreeMap<String, f64>,
    /// The body's up direction in the torso link's frame.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub up: Option<[f64; 3]>,
    /// The body's forward direction in the torso link's frame.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub forward: Option<[f64; 3]>,
    /// The neutral posture's arm joint values.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub neutral: BTreeMap<String, f64>,
    /// Degrees the person's arm is turned outward about the forward axis
    /// ([`super::Mount`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mount_roll_deg: Option<f64>,
    /// `"arms"`, `"all"` or joint names.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub command_joints: Option<serde_json::Value>,
}

impl AnatomyFile {
    /// The file that describes `a` completely: its arms, hold values, body axes, neutral
    /// posture, mount and command joints.
    pub fn of(a: &Anatomy) -> AnatomyFile {
        let arm = |arm: &super::AnatomyArm| {
            let c = &arm.chain;
            (
                arm.side.as_str().to_string(),
                format!("{}:{}", c.base(), c.tip()),
            )
        };
        let axis = |k: usize| {
            let v = a.body_in_torso * Vector3::ith(k, 1.0);
            [v.x, v.y, v.z].map(|x| (x * 1e9).round() / 1e9)
        };
        let names = a.robot.joint_names();
        let command = a.command_joint_names();
        let command_joints = if command == a.arm_joint_names() {
            serde_json::Value::from("arms")
        } else if command == names {
            serde_json::Value::from("all")
        } else {
            serde_json::Value::from(command)
        };
        AnatomyFile {
            sgplvm_anatomy: ANATOMY_FILE_VERSION,
            arms: a.arms.iter().map(arm).collect(),
            hold: a.held_joints().into_iter().collect(),
            up: Some(axis(2)),
            forward: Some(axis(0)),
            neutral: a
                .arms
                .iter()
                .flat_map(|arm| {
                    arm.chain
                        .joint_names()
                        .iter()
                        .cloned()
                        .zip(arm.neutral.iter().copied())
                })
                .collect(),
            mount_roll_deg: Some(a.mount.roll_deg),
            command_joints: Some(command_joints),
        }
    }

    /// The file as pretty JSON.
    pub fn to_json(&self) -> String {
        serde_json::to_string_pretty(self).unwrap_or_default() + "\n"
    }
}

impl AnatomySpec {
    /// Reads a description file.
    pub fn read(path: &Path) -> AnatomyResult<AnatomySpec> {
        let file = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|e| AnatomyError::File {
            file: file.clone(),
            message: format!("cannot read the description file: {e}"),
        })?;
        AnatomySpec::from_json(&text, path)
    }

    /// Parses a description file's text (`path` names it in messages).
    pub fn from_json(text: &str, path: &Path) -> AnatomyResult<AnatomySpec> {
        let file = path.display().to_string();
        let bad = |message: String| AnatomyError::File {
            file: file.clone(),
            message,
        };
        let version = serde_json::from_str::<serde_json::Value>(text)
            .map_err(|e| bad(format!("not JSON: {e}")))?
            .get("sgplvm_anatomy")
            .and_then(serde_json::Value::as_u64);
        if version != Some(u64::from(ANATOMY_FILE_VERSION)) {
            return Err(bad(format!(
                "`sgplvm_anatomy` is {}; expected {ANATOMY_FILE_VERSION} (the format this sgplvm reads)",
                version.map_or_else(|| "missing".to_string(), |v| v.to_string())
            )));
        }
        let f: AnatomyFile = serde_json::from_str(text).map_err(|e| bad(e.to_string()))?;
        let mut spec = AnatomySpec {
            source: Some(path.to_path_buf()),
            hold: f.hold,
            neutral: f.neutral,
            up: f.up.map(Vector3::from),
            forward: f.forward.map(Vector3::from),
            mount_roll_deg: f.mount_roll_deg,
            ..AnatomySpec::default()
        };
        if let Some(deg) = f.mount_roll_deg.filter(|&d| !super::Mount::valid_roll(d)) {
            return Err(bad(format!(
                "mount_roll_deg: {deg}; expected degrees within ±180 (0: the person's arm as it is)"
            )));
        }
        for (side, text) in &f.arms {
            let arm = ArmSpec::parse(text).map_err(|e| bad(format!("arms.{side}: {e}")))?;
            match side.as_str() {
                "left" => spec.left = Some(arm),
                "right" => spec.right = Some(arm),
                other => {
                    return Err(bad(format!(
                        "arms.{other}: expected the keys left and right"
                    )))
                }
            }
        }
        spec.command_joints = match f.command_joints {
            None => CommandJoints::Arms,
            Some(serde_json::Value::String(s)) if s == "arms" => CommandJoints::Arms,
            Some(serde_json::Value::String(s)) if s == "all" => CommandJoints::All,
            Some(serde_json::Value::Array(list)) => CommandJoints::List(
                list.iter()
                    .map(|v| {
                        v.as_str()
                            .map(str::to_string)
                            .ok_or_else(|| bad(format!("command_joints: {v} is not a joint name")))
                    })
                    .collect::<AnatomyResult<_>>()?,
            ),
            Some(other) => {
                return Err(bad(format!(
                    "command_joints: {other}; expected \"arms\", \"all\" or a list of joint names"
                )))
            }
        };
        for (key, v) in spec.hold.iter().chain(&spec.neutral) {
            if !v.is_finite() {
                return Err(bad(format!("{key}: {v} is not a finite number")));
            }
        }
        Ok(spec)
    }
}
