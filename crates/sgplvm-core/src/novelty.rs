//! How far a human frame is from every pose the model was trained on: the distance to the
//! nearest training pose, each joint in units of its spread over the training poses.
//!
//! `n(h) = min_i √( (1/D_H) Σ_t ((u_t − Y_it) / σ_t)² )`,  `u = (h − o)/s`
//!
//! with `Y` the human space's centred, scaled training poses (at most [`NOVELTY_POINTS`],
//! evenly spaced), `o`, `s` its offsets and scales and `σ_t` the standard deviation of
//! column `t` of `Y` (at least [`NOVELTY_FLOOR_RAD`] in the user's units: a joint the training
//! never moved is not infinitely strict). The reconstruction error (`reconstruction` module)
//! asks whether the model gives a pose back; a model whose latent space keeps little of the
//! human (a few dimensions, few iterations) gives back every pose about equally badly, and its
//! threshold then follows poses no one makes. This signal asks only whether someone in the
//! training data stood like that: a pose drawn at random within the human's joint limits is
//! far from all of them on the joints people keep still (clavicles, wrists), where a stranger's
//! pose is near someone's.
//!
//! **The threshold**, where the human's joint limits are known
//! ([`SharedGplvm::set_pose_bounds`]), is the percentile of the distances of [`RANDOM_POSES`]
//! poses drawn uniformly within them (ChaCha8, a fixed seed) below which the share of them to
//! follow lies ([`RANDOM_PERCENTILE`], 1 %, for a whole frame), however near or far the people
//! in the data stand from each other. A body part's model follows a larger share of its part's
//! random poses: a random frame is followed only where every part is, so `P` parts each
//! following 1 %^(1/P) of theirs follow 1 % of random frames (two arms: 10 % each,
//! [`crate::PartsGplvm::set_pose_bounds`]).
//! Without the limits it is the [`NOVELTY_PERCENTILE`] of the training frames' distances to
//! the nearest training pose of *another* group (the groups of the trust threshold,
//! [`SharedGplvm::set_trust_groups`]: per person where the data names people), which is
//! computed and reported in either case: how far a person the model has not seen stands from
//! those it has. (Where the training frames stand close together, as repetitions of generated
//! motions do, that distance would hold a new motion between poses the model knows: 13 % of
//! the shipped generated data's test frames. The reconstruction error gates beside it:
//! teleop's default gate holds a frame beyond either.)
//!
//! It is stored in the model file and computed on first use otherwise.

use std::collections::BTreeMap;

use faer::MatRef;
use rand::Rng;
use rand_chacha::rand_core::SeedableRng;

use crate::error::{Error, Result};
use crate::model::SharedGplvm;
use crate::trust::{default_groups, percentile};

/// The percentile of the held-out training frames' distances that bounds the threshold.
pub const NOVELTY_PERCENTILE: f64 = 0.99;
/// The share of random poses within the joint limits the threshold lets through at most.
pub const RANDOM_PERCENTILE: f64 = 0.01;
/// How many random poses the threshold is computed from.
pub const RANDOM_POSES: usize = 2000;
/// The most training poses a frame is compared with (evenly spaced).
pub const NOVELTY_POINTS: usize = 4000;
/// The least spread of a joint (radians, or the user's units), so that a joint the training
/// never moved does not make every other value infinitely far.
pub const NOVELTY_FLOOR_RAD: f64 = 0.05;
/// The seed of the random poses.
const RANDOM_SEED: u64 = 0x006e_6f76_656c_7479;

/// The distances the novelty threshold is computed from (see the `novelty` module).
#[derive(Clone, Debug, PartialEq)]
pub struct NoveltyCalibration {
    /// Each training frame's distance (at most [`crate::TRUST_POINTS`], evenly spaced) to the
    /// nearest training pose of another group.
    pub held_out: Vec<f64>,
    /// Their [`NOVELTY_PERCENTILE`].
    pub percentile: f64,
    /// The percentile of random poses' distances below which the share to follow lies
    /// ([`RANDOM_PERCENTILE`] unless set), when the bounds are known.
    pub random: Option<f64>,
    /// The threshold: `random` where the bounds are known, else `percentile`.
    pub threshold: f64,
}

/// The training poses a frame is compared with, in units of each joint's spread.
#[derive(Debug)]
pub(crate) struct Reference {
    /// Row-major, `d` columns, standardised by `spread`.
    rows: Vec<f64>,
    /// The index of each row among the training frames.
    frames: Vec<usize>,
    d: usize,
    spread: Vec<f64>,
}

impl Reference {
    fn of(model: &SharedGplvm) -> Reference {
        let s = &model.spaces[0];
        let (n, d) = (s.data.nrows(), s.data.ncols());
        let spread: Vec<f64> = (0..d)
            .map(|t| {
                let mean = (0..n).map(|i| s.data[(i, t)]).sum::<f64>() / n.max(1) as f64;
                let var =
                    (0..n).map(|i| (s.data[(i, t)] - mean).powi(2)).sum::<f64>() / n.max(1) as f64;
                var.sqrt().max(NOVELTY_FLOOR_RAD / s.scale[t])
            })
            .collect();
        let m = n.min(NOVELTY_POINTS);
        let frames: Vec<usize> = (0..m).map(|i| i * n / m).collect();
        let rows = frames
            .iter()
            .flat_map(|&i| (0..d).map(move |t| (i, t)))
            .map(|(i, t)| s.data[(i, t)] / spread[t])
            .collect();
        Reference {
            rows,
            frames,
            d,
            spread,
        }
    }

    /// The distance of standardised pose `u` to the nearest row `keep` admits.
    fn nearest(&self, u: &[f64], keep: impl Fn(usize) -> bool) -> f64 {
        let mut best = f64::INFINITY;
        for (r, row) in self.rows.chunks_exact(self.d).enumerate() {
            if !keep(self.frames[r]) {
                continue;
            }
            let mut sum = 0.0;
            for (a, b) in u.iter().zip(row) {
                sum += (a - b) * (a - b);
                if sum >= best {
                    break;
                }
            }
            best = best.min(sum);
        }
        (best / self.d as f64).sqrt()
    }

    /// Raw frame `h` standardised into `u`.
    fn standardise(&self, model: &SharedGplvm, h: &[f64], u: &mut [f64]) {
        let s = &model.spaces[0];
        for t in 0..self.d {
            u[t] = (h[t] - s.offset[t]) / s.scale[t] / self.spread[t];
        }
    }
}

impl SharedGplvm {
    /// The human's joint limits (raw units, one `(lower, upper)` per human column) that the
    /// novelty threshold's random poses are drawn within, and the share of them to follow
    /// (in (0, 1); [`RANDOM_PERCENTILE`] for a model of the whole frame); a stored threshold
    /// is dropped.
    pub fn set_pose_bounds(&mut self, bounds: Vec<(f64, f64)>, followed: f64) -> Result<()> {
        if !(followed > 0.0 && followed < 1.0) {
            return Err(Error::InvalidValue {
                what: "share of random poses to follow".into(),
                reason: format!("{followed}: expected a number between 0 and 1"),
            });
        }
        let d = self.spaces[0].data.ncols();
        if bounds.len() != d {
            return Err(Error::DimensionMismatch {
                what: "pose bounds (one per human joint)".into(),
                expected: d,
                found: bounds.len(),
            });
        }
        if let Some((t, b)) = bounds
            .iter()
            .enumerate()
            .find(|(_, (lo, hi))| !(lo.is_finite() && hi.is_finite() && lo <= hi))
        {
            return Err(Error::InvalidValue {
                what: format!("pose bounds of human joint {t}"),
                reason: format!("{b:?}: expected finite lower ≤ upper"),
            });
        }
        self.pose_bounds = Some(bounds);
        self.random_followed = followed;
        self.novelty = None;
        Ok(())
    }

    /// The bounds set by [`SharedGplvm::set_pose_bounds`].
    pub fn pose_bounds(&self) -> Option<&[(f64, f64)]> {
        self.pose_bounds.as_deref()
    }

    /// The share of random poses within the bounds the novelty threshold follows.
    pub fn random_followed(&self) -> f64 {
        self.random_followed
    }

    /// The novelty threshold: the distance to the nearest training pose (see the `novelty`
    /// module) above which a human frame is one no one in the training data made; the stored
    /// one, or [`SharedGplvm::novelty_calibration`]'s.
    pub fn novelty_threshold(&self) -> Result<f64> {
        match self.novelty {
            Some(t) => Ok(t),
            None => Ok(self.novelty_calibration()?.threshold),
        }
    }

    /// The distances the novelty threshold is computed from, computed now.
    pub fn novelty_calibration(&self) -> Result<NoveltyCalibration> {
        let groups = match &self.trust_groups {
            Some(g) => g.clone(),
            None => default_groups(self.n()),
        };
        let reference = self.novelty_reference();
        let n = self.n();
        let picked = n.min(crate::TRUST_POINTS);
        let mut members: BTreeMap<usize, usize> = BTreeMap::new();
        for &g in &groups {
            *members.entry(g).or_default() += 1;
        }
        if members.len() < 2 {
            return Err(Error::InvalidValue {
                what: "novelty threshold".into(),
                reason: "it needs two groups of training frames".into(),
            });
        }
        let s = &self.spaces[0];
        let mut u = vec![0.0; reference.d];
        let held_out: Vec<f64> = (0..picked)
            .map(|k| {
                let i = k * n / picked;
                for (t, v) in u.iter_mut().enumerate() {
                    *v = s.data[(i, t)] / reference.spread[t];
                }
                reference.nearest(&u, |j| groups[j] != groups[i])
            })
            .collect();
        let p = percentile(held_out.clone(), NOVELTY_PERCENTILE);
        let random = self.pose_bounds.as_ref().map(|bounds| {
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(RANDOM_SEED);
            let mut h = vec![0.0; bounds.len()];
            let distances: Vec<f64> = (0..RANDOM_POSES)
                .map(|_| {
                    for (v, &(lo, hi)) in h.iter_mut().zip(bounds) {
                        *v = if hi > lo {
                            rng.random_range(lo..hi)
                        } else {
                            lo
                        };
                    }
                    reference.standardise(self, &h, &mut u);
                    reference.nearest(&u, |_| true)
                })
                .collect();
            percentile(distances, self.random_followed)
        });
        Ok(NoveltyCalibration {
            threshold: random.unwrap_or(p),
            held_out,
            percentile: p,
            random,
        })
    }

    /// The distance of one raw human frame `h` to the nearest training pose (see the `novelty`
    /// module).
    pub fn novelty(&self, h: &[f64]) -> Result<f64> {
        self.check_input_row(h)?;
        let reference = self.novelty_reference();
        let mut stack = [0.0f64; 64];
        let mut heap;
        let u: &mut [f64] = if h.len() <= 64 {
            &mut stack[..h.len()]
        } else {
            heap = vec![0.0; h.len()];
            &mut heap
        };
        reference.standardise(self, h, u);
        let n = reference.nearest(u, |_| true);
        match n.is_finite() {
            true => Ok(n),
            false => Err(Error::InvalidValue {
                what: "human frame".into(),
                reason: format!("its distance to the training poses is {n}"),
            }),
        }
    }

    /// The distance of each raw human frame (row of `h`) to the nearest training pose.
    pub fn novelties(&self, h: MatRef<'_, f64>) -> Result<Vec<f64>> {
        let mut row = vec![0.0; h.ncols()];
        (0..h.nrows())
            .map(|i| {
                row.iter_mut().enumerate().for_each(|(t, v)| *v = h[(i, t)]);
                self.novelty(&row)
            })
            .collect()
    }

    /// The standardised training poses, built once per model.
    fn novelty_reference(&self) -> &Reference {
        self.novelty_reference
            .get_or_init(|| std::sync::Arc::new(Reference::of(self)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_support::{demo, fit, BackConstraint};

    /// The distance by hand: the nearest of `h`'s training rows, each joint over its spread.
    fn by_hand(train: &faer::Mat<f64>, frame: &[f64]) -> f64 {
        let (n, d) = (train.nrows(), train.ncols());
        let spread: Vec<f64> = (0..d)
            .map(|t| {
                let mean = (0..n).map(|i| train[(i, t)]).sum::<f64>() / n as f64;
                let var = (0..n).map(|i| (train[(i, t)] - mean).powi(2)).sum::<f64>() / n as f64;
                var.sqrt().max(NOVELTY_FLOOR_RAD)
            })
            .collect();
        (0..n)
            .map(|i| {
                let s: f64 = (0..d)
                    .map(|t| ((frame[t] - train[(i, t)]) / spread[t]).powi(2))
                    .sum();
                (s / d as f64).sqrt()
            })
            .fold(f64::INFINITY, f64::min)
    }

    #[test]
    fn novelty_is_the_distance_to_the_nearest_training_pose_in_units_of_its_spread() {
        let m = fit(BackConstraint::Input, 40, 5, 1);
        let (h, ..) = demo(40, 7);
        // A training pose is at distance 0; one moved is as far as by hand, and a pose 3 rad off
        // on every joint (past the data's whole range) is beyond the threshold.
        let row =
            |i: usize, shift: f64| -> Vec<f64> { (0..6).map(|t| h[(i, t)] + shift).collect() };
        assert!(m.novelty(&row(3, 0.0)).unwrap() < 1e-12);
        for (i, shift) in [(5, 0.05), (17, -0.3), (30, 1.0)] {
            let got = m.novelty(&row(i, shift)).unwrap();
            let want = by_hand(&h, &row(i, shift));
            assert!((got - want).abs() < 1e-12, "{got} vs {want}");
        }
        let t = m.novelty_threshold().unwrap();
        assert!(m.novelty(&row(30, 3.0)).unwrap() > t, "threshold {t}");
        // Bad input is an error naming what was expected.
        let e = m.novelty(&[0.0; 5]).unwrap_err().to_string();
        assert!(e.contains('6'), "{e}");
        assert!(m.novelty(&[f64::NAN; 6]).is_err());
    }

    #[test]
    fn the_threshold_holds_out_groups_and_lets_few_random_poses_through() {
        let mut m = fit(BackConstraint::Input, 60, 5, 1);
        m.set_trust_groups((0..60).map(|i| i / 20).collect())
            .unwrap();
        let c = m.novelty_calibration().unwrap();
        assert_eq!((c.random, c.threshold), (None, c.percentile));
        // Held out by group: each frame's nearest pose is in another group, farther than its
        // neighbours in its own.
        assert!(c.held_out.iter().all(|&d| d > 0.0));
        // Bounds wide around the data: the random poses' 1st percentile is the threshold, and
        // at most 1 % of other such poses fall within it.
        m.set_pose_bounds(vec![(-3.0, 6.0); 6], RANDOM_PERCENTILE)
            .unwrap();
        let c = m.novelty_calibration().unwrap();
        assert_eq!(Some(c.threshold), c.random);
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(99);
        let poses = faer::Mat::from_fn(2000, 6, |_, _| rng.random_range(-3.0..6.0));
        let within = m
            .novelties(poses.as_ref())
            .unwrap()
            .iter()
            .filter(|&&d| d <= c.threshold)
            .count();
        assert!(
            within <= 40,
            "{within} of 2000 random poses within {}",
            c.threshold
        );
        // Bad bounds are refused, naming the joint.
        let e = m
            .set_pose_bounds(vec![(0.0, 1.0); 5], RANDOM_PERCENTILE)
            .unwrap_err()
            .to_string();
        assert!(e.contains('6') && e.contains('5'), "{e}");
        let mut bad = vec![(0.0, 1.0); 6];
        bad[2] = (1.0, 0.0);
        let e = m
            .set_pose_bounds(bad, RANDOM_PERCENTILE)
            .unwrap_err()
            .to_string();
        assert!(e.contains("joint 2"), "{e}");
    }

    #[test]
    fn the_threshold_and_bounds_are_stored_and_files_without_them_compute_it() {
        let mut m = fit(BackConstraint::Input, 40, 5, 1);
        m.set_trust_groups((0..40).map(|i| i / 10).collect())
            .unwrap();
        // A part's share (two parts: 10 % of their random poses each).
        m.set_pose_bounds(vec![(-3.0, 6.0); 6], 0.1).unwrap();
        let t = m.novelty_threshold().unwrap();
        let bytes = m.to_bytes();
        let back = SharedGplvm::from_bytes(&bytes).unwrap();
        assert_eq!(
            (back.novelty, back.pose_bounds(), back.random_followed()),
            (Some(t), m.pose_bounds(), 0.1)
        );
        // Recomputed from what the file says, the same threshold; a share out of (0, 1) refused.
        let recomputed = crate::io::with_payload(&bytes, |json| {
            assert!(json.as_object_mut().unwrap().remove("novelty").is_some());
        });
        let back = SharedGplvm::from_bytes(&recomputed).unwrap();
        assert_eq!(back.novelty_threshold().unwrap(), t);
        assert!(m.set_pose_bounds(vec![(-3.0, 6.0); 6], 1.0).is_err());
        let old = crate::io::with_payload(&bytes, |json| {
            let o = json.as_object_mut().unwrap();
            assert!(o.remove("novelty").is_some() && o.remove("pose_bounds").is_some());
            assert!(o.remove("random_followed").is_some());
        });
        let back = SharedGplvm::from_bytes(&old).unwrap();
        assert_eq!(back.novelty, None);
        assert_eq!(
            back.novelty_threshold().unwrap(),
            back.novelty_calibration().unwrap().percentile
        );
        let bad = crate::io::with_payload(&bytes, |json| {
            json.as_object_mut()
                .unwrap()
                .insert("novelty".into(), (-1.0).into());
        });
        let e = SharedGplvm::from_bytes(&bad).unwrap_err().to_string();
        assert!(e.contains("novelty threshold -1"), "{e}");
    }
}
