//! How far a human frame is from the poses the model learned: the human space's own
//! reconstruction of it.
//!
//! `e(h) = √( (1/D_H) Σ_t ((h_t − o_t)/s_t − μ_H,t(x(h)))² )`
//!
//! with `x(h)` the frame's latent point (the back constraint `k_bc(h, H) W`, or the input
//! map), `μ_H` the posterior mean of the shared model's *human* space at it (the model
//! generates the human as it generates every robot) and `o`, `s` the human space's offsets and
//! scales: the root mean square, over the human joints, of what the model cannot give back of
//! the pose (radians for unscaled data). The robots' predictive standard deviation (`trust`
//! module) does not see a far input: the back constraint's kernel vanishes there, so a pose
//! with every joint 1 rad off maps near the latent origin, inside the data, where the robots'
//! predictions are certain. Its reconstruction is a pose the model knows, about 1 rad from the
//! input on every joint.
//!
//! **The threshold** is computed from the training frames, each group of them held out in
//! turn (the groups of the trust threshold: [`SharedGplvm::set_trust_groups`], else
//! consecutive blocks), as the larger of two held-out errors:
//!
//! - the [`RECONSTRUCTION_PERCENTILE`] of the model's: each frame reconstructed by the human
//!   space's GP from the other groups, in closed form at its trained latent point:
//!   `Y_G − μ₋G = [(K + σₙ² I)⁻¹]_GG⁻¹ [(K + σₙ² I)⁻¹ Y]_G`. This is how well the model
//!   gives back a repetition of a motion it knows, and no more than 1 % of such frames are
//!   beyond the threshold;
//! - the mean pose's (root mean square over the held-out frames of their distance to the mean
//!   pose of the other groups): beyond it the model explains the pose no better than the
//!   mean pose explains the training poses, and the pose is not one it has learned.
//!
//! The first alone is the rule of the trust threshold, and it holds new motion as it holds
//! nonsense: repetitions of a motion nearly coincide, so a motion between poses no training
//! motion joins is reconstructed worse than any held-out repetition. The second is the scale
//! at which "new" becomes "unknown": a pose with every joint 1 rad off, or a pose drawn at
//! random within the human's joint limits, is several times further from its reconstruction
//! than the training poses are from their mean. (`docs/trust-gate.md` has the rates.)
//!
//! The threshold is computed from the trained model alone (at most [`crate::TRUST_POINTS`]
//! frames, evenly spaced), stored in the model file and computed on first use for files
//! written before it existed. One frame costs one kernel-weighted sum over the training points
//! (the cost of a robot's mean, O(N(Q + D_H))), on the latent point the robots' predictions
//! use.

use std::collections::BTreeMap;

use faer::{Mat, MatRef};

use crate::error::{Error, Result};
use crate::factor::cholesky;
use crate::kernel::KernelParams;
use crate::model::SharedGplvm;
use crate::trust::{default_groups, percentile, TRUST_POINTS};

/// The percentile of the held-out training frames' reconstruction errors that bounds the
/// threshold from below.
pub const RECONSTRUCTION_PERCENTILE: f64 = 0.99;

/// The held-out errors the reconstruction threshold is computed from (see the
/// `reconstruction` module).
#[derive(Clone, Debug, PartialEq)]
pub struct ReconstructionCalibration {
    /// The model's reconstruction error of each training frame (at most
    /// [`crate::TRUST_POINTS`], evenly spaced) with its group held out.
    pub held_out: Vec<f64>,
    /// Their [`RECONSTRUCTION_PERCENTILE`].
    pub percentile: f64,
    /// The root mean square distance of the same frames to the mean pose of the other groups
    /// (the human space's standardised units, as the errors).
    pub mean_pose: f64,
    /// The threshold: the larger of `percentile` and `mean_pose`.
    pub threshold: f64,
}

/// The root mean square of `r`.
fn rms(r: impl ExactSizeIterator<Item = f64>) -> f64 {
    let n = r.len().max(1) as f64;
    (r.map(|v| v * v).sum::<f64>() / n).sqrt()
}

/// `L⁻¹ (L⁻ᵀ b)`: `b` overwritten by `(L Lᵀ)⁻¹ b` for the lower factor `l`.
fn solve_factored(l: MatRef<'_, f64>, b: faer::MatMut<'_, f64>) {
    let mut b = b;
    faer::linalg::triangular_solve::solve_lower_triangular_in_place(l, b.as_mut(), faer::Par::Seq);
    faer::linalg::triangular_solve::solve_upper_triangular_in_place(
        l.transpose(),
        b,
        faer::Par::Seq,
    );
}

/// The held-out errors (see [`ReconstructionCalibration`]) of the training frames whose latent
/// points are the rows of `x_rows` (row-major, `q` columns) and centred, scaled poses the rows
/// of `y`, under a GP with `kernel`, each group (`groups`: one label per frame) held out in
/// turn. Frames beyond [`TRUST_POINTS`] are thinned evenly first.
pub(crate) fn calibrate(
    x_rows: &[f64],
    q: usize,
    y: MatRef<'_, f64>,
    kernel: &KernelParams,
    groups: &[usize],
) -> Result<ReconstructionCalibration> {
    let n_all = y.nrows();
    let distinct = groups.iter().any(|&g| Some(&g) != groups.first());
    if n_all < 2 || groups.len() != n_all || x_rows.len() != n_all * q || !distinct {
        return Err(Error::InvalidValue {
            what: "reconstruction threshold".into(),
            reason: format!(
                "it needs at least 2 training frames, one latent point and one group each, and \
                 two groups ({n_all} frames, {} latent values for Q = {q}, {} group labels)",
                x_rows.len(),
                groups.len()
            ),
        });
    }
    let n = n_all.min(TRUST_POINTS);
    let d = y.ncols();
    let pick: Vec<usize> = (0..n).map(|i| i * n_all / n).collect();
    let inv_l2: Vec<f64> = kernel.lengthscale.iter().map(|l| 1.0 / (l * l)).collect();
    // The same small jitter the factorisation of training would add first.
    let noise = kernel.noise + 1e-8 * kernel.variance;
    let mut k = Mat::<f64>::from_fn(n, n, |a, b| {
        let (xa, xb) = (&x_rows[pick[a] * q..][..q], &x_rows[pick[b] * q..][..q]);
        let d2: f64 = (0..q).map(|t| (xa[t] - xb[t]).powi(2) * inv_l2[t]).sum();
        kernel.variance * (-0.5 * d2).exp() + if a == b { noise } else { 0.0 }
    });
    let singular = || Error::NotPositiveDefinite {
        space: "(reconstruction threshold)".into(),
        jitter: 1e-8 * kernel.variance,
    };
    cholesky(k.as_mut(), faer::Par::Seq).map_err(|_| singular())?;
    // (K + σₙ² I)⁻¹ and α = (K + σₙ² I)⁻¹ Y.
    let mut k_inv = Mat::<f64>::identity(n, n);
    solve_factored(k.as_ref(), k_inv.as_mut());
    let y_pick = Mat::<f64>::from_fn(n, d, |i, t| y[(pick[i], t)]);
    let alpha = &k_inv * &y_pick;
    let mut members: BTreeMap<usize, Vec<usize>> = BTreeMap::new();
    for (i, &p) in pick.iter().enumerate() {
        members.entry(groups[p]).or_default().push(i);
    }
    let total: Vec<f64> = (0..d)
        .map(|t| (0..n).map(|i| y_pick[(i, t)]).sum())
        .collect();
    let (mut held_out, mut mean_pose) = (vec![0.0; n], vec![0.0; n]);
    for idx in members.values() {
        // The residual Y_G − μ₋G = [(K⁻¹)_GG]⁻¹ α_G.
        let g = idx.len();
        let mut block = Mat::<f64>::from_fn(g, g, |a, b| k_inv[(idx[a], idx[b])]);
        cholesky(block.as_mut(), faer::Par::Seq).map_err(|_| singular())?;
        let mut r = Mat::<f64>::from_fn(g, d, |a, t| alpha[(idx[a], t)]);
        solve_factored(block.as_ref(), r.as_mut());
        // The other groups' mean pose (there are frames outside the group: two groups).
        let others = n.saturating_sub(g).max(1) as f64;
        let mean: Vec<f64> = (0..d)
            .map(|t| (total[t] - idx.iter().map(|&i| y_pick[(i, t)]).sum::<f64>()) / others)
            .collect();
        for (a, &i) in idx.iter().enumerate() {
            held_out[i] = rms((0..d).map(|t| r[(a, t)]));
            mean_pose[i] = rms((0..d).map(|t| y_pick[(i, t)] - mean[t]));
        }
    }
    let p = percentile(held_out.clone(), RECONSTRUCTION_PERCENTILE);
    let mean_pose = rms(mean_pose.into_iter());
    Ok(ReconstructionCalibration {
        held_out,
        percentile: p,
        mean_pose,
        threshold: p.max(mean_pose),
    })
}

impl SharedGplvm {
    /// The reconstruction threshold: the reconstruction error (see the `reconstruction`
    /// module) above which a human frame is not one the model has learned; the stored one, or
    /// [`SharedGplvm::reconstruction_calibration`]'s.
    pub fn reconstruction_threshold(&self) -> Result<f64> {
        match self.reconstruction {
            Some(t) => Ok(t),
            None => Ok(self.reconstruction_calibration()?.threshold),
        }
    }

    /// The held-out errors the reconstruction threshold is computed from, computed now from
    /// the model's latent points, human kernel and trust groups.
    pub fn reconstruction_calibration(&self) -> Result<ReconstructionCalibration> {
        let groups = match &self.trust_groups {
            Some(g) => g.clone(),
            None => default_groups(self.n()),
        };
        let human = &self.spaces[0];
        calibrate(
            &self.x_rows,
            self.q(),
            human.data.as_ref(),
            &human.kernel,
            &groups,
        )
    }

    /// The reconstruction error of one raw human frame `h` whose latent point is `x`
    /// ([`SharedGplvm::latent_frame`]). Allocates nothing for D_H ≤ 64.
    pub fn reconstruction_error(&self, h: &[f64], x: &[f64]) -> Result<f64> {
        self.check_input_row(h)?;
        if x.len() != self.q() {
            return Err(Error::DimensionMismatch {
                what: "latent point".into(),
                expected: self.q(),
                found: x.len(),
            });
        }
        let dh = h.len();
        let mut stack = [0.0f64; 64];
        let mut heap;
        let out: &mut [f64] = if dh <= 64 {
            &mut stack[..dh]
        } else {
            heap = vec![0.0; dh];
            &mut heap
        };
        // The mean in the user's units, compared in the space's standardised units.
        self.mean_into(0, x, out)?;
        let s = &self.spaces[0];
        let e = rms((0..dh).map(|t| (h[t] - out[t]) / s.scale[t]));
        match e.is_finite() {
            true => Ok(e),
            false => Err(Error::NonFinitePrediction {
                space: s.name.clone(),
                row: 0,
                col: 0,
                value: e,
            }),
        }
    }

    /// The reconstruction error of each raw human frame (row of `h`).
    pub fn reconstruction_errors(&self, h: MatRef<'_, f64>) -> Result<Vec<f64>> {
        let x = self.latent(h)?;
        let mut row = vec![0.0; h.ncols()];
        let mut xi = vec![0.0; self.q()];
        (0..h.nrows())
            .map(|i| {
                row.iter_mut().enumerate().for_each(|(t, v)| *v = h[(i, t)]);
                xi.iter_mut().enumerate().for_each(|(t, v)| *v = x[(i, t)]);
                self.reconstruction_error(&row, &xi).map_err(|e| match e {
                    Error::NonFinitePrediction {
                        space, col, value, ..
                    } => Error::NonFinitePrediction {
                        space,
                        row: i,
                        col,
                        value,
                    },
                    other => other,
                })
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_support::{fit, gp_solve_1d, kernel_1d, BackConstraint};

    /// The posterior mean at `at` of a GP with `kern` fitted to the 1-D points `xs` with
    /// values `ys` (Gaussian elimination, with the jitter the formula's factorisation adds).
    fn refit_mean(kern: &KernelParams, xs: &[f64], ys: &[f64], at: f64) -> f64 {
        let weights = gp_solve_1d(kern, xs, ys);
        (0..xs.len())
            .map(|a| kernel_1d(kern, xs[a], at) * weights[a])
            .sum()
    }

    #[test]
    fn held_out_errors_match_refitting_without_the_group() {
        // Six 1-D latent points with two-column poses, held out in groups: each error is the
        // RMS distance of the pose to the mean of a GP fitted to the other groups' poses, and
        // the mean pose's is the RMS distance to the other groups' mean pose.
        let x = [0.0, 0.3, 1.1, 1.5, 3.0, 3.2];
        let y = Mat::from_fn(6, 2, |i, t| {
            (x[i] * (1.0 + t as f64)).sin() - 0.2 * t as f64
        });
        let kern = KernelParams {
            variance: 1.3,
            lengthscale: vec![0.7],
            noise: 0.05,
        };
        for groups in [
            vec![0, 1, 2, 3, 4, 5],
            vec![0, 0, 1, 1, 2, 2],
            vec![7, 3, 7, 3, 7, 3],
        ] {
            let c = calibrate(&x, 1, y.as_ref(), &kern, &groups).unwrap();
            let mut squares = 0.0;
            for i in 0..6 {
                let others: Vec<usize> = (0..6).filter(|&j| groups[j] != groups[i]).collect();
                let xs: Vec<f64> = others.iter().map(|&j| x[j]).collect();
                let (mut e2, mut m2) = (0.0, 0.0);
                for t in 0..2 {
                    let ys: Vec<f64> = others.iter().map(|&j| y[(j, t)]).collect();
                    e2 += (y[(i, t)] - refit_mean(&kern, &xs, &ys, x[i])).powi(2);
                    let mean = ys.iter().sum::<f64>() / ys.len() as f64;
                    m2 += (y[(i, t)] - mean).powi(2);
                }
                let e = (e2 / 2.0).sqrt();
                assert!(
                    (c.held_out[i] - e).abs() < 1e-7,
                    "{groups:?} {i}: {} vs {e}",
                    c.held_out[i]
                );
                squares += m2 / 2.0;
            }
            let mean_pose = (squares / 6.0).sqrt();
            assert!(
                (c.mean_pose - mean_pose).abs() < 1e-12,
                "{} vs {mean_pose}",
                c.mean_pose
            );
            assert_eq!(
                c.percentile,
                percentile(c.held_out.clone(), RECONSTRUCTION_PERCENTILE)
            );
            assert_eq!(c.threshold, c.percentile.max(c.mean_pose));
        }
        // One group, or groups of another length: nothing to hold out from.
        assert!(calibrate(&x, 1, y.as_ref(), &kern, &[1; 6]).is_err());
        assert!(calibrate(&x, 1, y.as_ref(), &kern, &[0, 1]).is_err());
    }

    #[test]
    fn a_frame_is_scored_by_the_human_spaces_mean_at_its_latent_point() {
        let m = fit(BackConstraint::Input, 40, 20, 1);
        let (h, ..) = crate::test_support::demo(40, 7);
        let e = m.reconstruction_errors(h.as_ref()).unwrap();
        // The human space's posterior mean k(x, X) (K + σ²I)⁻¹ Y, by a dense solve.
        let s = &m.spaces[0];
        let (n, q, d) = (m.n(), m.q(), s.data.ncols());
        let x = m.latent(h.as_ref()).unwrap();
        let kern = |a: &[f64], b: &[f64]| {
            let d2: f64 = (0..q)
                .map(|t| ((a[t] - b[t]) / s.kernel.lengthscale[t]).powi(2))
                .sum();
            s.kernel.variance * (-0.5 * d2).exp()
        };
        let row = |i: usize| &m.x_rows[i * q..(i + 1) * q];
        let mut kk = Mat::from_fn(n, n, |a, b| {
            kern(row(a), row(b)) + if a == b { s.kernel.noise } else { 0.0 }
        });
        cholesky(kk.as_mut(), faer::Par::Seq).unwrap();
        let mut alpha = s.data.clone();
        solve_factored(kk.as_ref(), alpha.as_mut());
        for i in [0, 13, 39] {
            let xi: Vec<f64> = (0..q).map(|t| x[(i, t)]).collect();
            let mean: Vec<f64> = (0..d)
                .map(|t| {
                    (0..n)
                        .map(|j| kern(&xi, row(j)) * alpha[(j, t)])
                        .sum::<f64>()
                        * s.scale[t]
                        + s.offset[t]
                })
                .collect();
            let want = rms((0..d).map(|t| (h[(i, t)] - mean[t]) / s.scale[t]));
            // The training jitter (none needed here) and the summation order differ.
            assert!(
                (e[i] - want).abs() < 1e-8 * want.max(1.0),
                "{i}: {} vs {want}",
                e[i]
            );
            assert_eq!(
                m.reconstruction_error(&(0..d).map(|t| h[(i, t)]).collect::<Vec<_>>(), &xi)
                    .unwrap(),
                e[i]
            );
        }
        // Within the threshold on the training frames; every joint 5 units off (five times the
        // spread of these poses about their mean) is beyond it, by about those 5 units.
        let c = m.reconstruction_calibration().unwrap();
        assert!(e.iter().all(|&v| v <= c.threshold), "{c:?} {e:?}");
        assert!(c.mean_pose > 0.5 && c.mean_pose < 1.5, "{c:?}");
        let far = Mat::from_fn(40, d, |i, j| h[(i, j)] + 5.0);
        let e_far = m.reconstruction_errors(far.as_ref()).unwrap();
        assert!(
            e_far.iter().all(|&v| v > c.threshold && v > 4.0),
            "{c:?} {e_far:?}"
        );
        // Wrong lengths and values that are not numbers are errors naming what was expected.
        let mut x0 = vec![0.0; q];
        let h0: Vec<f64> = (0..d).map(|t| h[(0, t)]).collect();
        assert!(matches!(
            m.reconstruction_error(&h0[1..], &x0),
            Err(Error::DimensionMismatch { .. })
        ));
        assert!(
            matches!(m.reconstruction_error(&h0, &x0[1..]), Err(Error::DimensionMismatch { expected, .. }) if expected == q)
        );
        let mut bad = h0.clone();
        bad[2] = f64::NAN;
        assert!(matches!(
            m.reconstruction_error(&bad, &x0),
            Err(Error::NonFinite { col: 2, .. })
        ));
        // The live path (one frame's latent point) gives the batch's value, to rounding.
        m.latent_frame(&h0, &mut x0).unwrap();
        let live = m.reconstruction_error(&h0, &x0).unwrap();
        assert!(
            (live - e[0]).abs() < 1e-12 * e[0].max(1.0),
            "{live} vs {}",
            e[0]
        );
    }

    #[test]
    fn every_kind_of_model_scores_its_training_frames_within_and_far_frames_beyond() {
        use crate::test_support::{quick, ModelConfig};
        let (h, r, ..) = crate::test_support::demo(40, 7);
        let spaces = [("human", h.as_ref()), ("walkman", r.as_ref())];
        let far = Mat::from_fn(40, h.ncols(), |i, j| h[(i, j)] + 5.0);
        for config in [
            ModelConfig::default().with_back_constraint(BackConstraint::None),
            ModelConfig::default().with_back_constraint(BackConstraint::Output),
            ModelConfig::default()
                .with_back_constraint(BackConstraint::Input)
                .with_inducing(Some(12)),
        ] {
            let config = config.with_latent_dim(2);
            let m = SharedGplvm::fit(&config, &spaces, "human", &quick(20), None).unwrap();
            let t = m.reconstruction_threshold().unwrap();
            let e = m.reconstruction_errors(h.as_ref()).unwrap();
            let within = e.iter().filter(|&&v| v <= t).count();
            assert!(within >= 38, "{config:?}: {within} of 40 within {t}: {e:?}");
            let e_far = m.reconstruction_errors(far.as_ref()).unwrap();
            assert!(e_far.iter().all(|&v| v > t), "{config:?}: {t} {e_far:?}");
        }
    }

    /// `bytes` (a model file) with its payload's JSON object changed by `edit`.
    fn edited(
        bytes: &[u8],
        edit: impl FnOnce(&mut serde_json::Map<String, serde_json::Value>),
    ) -> Vec<u8> {
        crate::io::with_payload(bytes, |json| edit(json.as_object_mut().unwrap()))
    }

    #[test]
    fn the_threshold_is_stored_and_files_without_it_compute_it() {
        let mut m = fit(BackConstraint::Input, 40, 20, 1);
        m.set_trust_groups((0..40).map(|i| i / 10).collect())
            .unwrap();
        let t = m.reconstruction_threshold().unwrap();
        assert_eq!(t, m.reconstruction_calibration().unwrap().threshold);
        let bytes = m.to_bytes();
        let back = SharedGplvm::from_bytes(&bytes).unwrap();
        assert_eq!(
            (
                back.reconstruction,
                back.reconstruction_threshold().unwrap()
            ),
            (Some(t), t)
        );
        // A file from before it: computed on first use, the same.
        let old = edited(&bytes, |o| {
            assert!(o.remove("reconstruction").is_some());
        });
        let back = SharedGplvm::from_bytes(&old).unwrap();
        assert_eq!(
            (
                back.reconstruction,
                back.reconstruction_threshold().unwrap()
            ),
            (None, t)
        );
        // The stored value is what a file says (as the trust thresholds are), if it is one.
        let other = edited(&bytes, |o| {
            o.insert("reconstruction".into(), 0.5.into());
        });
        assert_eq!(
            SharedGplvm::from_bytes(&other)
                .unwrap()
                .reconstruction_threshold()
                .unwrap(),
            0.5
        );
        let bad = edited(&bytes, |o| {
            o.insert("reconstruction".into(), (-1.0).into());
        });
        let err = SharedGplvm::from_bytes(&bad).unwrap_err().to_string();
        assert!(err.contains("reconstruction threshold -1"), "{err}");
        // Other groups, another threshold: the stored one is dropped.
        let mut regrouped = SharedGplvm::from_bytes(&bytes).unwrap();
        regrouped
            .set_trust_groups((0..40).map(|i| i % 2).collect())
            .unwrap();
        assert_eq!(regrouped.reconstruction, None);
        assert_ne!(regrouped.reconstruction_threshold().unwrap(), t);
    }
}
