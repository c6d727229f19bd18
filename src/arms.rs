//! How far a robot's arms are from where they should be, on bone lines (shoulder centre → elbow
//! centre → wrist centre): a learned mapping's commands against the demonstrated (retargeted)
//! postures, and both against the person (`sgplvm evaluate`, and `sgplvm experiment`'s study of
//! the learned mapping against retargeting each frame directly).

use serde::{Deserialize, Serialize};
use sgplvm_core::MatRef;
use sgplvm_robots::anatomy::Anatomy;
use sgplvm_robots::retarget::whole_arm::{ArmAngles, PersonDistance};

use crate::stats::quantile;

/// An upper arm this far from the wanted one is a frame badly served (issue 49's bar), degrees.
pub const FAR_DEG: f64 = 30.0;

/// The angles of a set of frames (the arms of each pooled: both, or a single-arm robot's one),
/// degrees.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ArmSummary {
    /// Frames summarised.
    pub frames: usize,
    /// Upper arm, median and 90th percentile (none without frames).
    pub upper_arm_median_deg: Option<f64>,
    /// See `upper_arm_median_deg`.
    pub upper_arm_p90_deg: Option<f64>,
    /// Forearm, median and 90th percentile.
    pub forearm_median_deg: Option<f64>,
    /// See `forearm_median_deg`.
    pub forearm_p90_deg: Option<f64>,
    /// Share of the frames with an upper arm more than [`FAR_DEG`] off (either arm).
    pub upper_arm_far_share: Option<f64>,
}

impl ArmSummary {
    /// The summary of per-frame angles.
    pub fn of(angles: &[Vec<ArmAngles>]) -> ArmSummary {
        let pooled = |f: fn(&ArmAngles) -> f64| -> Vec<f64> {
            let mut v: Vec<f64> = angles.iter().flat_map(|a| a.iter().map(f)).collect();
            v.sort_by(f64::total_cmp);
            v
        };
        let (upper, fore) = (pooled(|a| a.upper_arm_deg), pooled(|a| a.forearm_deg));
        let q = |v: &[f64], p: f64| (!v.is_empty()).then(|| quantile(v, p));
        ArmSummary {
            frames: angles.len(),
            upper_arm_median_deg: q(&upper, 0.5),
            upper_arm_p90_deg: q(&upper, 0.9),
            forearm_median_deg: q(&fore, 0.5),
            forearm_p90_deg: q(&fore, 0.9),
            upper_arm_far_share: (!angles.is_empty()).then(|| {
                angles
                    .iter()
                    .filter(|a| a.iter().any(|s| s.upper_arm_deg > FAR_DEG))
                    .count() as f64
                    / angles.len() as f64
            }),
        }
    }
}

/// Each row of `commands` (frames × the robot's command columns `joints`) as a whole
/// configuration of `anatomy`'s URDF, the other joints at their hold values; an error names the
/// first column that is no joint of the URDF.
pub fn configurations(
    anatomy: &Anatomy,
    joints: &[String],
    commands: MatRef<'_, f64>,
) -> Result<Vec<Vec<f64>>, String> {
    (0..commands.nrows())
        .map(|i| {
            let row: Vec<f64> = (0..commands.ncols()).map(|c| commands[(i, c)]).collect();
            anatomy.configuration(joints, &row)
        })
        .collect()
}

/// Per frame, the angles between the robot's arms at each of `configurations` (whole
/// configurations, [`configurations`]) and the person at the same row of `human` (the human
/// model's 18 joints), measured by `person`.
pub fn from_person(
    person: &PersonDistance<'_>,
    configurations: &[Vec<f64>],
    human: MatRef<'_, f64>,
) -> Result<Vec<Vec<ArmAngles>>, String> {
    if configurations.len() != human.nrows() {
        return Err(format!(
            "{} frames of commands for {} frames of the person",
            configurations.len(),
            human.nrows()
        ));
    }
    Ok(configurations
        .iter()
        .enumerate()
        .map(|(i, q)| {
            let h: Vec<f64> = (0..human.ncols()).map(|c| human[(i, c)]).collect();
            person.between(q, &h)
        })
        .collect())
}
