//! How far from what it learned a prediction is: a robot space's predictive standard deviation
//! and its trust threshold.
//!
//! A prediction's standard deviation `σ(x*) = √(α² − k*ᵀ (K + σₙ² I)⁻¹ k*)`, in the space's
//! standardised units, grows from near 0 at the training points to α far from them. The trust
//! threshold is the [`TRUST_PERCENTILE`] of the same quantity over the training frames, each
//! held out in turn: `σ²₋ᵢ = 1 / [(K + σₙ² I)⁻¹]ᵢᵢ − σₙ²` (leave-one-out, in closed form). A
//! new frame less certain than 99 % of the held-out training frames is one the model has not
//! learned: a live controller should not pass it to a robot as it is.
//!
//! The threshold is computed from the trained model alone (its latent points and the space's
//! kernel; at most [`TRUST_POINTS`] of them, evenly spaced), stored in the model file when it is
//! saved, and computed on first use for files written before it existed.

use faer::Mat;

use crate::error::{Error, Result};
use crate::factor::cholesky;
use crate::kernel::KernelParams;
use crate::model::SharedGplvm;

/// The percentile of the held-out training frames' standard deviations that is the threshold.
pub const TRUST_PERCENTILE: f64 = 0.99;

/// Most training frames the threshold is computed from (evenly spaced among them).
pub const TRUST_POINTS: usize = 1000;

/// The leave-one-out standard deviations (standardised units) of the latent points `x_rows`
/// (row-major, `q` columns) under `kernel`.
pub(crate) fn leave_one_out_sd(
    x_rows: &[f64],
    q: usize,
    kernel: &KernelParams,
) -> Result<Vec<f64>> {
    let n_all = if q == 0 { 0 } else { x_rows.len() / q };
    if n_all < 2 {
        return Err(Error::InvalidValue {
            what: "trust threshold".into(),
            reason: "it needs at least 2 training frames".into(),
        });
    }
    let n = n_all.min(TRUST_POINTS);
    let pick: Vec<usize> = (0..n).map(|i| i * n_all / n).collect();
    let inv_l2: Vec<f64> = kernel.lengthscale.iter().map(|l| 1.0 / (l * l)).collect();
    // The same small jitter the factorisation of training would add first.
    let noise = kernel.noise + 1e-8 * kernel.variance;
    let mut k = Mat::<f64>::zeros(n, n);
    for a in 0..n {
        let xa = &x_rows[pick[a] * q..(pick[a] + 1) * q];
        for b in 0..=a {
            let xb = &x_rows[pick[b] * q..(pick[b] + 1) * q];
            let d2: f64 = (0..q).map(|t| (xa[t] - xb[t]).powi(2) * inv_l2[t]).sum();
            k[(a, b)] = kernel.variance * (-0.5 * d2).exp();
        }
        k[(a, a)] += noise;
    }
    cholesky(k.as_mut(), faer::Par::Seq).map_err(|_| Error::NotPositiveDefinite {
        space: "(trust threshold)".into(),
        jitter: 1e-8 * kernel.variance,
    })?;
    // [K⁻¹]ᵢᵢ = Σₖ [L⁻¹]ₖᵢ²: solve L Z = I column by column.
    let mut z = Mat::<f64>::identity(n, n);
    faer::linalg::triangular_solve::solve_lower_triangular_in_place(
        k.as_ref(),
        z.as_mut(),
        faer::Par::Seq,
    );
    Ok((0..n)
        .map(|i| {
            let d: f64 = (i..n).map(|r| z[(r, i)] * z[(r, i)]).sum();
            (1.0 / d - kernel.noise).max(0.0).sqrt()
        })
        .collect())
}

/// The `p`-quantile (nearest rank) of `v`.
fn percentile(mut v: Vec<f64>, p: f64) -> f64 {
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
        let sd = leave_one_out_sd(&self.x_rows, self.q(), &self.spaces[si].kernel)?;
        Ok(percentile(sd, TRUST_PERCENTILE))
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
        self.check_input_row(h)?;
        let si = self.output_index(space)?;
        let d = self.spaces[si].data.ncols();
        for (what, len) in [("mean", mean.len()), ("standard deviation", sd.len())] {
            if len != d {
                return Err(Error::DimensionMismatch {
                    what: format!("{what} buffer for '{space}'"),
                    expected: d,
                    found: len,
                });
            }
        }
        let row = faer::MatRef::from_row_major_slice(h, 1, h.len());
        let p = self.predict_rows(row, si, true)?;
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn leave_one_out_matches_refitting_without_the_frame() {
        // Five 1-D latent points: σ²₋ᵢ by the formula equals the variance of a GP fitted to the
        // other four, at the fifth.
        let x = [0.0, 0.3, 1.1, 1.5, 3.0];
        let kern = KernelParams {
            variance: 1.3,
            lengthscale: vec![0.7],
            noise: 0.05,
        };
        let sd = leave_one_out_sd(&x, 1, &kern).unwrap();
        let k = |a: f64, b: f64| kern.variance * (-0.5 * (a - b) * (a - b) / 0.49).exp();
        for i in 0..5 {
            let others: Vec<f64> = (0..5).filter(|&j| j != i).map(|j| x[j]).collect();
            let m = others.len();
            let mut kk = Mat::from_fn(m, m, |a, b| k(others[a], others[b]));
            for a in 0..m {
                kk[(a, a)] += kern.noise + 1e-8 * kern.variance;
            }
            // v = α² − k*ᵀ K⁻¹ k*, K⁻¹ k* by Gaussian elimination (4×4).
            let mut aug: Vec<Vec<f64>> = (0..m)
                .map(|a| {
                    (0..m)
                        .map(|b| kk[(a, b)])
                        .chain([k(others[a], x[i])])
                        .collect()
                })
                .collect();
            for c in 0..m {
                for r in c + 1..m {
                    let f = aug[r][c] / aug[c][c];
                    for j in c..=m {
                        aug[r][j] -= f * aug[c][j];
                    }
                }
            }
            let mut sol = vec![0.0; m];
            for r in (0..m).rev() {
                let s: f64 = (r + 1..m).map(|j| aug[r][j] * sol[j]).sum();
                sol[r] = (aug[r][m] - s) / aug[r][r];
            }
            let v = kern.variance - (0..m).map(|a| k(others[a], x[i]) * sol[a]).sum::<f64>();
            // The formula's σₙ² includes the jitter the refit adds too, to 1e-8 relative.
            assert!(
                (sd[i] * sd[i] - v).abs() < 1e-7,
                "{i}: {} vs {v}",
                sd[i] * sd[i]
            );
        }
        assert_eq!(percentile(vec![3.0, 1.0, 2.0, 4.0], 0.99), 4.0);
        assert_eq!(percentile(vec![3.0, 1.0, 2.0, 4.0], 0.5), 2.0);
    }
}
