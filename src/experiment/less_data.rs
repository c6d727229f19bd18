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

use sgplvm_core::{Mat, MatRef};

use super::ExperimentConfig;

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
pub(super) fn rows_of(m: MatRef<'_, f64>, rows: &[usize]) -> Mat<f64> {
    Mat::from_fn(rows.len(), m.ncols(), |i, j| m[(rows[i], j)])
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
