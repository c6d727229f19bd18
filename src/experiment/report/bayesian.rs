//! The report's section on the Bayesian study (issue 34): each Bayesian model against the
//! paper's model of the same kind, back constraint and runs; whether its test error rises after
//! its best iteration (the overfitting early stopping guards against); and the latent dimensions
//! each space uses.

use std::collections::BTreeMap;

use sgplvm_core::BackConstraint;

use super::format::{mean_sd, num, with_interval};
use super::judged;
use super::pairs::{by_pair_of, paired};
use crate::results::{used_dimensions, ModelKind, Results, RunRecord, ARD_USED_SHARE};
use crate::stats::{self, Bootstrap, Interval, StatsError};

/// The section, or `None` when the study was not run.
pub(super) fn bayesian_section(results: &Results, boot: &Bootstrap) -> Option<String> {
    let study = results.config.bayesian?;
    let budget = match results.config.patience {
        Some(_) => "its iteration budget chosen on held-out training frames",
        None => "the paper's fixed budget",
    };
    let mut out = format!(
        "## The Bayesian shared GP-LVM (issue 34)\n\n\
         Each model of the Bayesian study (q(X) with a KL term to its prior, RBF-ARD kernels, \
         M = {} inducing inputs per space) trained until it converged or reached {} iterations, \
         never stopped by held-out frames, against the paper's model of the same kind, back \
         constraint and seeds ({budget}). \"Ratio\" divides the mean test MSE of the Bayesian \
         model by the paper's model's, paired by run, with a 95 % bootstrap interval: *better* or \
         *worse* when the interval excludes 1, *no clear difference* otherwise. \"Rise\" is how \
         far the shipped model's test error lies above the lowest on its training curve \
         (median and largest over runs): a model that needs early stopping rises. \"Late\" is the \
         change of the test error over the second half of the training (from its middle \
         iteration to the shipped model; median over runs): whether it is still rising when \
         training ends.\n\n\
         | robot | model | BC | runs | Bayesian | paper's model | ratio | finding | ÷ direct GP | rise (median, max) | late | stopped by |\n\
         |---|---|---|---|---|---|---|---|---|---|---|---|\n",
        study.inducing, study.max_iters
    );
    for robot in &results.robots {
        for kind in [ModelKind::Baseline, ModelKind::Transfer, ModelKind::Multi] {
            for bc in [BackConstraint::None, BackConstraint::Input] {
                out.push_str(&comparison_row(results, boot, robot, kind, bc));
            }
        }
    }
    out.push('\n');
    out.push_str(&dimensions_used(results));
    Some(out)
}

/// One row of the comparison table (empty when the study has no such runs).
fn comparison_row(
    results: &Results,
    boot: &Bootstrap,
    robot: &str,
    kind: ModelKind,
    bc: BackConstraint,
) -> String {
    let runs = results.select_of(true, robot, kind, bc.name());
    if runs.is_empty() {
        return String::new();
    }
    let test = |bayesian| by_pair_of(results, bayesian, robot, kind, bc, |s| s.test_mse);
    let (bayes, paper) = paired(&test(true), &test(false));
    let ci = boot.ratio_of_means(&bayes, &paper);
    let ratio = stats::mean(&bayes) / stats::mean(&paper);
    let name = match kind {
        ModelKind::Baseline => "baseline",
        ModelKind::Transfer => "transfer",
        ModelKind::Multi => "multi-robot",
    };
    // Both columns over every run (as the report's first table); the ratio over pairs.
    let shipped = |bayesian| -> Vec<f64> {
        let runs = results.select_of(bayesian, robot, kind, bc.name());
        runs.iter().map(|r| r.shipped().test_mse).collect()
    };
    let (all_bayes, all_paper) = (shipped(true), shipped(false));
    let mut rises: Vec<f64> = runs.iter().map(|r| rise(r)).collect();
    rises.sort_by(f64::total_cmp);
    let mut late: Vec<f64> = runs.iter().map(|r| late_change(r)).collect();
    late.sort_by(f64::total_cmp);
    format!(
        "| {robot} | {name} | {bc} | {} | {} | {} | {} | {} | {} | {}, {} | {} | {} |\n",
        runs.len(),
        mean_sd(&all_bayes, 5),
        mean_sd(&all_paper, 5),
        with_interval(results, ratio, &ci, |v| num(v, 2)),
        finding(results, &ci),
        num(stats::mean(&all_bayes) / results.direct_mse(robot), 2),
        percent(stats::quantile(&rises, 0.5)),
        percent(rises.last().copied().unwrap_or(f64::NAN)),
        signed_percent(stats::quantile(&late, 0.5)),
        stop_reasons(&runs),
    )
}

/// How far a run's shipped test error lies above the lowest on its curve, relative to it.
fn rise(run: &RunRecord) -> f64 {
    let best = run.test_mse.iter().copied().fold(f64::INFINITY, f64::min);
    run.shipped().test_mse / best - 1.0
}

/// The relative change of a run's test error from its curve's middle iteration to the shipped
/// model.
fn late_change(run: &RunRecord) -> f64 {
    let middle = run.test_mse.get(run.test_mse.len() / 2).copied();
    middle.map_or(f64::NAN, |m| run.shipped().test_mse / m - 1.0)
}

/// A relative change as a signed percentage with one decimal ("—" when not finite).
fn signed_percent(value: f64) -> String {
    match value.is_finite() {
        true => super::format::signed(value * 100.0, 1) + " %",
        false => "—".into(),
    }
}

/// A relative change as a percentage with one decimal ("—" when not finite).
fn percent(value: f64) -> String {
    if value.is_finite() {
        format!("{:.1} %", value * 100.0)
    } else {
        "—".into()
    }
}

/// What a ratio's interval says.
fn finding(results: &Results, ci: &Result<Interval, StatsError>) -> String {
    if !judged(results) {
        return "not judged".into();
    }
    match ci {
        Ok(ci) if ci.below(1.0) => "better".into(),
        Ok(ci) if ci.above(1.0) => "worse".into(),
        Ok(_) => "no clear difference".into(),
        Err(e) => format!("not judged ({e})"),
    }
}

/// Why the runs' final trainings stopped, counted: "max_iterations ×3, line_search ×1".
fn stop_reasons(runs: &[&RunRecord]) -> String {
    let mut counts: BTreeMap<&str, usize> = BTreeMap::new();
    for r in runs {
        *counts
            .entry(r.stop_reason.as_deref().unwrap_or("unknown"))
            .or_default() += 1;
    }
    counts
        .iter()
        .map(|(reason, n)| format!("{reason} ×{n}"))
        .collect::<Vec<_>>()
        .join(", ")
}

/// The latent dimensions each space of the multi-robot models uses, per back constraint
/// (Fig. 12 draws the weights).
fn dimensions_used(results: &Results) -> String {
    let q = results.config.latent_dim;
    let mut header = None;
    let mut rows = String::new();
    for bc in [BackConstraint::None, BackConstraint::Input] {
        let models = results.bayesian_multi_models(bc.name());
        let Some(first) = models.first() else {
            continue;
        };
        let spaces: Vec<&str> = first.ard_weights.iter().map(|(s, _)| s.as_str()).collect();
        header.get_or_insert(format!(
            "| back constraint | runs | {} | shared |\n|---|---|{}\n",
            spaces.join(" | "),
            "---|".repeat(spaces.len() + 1)
        ));
        // Per model, which dimensions each space uses.
        let used: Vec<Vec<Vec<bool>>> = models
            .iter()
            .map(|m| {
                m.ard_weights
                    .iter()
                    .map(|(_, w)| used_dimensions(w))
                    .collect()
            })
            .collect();
        rows.push_str(&format!("| {bc} | {} |", models.len()));
        for s in 0..spaces.len() {
            let counts: Vec<f64> = used
                .iter()
                .filter_map(|m| m.get(s))
                .map(|u| u.iter().filter(|x| **x).count() as f64)
                .collect();
            rows.push_str(&format!(" {} |", num(stats::mean(&counts), 1)));
        }
        let shared: Vec<f64> = used
            .iter()
            .map(|m| {
                let all = |t: usize| m.iter().all(|u| u.get(t).copied().unwrap_or(false));
                (0..q).filter(|&t| all(t)).count() as f64
            })
            .collect();
        rows.push_str(&format!(" {} |\n", num(stats::mean(&shared), 1)));
    }
    let Some(header) = header else {
        return String::new();
    };
    format!(
        "Latent dimensions each space of the Bayesian multi-robot models uses (ARD weight above \
         {:.0} % of the space's largest; of Q = {q}), mean over runs, and those every space \
         uses (shared); Fig. 12 draws the weights.\n\n{header}{rows}",
        ARD_USED_SHARE * 100.0
    )
}
