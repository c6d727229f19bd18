//! The body models shipped with sgplvm (WALK-MAN, COMAN and CENTAURO upper bodies and a 1.75 m
//! human with 9-joint arms, the paper's bodies; and `ur5e`, two 6-joint Universal Robots UR5e
//! arms on a torso, a robot of a different kinematic structure), embedded in the binary, and the
//! arm convention they follow.
//!
//! Convention (any URDF may follow it): links named `left_shoulder`, `left_hand`,
//! `right_shoulder` and `right_hand`. The shoulder links are fixed frames on the torso at the
//! shoulder joint centre (children of the root link, not of the arm), the hand links are fixed
//! frames at the hand (palm) point below the last wrist joint. The arm chains run from the root
//! link to the hand links; the built-in models list their movable joints left arm then right
//! arm, shoulder to wrist, and this is the column order of R and H everywhere in the project.

use crate::error::{RobotError, RobotResult};
use crate::kinematics::Chain;
use crate::urdf::Robot;

const WALKMAN: &str = include_str!("../../../data/urdf/walkman.urdf");
const COMAN: &str = include_str!("../../../data/urdf/coman.urdf");
const CENTAURO: &str = include_str!("../../../data/urdf/centauro.urdf");
const HUMAN: &str = include_str!("../../../data/urdf/human.urdf");
const UR5E: &str = include_str!("../../../data/urdf/ur5e.urdf");

const NAMES: &[&str] = &["walkman", "coman", "centauro", "human", "ur5e"];

/// Which arm.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Side {
    /// The robot's left (+y in the torso frame).
    Left,
    /// The robot's right (−y).
    Right,
}

impl Side {
    /// `"left"` or `"right"`, the prefix of the convention's link names.
    pub fn as_str(self) -> &'static str {
        match self {
            Side::Left => "left",
            Side::Right => "right",
        }
    }

    /// The other side.
    pub fn other(self) -> Side {
        match self {
            Side::Left => Side::Right,
            Side::Right => Side::Left,
        }
    }

    /// 0 for the left, 1 for the right: the index of a side in per-side arrays (the person's
    /// two arms).
    pub fn index(self) -> usize {
        usize::from(self == Side::Right)
    }
}

/// One arm of a robot that follows the shoulder/hand link convention.
#[derive(Debug, Clone)]
pub struct Arm {
    /// Left or right.
    pub side: Side,
    /// Movable joints from the root link to the hand link (poses in the root frame).
    pub chain: Chain,
    /// The fixed frame at the shoulder joint centre (`left_shoulder` / `right_shoulder`).
    pub shoulder_link: String,
    /// The hand frame (`left_hand` / `right_hand`), the chain's tip.
    pub hand_link: String,
    /// Distance shoulder frame → hand frame with every joint at 0 (arm hanging straight for
    /// the built-in models): the scale for placing hand targets.
    pub length: f64,
}

impl Robot {
    /// One of the shipped models by name: `"walkman"`, `"coman"`, `"centauro"`, `"human"` or
    /// `"ur5e"`.
    pub fn builtin(name: &str) -> RobotResult<Robot> {
        let xml = Robot::builtin_urdf(name).ok_or_else(|| RobotError::UnknownBuiltin {
            name: name.to_string(),
            available: NAMES.to_vec(),
        })?;
        Robot::from_urdf_str(xml, &format!("builtin:{name}"))
    }

    /// Names accepted by [`Robot::builtin`].
    pub fn builtin_names() -> &'static [&'static str] {
        NAMES
    }

    /// The embedded URDF text of a shipped model (e.g. for a physics engine's loader).
    pub fn builtin_urdf(name: &str) -> Option<&'static str> {
        match name {
            "walkman" => Some(WALKMAN),
            "coman" => Some(COMAN),
            "centauro" => Some(CENTAURO),
            "human" => Some(HUMAN),
            "ur5e" => Some(UR5E),
            _ => None,
        }
    }

    /// Left and right arm, if the robot has the `left_shoulder`, `left_hand`, `right_shoulder`
    /// and `right_hand` links of the convention.
    pub fn arms(&self) -> Option<[Arm; 2]> {
        let root = self.root_link().to_string();
        let zero = vec![0.0; self.dof()];
        let arm = |side: Side| -> Option<Arm> {
            let shoulder_link = format!("{}_shoulder", side.as_str());
            let hand_link = format!("{}_hand", side.as_str());
            let chain = self.chain(&root, &hand_link).ok()?;
            let shoulder = self.forward_kinematics(&zero, &shoulder_link).ok()?;
            let hand = self.forward_kinematics(&zero, &hand_link).ok()?;
            let length = (hand.translation.vector - shoulder.translation.vector).norm();
            Some(Arm {
                side,
                chain,
                shoulder_link,
                hand_link,
                length,
            })
        };
        Some([arm(Side::Left)?, arm(Side::Right)?])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_builtin_loads_with_its_arm_order() {
        let expect: [(&str, usize, &str, &str, &str); 5] = [
            ("walkman", 14, "DWYTorso", "LShSag", "RWrj2"),
            (
                "ur5e",
                12,
                "torso",
                "left_shoulder_pan_joint",
                "right_wrist_3_joint",
            ),
            ("coman", 14, "DWYTorso", "LShSag", "RWrj2"),
            ("centauro", 14, "torso_2", "j_arm1_1", "j_arm2_7"),
            (
                "human",
                18,
                "T8",
                "jLeftC7Shoulder_elevation",
                "jRightWrist_deviation",
            ),
        ];
        for (name, dof, root, first, last) in expect {
            let r = Robot::builtin(name).unwrap();
            assert_eq!(r.name(), name);
            assert_eq!(r.dof(), dof, "{name}");
            assert_eq!(r.root_link(), root);
            let names = r.joint_names();
            assert_eq!(names[0], first);
            assert_eq!(names[dof - 1], last);
            let [left, right] = r.arms().expect("builtins follow the arm convention");
            assert_eq!(left.side, Side::Left);
            assert_eq!(right.side, Side::Right);
            // Left arm = first half of q, right arm = second half, shoulder to wrist.
            let half = dof / 2;
            assert_eq!(
                left.chain.robot_indices(),
                (0..half).collect::<Vec<_>>().as_slice()
            );
            assert_eq!(
                right.chain.robot_indices(),
                (half..dof).collect::<Vec<_>>().as_slice()
            );
            assert_eq!(left.chain.joint_names(), &names[..half]);
            // urdf-rs read the same file.
            assert_eq!(r.urdf().joints.len(), r.joints().len());
        }
    }

    #[test]
    fn shoulder_widths_and_arm_lengths_follow_robots_md() {
        // (name, shoulder width, arm length shoulder→hand at zero)
        let expect = [
            ("coman", 0.312, 0.181 + 0.195 + 0.07),
            (
                "centauro",
                0.444,
                0.21915 + 0.074 + 0.061 + 0.18 + 0.169 + 0.07,
            ),
            ("human", 0.2 * 1.75, (0.168 + 0.138 + 0.108) * 1.75),
            // Shoulder centres (pan and lift axes meet) d1 along the pan axis, turned 30° back,
            // from bases 0.13 m out of the torso's middle; at q = 0 the flange is a2 + a3 below
            // the shoulder, d4 + d6 to one side and d5 to another (data/urdf/README.md).
            (
                "ur5e",
                2.0 * (0.13 + 0.1625 * 3f64.sqrt() / 2.0),
                ((0.425f64 + 0.3922).powi(2) + (0.1333f64 + 0.0996).powi(2) + 0.0997f64.powi(2))
                    .sqrt(),
            ),
        ];
        for (name, width, length) in expect {
            let r = Robot::builtin(name).unwrap();
            let [l, rt] = r.arms().unwrap();
            let zero = vec![0.0; r.dof()];
            let ls = r.forward_kinematics(&zero, &l.shoulder_link).unwrap();
            let rs = r.forward_kinematics(&zero, &rt.shoulder_link).unwrap();
            let w = (ls.translation.vector - rs.translation.vector).norm();
            assert!(
                (w - width).abs() < 5e-3,
                "{name}: shoulder width {w} vs {width}"
            );
            assert!(
                (l.length - length).abs() < 0.01,
                "{name}: arm length {} vs {length}",
                l.length
            );
            assert!((l.length - rt.length).abs() < 1e-12, "{name}: arms differ");
        }
        // WALK-MAN's shoulder axes do not meet: its centre is the point nearest to them.
        let w = Robot::builtin("walkman").unwrap();
        let [l, r] = w.arms().unwrap();
        let zero = vec![0.0; 14];
        let ls = w.forward_kinematics(&zero, &l.shoulder_link).unwrap();
        let rs = w.forward_kinematics(&zero, &r.shoulder_link).unwrap();
        let width = (ls.translation.vector - rs.translation.vector).norm();
        assert!(
            (width - 0.657).abs() < 0.03,
            "walkman shoulder width {width}"
        );
    }

    #[test]
    fn hands_sit_at_the_robots_md_offsets_below_the_last_wrist_joint() {
        for (name, wrist_link, offset) in [
            ("coman", "LWrMot3", [0.0, 0.0, -0.07]),
            ("walkman", "LWrMot3", [0.0, -0.0305, -0.21]),
            ("centauro", "arm1_7", [0.0, 0.0, -0.07]),
            ("human", "left_hand_segment", [0.0, 0.0, -0.108 * 1.75]),
            // The UR5e's hand is its tool flange, d6 along the last joint's axis.
            ("ur5e", "left_wrist_3_link", [0.0, 0.0, 0.0996]),
        ] {
            let r = Robot::builtin(name).unwrap();
            let q: Vec<f64> = (0..r.dof()).map(|i| 0.1 * (i as f64 + 1.0).sin()).collect();
            let wrist = r.forward_kinematics(&q, wrist_link).unwrap();
            let hand = r.forward_kinematics(&q, "left_hand").unwrap();
            let local = wrist.inverse() * hand;
            for (got, want) in local.translation.vector.iter().zip(offset) {
                assert!((got - want).abs() < 1e-12, "{name}");
            }
        }
    }

    #[test]
    fn human_right_arm_mirrors_the_left_for_equal_angles() {
        let r = Robot::builtin("human").unwrap();
        let left: Vec<f64> = [0.2, 0.1, 0.8, 0.4, -0.3, 1.2, 0.5, 0.3, 0.1].to_vec();
        let q: Vec<f64> = left.iter().chain(left.iter()).copied().collect();
        let pl = r
            .forward_kinematics(&q, "left_hand")
            .unwrap()
            .translation
            .vector;
        let pr = r
            .forward_kinematics(&q, "right_hand")
            .unwrap()
            .translation
            .vector;
        assert!(
            (pl.x - pr.x).abs() < 1e-12
                && (pl.y + pr.y).abs() < 1e-12
                && (pl.z - pr.z).abs() < 1e-12
        );
        // Flexion lifts the arm forward, abduction sideways.
        let mut q = vec![0.0; 18];
        q[2] = std::f64::consts::FRAC_PI_2;
        let p = r
            .forward_kinematics(&q, "left_hand")
            .unwrap()
            .translation
            .vector;
        let s = r
            .forward_kinematics(&q, "left_shoulder")
            .unwrap()
            .translation
            .vector;
        assert!((p - s - nalgebra::Vector3::new(0.414 * 1.75, 0.0, 0.0)).norm() < 1e-9);
        let mut q = vec![0.0; 18];
        q[3] = std::f64::consts::FRAC_PI_2;
        let p = r
            .forward_kinematics(&q, "left_hand")
            .unwrap()
            .translation
            .vector;
        assert!((p - s - nalgebra::Vector3::new(0.0, 0.414 * 1.75, 0.0)).norm() < 1e-9);
    }

    #[test]
    fn limits_follow_the_tables() {
        let c = Robot::builtin("coman").unwrap();
        let lim = c.joint_limits();
        assert_eq!(lim[0], (-3.4034, 1.6581));
        assert_eq!(lim[8], (-2.094, 0.31415)); // RShLat
        assert_eq!(lim[13], (-1.395, 0.785375)); // RWrj2
        let w = Robot::builtin("walkman").unwrap();
        let lim = w.joint_limits();
        assert_eq!(lim[1], (0.0872665, 3.85718));
        assert_eq!(lim[7], (-2.84489, 2.80998));
        #[allow(clippy::approx_constant)] // WALK-MAN's published velocity limit, not 2π
        let walkman_velocity = 6.283;
        assert_eq!(w.velocity_limits()[3], walkman_velocity);
        let h = Robot::builtin("human").unwrap();
        let lim = h.joint_limits();
        assert!((lim[5].1 - 150f64.to_radians()).abs() < 1e-9);
        assert!((lim[2].0 + 60f64.to_radians()).abs() < 1e-9);
        // UR5e user manual: ±360° per joint, the elbow ±180° (UR's ROS description), 180°/s.
        let u = Robot::builtin("ur5e").unwrap();
        for (j, &(lo, hi)) in u.joint_limits().iter().enumerate() {
            let half = if j % 6 == 2 { 180f64 } else { 360f64 }.to_radians();
            assert!((lo + half).abs() < 1e-9 && (hi - half).abs() < 1e-9, "{j}");
        }
        for v in u.velocity_limits() {
            assert!((v - 180f64.to_radians()).abs() < 1e-9);
        }
    }

    #[test]
    fn unknown_builtin_lists_the_names() {
        let e = Robot::builtin("asimo").unwrap_err().to_string();
        assert_eq!(
            e,
            "unknown built-in robot \"asimo\"; expected one of: walkman, coman, centauro, human, ur5e"
        );
        assert_eq!(Robot::builtin_names().len(), 5);
        assert!(Robot::builtin_urdf("coman").unwrap().contains("LShSag"));
        assert!(Robot::builtin_urdf("nao").is_none());
    }
}
