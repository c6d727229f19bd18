//! How the report pairs runs: by run index (the seed shared by the fully trained and
//! multi-robot models of a run), a transfer under the run of its source model, and the values of
//! two groups at the keys both have.

use std::collections::BTreeMap;

use sgplvm_core::BackConstraint;

use crate::results::{ModelKind, Results, RunRecord, Shipped};
use crate::stats;

/// The key that pairs a run with the runs of other models: its run index, and for a transfer the
/// run of its source model.
pub(super) fn pair_key(run: &RunRecord, transfers_per_run: usize) -> usize {
    match run.model {
        ModelKind::Transfer => run.source_run.unwrap_or(run.run / transfers_per_run.max(1)),
        _ => run.run,
    }
}

/// Per pair key, the mean of `value` of the shipped models of one robot, kind and back constraint.
pub(super) fn by_pair(
    results: &Results,
    robot: &str,
    kind: ModelKind,
    bc: BackConstraint,
    value: impl Fn(&Shipped) -> f64,
) -> BTreeMap<usize, f64> {
    by_pair_of(results, false, robot, kind, bc, value)
}

/// [`by_pair`] of the Bayesian study's runs (`bayesian`) or the paper's model's.
pub(super) fn by_pair_of(
    results: &Results,
    bayesian: bool,
    robot: &str,
    kind: ModelKind,
    bc: BackConstraint,
    value: impl Fn(&Shipped) -> f64,
) -> BTreeMap<usize, f64> {
    let mut groups: BTreeMap<usize, Vec<f64>> = BTreeMap::new();
    for run in results.select_of(bayesian, robot, kind, bc.name()) {
        groups
            .entry(pair_key(run, results.config.transfers_per_run))
            .or_default()
            .push(value(&run.shipped()));
    }
    groups
        .into_iter()
        .map(|(key, values)| (key, stats::mean(&values)))
        .collect()
}

/// The values of two groups at the pair keys both have, in key order.
pub(super) fn paired(a: &BTreeMap<usize, f64>, b: &BTreeMap<usize, f64>) -> (Vec<f64>, Vec<f64>) {
    a.iter()
        .filter_map(|(key, x)| b.get(key).map(|y| (*x, *y)))
        .unzip()
}

/// Values of a map in key order.
pub(super) fn values(map: &BTreeMap<usize, f64>) -> Vec<f64> {
    map.values().copied().collect()
}
