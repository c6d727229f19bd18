//! Training a model from data: the paper's *full* model (human + one robot) and the
//! *multi-robot* model (human + every robot), all parameters jointly by L-BFGS.

use faer::MatRef;

use crate::back_constraint::{initial_latent, latent_points};
use crate::config::{BackConstraint, ModelConfig};
use crate::error::Result;
use crate::init::initial_latent_points;
use crate::kernel::row_major;
use crate::memory;
use crate::model::{Callback, Latent, SharedGplvm, Space};
use crate::objective::{Mode, ModelObjective};
use crate::pool::par_for;
use crate::preprocess::checked_order;
use crate::sparse::objective::SparseObjective;
use crate::train::{minimise_capped, Control, Limits, Objective, TrainOptions};

impl SharedGplvm {
    /// Fits a shared GP-LVM. `spaces` are named data matrices with the same number of rows;
    /// `input` names the human space; with one other space this is the paper's *full* model,
    /// with several the *multi-robot* model. `callback` sees every iteration with a model
    /// snapshot (built only when a callback is given) and may stop training.
    pub fn fit(
        config: &ModelConfig,
        spaces: &[(&str, MatRef<'_, f64>)],
        input: &str,
        options: &TrainOptions,
        callback: Option<Callback<'_>>,
    ) -> Result<Self> {
        options.check_for(config)?;
        let limits = Limits::start(options);
        let mut model = Self::initial(config, spaces, input)?;
        model.train(Mode::Full, options, &limits, callback)?;
        Ok(model)
    }

    /// The model [`SharedGplvm::fit`] starts training from: spaces checked and preprocessed,
    /// latent points initialised (X, or W for back constraints), not yet trained.
    pub(crate) fn initial(
        config: &ModelConfig,
        spaces: &[(&str, MatRef<'_, f64>)],
        input: &str,
    ) -> Result<Self> {
        config.check()?;
        let order = checked_order(spaces, input, config.latent_dim)?;
        let n = spaces[order[0]].1.nrows();
        match config.inducing {
            None => memory::check("training", n, memory::fit_matrices(spaces.len()))?,
            // More inducing inputs than frames is refused below, by that name.
            Some(m) if m <= n => {
                let dims: Vec<usize> = spaces.iter().map(|(_, d)| d.ncols()).collect();
                memory::check_sparse("training", n, m, config.latent_dim, &dims)?
            }
            Some(_) => {}
        }
        let sp: Vec<Space> = order
            .iter()
            .map(|&i| Space::from_data(spaces[i].0, spaces[i].1, config))
            .collect::<Result<_>>()?;
        let x0 = initial_latent_points(&sp, config)?;
        if let Some(m) = config.inducing {
            return Self::initial_sparse(config, sp, x0, m);
        }
        let latent = initial_latent(config.back_constraint, &sp, x0.as_ref(), config.bc_ridge)?;
        let mut model = SharedGplvm::new(config.clone(), sp, latent);
        model.update_latent_points();
        Ok(model)
    }

    /// Recomputes X (and its row-major copy) from the latent representation.
    pub(crate) fn update_latent_points(&mut self) {
        self.x = match &self.latent {
            Latent::Free { x } => x.clone(),
            Latent::Back {
                weights,
                bandwidth,
                data,
            } if self.sparse.is_some() => {
                self.sparse_latent_points(weights.as_ref(), *bandwidth, data.as_ref())
            }
            Latent::Back {
                weights,
                bandwidth,
                data,
            } => latent_points(
                self.bc.kbc(data.as_ref(), *bandwidth).as_ref().as_ref(),
                weights.as_ref(),
                par_for(weights.nrows()),
            ),
        };
        self.x_rows = row_major(self.x.as_ref());
    }

    /// True when human → latent goes through the input map (no input back constraint).
    pub(crate) fn needs_map(&self) -> bool {
        self.config.back_constraint != BackConstraint::Input
    }

    /// Runs the optimiser in `mode` within `limits` (the calling training's deadline and
    /// interrupt), then fits the input map (full mode) and rebuilds caches. The exact and the
    /// sparse model differ only in their objective.
    pub(crate) fn train(
        &mut self,
        mode: Mode,
        options: &TrainOptions,
        limits: &Limits,
        callback: Option<Callback<'_>>,
    ) -> Result<()> {
        let applied = if self.sparse.is_some() {
            let obj = SparseObjective::new(self, mode.clone())?;
            self.optimised(&obj, &mode, options, limits, callback)?
        } else {
            let mut obj = ModelObjective::new(self, mode.clone())?;
            if options.whiten_back_constraint {
                obj = obj.whitened()?;
            }
            self.optimised(&obj, &mode, options, limits, callback)?
        };
        *self = applied;
        Ok(())
    }

    /// The model trained by minimising `obj` (built on this model in `mode`), with its input
    /// map fitted (full mode) and caches rebuilt.
    fn optimised(
        &self,
        obj: &impl ParameterObjective,
        mode: &Mode,
        options: &TrainOptions,
        limits: &Limits,
        mut callback: Option<Callback<'_>>,
    ) -> Result<SharedGplvm> {
        let theta0 = obj.theta0();
        let mut prev_map = self.map.as_ref().map(|m| m.kernel.clone());
        // A transfer's kernel (log-parameters alone), exact or sparse: first trials of at most
        // an e-fold change.
        let first_trial = match mode {
            Mode::Kernels(_) => 1.0,
            Mode::Full => f64::INFINITY,
        };
        // The exact model's back-constraint weights: their own L-BFGS history size.
        let back_constrained = matches!(mode, Mode::Full)
            && self.sparse.is_none()
            && matches!(self.latent, Latent::Back { .. });
        let lbfgs = TrainOptions {
            memory: if back_constrained {
                options.back_constraint_memory
            } else {
                options.memory
            },
            ..options.clone()
        };
        let outcome = minimise_capped(obj, theta0, &lbfgs, limits, first_trial, |rec, theta| {
            let Some(cb) = callback.as_mut() else {
                return Control::Continue;
            };
            let mut snap = self.clone();
            obj.apply(theta, &mut snap);
            snap.update_latent_points();
            // The snapshot's map starts from the previous snapshot's (a cold start costs a
            // whole regression per iteration, 3× the experiment's time); the returned model
            // fits its map from a cold start, so a snapshot of a model with an input map
            // predicts what the model stopped there predicts only to the map's convergence
            // (relative 1e-6 on the shipped data; on small problems the two optima can differ).
            if matches!(mode, Mode::Full) && snap.needs_map() {
                if snap.fit_map(options, limits, prev_map.clone()).is_err() {
                    return Control::Continue;
                }
                prev_map = snap.map.as_ref().map(|m| m.kernel.clone());
            }
            if snap.rebuild_for(mode).is_err() {
                return Control::Continue;
            }
            snap.history = Vec::new();
            cb(rec, &snap)
        })?;
        let mut applied = self.clone();
        obj.apply(&outcome.theta, &mut applied);
        applied.update_latent_points();
        if matches!(mode, Mode::Full) && applied.needs_map() {
            applied.fit_map(options, limits, None)?;
        }
        applied.rebuild_for(mode)?;
        applied.history = outcome.history;
        applied.stop_reason = Some(outcome.reason);
        Ok(applied)
    }
}

impl SharedGplvm {
    /// The caches after training in `mode` (see [`SharedGplvm::rebuild_kernels`]).
    fn rebuild_for(&mut self, mode: &Mode) -> Result<()> {
        match mode {
            Mode::Full => self.rebuild(),
            Mode::Kernels(changed) => self.rebuild_kernels(changed),
        }
    }
}

/// What [`SharedGplvm::train`] needs of an objective besides its value and gradient: its
/// starting point and how its parameters go back into a model.
pub(crate) trait ParameterObjective: Objective {
    /// The parameter vector of the model the objective was built on.
    fn theta0(&self) -> Vec<f64>;
    /// Writes `theta` into `target` (no caches rebuilt).
    fn apply(&self, theta: &[f64], target: &mut SharedGplvm);
}

impl ParameterObjective for ModelObjective<'_> {
    fn theta0(&self) -> Vec<f64> {
        ModelObjective::theta0(self)
    }
    fn apply(&self, theta: &[f64], target: &mut SharedGplvm) {
        ModelObjective::apply(self, theta, target)
    }
}

impl ParameterObjective for SparseObjective<'_> {
    fn theta0(&self) -> Vec<f64> {
        SparseObjective::theta0(self)
    }
    fn apply(&self, theta: &[f64], target: &mut SharedGplvm) {
        SparseObjective::apply(self, theta, target)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_support::*;

    #[test]
    fn training_decreases_objective_monotonically_and_is_deterministic() {
        for bc in [
            BackConstraint::None,
            BackConstraint::Input,
            BackConstraint::Output,
        ] {
            let a = fit(bc, 40, 25, 3);
            let h = a.history();
            assert!(h.len() > 3, "{bc:?}: only {} records", h.len());
            assert!(
                h.last().expect("records").objective < h[0].objective - 1.0,
                "{bc:?} did not improve"
            );
            for w in h.windows(2) {
                assert!(
                    w[1].objective <= w[0].objective,
                    "{bc:?} history not monotone"
                );
                assert!(w[1].seconds >= w[0].seconds);
            }
            // The reported objective is the model's objective at its final parameters.
            let f = a.objective();
            assert!((f - h.last().expect("records").objective).abs() < 1e-9 * f.abs());
            let b = fit(bc, 40, 25, 3);
            assert_eq!(a.params(), b.params(), "{bc:?} not deterministic");
            let c = fit(bc, 40, 25, 4);
            assert_ne!(a.params(), c.params(), "{bc:?}: seed ignored");
        }
    }

    /// Back-constrained full training takes `back_constraint_memory` as its L-BFGS history,
    /// every other training `memory`: a history size shows only once the smaller one is full,
    /// so the first records agree and later ones differ.
    #[test]
    fn back_constrained_training_uses_its_own_history_size() {
        let objectives = |bc: BackConstraint, options: TrainOptions| -> Vec<f64> {
            let m = fit_with(bc, 40, 0, &options);
            m.history().iter().map(|r| r.objective).collect()
        };
        let base = quick(40).with_memory(3).with_back_constraint_memory(3);
        for bc in [BackConstraint::Input, BackConstraint::Output] {
            let short = objectives(bc, base.clone());
            let long = objectives(bc, base.clone().with_back_constraint_memory(30));
            assert_eq!(
                short[..5],
                long[..5],
                "{bc:?}: the first iterations changed"
            );
            assert_ne!(short, long, "{bc:?}: back_constraint_memory ignored");
            let other = objectives(bc, base.clone().with_memory(30));
            assert_eq!(short, other, "{bc:?}: memory used instead");
        }
        let free = objectives(BackConstraint::None, base.clone());
        let free_other = objectives(BackConstraint::None, base.with_back_constraint_memory(30));
        assert_eq!(
            free, free_other,
            "free latent points took back_constraint_memory"
        );
    }

    #[test]
    fn callback_sees_snapshots_and_can_stop() {
        let (h, r1, _, _) = demo(30, 1);
        let config = ModelConfig::default().with_latent_dim(2);
        let mut seen = Vec::new();
        let mut cb = |rec: &IterationRecord, m: &SharedGplvm| {
            let p = m
                .predict(h.as_ref(), "walkman", false)
                .expect("snapshot predicts");
            seen.push((rec.iteration, p.mean[(0, 0)]));
            if rec.iteration == 4 {
                Control::Stop
            } else {
                Control::Continue
            }
        };
        let m = SharedGplvm::fit(
            &config,
            &[("human", h.as_ref()), ("walkman", r1.as_ref())],
            "human",
            &quick(100),
            Some(&mut cb),
        )
        .expect("fit");
        assert_eq!(
            seen.iter().map(|s| s.0).collect::<Vec<_>>(),
            vec![1, 2, 3, 4]
        );
        assert_eq!(m.stop_reason(), Some(&StopReason::Callback));
        assert_eq!(m.history().len(), 5);
        // The last snapshot predicts exactly what the returned model predicts.
        let p = m.predict(h.as_ref(), "walkman", false).expect("predict");
        assert_eq!(p.mean[(0, 0)], seen[3].1);
    }

    #[test]
    fn multi_robot_fit_predicts_every_robot() {
        let (h, r1, r2, r3) = demo(40, 2);
        let config = ModelConfig::default().with_latent_dim(2);
        let m = SharedGplvm::fit(
            &config,
            &[
                ("walkman", r1.as_ref()),
                ("human", h.as_ref()),
                ("coman", r2.as_ref()),
                ("centauro", r3.as_ref()),
            ],
            "human",
            &quick(60),
            None,
        )
        .expect("fit");
        assert_eq!(m.input_name(), "human");
        assert_eq!(m.output_names(), vec!["walkman", "coman", "centauro"]);
        for (name, r) in [("walkman", &r1), ("coman", &r2), ("centauro", &r3)] {
            let p = m.predict(h.as_ref(), name, false).expect("predict");
            let mse: f64 = (0..40)
                .flat_map(|i| (0..4).map(move |j| (i, j)))
                .map(|(i, j)| (p.mean[(i, j)] - r[(i, j)]).powi(2))
                .sum::<f64>()
                / 160.0;
            assert!(mse < 0.05, "{name} training mse {mse}");
        }
    }
}
