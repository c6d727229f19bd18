//! What an anatomy found, for a person to check at a glance (`sgplvm robot ROBOT.urdf`) or
//! as JSON.

use serde::Serialize;

use super::{Anatomy, AnatomyArm, Found, Mount};

/// One arm as reported.
#[derive(Debug, Clone, Serialize)]
pub struct ArmReport {
    /// `left` or `right`.
    pub side: &'static str,
    /// The link the arm hangs from.
    pub from: String,
    /// The hand link.
    pub to: String,
    /// The arm's joints, shoulder to hand.
    pub joints: Vec<String>,
    /// The straightened arm's reach, metres.
    pub reach_m: f64,
    /// The shoulder-to-hand distance at the zero pose, metres.
    pub zero_pose_reach_m: f64,
    /// The shoulder point in the torso link's frame, metres.
    pub shoulder: [f64; 3],
    /// Distance from the shoulder point to the farthest of the axes that define it, metres.
    pub shoulder_spread_m: f64,
    /// The joint at the elbow.
    pub elbow_joint: String,
    /// The neutral posture, per joint (radians or metres).
    pub neutral: Vec<f64>,
}

/// An anatomy as reported.
#[derive(Debug, Clone, Serialize)]
pub struct AnatomyReport {
    /// The robot's name.
    pub robot: String,
    /// The URDF it was read from.
    pub urdf: String,
    /// How the arms were found.
    pub found: Found,
    /// Left then right.
    pub arms: Vec<ArmReport>,
    /// The link both arms branch from.
    pub torso_link: String,
    /// The root link.
    pub root_link: String,
    /// The body's forward, left and up axes in the root frame at the hold posture.
    pub body_axes_in_root: [[f64; 3]; 3],
    /// Joints outside the arms and their hold values.
    pub held: Vec<(String, f64)>,
    /// The joints commands name.
    pub command_joints: Vec<String>,
    /// How the person's arm is turned before the robot takes it.
    pub mount: Mount,
    /// Distance between the shoulder points, metres (`None` on a single-arm robot).
    pub shoulder_width_m: Option<f64>,
    /// What was noticed.
    pub notes: Vec<String>,
}

impl Anatomy {
    /// The anatomy as a report.
    pub fn report(&self) -> AnatomyReport {
        let arm = |a: &AnatomyArm| ArmReport {
            side: a.side.as_str(),
            from: a.chain.base().to_string(),
            to: a.chain.tip().to_string(),
            joints: a.chain.joint_names().to_vec(),
            reach_m: a.reach,
            zero_pose_reach_m: a.zero_pose_reach,
            shoulder: [a.shoulder.x, a.shoulder.y, a.shoulder.z],
            shoulder_spread_m: a.shoulder_spread_m,
            elbow_joint: a.chain.joint_names()[a.elbow].clone(),
            neutral: a.neutral.clone(),
        };
        AnatomyReport {
            robot: self.robot.name().to_string(),
            urdf: self.robot.source().to_string(),
            found: self.found.clone(),
            arms: self.arms.iter().map(arm).collect(),
            torso_link: self.torso_link.clone(),
            root_link: self.robot.root_link().to_string(),
            body_axes_in_root: self.body_axes_in_root().map(|v| [v.x, v.y, v.z]),
            held: self.held_joints(),
            command_joints: self.command_joint_names(),
            mount: self.mount,
            shoulder_width_m: match self.arms.as_slice() {
                [left, right] => Some((left.shoulder - right.shoulder).norm()),
                _ => None,
            },
            notes: self.notes.clone(),
        }
    }

    /// The anatomy in a few lines of text.
    pub fn summary(&self) -> String {
        let r = self.report();
        let mut out = format!(
            "robot {} ({}): {} movable joints, {} in the arms, {} held\narms: {}\n",
            r.robot,
            r.urdf,
            self.robot.dof(),
            self.arm_joint_names().len(),
            r.held.len(),
            r.found
        );
        for a in &r.arms {
            out += &format!(
                "  {:<5} {} → {}: {} joints ({} … {}); reach {:.3} m (zero pose {:.0} %), elbow {}\n",
                a.side,
                a.from,
                a.to,
                a.joints.len(),
                a.joints.first().map_or("", String::as_str),
                a.joints.last().map_or("", String::as_str),
                a.reach_m,
                100.0 * a.zero_pose_reach_m / a.reach_m.max(1e-12),
                a.elbow_joint,
            );
        }
        let axis = |v: [f64; 3]| format!("({:.2}, {:.2}, {:.2})", v[0], v[1], v[2]);
        out += &format!(
            "body frame: on {}; forward {}, left {}, up {} in {}'s frame; {} (axes meet within {:.1} mm)\n",
            r.torso_link,
            axis(r.body_axes_in_root[0]),
            axis(r.body_axes_in_root[1]),
            axis(r.body_axes_in_root[2]),
            r.root_link,
            match r.shoulder_width_m {
                Some(w) => format!("shoulders {w:.3} m apart"),
                None => "one arm (forward the root's x, --forward to turn it)".into(),
            },
            1e3 * r.arms.iter().map(|a| a.shoulder_spread_m).fold(0.0, f64::max),
        );
        if r.held.is_empty() {
            out += "held: none\n";
        } else {
            let shown: Vec<String> = r
                .held
                .iter()
                .take(8)
                .map(|(n, v)| format!("{n} {v:.3}"))
                .collect();
            out += &format!(
                "held ({}): {}{}\n",
                r.held.len(),
                shown.join(", "),
                if r.held.len() > 8 {
                    format!(", and {} more", r.held.len() - 8)
                } else {
                    String::new()
                }
            );
        }
        out += &format!(
            "commands name: {}\n",
            if r.command_joints == self.arm_joint_names() {
                format!("the {} arm joints", r.command_joints.len())
            } else {
                crate::names::few(&r.command_joints, 6)
            }
        );
        out += &format!("mount: {}\n", r.mount.describe());
        // The notes say the mount too (every command prints them); said once here.
        for n in r.notes.iter().filter(|n| !n.starts_with("mount: ")) {
            out += &format!("note: {n}\n");
        }
        out
    }
}
