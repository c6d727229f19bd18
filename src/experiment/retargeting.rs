//! The learned mapping against retargeting each frame directly (issue 49): on the test frames,
//! how far each model's commands put the robot's arms from the person (on bone lines, as
//! `retarget` reports), beside how far the retargeted postures themselves are — what the learned
//! mapping adds to retargeting's own error, and so when a lab should retarget directly
//! (`teleop --retarget`) and when the learned mapping is worth it. With a people split
//! (`retarget --split people`) the test frames are of people never in training: strangers.
//!
//! Robots without a built-in body (no URDF to measure on) are named and left out.

use serde::{Deserialize, Serialize};
use sgplvm_core::{MatRef, SharedGplvm};
use sgplvm_robots::anatomy::Anatomy;
use sgplvm_robots::retarget::whole_arm::PersonDistance;

use super::{ExperimentData, ExperimentError};
use crate::arms::{configurations, from_person, ArmSummary};

/// What the study needs beside the experiment's matrices: each robot's joint names (its
/// columns) and who the training and test frames are of.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RetargetingData {
    /// Each robot's joint names, in the order of [`ExperimentData::robots`].
    pub robot_joints: Vec<Vec<String>>,
    /// The people of the test frames, and of the training frames (empty where the data names
    /// nobody).
    pub test_people: Vec<String>,
    /// See `test_people`.
    pub training_people: Vec<String>,
}

/// The study's record of the data: who the test frames are of and the retargeted postures
/// against the person, per robot.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RetargetingStudy {
    /// The people of the test frames.
    pub test_people: Vec<String>,
    /// The people of the training frames.
    pub training_people: Vec<String>,
    /// Per robot with a built-in body, the retargeted postures against the person.
    pub retargeted: Vec<(String, ArmSummary)>,
    /// Robots left out: no built-in body to measure on.
    pub left_out: Vec<String>,
}

impl RetargetingStudy {
    /// Whether every test frame is of a person never in training (a people split).
    pub fn strangers(&self) -> bool {
        !self.test_people.is_empty()
            && self
                .test_people
                .iter()
                .all(|p| !self.training_people.contains(p))
    }
}

/// Robot `name`'s built-in body, if it has one.
fn body(name: &str) -> Option<Anatomy> {
    Anatomy::builtin(name).ok()
}

/// The error of the study on robot `name` (its joints `joints` no joints of its body).
fn failed(name: &str, problem: String) -> ExperimentError {
    ExperimentError::Task {
        context: format!("the learned mapping against retargeting, on {name}"),
        problem,
    }
}

/// `model`'s commands for robot `name` on the test frames against the person; `None` when the
/// data carries no study or the robot has no built-in body.
pub(crate) fn learned(
    data: &ExperimentData,
    name: &str,
    model: &SharedGplvm,
) -> Result<Option<ArmSummary>, ExperimentError> {
    let Some(study) = &data.retargeting else {
        return Ok(None);
    };
    let Some(r) = data.robots.iter().position(|(n, _)| n == name) else {
        return Ok(None);
    };
    let (Some(anatomy), Some(joints)) = (body(name), study.robot_joints.get(r)) else {
        return Ok(None);
    };
    let human = data.human.test.as_ref();
    let predicted = model
        .predict(human, name, false)
        .map_err(|e| failed(name, e.to_string()))?
        .mean;
    against_person(&anatomy, joints, predicted.as_ref(), human)
        .map(Some)
        .map_err(|e| failed(name, e))
}

/// The summary of `anatomy`'s arms at each row of `commands` (columns `joints`) against the
/// person at the same row of `human`.
fn against_person(
    anatomy: &Anatomy,
    joints: &[String],
    commands: MatRef<'_, f64>,
    human: MatRef<'_, f64>,
) -> Result<ArmSummary, String> {
    let person = PersonDistance::new(anatomy).map_err(|e| e.to_string())?;
    let configurations = configurations(anatomy, joints, commands)?;
    Ok(ArmSummary::of(&from_person(
        &person,
        &configurations,
        human,
    )?))
}

/// The retargeted test frames against the person, per robot with a built-in body; `None` when
/// the data carries no study.
pub(crate) fn study(data: &ExperimentData) -> Result<Option<RetargetingStudy>, ExperimentError> {
    let Some(study) = &data.retargeting else {
        return Ok(None);
    };
    let (mut retargeted, mut left_out) = (Vec::new(), Vec::new());
    for (r, (name, split)) in data.robots.iter().enumerate() {
        match (body(name), study.robot_joints.get(r)) {
            (Some(anatomy), Some(joints)) => {
                let summary = against_person(
                    &anatomy,
                    joints,
                    split.test.as_ref(),
                    data.human.test.as_ref(),
                )
                .map_err(|e| failed(name, e))?;
                retargeted.push((name.clone(), summary));
            }
            _ => left_out.push(name.clone()),
        }
    }
    Ok(Some(RetargetingStudy {
        test_people: study.test_people.clone(),
        training_people: study.training_people.clone(),
        retargeted,
        left_out,
    }))
}
