//! How far from what it learned a prediction is: a robot space's predictive standard deviation
//! and its trust threshold.
//!
//! A prediction's standard deviation `σ(x*) = √(α² − k*ᵀ (K + σₙ² I)⁻¹ k*)`, in the space's
//! standardised units, grows from near 0 at the training points to α far from them. The trust
//! threshold is the [`TRUST_PERCENTILE`] of the same quantity over the training frames, each
//! predicted from the *other groups* of training frames: the groups are those the training
//! data was held out by to choose iteration budgets (the facade passes them:
//! [`SharedGplvm::set_trust_groups`]; for the shipped demonstrations, every repetition of the
//! motions), else nine consecutive blocks of the training frames. Held out a group at a time,
//! in closed form: `Σ₋G = [(K + σₙ² I)⁻¹]_GG⁻¹ − σₙ² I`. A new frame less certain than 99 % of
//! the held-out training frames is one the model has not learned: a live controller should not
//! pass it to a robot as it is.
//!
//! Why groups and not single frames: training frames sampled along smooth motions each have a
//! neighbour a few centimetres away, so each left out alone is predicted almost as well as if
//! it were kept, and a threshold from them flags a large part of any new motion.
//!
//! The threshold is computed from the trained model alone (its latent points, the space's
//! kernel and the groups; at most [`TRUST_POINTS`] frames, evenly spaced), stored in the model
//! file when it is saved, and computed on first use for files written before it existed.

use faer::Mat;

use crate::error::{check_buffer, Error, Result};
use crate::factor::cholesky;
use crate::kernel::KernelParams;
use crate::model::SharedGplvm;

/// The percentile of the held-out training frames' standard deviations that is the threshold.
pub const TRUST_PERCENTILE: f64 = 0.99;

/// Most training frames the threshold is computed from (evenly spaced among them).
pub const TRUST_POINTS: usize = 1000;

/// Blocks of consecutive training frames held out in turn when no groups were given.
pub const TRUST_BLOCKS: usize = 9;

/// The group of each of `n` training frames without given groups: [`TRUST_BLOCKS`] consecutive
/// blocks.
pub(crate) fn default_groups(n: usize) -> Vec<usize> {
    (0..n).map(|i| i * TRUST_BLOCKS / n.max(1)).collect()
}

/// The diagonal of `a⁻¹` for a symmetric positive definite `a` (overwritten by its factor).
fn inverse_diagonal(mut a: Mat<f64>) -> Option<Vec<f64>> {
    let n = a.nrows();
    cholesky(a.as_mut(), faer::Par::Seq).ok()?;
    // [A⁻¹]ᵢᵢ = Σₖ [L⁻¹]ₖᵢ²: solve L Z = I.
    let mut z = Mat::<f64>::identity(n, n);
    faer::linalg::triangular_solve::solve_lower_triangular_in_place(
        a.as_ref(),
        z.as_mut(),
        faer::Par::Seq,
    );
    Some(
        (0..n)
            .map(|i| (i..n).map(|r| z[(r, i)] * z[(r, i)]).sum())
            .collect(),
    )
}

/// The standard deviations (standardised units) of the latent points `x_rows` (row-major, `q`
/// columns) under `kernel`, each predicted from the points of the other groups (`groups`: one
/// label per point).
pub(crate) fn held_out_sd(
    x_rows: &[f64],
    q: usize,
    kernel: &KernelParams,
    groups: &[usize],
) -> Result<Vec<f64>> {
    let n_all = x_rows.len().checked_div(q).unwrap_or(0);
    if n_all < 2 || groups.len() != n_all {
        return Err(Error::InvalidValue {
            what: "trust threshold".into(),
            reason: format!(
                "it needs at least 2 training frames and one group per frame ({n_all} frames, {} groups)",
                groups.len()
            ),
        });
    }
    let n = n_all.min(TRUST_POINTS);
    let pick: Vec<usize> = (0..n).map(|i| i * n_all / n).collect();
    let inv_l2: Vec<f64> = kernel.lengthscale.iter().map(|l| 1.0 / (l * l)).collect();
    // The same small jitter the factorisation of training would add first.
    let noise = kernel.noise + 1e-8 * kernel.variance;
    let k = Mat::<f64>::from_fn(n, n, |a, b| {
        let (xa, xb) = (&x_rows[pick[a] * q..][..q], &x_rows[pick[b] * q..][..q]);
        let d2: f64 = (0..q).map(|t| (xa[t] - xb[t]).powi(2) * inv_l2[t]).sum();
        kernel.variance * (-0.5 * d2).exp() + if a == b { noise } else { 0.0 }
    });
    let singular = || Error::NotPositiveDefinite {
        space: "(trust threshold)".into(),
        jitter: 1e-8 * kernel.variance,
    };
    // (K + σₙ² I)⁻¹ = Zᵀ Z with Z = L⁻¹.
    let mut l = k;
    cholesky(l.as_mut(), faer::Par::Seq).map_err(|_| singular())?;
    let mut z = Mat::<f64>::identity(n, n);
    faer::linalg::triangular_solve::solve_lower_triangular_in_place(
        l.as_ref(),
        z.as_mut(),
        faer::Par::Seq,
    );
    let k_inv = z.transpose() * &z;
    let mut members: std::collections::BTreeMap<usize, Vec<usize>> = Default::default();
    for (i, &p) in pick.iter().enumerate() {
        members.entry(groups[p]).or_default().push(i);
    }
    let mut sd = vec![0.0; n];
    for idx in members.values() {
        let block = Mat::<f64>::from_fn(idx.len(), idx.len(), |a, b| k_inv[(idx[a], idx[b])]);
        // Σ₋G = (K⁻¹)_GG⁻¹ − σₙ² I: its diagonal is that of the inverse of (K⁻¹)_GG.
        let block_inverse = inverse_diagonal(block).ok_or_else(singular)?;
        for (&i, v) in idx.iter().zip(block_inverse) {
            sd[i] = (v - kernel.noise).max(0.0).sqrt();
        }
    }
    Ok(sd)
}

/// The `p`-quantile (nearest rank) of `v`.
pub(crate) fn percentile(mut v: Vec<f64>, p: f64) -> f64 {
    v.sort_by(|a, b| a.total_cmp(b));
    let rank = ((p * v.len() as f64).ceil() as usize).clamp(1, v.len());
    v[rank - 1]
}

impl SharedGplvm {
    /// The trust threshold of robot space `space`: the standardised predictive standard
    /// deviation above which a prediction is not trusted (see the module documentation).
    pub fn trust_threshold(&self, space: &str) -> Result<f64> {
        let si = self.output_index(space)?;
        if let Some(&t) = self.trust.get(space) {
            return Ok(t);
        }
        let groups = match &self.trust_groups {
            Some(g) => g.clone(),
            None => default_groups(self.n()),
        };
        let sd = held_out_sd(&self.x_rows, self.q(), &self.spaces[si].kernel, &groups)?;
        Ok(percentile(sd, TRUST_PERCENTILE))
    }

    /// The groups of training frames held out in turn to compute the trust thresholds: one
    /// label per training frame, at least two distinct labels (for example the repetition or
    /// trajectory each frame belongs to). Thresholds already computed are dropped.
    pub fn set_trust_groups(&mut self, groups: Vec<usize>) -> Result<()> {
        if groups.len() != self.n() {
            return Err(Error::DimensionMismatch {
                what: "trust groups (one per training frame)".into(),
                expected: self.n(),
                found: groups.len(),
            });
        }
        if groups.iter().all(|&g| g == groups[0]) {
            return Err(Error::InvalidValue {
                what: "trust groups".into(),
                reason: "they need at least two distinct groups (one group leaves nothing to \
                         predict from)"
                    .into(),
            });
        }
        self.trust_groups = Some(groups);
        self.trust.clear();
        self.reconstruction = None;
        self.novelty = None;
        Ok(())
    }

    /// The groups set by [`SharedGplvm::set_trust_groups`] (`None`: [`TRUST_BLOCKS`]
    /// consecutive blocks).
    pub fn trust_groups(&self) -> Option<&[usize]> {
        self.trust_groups.as_deref()
    }

    /// The standardised predictive standard deviation for `space` of each raw human frame (row
    /// of `h`): the quantity [`SharedGplvm::trust_threshold`] bounds.
    pub fn prediction_sd(&self, h: faer::MatRef<'_, f64>, space: &str) -> Result<Vec<f64>> {
        let si = self.output_index(space)?;
        let p = self.predict(h, space, true)?;
        let var = p.variance.as_ref().ok_or_else(|| Error::InvalidValue {
            what: "prediction".into(),
            reason: "no variance was computed".into(),
        })?;
        let scale = self.spaces[si].scale[0];
        Ok((0..h.nrows())
            .map(|i| var[(i, 0)].max(0.0).sqrt() / scale)
            .collect())
    }

    /// One raw human frame's prediction for `space`: the mean into `mean` and each joint's
    /// predictive standard deviation (original units) into `sd`; returns the standard deviation
    /// in the space's standardised units, the scale of [`SharedGplvm::trust_threshold`].
    pub fn predict_frame_sd(
        &self,
        h: &[f64],
        space: &str,
        mean: &mut [f64],
        sd: &mut [f64],
    ) -> Result<f64> {
        let mut x = vec![0.0; self.q()];
        self.latent_frame(h, &mut x)?;
        self.predict_latent_sd(&x, space, mean, sd)
    }

    /// The latent point of one raw human frame into `x` (length Q): the input of
    /// [`SharedGplvm::predict_latent_sd`], computed once for every robot space of the model.
    pub fn latent_frame(&self, h: &[f64], x: &mut [f64]) -> Result<()> {
        self.check_input_row(h)?;
        self.check_latent_len(x)?;
        self.latent_into(h, x)?;
        check_finite_latent(x)
    }

    /// [`SharedGplvm::predict_frame_sd`] from the frame's latent point `x`
    /// ([`SharedGplvm::latent_frame`]).
    pub fn predict_latent_sd(
        &self,
        x: &[f64],
        space: &str,
        mean: &mut [f64],
        sd: &mut [f64],
    ) -> Result<f64> {
        let si = self.output_index(space)?;
        let d = self.spaces[si].data.ncols();
        check_buffer("mean", space, d, mean.len())?;
        check_buffer("standard deviation", space, d, sd.len())?;
        self.check_latent_len(x)?;
        let xs = Mat::from_fn(1, x.len(), |_, t| x[t]);
        let p = self.predict_latent_rows(xs, si, true)?;
        let var = p.variance.as_ref().ok_or_else(|| Error::InvalidValue {
            what: "prediction".into(),
            reason: "no variance was computed".into(),
        })?;
        let scale = &self.spaces[si].scale;
        for t in 0..d {
            mean[t] = p.mean[(0, t)];
            sd[t] = var[(0, t)].max(0.0).sqrt();
        }
        Ok(sd[0] / scale[0])
    }
}

impl SharedGplvm {
    /// A latent point (or its buffer) has Q values.
    fn check_latent_len(&self, x: &[f64]) -> Result<()> {
        if x.len() == self.q() {
            return Ok(());
        }
        Err(Error::DimensionMismatch {
            what: "latent point".into(),
            expected: self.q(),
            found: x.len(),
        })
    }
}

/// A latent point with a value that is not a number is an error, as a prediction's would be.
fn check_finite_latent(x: &[f64]) -> Result<()> {
    match x.iter().position(|v| !v.is_finite()) {
        None => Ok(()),
        Some(col) => Err(Error::NonFinitePrediction {
            space: "latent".into(),
            row: 0,
            col,
            value: x[col],
        }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_support::{gp_solve_1d, kernel_1d};

    /// The variance at `at` of a GP with `kern` fitted to the 1-D points `others` (Gaussian
    /// elimination, with the jitter the formula's factorisation adds).
    fn refit_variance(kern: &KernelParams, others: &[f64], at: f64) -> f64 {
        let k_at: Vec<f64> = others.iter().map(|&x| kernel_1d(kern, x, at)).collect();
        let weights = gp_solve_1d(kern, others, &k_at);
        kern.variance - k_at.iter().zip(&weights).map(|(k, w)| k * w).sum::<f64>()
    }

    #[test]
    fn held_out_groups_match_refitting_without_them() {
        // Six 1-D latent points, held out one at a time and in groups: σ²₋G by the formula
        // equals the variance of a GP fitted to the other groups' points, at each held-out one.
        let x = [0.0, 0.3, 1.1, 1.5, 3.0, 3.2];
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
            let sd = held_out_sd(&x, 1, &kern, &groups).unwrap();
            for i in 0..x.len() {
                let others: Vec<f64> = (0..x.len())
                    .filter(|&j| groups[j] != groups[i])
                    .map(|j| x[j])
                    .collect();
                let v = refit_variance(&kern, &others, x[i]);
                // The formula's σₙ² includes the jitter the refit adds too, to 1e-8 relative.
                assert!(
                    (sd[i] * sd[i] - v).abs() < 1e-7,
                    "{groups:?} {i}: {} vs {v}",
                    sd[i] * sd[i]
                );
            }
        }
        // A group's frames are less certain held out together than each alone.
        let alone = held_out_sd(&x, 1, &kern, &[0, 1, 2, 3, 4, 5]).unwrap();
        let paired = held_out_sd(&x, 1, &kern, &[0, 0, 1, 1, 2, 2]).unwrap();
        assert!(alone.iter().zip(&paired).all(|(a, p)| p > a));
        assert_eq!(percentile(vec![3.0, 1.0, 2.0, 4.0], 0.99), 4.0);
        assert_eq!(percentile(vec![3.0, 1.0, 2.0, 4.0], 0.5), 2.0);
        assert_eq!(default_groups(18)[..4], [0, 0, 1, 1]);
        assert_eq!(default_groups(18)[17], TRUST_BLOCKS - 1);
    }

    #[test]
    fn groups_are_checked_stored_and_change_the_threshold() {
        let mut m = crate::test_support::fit(crate::BackConstraint::Input, 40, 20, 1);
        let blocks = m.trust_threshold("walkman").unwrap();
        let single = {
            let mut one = m.clone();
            one.set_trust_groups((0..40).collect()).unwrap();
            one.trust_threshold("walkman").unwrap()
        };
        // Neighbours left out together: less certain than each alone.
        assert!(blocks > single, "{blocks} vs {single}");
        assert!(m.set_trust_groups(vec![0; 39]).is_err());
        assert!(m.set_trust_groups(vec![3; 40]).is_err());
        let halves: Vec<usize> = (0..40).map(|i| i / 20).collect();
        m.set_trust_groups(halves.clone()).unwrap();
        let t = m.trust_threshold("walkman").unwrap();
        let back = SharedGplvm::from_bytes(&m.to_bytes()).unwrap();
        assert_eq!(back.trust_groups(), Some(&halves[..]));
        assert_eq!(back.trust_threshold("walkman").unwrap(), t);
        assert!(m.trust_threshold("nao").is_err());
    }
}
