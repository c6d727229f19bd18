//! Training of the sparse model: [`crate::train::minimise`] on [`SparseObjective`], then the
//! input map (free latent points) and the caches, as the exact model's `train`.

use super::objective::SparseObjective;
use crate::error::Result;
use crate::model::{Callback, SharedGplvm};
use crate::objective::Mode;
use crate::train::{minimise, Control, Limits, TrainOptions};

impl SharedGplvm {
    /// The sparse model's `train`: runs the optimiser in `mode` within `limits`, then fits the
    /// input map (full mode, free latent points) and rebuilds caches.
    pub(crate) fn train_sparse(
        &mut self,
        mode: Mode,
        options: &TrainOptions,
        limits: &Limits,
        mut callback: Option<Callback<'_>>,
    ) -> Result<()> {
        let (outcome, mut applied) = {
            let obj = SparseObjective::new(self, mode.clone())?;
            let theta0 = obj.theta0();
            let d_total: usize = obj
                .evaluated()
                .iter()
                .map(|&s| self.spaces[s].data.ncols())
                .sum();
            let scale = 1.0 / (self.n() * d_total.max(1)) as f64;
            let mut prev_map = self.map.as_ref().map(|m| m.kernel.clone());
            let outcome = minimise(&obj, theta0, scale, options, limits, |rec, theta| {
                let Some(cb) = callback.as_mut() else {
                    return Control::Continue;
                };
                let mut snap = self.clone();
                obj.apply(theta, &mut snap);
                snap.update_latent_points();
                if matches!(mode, Mode::Full) && snap.needs_map() {
                    if snap.fit_map(options, limits, prev_map.clone()).is_err() {
                        return Control::Continue;
                    }
                    prev_map = snap.map.as_ref().map(|m| m.kernel.clone());
                }
                if snap.rebuild().is_err() {
                    return Control::Continue;
                }
                snap.history = Vec::new();
                cb(rec, &snap)
            })?;
            let mut applied = self.clone();
            obj.apply(&outcome.theta, &mut applied);
            (outcome, applied)
        };
        applied.update_latent_points();
        if matches!(mode, Mode::Full) && applied.needs_map() {
            applied.fit_map(options, limits, None)?;
        }
        applied.rebuild()?;
        applied.history = outcome.history;
        applied.stop_reason = Some(outcome.reason);
        *self = applied;
        Ok(())
    }
}
