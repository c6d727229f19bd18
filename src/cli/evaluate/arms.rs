//! How far the model's commands put the robot's arms from the demonstrated (retargeted) ones:
//! the angles between the upper arms and between the forearms on bone lines, on the test frames
//! the gate follows and on those it holds, overall and per person.

use anyhow::{anyhow, Result};
use serde::Serialize;
use sgplvm::pipeline::{to_mat, Demonstrations};
use sgplvm::robots::anatomy::Anatomy;
use sgplvm::robots::retarget::whole_arm::{ArmAngles, PostureDistance};
use sgplvm::stats::quantile;
use sgplvm::Mat;

/// An upper arm this far from the demonstrated one is a frame badly served (issue 49's bar).
pub const FAR_DEG: f64 = 30.0;

/// The angles of a set of frames (both arms of each pooled), degrees.
#[derive(Serialize, Clone)]
pub struct ArmSummary {
    pub frames: usize,
    pub upper_arm_median_deg: Option<f64>,
    pub upper_arm_p90_deg: Option<f64>,
    pub forearm_median_deg: Option<f64>,
    pub forearm_p90_deg: Option<f64>,
    /// Share of the frames with an upper arm more than [`FAR_DEG`] off (either arm).
    pub upper_arm_far_share: Option<f64>,
}

impl ArmSummary {
    fn of(angles: &[[ArmAngles; 2]]) -> ArmSummary {
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

/// One person's test frames.
#[derive(Serialize)]
pub struct PersonArms {
    pub person: String,
    /// Test frames of theirs the gate follows / holds.
    pub followed: usize,
    pub held: usize,
    /// The angles on the frames followed.
    pub arms_followed: ArmSummary,
}

/// The arms' report of `evaluate`.
#[derive(Serialize)]
pub struct ArmsReport {
    /// The teleop default gate's followed test frames, and its held ones.
    pub followed: ArmSummary,
    pub held: ArmSummary,
    /// Per person of the test frames (empty when the data names nobody).
    pub people: Vec<PersonArms>,
}

/// The test frames' arm angles between the model's predictions `predicted` (test frames ×
/// the model's columns for `robot`) and the demonstrations, split by `held` (per test frame).
pub fn report(
    anatomy: &Anatomy,
    demos: &Demonstrations,
    robot: &str,
    predicted: &Mat<f64>,
    held: &[bool],
) -> Result<ArmsReport> {
    let ds = &demos.dataset;
    let body = demos.robot(robot)?;
    let desired = to_mat(&body.rows(&ds.test));
    // Each model column's place in the URDF's configuration; the rest at their hold values.
    let urdf_names = anatomy.robot().joint_names();
    let places =
        body.joint_names
            .iter()
            .map(|n| {
                urdf_names.iter().position(|u| u == n).ok_or_else(|| {
                    anyhow!("the data's {robot} joint `{n}` is not a joint of its URDF")
                })
            })
            .collect::<Result<Vec<usize>>>()?;
    let configuration = |m: &Mat<f64>, i: usize| {
        let mut q = anatomy.hold_configuration().to_vec();
        for (c, &p) in places.iter().enumerate() {
            q[p] = m[(i, c)];
        }
        q
    };
    let distance = PostureDistance::new(anatomy);
    let angles: Vec<[ArmAngles; 2]> = (0..ds.test.len())
        .map(|i| distance.between(&configuration(predicted, i), &configuration(&desired, i)))
        .collect();
    let pick = |want_held: bool, person: Option<&str>| -> Vec<[ArmAngles; 2]> {
        (0..angles.len())
            .filter(|&i| held[i] == want_held)
            .filter(|&i| {
                person.is_none_or(|p| {
                    ds.segment_of(ds.test[i]).and_then(|s| s.person.as_deref()) == Some(p)
                })
            })
            .map(|i| angles[i])
            .collect()
    };
    let people = ds
        .people_of(&ds.test)
        .into_iter()
        .map(|person| {
            let followed = pick(false, Some(&person));
            PersonArms {
                followed: followed.len(),
                held: pick(true, Some(&person)).len(),
                arms_followed: ArmSummary::of(&followed),
                person,
            }
        })
        .collect();
    Ok(ArmsReport {
        followed: ArmSummary::of(&pick(false, None)),
        held: ArmSummary::of(&pick(true, None)),
        people,
    })
}

/// Prints the report.
pub fn print(r: &ArmsReport, robot: &str) {
    let deg = |v: Option<f64>| v.map_or("-".to_string(), |d| format!("{d:.1}°"));
    let pct = |v: Option<f64>| v.map_or("-".to_string(), |s| format!("{:.1} %", 100.0 * s));
    let row = |name: &str, s: &ArmSummary| {
        println!(
            "  {name:<22} {:>6}   {:>7} {:>7}   {:>7} {:>7}   {:>8}",
            s.frames,
            deg(s.upper_arm_median_deg),
            deg(s.upper_arm_p90_deg),
            deg(s.forearm_median_deg),
            deg(s.forearm_p90_deg),
            pct(s.upper_arm_far_share)
        )
    };
    println!(
        "arms: the model's {robot} against the demonstrated posture on bone lines (both arms pooled)"
    );
    println!(
        "  {:<22} {:>6}   {:>15}   {:>15}   {:>8}",
        "test frames",
        "frames",
        "upper arm p50/90",
        "forearm p50/90",
        format!("UA>{FAR_DEG:.0}°")
    );
    row("followed by the gate", &r.followed);
    row("held by the gate", &r.held);
    for p in &r.people {
        row(
            &format!("person {} ({} held)", p.person, p.held),
            &p.arms_followed,
        );
    }
}
