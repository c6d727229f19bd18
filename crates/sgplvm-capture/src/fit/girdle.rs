//! The shoulder girdle's share of an arm's turn. Where a rig puts the sternoclavicular joint and
//! the shoulder's centre decides how much of the upper arm's orientation its clavicle carries:
//! the CMU rigs hold the clavicle about 6° forward on average, a Kinect's skeleton (no clavicle
//! segment) at 0, studio rigs whose collar starts at the sternum up to 10° back. The same arm
//! pose then reads as other clavicle *and* shoulder angles. [`with_clavicle`] moves an arm's
//! turn between the two: the clavicle set, the shoulder turned so that the upper arm keeps its
//! orientation in the body (and the elbow and the hand, measured from the upper arm, theirs).

use super::{clavicle_rotation, shoulder::shoulder_angles, shoulder_rotation, ArmAngles};

/// `angles` (one arm, the model's order) with the clavicle at `elevation`, `protraction` and the
/// shoulder's flexion, abduction and rotation chosen so that the upper arm's orientation in the
/// body is unchanged: of the shoulder's two Euler solutions the one the fit would take after
/// the arm's own angles — the nearest, unless the other lies within the arm's `limits` (the
/// model's order; the shoulder's three are used) by a margin more — so that a motion's angles
/// stay continuous and an arm near the shoulder's gimbal point (abduction 90°), where the two
/// lie close, takes the one within the limits whatever its own were. Elbow and wrist unchanged.
pub fn with_clavicle(
    angles: &ArmAngles,
    elevation: f64,
    protraction: f64,
    limits: &[(f64, f64); 9],
) -> ArmAngles {
    let upper = clavicle_rotation(angles[0], angles[1])
        * shoulder_rotation(angles[2], angles[3], angles[4]);
    let shoulder = clavicle_rotation(elevation, protraction).inverse() * upper;
    let own = [angles[2], angles[3], angles[4]];
    let solved = shoulder_angles(shoulder.matrix(), Some(own), &limits[2..5]);
    let mut out = *angles;
    out[0] = elevation;
    out[1] = protraction;
    // `shoulder_angles` always gives a solution (its reference where none reproduces the turn).
    out[2..5].copy_from_slice(&solved[0]);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn upper(a: &ArmAngles) -> nalgebra::Rotation3<f64> {
        clavicle_rotation(a[0], a[1]) * shoulder_rotation(a[2], a[3], a[4])
    }

    #[test]
    fn the_upper_arm_keeps_its_orientation_and_the_shoulder_its_branch() {
        // A raised, turned arm on a clavicle 6° forward, given the Kinect's 0 and a studio's
        // 10° back: the upper arm's orientation is the same to rounding, elbow and wrist as
        // they were, and the shoulder moves by about the clavicle's change, not half a turn.
        let arm: ArmAngles = [0.05, -0.1, 1.2, 0.4, -0.6, 0.9, 0.3, -0.2, 0.1];
        let lim = limits();
        for (e, p) in [(0.0, 0.0), (0.1, 0.17), (-0.17, -0.2)] {
            let moved = with_clavicle(&arm, e, p, &lim);
            assert_eq!((moved[0], moved[1]), (e, p));
            assert!((upper(&moved).matrix() - upper(&arm).matrix()).norm() < 1e-12);
            assert_eq!(moved[5..], arm[5..]);
            let shift: f64 = (2..5).map(|k| (moved[k] - arm[k]).abs()).sum();
            assert!(shift < 1.0, "{moved:?}");
        }
        // Its own clavicle back: the angles it had.
        let back = with_clavicle(&with_clavicle(&arm, 0.0, 0.0, &lim), arm[0], arm[1], &lim);
        assert!(
            back.iter().zip(&arm).all(|(a, b)| (a - b).abs() < 1e-12),
            "{back:?}"
        );
        // Near the gimbal point (abduction 95°) the two Euler solutions lie close: the same
        // arm given on either takes the one within the limits (CMU 13_26's right arm).
        let near: ArmAngles = [-0.17, 0.07, 0.29, 1.66, -0.78, 1.53, 0.08, -0.15, 0.0];
        let other = with_clavicle(&near, -0.17, -0.13, &wide());
        let (a, b) = (
            with_clavicle(&near, -0.09, 0.06, &lim),
            with_clavicle(&other, -0.09, 0.06, &lim),
        );
        assert!(
            a.iter().zip(&b).all(|(x, y)| (x - y).abs() < 1e-9),
            "{a:?}\n{b:?}"
        );
        assert!(
            (2..5).all(|k| (lim[k].0..=lim[k].1).contains(&a[k])),
            "{a:?}"
        );
    }

    /// The shipped human's left-arm limits.
    fn limits() -> [(f64, f64); 9] {
        let robot = sgplvm_robots::Robot::builtin("human").unwrap();
        let h = crate::HumanArms::new(&robot).unwrap();
        *h.limits(sgplvm_robots::Side::Left)
    }

    fn wide() -> [(f64, f64); 9] {
        [(f64::NEG_INFINITY, f64::INFINITY); 9]
    }
}
