//! The model's parameters in natural units, as users read and set them: the latent block
//! (X, or W and the bandwidth) and each space's kernel. The same structure carries gradients.

use std::sync::OnceLock;

use faer::Mat;

use crate::error::{Error, Result};
use crate::kernel::KernelParams;
use crate::model::{Latent, SharedGplvm, Workspace};
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
    /// name and must all be given; on an error nothing changes). The prediction caches are
    /// rebuilt on the first prediction that needs them, and for models with a GP regression
    /// human → latent the regression is then refitted (warm-started, default options): an
    /// optimiser that drives the model through `set_params` and [`SharedGplvm::evaluate`]
    /// pays only for the evaluations. A kernel matrix that cannot be factorised is reported
    /// by `evaluate` and by that prediction. A sparse model's caches (M×M, M×D) are rebuilt at
    /// once, as after training, and their errors reported here.
    pub fn set_params(&mut self, p: &Params) -> Result<()> {
        if self.sparse.is_none() {
            return self.replace_params(p);
        }
        let mut next = self.clone();
        next.replace_params(p)?;
        if next.map_stale {
            let warm = next.map.as_ref().map(|m| m.kernel.clone());
            next.fit_map(&TrainOptions::default(), &Limits::default(), warm)?;
        }
        next.rebuild()?;
        *self = next;
        Ok(())
    }

    /// [`SharedGplvm::set_params`] of the exact model: checks, then replaces the parameters and
    /// leaves the prediction caches to be built on first use.
    fn replace_params(&mut self, p: &Params) -> Result<()> {
        let (n, q) = (self.n(), self.q());
        // Everything is checked on copies of the small parts before the model changes; the
        // model itself (its data and evaluation buffers) is not copied.
        let mut latent = match (&self.latent, &p.latent) {
            (Latent::Free { .. }, LatentParams::Free { x: nx }) => {
                check_shape("latent x", nx.as_ref(), n, q)?;
                Latent::Free { x: nx.clone() }
            }
            (Latent::Back { weights, .. }, LatentParams::BackConstrained { weights: nw, bandwidth: nb }) => {
                // N rows, or a sparse model's M_c centres.
                check_shape("latent weights", nw.as_ref(), weights.nrows(), q)?;
                if !(nb.is_finite() && *nb > 0.0) {
                    return Err(Error::InvalidValue { what: "bandwidth".into(), reason: format!("{nb}; expected a finite number > 0") });
                }
                Latent::Back { weights: nw.clone(), bandwidth: *nb, data: Mat::zeros(0, 0) }
            }
            _ => {
                return Err(Error::InvalidValue {
                    what: "params.latent".into(),
                    reason: "kind does not match the model's back constraint (Free for None, BackConstrained otherwise)".into(),
                })
            }
        };
        if p.spaces.len() != self.spaces.len() {
            return Err(Error::DimensionMismatch {
                what: "params.spaces".into(),
                expected: self.spaces.len(),
                found: p.spaces.len(),
            });
        }
        let known: Vec<String> = self.spaces.iter().map(|s| s.name.clone()).collect();
        let mut kernels: Vec<Option<KernelParams>> = vec![None; self.spaces.len()];
        for (name, k) in &p.spaces {
            let Some(s) = self.spaces.iter().position(|s| &s.name == name) else {
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
            kernels[s] = Some(k.clone());
        }
        if kernels.iter().any(Option::is_none) {
            // A space named twice leaves another one out.
            return Err(Error::InvalidValue {
                what: "params.spaces".into(),
                reason: format!("expected each of {known:?} once"),
            });
        }
        if let (
            Latent::Back {
                data: new_data,
                bandwidth: new_bw,
                ..
            },
            Latent::Back {
                data, bandwidth, ..
            },
        ) = (&mut latent, &mut self.latent)
        {
            std::mem::swap(new_data, data);
            if new_bw.to_bits() != bandwidth.to_bits() {
                self.bc = Default::default();
            }
        }
        self.latent = latent;
        for (s, k) in self.spaces.iter_mut().zip(kernels.into_iter().flatten()) {
            s.kernel = k;
        }
        self.update_latent_points();
        // New parameters, a new reconstruction threshold: computed when asked for.
        self.reconstruction = None;
        if let Some(refitted) = self.prepared.take().and_then(|p| p.map) {
            // The map refitted after an earlier `set_params` is the better warm start.
            self.map = Some(refitted);
        }
        self.map_stale = self.needs_map();
        Ok(())
    }
}

impl SharedGplvm {
    /// A copy of the model with parameters `p` (see [`SharedGplvm::set_params`]). The copy
    /// takes over this model's evaluation buffers (this model gets new ones if evaluated
    /// again) and not its prediction caches: for a caller that replaces a model by its copy
    /// on every step of an optimiser, as the Python binding does, a step costs little more
    /// than the evaluation.
    pub fn with_params(&self, p: &Params) -> Result<SharedGplvm> {
        let mut next = SharedGplvm {
            config: self.config.clone(),
            spaces: self.spaces.clone(),
            latent: self.latent.clone(),
            map: self.map.clone(),
            history: self.history.clone(),
            stop_reason: self.stop_reason.clone(),
            selection: self.selection.clone(),
            sparse: self.sparse.clone(),
            // New parameters, new thresholds: computed when asked for.
            trust: std::collections::BTreeMap::new(),
            trust_groups: self.trust_groups.clone(),
            reconstruction: None,
            pose_bounds: self.pose_bounds.clone(),
            random_followed: self.random_followed,
            novelty: self.novelty,
            map_stale: self.map_stale,
            annotations: self.annotations.clone(),
            x: self.x.clone(),
            x_rows: self.x_rows.clone(),
            prepared: OnceLock::new(),
            novelty_reference: self.novelty_reference.clone(),
            bc: self.bc.clone(),
            workspace: Workspace::default(),
        };
        if self.map_stale {
            if let Some(m) = self.prepared.get().and_then(|p| p.map.clone()) {
                next.map = Some(m);
            }
        }
        next.set_params(p)?;
        next.workspace.put(self.workspace.take_all());
        Ok(next)
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

    #[test]
    fn set_params_defers_the_caches_and_predicts_what_a_rebuilt_model_predicts() {
        let (h, _, _, _) = demo(30, 7);
        for bc in [
            BackConstraint::None,
            BackConstraint::Input,
            BackConstraint::Output,
        ] {
            let m = fit(bc, 30, 5, 1);
            let mut p = m.params();
            match &mut p.latent {
                LatentParams::Free { x } => *x = x.clone() * faer::Scale(1.3),
                LatentParams::BackConstrained { weights, .. } => {
                    *weights = weights.clone() * faer::Scale(1.3)
                }
            }
            p.spaces[1].1.noise *= 2.0;
            m.evaluate().expect("evaluates");
            let moved = m.with_params(&p).expect("valid");
            // The copy took the evaluation buffers, and has no caches until a prediction.
            assert_eq!(moved.workspace.take_all().len(), 2);
            assert!(moved.prepared.get().is_none());
            let mut in_place = m.clone();
            in_place.set_params(&p).expect("valid");
            assert!(in_place.prepared.get().is_none());
            let lazy = in_place
                .predict(h.as_ref(), "walkman", true)
                .expect("predicts");
            assert_ne!(lazy, m.predict(h.as_ref(), "walkman", true).expect("p"));
            // A model loaded from the file (its caches built at once, with the map as saved)
            // predicts the same bits; so does the copy.
            let loaded = SharedGplvm::from_bytes(&in_place.to_bytes()).expect("loads");
            assert_eq!(loaded.params(), p);
            assert_eq!(
                loaded.predict(h.as_ref(), "walkman", true).expect("p"),
                lazy
            );
            assert_eq!(moved.predict(h.as_ref(), "walkman", true).expect("p"), lazy);
            assert_eq!(loaded.input_map().is_some(), bc != BackConstraint::Input);
            assert_eq!(loaded.input_map(), in_place.input_map());
            // Parameters that are refused change nothing.
            let mut bad = p.clone();
            bad.spaces[0].0 = "walkman".into();
            assert!(in_place.set_params(&bad).is_err());
            assert_eq!(in_place.params(), p);
        }
    }
}
