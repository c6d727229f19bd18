//! A person's shoulder girdle aligned to the people a model learned from ([`GirdleAlignment`]),
//! the arm's turn moved between clavicle and shoulder ([`crate::fit::with_clavicle`]) so that
//! the arm keeps its pose. Why, and where it is used: the `sgplvm::girdle` module.

use crate::fit::{with_clavicle, ArmAngles, ANGLE_NAMES};

/// The human model's limits of each arm's nine angles (left, right; the model's order): a
/// frame whose clavicle lies beyond them (a pose no fit gives: a test's far pose, a corrupt
/// stream) says nothing of where the person's rig puts the collarbone and is not counted into
/// their means, and the shoulder's Euler solution is chosen within them
/// ([`with_clavicle`]). Unlimited where the human model cannot be read.
fn arm_limits() -> [[(f64, f64); 9]; 2] {
    let wide = [(f64::NEG_INFINITY, f64::INFINITY); 9];
    let Ok(human) = sgplvm_robots::Robot::builtin("human") else {
        return [wide; 2];
    };
    let (names, limits) = (human.joint_names(), human.joint_limits());
    ["Left", "Right"].map(|side| {
        ANGLE_NAMES.map(|angle| {
            names
                .iter()
                .position(|n| *n == format!("j{side}{angle}"))
                .map_or((f64::NEG_INFINITY, f64::INFINITY), |k| limits[k])
        })
    })
}

/// A clavicle shift below this (radians) leaves the frame as it is: re-solving the shoulder
/// would only add the rotations' rounding (data far from radians, such as angles scaled by
/// 1e-150, would lose every digit).
const NEGLIGIBLE_SHIFT_RAD: f64 = 1e-9;

/// One arm's nine columns, the model's people's mean clavicle angles, and the person's mean
/// over the frames counted and their count.
#[derive(Clone, Debug)]
struct ArmGirdle {
    columns: [usize; 9],
    limits: [(f64, f64); 9],
    reference: [f64; 2],
    means: [f64; 2],
    counted: usize,
}

impl ArmGirdle {
    /// Counts clavicle angles `v` into the person's means, updated as `m += (v − m) / n`: a
    /// person standing still keeps exactly their own values (a sum divided would round, and
    /// move a still robot by 1e-13 rad).
    fn count(&mut self, v: [f64; 2]) {
        self.counted += 1;
        let n = self.counted as f64;
        for (m, v) in self.means.iter_mut().zip(v) {
            *m += (v - *m) / n;
        }
    }

    /// The shift of the clavicle's elevation and protraction: the people's mean minus the
    /// person's so far (none before a frame is counted).
    fn shift(&self) -> [f64; 2] {
        match self.counted {
            0 => [0.0; 2],
            _ => [
                self.reference[0] - self.means[0],
                self.reference[1] - self.means[1],
            ],
        }
    }
}

/// The alignment of one person's frames, in their order (module docs).
#[derive(Clone, Debug)]
pub struct GirdleAlignment {
    arms: Vec<ArmGirdle>,
}

impl GirdleAlignment {
    /// The alignment for frames of human joints `names` to people whose mean of each joint is
    /// `means`; `None` where no arm has all nine of the human model's angles among `names` (a
    /// model of other joints: nothing to align).
    pub fn new(names: &[String], means: &[f64]) -> Option<GirdleAlignment> {
        let limits = arm_limits();
        let arms: Vec<ArmGirdle> = ["Left", "Right"]
            .iter()
            .zip(limits)
            .filter_map(|(side, limits)| {
                let mut columns = [0; 9];
                for (c, angle) in columns.iter_mut().zip(ANGLE_NAMES) {
                    let name = format!("j{side}{angle}");
                    *c = names.iter().position(|n| *n == name)?;
                }
                let reference = [*means.get(columns[0])?, *means.get(columns[1])?];
                Some(ArmGirdle {
                    columns,
                    limits,
                    reference,
                    means: [0.0; 2],
                    counted: 0,
                })
            })
            .collect();
        (!arms.is_empty()).then_some(GirdleAlignment { arms })
    }

    /// Aligns raw human frame `h` (the model's columns) in place, each arm's clavicle counted
    /// into the person's means first where it lies within the human model's limits. A frame
    /// with an arm angle that is not a finite number is left as it is and not counted (the
    /// model refuses it, naming the joint).
    pub fn align(&mut self, h: &mut [f64]) {
        let finite = self.arms.iter().all(|a| {
            a.columns
                .iter()
                .all(|&c| h.get(c).is_some_and(|v| v.is_finite()))
        });
        if !finite {
            return;
        }
        for arm in &mut self.arms {
            let mut angles: ArmAngles = [0.0; 9];
            for (a, &c) in angles.iter_mut().zip(&arm.columns) {
                *a = h[c];
            }
            let within = (0..2).all(|k| {
                let (lo, hi) = arm.limits[k];
                (lo..=hi).contains(&angles[k])
            });
            if within {
                arm.count([angles[0], angles[1]]);
            }
            let shift = arm.shift();
            if shift.iter().all(|v| v.abs() < NEGLIGIBLE_SHIFT_RAD) {
                continue;
            }
            let moved = with_clavicle(
                &angles,
                angles[0] + shift[0],
                angles[1] + shift[1],
                &arm.limits,
            );
            for (&v, &c) in moved.iter().zip(&arm.columns) {
                h[c] = v;
            }
        }
    }

    /// Per arm (left, right where the model has both), the shift of the clavicle's elevation
    /// and protraction the next frame gets (radians): the model's people's mean minus the
    /// person's so far.
    pub fn shifts(&self) -> Vec<[f64; 2]> {
        self.arms.iter().map(ArmGirdle::shift).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn names() -> Vec<String> {
        ["Left", "Right"]
            .iter()
            .flat_map(|s| ANGLE_NAMES.iter().map(move |a| format!("j{s}{a}")))
            .collect()
    }

    #[test]
    fn a_person_s_mean_clavicle_is_moved_to_the_model_s_people_s() {
        let mut means = vec![0.0; 18];
        (means[0], means[1], means[9], means[10]) = (0.05, -0.1, 0.06, -0.11);
        let mut a = GirdleAlignment::new(&names(), &means).unwrap();
        // A rig without clavicles (0, 0) over three frames of a moving arm: every frame's
        // clavicle becomes the people's mean, the shoulders re-solved.
        for k in 0..3 {
            let mut h = vec![0.0; 18];
            (h[2], h[3], h[4], h[5]) = (0.3 * k as f64, 0.2, -0.1, 0.8);
            (h[11], h[12]) = (0.4, 0.1);
            let before = h.clone();
            a.align(&mut h);
            assert!(
                (h[0] - 0.05).abs() < 1e-12 && (h[1] + 0.1).abs() < 1e-12,
                "{h:?}"
            );
            assert!(
                (h[9] - 0.06).abs() < 1e-12 && (h[10] + 0.11).abs() < 1e-12,
                "{h:?}"
            );
            assert_eq!(h[5..9], before[5..9]);
            assert!(h[2..5] != before[2..5]);
        }
        assert!(a.shifts().iter().all(|s| s.iter().all(|v| v.abs() > 0.04)));
        // A frame with no number in an arm is left alone and not counted; one whose clavicle
        // lies beyond the human's limits is aligned but not counted.
        let mut bad = vec![0.0; 18];
        bad[3] = f64::NAN;
        let before = a.shifts();
        a.align(&mut bad);
        assert_eq!(bad[0], 0.0);
        let mut far = vec![2.5; 18];
        a.align(&mut far);
        assert_eq!(a.shifts(), before);
        // Frames of other joints: nothing to align.
        assert!(GirdleAlignment::new(&["x".to_string()], &[0.0]).is_none());
        // A person standing still gives the very same frame every time (a robot held still).
        let mut still = GirdleAlignment::new(&names(), &means).unwrap();
        let pose: Vec<f64> = (0..18).map(|k| 0.1 + 0.013 * k as f64).collect();
        let first = {
            let mut h = pose.clone();
            still.align(&mut h);
            h
        };
        for _ in 0..500 {
            let mut h = pose.clone();
            still.align(&mut h);
            assert_eq!(h, first);
        }
    }
}
