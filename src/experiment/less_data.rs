//! Less data (Fig. 9; the paper's Section V: transfer "allows us to train the transferred shared
//! GP-LVMs with less datapoints, and obtain better results than the models that were
//! independently trained for each robot").
//!
//! For each fraction f of the training frames (evenly spaced, [`subset`]), each run and each
//! robot: the robot trained fully on those frames alone (input back constraints), and transferred
//! to from every other robot's fully trained model of the same run (trained on *all* frames:
//! the new robot is the one with less data), its latent → joints mapping learned from the same
//! frames ([`SharedGplvm::transfer_partial`]). Budgets are chosen on the held-out training frames
//! among them, as everywhere else in the experiment.

use serde::{Deserialize, Serialize};
use sgplvm_core::{BackConstraint, Mat, MatRef, SharedGplvm, Validation};

use super::{
    mean_squared_error, model_config, ExperimentConfig, ExperimentData, ExperimentError, ModelKind,
    Runner, Sources,
};

/// One model of the less-data study.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct LessDataRecord {
    /// The robot whose test error is recorded.
    pub robot: String,
    /// Fraction of the training frames used.
    pub fraction: f64,
    /// Training frames used.
    pub frames: usize,
    /// [`ModelKind::Baseline`] (trained on those frames alone) or [`ModelKind::Transfer`]
    /// (from `source_robot`'s model of the same run, trained on all frames).
    pub model: ModelKind,
    /// Run (seed) index.
    pub run: usize,
    /// For transfers, the robot of the source model.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub source_robot: Option<String>,
    /// Test MSE (rad²).
    pub test_mse: f64,
}

/// About `fraction` of `n` training positions, evenly spaced: position p is kept when
/// ⌊(p + 1)·f⌋ > ⌊p·f⌋ (all of them for f ≥ 1).
pub fn subset(n: usize, fraction: f64) -> Vec<usize> {
    (0..n)
        .filter(|&p| ((p + 1) as f64 * fraction).floor() > (p as f64 * fraction).floor())
        .collect()
}

/// Trainings the study performs for `robots` robots.
pub(super) fn trainings(config: &ExperimentConfig, robots: usize) -> usize {
    config.fractions.len() * config.runs * robots * robots.max(1)
}

/// The rows `rows` of `m`.
fn rows_of(m: MatRef<'_, f64>, rows: &[usize]) -> Mat<f64> {
    Mat::from_fn(rows.len(), m.ncols(), |i, j| m[(rows[i], j)])
}

impl<'a> Runner<'a, '_> {
    /// The less-data study, from the input-back-constrained baselines of every run (`sources`).
    pub(super) fn less_data(
        &mut self,
        data: &'a ExperimentData,
        config: &ExperimentConfig,
        sources: &Sources,
    ) -> Result<Vec<LessDataRecord>, ExperimentError> {
        let bc = BackConstraint::Input;
        let input = data.input_name.as_str();
        let options = config.options(config.max_iters);
        let transfer_options = config.options(config.transfer_max_iters);
        let n = data.human.train.nrows();
        let mut records = Vec::new();
        for &fraction in &config.fractions {
            let rows = subset(n, fraction);
            // The held-out frames among them, as positions in `rows`.
            let held: Vec<usize> = (0..rows.len())
                .filter(|&i| data.validation.binary_search(&rows[i]).is_ok())
                .collect();
            let validation = config
                .patience
                .filter(|_| !held.is_empty())
                .map(|p| Validation::new(held.clone()).with_patience(p));
            let human = rows_of(data.human.train.as_ref(), &rows);
            for run in 0..config.runs {
                for (t, (target, split)) in data.robots.iter().enumerate() {
                    let context = format!(
                        "less data: {target} on {} of {n} frames, run {run}",
                        rows.len()
                    );
                    let fail = |source| ExperimentError::Model {
                        context: context.clone(),
                        source,
                    };
                    let joints = rows_of(split.train.as_ref(), &rows);
                    let spaces = [(input, human.as_ref()), (target.as_str(), joints.as_ref())];
                    let model_config = model_config(config, bc, run);
                    let model = match &validation {
                        Some(v) => SharedGplvm::fit_validated(
                            &model_config,
                            &spaces,
                            input,
                            &options,
                            v,
                            None,
                        ),
                        None => SharedGplvm::fit(&model_config, &spaces, input, &options, None),
                    }
                    .map_err(fail)?;
                    let predicted = model
                        .predict(self.human_test, target, false)
                        .map_err(fail)?
                        .mean;
                    let record =
                        |model, source_robot: Option<&str>, predicted: Mat<f64>| LessDataRecord {
                            robot: target.clone(),
                            fraction,
                            frames: rows.len(),
                            model,
                            run,
                            source_robot: source_robot.map(str::to_string),
                            test_mse: mean_squared_error(predicted.as_ref(), split.test.as_ref()),
                        };
                    records.push(record(ModelKind::Baseline, None, predicted));
                    self.finished(context.clone());
                    for (s, (source_name, _)) in data.robots.iter().enumerate() {
                        let Some(source) = sources.get(&(run, s)).filter(|_| s != t) else {
                            continue;
                        };
                        let seed = config.seed + run as u64;
                        let partial = source
                            .transfer_partial(
                                target,
                                &rows,
                                joints.as_ref(),
                                Some(seed),
                                &transfer_options,
                                validation.as_ref(),
                            )
                            .map_err(fail)?;
                        let predicted = partial.predict(source, self.human_test).map_err(fail)?;
                        records.push(record(ModelKind::Transfer, Some(source_name), predicted));
                        self.finished(format!("{context}, from {source_name}"));
                    }
                }
            }
        }
        Ok(records)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn subsets_are_evenly_spaced() {
        assert_eq!(subset(10, 1.0), (0..10).collect::<Vec<_>>());
        assert_eq!(subset(10, 0.5), vec![1, 3, 5, 7, 9]);
        assert_eq!(subset(10, 0.25), vec![3, 7]);
        assert_eq!(subset(249, 0.1).len(), 24);
        assert!(subset(5, 0.0).is_empty());
    }
}
