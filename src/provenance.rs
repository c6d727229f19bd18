//! Which robot a model's commands were learned on, and of which person, carried in the model
//! file: `retarget` records each robot it retargeted onto ([`RobotIdentity`]: the URDF's name,
//! every joint from the root to the commanded ones) and `import` each capture's person
//! calibration; `train` and `transfer` — and Python's `model.annotate(demo["provenance"])` —
//! attach them ([`demonstration_annotations`]), and whoever drives a robot with the model
//! compares the robot it is given ([`other_robot`]): a robot of the same joint names but other
//! arms or limits (a family's other member, a revised URDF) is said, not driven silently.

use std::collections::BTreeMap;
use std::path::Path;

use serde_json::Value;
use sgplvm_robots::dataset::{capture_records_in, CAPTURE_METADATA};
use sgplvm_robots::joint_state::read_topics;
use sgplvm_robots::retarget::file::retargeted_arms_in;
use sgplvm_robots::{Anatomy, RobotIdentity};

use crate::pipeline::PipelineError;

/// The model annotation holding, per robot, the [`RobotIdentity`] its commands were
/// retargeted onto.
pub const ROBOTS_ANNOTATION: &str = "sgplvm.robots";

/// What a model trained on the demonstrations in the file `path` for its robots `robots` carries
/// of them, as annotations to add to one whose annotations are `existing`: where the frames
/// were captured — each capture's source with the person's calibration ([`CAPTURE_METADATA`]),
/// so that `teleop` fits a stream of the same person as the data was imported (kept where
/// `existing` has it: a transfer keeps its source's) — and the robots the commands were
/// retargeted onto ([`ROBOTS_ANNOTATION`], added to those `existing` records), so that driving
/// another is said. A robot without a record (generated data, a file written before records)
/// adds none.
pub fn demonstration_annotations(
    path: &Path,
    robots: &[String],
    existing: &BTreeMap<String, Value>,
) -> Result<Vec<(&'static str, Value)>, PipelineError> {
    let mut found = Vec::new();
    // The file's metadata read once for both records.
    let metadata = read_topics(path, &[])?.metadata;
    let records = capture_records_in(path, &metadata)?;
    if !records.is_empty() && !existing.contains_key(CAPTURE_METADATA) {
        found.push((CAPTURE_METADATA, Value::from(records)));
    }
    let mut arms = match robots {
        [] => BTreeMap::new(),
        _ => retargeted_arms_in(path, &metadata).map_err(|e| PipelineError::Parts {
            body: robots.join(", "),
            detail: e.to_string(),
        })?,
    };
    let identities: BTreeMap<String, RobotIdentity> = robots
        .iter()
        .filter_map(|name| Some((name.clone(), arms.remove(name)?.identity?)))
        .collect();
    if let Some(value) = robots_annotation(existing, identities) {
        found.push((ROBOTS_ANNOTATION, value));
    }
    Ok(found)
}

/// Whether `value` is what `sgplvm` reads under the annotation `key`: for
/// [`ROBOTS_ANNOTATION`] robot records by name, for [`CAPTURE_METADATA`] capture records as
/// `teleop` reads them (their calibrations valid); any value under another key. The error
/// says what was expected.
fn check_annotation(key: &str, value: &Value) -> Result<(), String> {
    match key {
        ROBOTS_ANNOTATION => serde_json::from_value::<BTreeMap<String, RobotIdentity>>(value.clone())
            .map(drop)
            .map_err(|e| format!("annotation `{key}`: expected robot records by name, as `retarget` writes them: {e}")),
        CAPTURE_METADATA => sgplvm_capture::calibrations_in(value).map(drop).map_err(|e| {
            format!("annotation `{key}`: expected capture records as `import` writes them: {e}")
        }),
        _ => Ok(()),
    }
}

/// The value to keep under annotation `key` when `value` is added to a model whose
/// annotations are `existing`: robot records join those there (a robot's replacing its
/// earlier one, as `transfer` adds each robot it fits), any other value replaces; checked as
/// sgplvm reads it (robot records, capture records with valid calibrations).
pub fn added_annotation(
    existing: &BTreeMap<String, Value>,
    key: &str,
    value: Value,
) -> Result<Value, String> {
    check_annotation(key, &value)?;
    if key != ROBOTS_ANNOTATION {
        return Ok(value);
    }
    let identities: BTreeMap<String, RobotIdentity> =
        serde_json::from_value(value).map_err(|e| e.to_string())?;
    Ok(robots_annotation(existing, identities).unwrap_or_else(|| serde_json::json!({})))
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
    fn the_annotations_sgplvm_reads_are_checked_and_others_taken_as_they_are() {
        assert!(check_annotation(ROBOTS_ANNOTATION, &serde_json::json!({})).is_ok());
        let wrong = check_annotation(ROBOTS_ANNOTATION, &serde_json::json!([1])).unwrap_err();
        assert!(wrong.contains(ROBOTS_ANNOTATION) && wrong.contains("robot records"));
        // A capture record is read as `teleop` reads it: what `import` writes, nothing less.
        assert!(check_annotation(CAPTURE_METADATA, &serde_json::json!([])).is_ok());
        for wrong in [serde_json::json!({"file": "a"}), serde_json::json!([{}])] {
            let said = check_annotation(CAPTURE_METADATA, &wrong).unwrap_err();
            assert!(said.contains("expected capture records"), "{said}");
        }
        assert!(check_annotation("lab.note", &serde_json::json!(3)).is_ok());
    }

    #[test]
    fn robot_records_added_join_those_there_and_other_values_replace() {
        let identity = |name: &str| RobotIdentity {
            urdf_name: name.into(),
            joints: BTreeMap::new(),
        };
        let robots = |names: &[&str]| {
            serde_json::json!(names
                .iter()
                .map(|n| (n.to_string(), identity(n)))
                .collect::<BTreeMap<_, _>>())
        };
        let existing = BTreeMap::from([
            (ROBOTS_ANNOTATION.to_string(), robots(&["walkman"])),
            ("lab.note".to_string(), serde_json::json!(1)),
        ]);
        let joined = added_annotation(&existing, ROBOTS_ANNOTATION, robots(&["coman"])).unwrap();
        let read: BTreeMap<String, RobotIdentity> = serde_json::from_value(joined).unwrap();
        assert_eq!(read.keys().collect::<Vec<_>>(), ["coman", "walkman"]);
        assert_eq!(
            added_annotation(&existing, "lab.note", serde_json::json!(2)).unwrap(),
            serde_json::json!(2)
        );
        assert!(added_annotation(&existing, ROBOTS_ANNOTATION, serde_json::json!(3)).is_err());
    }

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
