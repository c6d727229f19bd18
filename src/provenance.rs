//! Which robot a model's commands were learned on, carried in the model file: `retarget`
//! records each robot it retargeted onto ([`RobotIdentity`]: the URDF's name, every joint from
//! the root to the commanded ones), `train` and `transfer` attach the record of each robot they
//! fit ([`ROBOTS_ANNOTATION`]), and whoever drives a robot with the model compares the robot it
//! is given ([`other_robot`]): a robot of the same joint names but other arms or limits (a
//! family's other member, a revised URDF) is said, not driven silently.

use std::collections::BTreeMap;

use serde_json::Value;
use sgplvm_robots::{Anatomy, RobotIdentity};

use crate::pipeline::{Demonstrations, PipelineError};

/// The model annotation holding, per robot, the [`RobotIdentity`] its commands were
/// retargeted onto.
pub const ROBOTS_ANNOTATION: &str = "sgplvm.robots";

impl Demonstrations {
    /// The robots of `names` as `retarget` recorded them in the file these demonstrations came
    /// from (a robot without a record — generated data, a file written before records — is
    /// left out).
    pub fn robot_identities(
        &self,
        names: &[String],
    ) -> Result<BTreeMap<String, RobotIdentity>, PipelineError> {
        let mut found = BTreeMap::new();
        for name in names {
            if let Some(identity) = self.retargeted_arms(name)?.and_then(|a| a.identity) {
                found.insert(name.clone(), identity);
            }
        }
        Ok(found)
    }
}

/// The [`ROBOTS_ANNOTATION`] of a model whose `annotations` are these, with `identities` added
/// (replacing a robot's earlier record); `None` when there is nothing to record.
pub fn robots_annotation(
    annotations: &BTreeMap<String, Value>,
    identities: BTreeMap<String, RobotIdentity>,
) -> Option<Value> {
    let mut all = recorded(annotations);
    all.extend(identities);
    (!all.is_empty()).then(|| serde_json::json!(all))
}

/// The robots a model's `annotations` record (an unreadable record counts as none: it only
/// ever adds a warning).
fn recorded(annotations: &BTreeMap<String, Value>) -> BTreeMap<String, RobotIdentity> {
    annotations
        .get(ROBOTS_ANNOTATION)
        .and_then(|v| serde_json::from_value(v.clone()).ok())
        .unwrap_or_default()
}

/// How `given`, the body a model with these `annotations` is to drive as `robot`, differs from
/// the robot its commands for `robot` were learned on, as one sentence; `None` where it is the
/// same or the model records none.
pub fn other_robot(
    annotations: &BTreeMap<String, Value>,
    robot: &str,
    given: &Anatomy,
) -> Option<String> {
    let learned = recorded(annotations).remove(robot)?;
    let names: Vec<String> = learned.joints.keys().cloned().collect();
    let now = given.robot().identity(&names);
    let differences = learned.differences(&now);
    (!differences.is_empty()).then(|| {
        let urdfs = if learned.urdf_name == now.urdf_name {
            format!("URDF robot `{}`", now.urdf_name)
        } else {
            format!("URDF robot `{}`, learned on `{}`", now.urdf_name, learned.urdf_name)
        };
        format!(
            "{robot}: the model's commands were learned on another robot than the URDF given ({urdfs}: {}): its joint limits and collisions hold commands learned for the other; retarget the demonstrations onto this URDF and train again to drive it",
            differences.join("; ")
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_robot_recorded_again_replaces_its_record_and_keeps_the_others() {
        let identity = |name: &str| RobotIdentity {
            urdf_name: name.into(),
            joints: BTreeMap::new(),
        };
        let first = robots_annotation(
            &BTreeMap::new(),
            BTreeMap::from([
                ("a".to_string(), identity("a1")),
                ("b".into(), identity("b")),
            ]),
        )
        .unwrap();
        let annotations = BTreeMap::from([(ROBOTS_ANNOTATION.to_string(), first)]);
        let both = robots_annotation(
            &annotations,
            BTreeMap::from([("a".to_string(), identity("a2"))]),
        )
        .unwrap();
        let read: BTreeMap<String, RobotIdentity> = serde_json::from_value(both).unwrap();
        assert_eq!(read["a"].urdf_name, "a2");
        assert_eq!(read["b"].urdf_name, "b");
        assert!(robots_annotation(&BTreeMap::new(), BTreeMap::new()).is_none());
    }
}
