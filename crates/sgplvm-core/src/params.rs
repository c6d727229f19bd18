//! The model's parameters in natural units, as users read and set them: the latent block
//! (X, or W and the bandwidth) and each space's kernel. The same structure carries gradients.

use faer::Mat;

use crate::error::{Error, Result};
use crate::kernel::KernelParams;
use crate::model::{Latent, SharedGplvm};
use crate::preprocess::check_shape;
use crate::train::{Limits, TrainOptions};

/// Latent block of [`Params`].
#[derive(Clone, Debug, PartialEq)]
pub enum LatentParams {
    /// Free latent points X (N×Q).
    Free {
        /// Latent matrix.
        x: Mat<f64>,
    },
    /// Back-constrained latent points X = K_bc W.
    BackConstrained {
        /// Weights W (N×Q).
        weights: Mat<f64>,
        /// Bandwidth of the back-constraint RBF, `k(a,b) = exp(-|a-b|²/(2 bw²))` (not trained;
        /// its gradient is reported for completeness).
        bandwidth: f64,
    },
}

/// All model parameters in natural units (also used for gradients, same structure).
#[derive(Clone, Debug, PartialEq)]
pub struct Params {
    /// Latent points or back-constraint weights.
    pub latent: LatentParams,
    /// Per space (input first), its kernel hyperparameters.
    pub spaces: Vec<(String, KernelParams)>,
}

impl SharedGplvm {
    /// All parameters in natural units.
    pub fn params(&self) -> Params {
        Params {
            latent: match &self.latent {
                Latent::Free { x } => LatentParams::Free { x: x.clone() },
                Latent::Back {
                    weights, bandwidth, ..
                } => LatentParams::BackConstrained {
                    weights: weights.clone(),
                    bandwidth: *bandwidth,
                },
            },
            spaces: self
                .spaces
                .iter()
                .map(|s| (s.name.clone(), s.kernel.clone()))
                .collect(),
        }
    }

    /// Replaces the parameters (same structure as [`SharedGplvm::params`]; spaces are matched by
    /// name and must all be given) and recomputes the caches. For models with a GP regression
    /// human → latent the regression is refitted (warm-started, default options).
    pub fn set_params(&mut self, p: &Params) -> Result<()> {
        let (n, q) = (self.n(), self.q());
        let mut next = self.clone();
        match (&mut next.latent, &p.latent) {
            (Latent::Free { x }, LatentParams::Free { x: nx }) => {
                check_shape("latent x", nx.as_ref(), n, q)?;
                *x = nx.clone();
            }
            (Latent::Back { weights, bandwidth, .. }, LatentParams::BackConstrained { weights: nw, bandwidth: nb }) => {
                // N rows, or a sparse model's M_c centres.
                check_shape("latent weights", nw.as_ref(), weights.nrows(), q)?;
                if !(nb.is_finite() && *nb > 0.0) {
                    return Err(Error::InvalidValue { what: "bandwidth".into(), reason: format!("{nb}; expected a finite number > 0") });
                }
                *weights = nw.clone();
                *bandwidth = *nb;
            }
            _ => {
                return Err(Error::InvalidValue {
                    what: "params.latent".into(),
                    reason: "kind does not match the model's back constraint (Free for None, BackConstrained otherwise)".into(),
                })
            }
        }
        if p.spaces.len() != next.spaces.len() {
            return Err(Error::DimensionMismatch {
                what: "params.spaces".into(),
                expected: next.spaces.len(),
                found: p.spaces.len(),
            });
        }
        let known: Vec<String> = next.spaces.iter().map(|s| s.name.clone()).collect();
        for (name, k) in &p.spaces {
            let Some(s) = next.spaces.iter_mut().find(|s| &s.name == name) else {
                return Err(Error::UnknownSpace {
                    name: name.clone(),
                    known,
                });
            };
            if k.lengthscale.len() != q {
                return Err(Error::DimensionMismatch {
                    what: format!("lengthscale of '{name}'"),
                    expected: q,
                    found: k.lengthscale.len(),
                });
            }
            if !k.is_valid() {
                return Err(Error::InvalidValue {
                    what: format!("kernel of '{name}'"),
                    reason: "expected finite values > 0".into(),
                });
            }
            s.kernel = k.clone();
        }
        next.update_latent_points();
        if next.needs_map() {
            let warm = next.map.as_ref().map(|m| m.kernel.clone());
            next.fit_map(&TrainOptions::default(), &Limits::default(), warm)?;
        }
        next.rebuild()?;
        *self = next;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_support::*;

    #[test]
    fn set_params_round_trip_and_scaling_undone() {
        let (h, r1, _, _) = demo(25, 3);
        let mut big = r1.clone();
        for j in 0..4 {
            for i in 0..25 {
                big[(i, j)] = 100.0 * r1[(i, j)] + 50.0 * j as f64;
            }
        }
        for mode in [ScaleMode::PerColumn, ScaleMode::PerSpace] {
            let cfg = ModelConfig::default()
                .with_latent_dim(2)
                .with_scale_mode(mode);
            let m = SharedGplvm::fit(
                &cfg,
                &[("human", h.as_ref()), ("r", big.as_ref())],
                "human",
                &quick(30),
                None,
            )
            .expect("fit");
            let (_, scale) = m.normalisation("r").expect("space");
            assert!(scale.iter().all(|&s| s > 10.0), "{scale:?}");
            let p = m.predict(h.as_ref(), "r", false).expect("predict");
            let rms: f64 = ((0..25)
                .map(|i| (p.mean[(i, 1)] - big[(i, 1)]).powi(2))
                .sum::<f64>()
                / 25.0)
                .sqrt();
            assert!(
                rms < 10.0,
                "{mode:?}: predictions not in original units (rms {rms})"
            );
            let mut m2 = m.clone();
            m2.set_params(&m.params()).expect("set");
            assert_eq!(m2.predict(h.as_ref(), "r", false).expect("p"), p);
        }
    }
}
