//! How far the model's commands put the robot's arms from the demonstrated (retargeted) ones:
//! the angles between the upper arms and between the forearms on bone lines, on the test frames
//! the gate follows and on those it holds, overall and per person.

use anyhow::{anyhow, Result};
use serde::Serialize;
use sgplvm::arms::{configurations, from_person, ArmSummary, FAR_DEG};
use sgplvm::pipeline::{to_mat, Demonstrations};
use sgplvm::robots::anatomy::Anatomy;
use sgplvm::robots::retarget::whole_arm::{ArmAngles, PersonDistance, PostureDistance};
use sgplvm::Mat;

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

/// The learned mapping against direct retargeting, each against the person (on bone lines, as
/// `retarget` reports): whether the model is worth it over retargeting each frame.
#[derive(Serialize)]
pub struct FromPerson {
    /// The model's commands on the test frames the gate follows.
    pub learned_followed: ArmSummary,
    /// The demonstrated (retargeted) postures on the same frames.
    pub retargeted_followed: ArmSummary,
    /// The demonstrated postures on every test frame (retargeting holds none).
    pub retargeted_all: ArmSummary,
}

/// The arms' report of `evaluate`.
#[derive(Serialize)]
pub struct ArmsReport {
    /// The teleop default gate's followed test frames, and its held ones.
    pub followed: ArmSummary,
    pub held: ArmSummary,
    /// The model and retargeting, each against the person.
    pub from_person: FromPerson,
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
    let human = to_mat(&ds.human.rows(&ds.test));
    let in_urdf = |e: String| anyhow!("the data's {robot} joints: {e}");
    let (got, want) = (
        configurations(anatomy, &body.joint_names, predicted.as_ref()).map_err(in_urdf)?,
        configurations(anatomy, &body.joint_names, desired.as_ref()).map_err(in_urdf)?,
    );
    let distance = PostureDistance::new(anatomy);
    let angles: Vec<Vec<ArmAngles>> = got
        .iter()
        .zip(&want)
        .map(|(a, b)| distance.between(a, b))
        .collect();
    let person = PersonDistance::new(anatomy).map_err(|e| anyhow!("{e}"))?;
    let learned = from_person(&person, &got, human.as_ref()).map_err(in_urdf)?;
    let retargeted = from_person(&person, &want, human.as_ref()).map_err(in_urdf)?;
    let followed_only = |a: &[Vec<ArmAngles>]| -> Vec<Vec<ArmAngles>> {
        (0..a.len())
            .filter(|&i| !held[i])
            .map(|i| a[i].clone())
            .collect()
    };
    let from_person = FromPerson {
        learned_followed: ArmSummary::of(&followed_only(&learned)),
        retargeted_followed: ArmSummary::of(&followed_only(&retargeted)),
        retargeted_all: ArmSummary::of(&retargeted),
    };
    let pick = |want_held: bool, person: Option<&str>| -> Vec<Vec<ArmAngles>> {
        (0..angles.len())
            .filter(|&i| held[i] == want_held)
            .filter(|&i| {
                person.is_none_or(|p| {
                    ds.segment_of(ds.test[i]).and_then(|s| s.person.as_deref()) == Some(p)
                })
            })
            .map(|i| angles[i].clone())
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
        from_person,
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
        "arms: the model's {robot} against the demonstrated posture on bone lines (its arms pooled)"
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
    println!("arms: against the person on bone lines — the model, and retargeting each frame directly (the yardstick; `teleop --retarget` drives it)");
    row("model, followed", &r.from_person.learned_followed);
    row("retargeted, followed", &r.from_person.retargeted_followed);
    row("retargeted, every frame", &r.from_person.retargeted_all);
}
