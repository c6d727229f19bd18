//! What of a robot its commands depend on, recorded so that a model trained for one robot
//! can tell when it is given another: the URDF's robot name and every joint from the root to
//! the commanded joints (where each sits, how it turns, its limits).
//!
//! Two URDFs with the same joint names (a family's members, a revised description) give the
//! same command columns; only this record tells the model's commands were learned on other
//! arms, other limits.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use super::Robot;
use crate::names::few;

/// Positions (metres), angles (radians) and limits that differ by less than this are the
/// same: a URDF written again with other float formatting is the same robot.
pub const IDENTITY_TOLERANCE: f64 = 1e-6;

/// One joint as [`RobotIdentity`] records it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct JointRecord {
    /// The joint's name.
    pub name: String,
    /// Its type, lower case as in the URDF (`revolute`, `fixed`, …).
    pub kind: String,
    /// Its origin in the parent link: x, y, z (metres).
    pub origin: [f64; 3],
    /// Its origin's rotation as a unit quaternion (x, y, z, w; `q` and `−q` are the same).
    pub rotation: [f64; 4],
    /// Its unit axis.
    pub axis: [f64; 3],
    /// Lower and upper position limits (null where unbounded).
    pub limits: [Option<f64>; 2],
    /// Velocity limit (0 where the URDF states none).
    pub velocity: f64,
}

/// A robot as its commands depend on it: see the module docs.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RobotIdentity {
    /// The URDF's `<robot name>`.
    pub urdf_name: String,
    /// Every joint on the paths from the root link to the commanded joints, by name.
    pub joints: BTreeMap<String, JointRecord>,
}

impl Robot {
    /// The robot as commands of `commanded` joints depend on it (a name the robot lacks is
    /// left out: the model's columns are checked against the URDF elsewhere).
    pub fn identity(&self, commanded: &[String]) -> RobotIdentity {
        let by_child: BTreeMap<usize, usize> = self
            .joints
            .iter()
            .enumerate()
            .map(|(k, j)| (j.child, k))
            .collect();
        let mut joints = BTreeMap::new();
        for name in commanded {
            let mut next = self.joints.iter().position(|j| &j.name == name);
            while let Some(k) = next {
                let j = &self.joints[k];
                if joints.contains_key(&j.name) {
                    break;
                }
                let q = j.origin.rotation.coords;
                let t = j.origin.translation.vector;
                let bound = |v: f64| v.is_finite().then_some(v);
                joints.insert(
                    j.name.clone(),
                    JointRecord {
                        name: j.name.clone(),
                        kind: format!("{:?}", j.kind).to_lowercase(),
                        origin: [t.x, t.y, t.z],
                        rotation: [q.x, q.y, q.z, q.w],
                        axis: [j.axis.x, j.axis.y, j.axis.z],
                        limits: [bound(j.limits.0), bound(j.limits.1)],
                        velocity: j.velocity,
                    },
                );
                next = by_child.get(&j.parent).copied();
            }
        }
        RobotIdentity {
            urdf_name: self.name().to_string(),
            joints,
        }
    }
}

impl RobotIdentity {
    /// How `other` differs from this record, one sentence per difference, the first few of
    /// each kind (empty: the same robot as far as commands go).
    /// The URDF's name is no difference: a file copied under another name, or a nameless one
    /// named after its file, is the same robot.
    pub fn differences(&self, other: &RobotIdentity) -> Vec<String> {
        let mut out = Vec::new();
        let missing: Vec<&String> = self
            .joints
            .keys()
            .filter(|n| !other.joints.contains_key(*n))
            .collect();
        if !missing.is_empty() {
            out.push(format!("no joint {}", few(&missing, 3)));
        }
        let mut placed = Vec::new();
        let mut turned = Vec::new();
        let mut limited = Vec::new();
        for (name, was) in &self.joints {
            let Some(now) = other.joints.get(name) else {
                continue;
            };
            let dot: f64 = (0..4).map(|i| was.rotation[i] * now.rotation[i]).sum();
            if was.kind != now.kind
                || !close(&was.axis, &now.axis)
                || 1.0 - dot.abs() > IDENTITY_TOLERANCE
            {
                turned.push(name.clone());
            } else if !close(&was.origin, &now.origin) {
                let d: f64 = (0..3)
                    .map(|i| (was.origin[i] - now.origin[i]).powi(2))
                    .sum::<f64>()
                    .sqrt();
                placed.push(format!("{name} ({:.0} mm)", d * 1000.0));
            } else if was
                .limits
                .iter()
                .zip(&now.limits)
                .any(|(a, b)| match (a, b) {
                    (Some(a), Some(b)) => (a - b).abs() > IDENTITY_TOLERANCE,
                    (None, None) => false,
                    _ => true,
                })
                || (was.velocity - now.velocity).abs() > IDENTITY_TOLERANCE
            {
                limited.push(name.clone());
            }
        }
        if !placed.is_empty() {
            out.push(format!("joint {} elsewhere", few(&placed, 3)));
        }
        if !turned.is_empty() {
            out.push(format!(
                "joint {} turned or of another type",
                few(&turned, 3)
            ));
        }
        if !limited.is_empty() {
            out.push(format!("other limits on {}", few(&limited, 3)));
        }
        out
    }
}

/// Whether two vectors agree within [`IDENTITY_TOLERANCE`].
fn close(a: &[f64], b: &[f64]) -> bool {
    a.iter()
        .zip(b)
        .all(|(x, y)| (x - y).abs() <= IDENTITY_TOLERANCE)
}

#[cfg(test)]
mod tests {
    use super::*;

    const ARM: &str = r#"<robot name="arm">
      <link name="base"/><link name="upper"/><link name="fore"/><link name="finger"/>
      <joint name="shoulder" type="revolute"><parent link="base"/><child link="upper"/>
        <origin xyz="0 0.2 0.5"/><axis xyz="0 1 0"/><limit lower="-2" upper="2" velocity="3" effort="1"/></joint>
      <joint name="elbow" type="revolute"><parent link="upper"/><child link="fore"/>
        <origin xyz="0 0 -0.3"/><axis xyz="0 1 0"/><limit lower="0" upper="2.5" velocity="3" effort="1"/></joint>
      <joint name="finger" type="revolute"><parent link="fore"/><child link="finger"/>
        <origin xyz="0 0 -0.3"/><axis xyz="1 0 0"/><limit lower="0" upper="1" velocity="3" effort="1"/></joint>
    </robot>"#;

    fn identity(xml: &str) -> RobotIdentity {
        Robot::from_urdf_str(xml, "test")
            .unwrap()
            .identity(&["shoulder".into(), "elbow".into()])
    }

    #[test]
    fn the_same_arms_are_the_same_robot_and_a_joint_not_commanded_is_not_recorded() {
        let a = identity(ARM);
        assert_eq!(
            a.joints.len(),
            2,
            "the finger is not on a commanded joint's path"
        );
        assert!(a.differences(&a).is_empty());
        let finger = ARM.replace(r#"upper="1" velocity"#, r#"upper="0.5" velocity"#);
        assert!(a.differences(&identity(&finger)).is_empty());
    }

    #[test]
    fn another_robot_of_the_same_joint_names_is_told_apart_and_named() {
        let a = identity(ARM);
        let b = identity(
            &ARM.replace(r#"name="arm""#, r#"name="other""#)
                .replace(
                    r#"xyz="0 0 -0.3"/><axis xyz="0 1 0"/><limit lower="0" upper="2.5""#,
                    r#"xyz="0 0 -0.35"/><axis xyz="0 1 0"/><limit lower="0" upper="2.5""#,
                )
                .replace(r#"lower="-2" upper="2""#, r#"lower="-1" upper="2""#),
        );
        let said = a.differences(&b).join("; ");
        assert_eq!(
            said,
            "joint \"elbow (50 mm)\" elsewhere; other limits on \"shoulder\""
        );
        // The name alone is no difference, nor a rotation of π written two ways.
        let renamed = identity(&ARM.replace(r#"name="arm""#, r#"name="other""#));
        assert!(a.differences(&renamed).is_empty());
        let half_turn = |rpy: &str| {
            identity(&ARM.replace(
                r#"<origin xyz="0 0.2 0.5"/>"#,
                &format!(r#"<origin xyz="0 0.2 0.5" rpy="{rpy}"/>"#),
            ))
        };
        assert!(half_turn("3.14159265359 0 0")
            .differences(&half_turn("-3.14159265359 0 0"))
            .is_empty());
        let turned = identity(&ARM.replace(
            r#"<origin xyz="0 0 -0.3"/><axis xyz="0 1 0"/>"#,
            r#"<origin xyz="0 0 -0.3"/><axis xyz="1 0 0"/>"#,
        ));
        assert_eq!(
            a.differences(&turned),
            vec!["joint \"elbow\" turned or of another type"]
        );
    }
}
