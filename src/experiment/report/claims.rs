//! The paper's claims, one judge each ([`claim_1`] … [`claim_6`]): the statistics of a claim,
//! its rule and its finding for every robot ([`Claim`]), and the verdict the findings give
//! ([`verdict`]: supported only when the claim holds significantly for every robot).

use std::collections::BTreeMap;

use sgplvm_core::BackConstraint;

use crate::results::{ModelKind, Results, Shipped};
use crate::stats::{self, Bootstrap, Interval, StatsError};

use super::format::{mean_sd, num, signed, with_interval};
use super::judged;
use super::pairs::{by_pair, pair_key, paired, values};

/// "Similar" in claims 3 and 4: a ratio of mean test errors within `1/SIMILAR … SIMILAR`.
pub(super) const SIMILAR: f64 = 1.5;

/// What the evidence says about a claim for one robot.
#[derive(Debug, Clone, PartialEq)]
pub(super) enum Finding {
    /// Significant in the claimed direction.
    Holds,
    /// Significant in the other direction (why).
    Against(String),
    /// Not significant (what).
    NotSignificant(String),
    /// Could not be computed (why).
    Missing(String),
}

impl Finding {
    fn describe(&self) -> String {
        match self {
            Finding::Holds => "holds".into(),
            Finding::Against(why) => format!("against: {why}"),
            Finding::NotSignificant(what) => format!("not significant: {what}"),
            Finding::Missing(why) => format!("no data: {why}"),
        }
    }
}

/// The statistics and per-robot findings of one claim.
pub(super) struct Claim {
    /// The paper's statement.
    pub(super) statement: &'static str,
    /// How it is judged.
    pub(super) rule: String,
    /// Markdown tables with the numbers.
    pub(super) tables: String,
    /// Per robot.
    pub(super) findings: Vec<(String, Finding)>,
}

/// Claim 1: the input back constraint beats each of the others, paired by run.
pub(super) fn claim_1(results: &Results, boot: &Bootstrap) -> Claim {
    let mut tables = String::from(
        "Shipped test MSE of the fully trained models (rad², mean ± sd over runs); differences \
         paired by run seed, with 95 % bootstrap intervals.\n\n\
         | robot | runs | none | input | output | none − input | output − input | finding |\n\
         |---|---|---|---|---|---|---|---|\n",
    );
    let mut findings = Vec::new();
    for robot in &results.robots {
        let [none, input, output] = BackConstraint::ALL
            .map(|bc| by_pair(results, robot, ModelKind::Baseline, bc, |s| s.test_mse));
        let mut cells = Vec::new();
        let mut parts = Vec::new();
        for (other, name) in [(&none, "none"), (&output, "output")] {
            let (o, i) = paired(other, &input);
            let ci = boot.mean_difference(&o, &i);
            let difference = stats::mean(&o) - stats::mean(&i);
            cells.push(with_interval(results, difference, &ci, |v| signed(v, 5)));
            parts.push(match &ci {
                Err(e) => Finding::Missing(format!("{name} − input: {e}")),
                Ok(ci) if ci.above(0.0) => Finding::Holds,
                Ok(ci) if ci.below(0.0) => {
                    Finding::Against(format!("input significantly worse than {name}"))
                }
                Ok(_) => Finding::NotSignificant(format!("input against {name}")),
            });
        }
        let finding = combine(parts);
        tables.push_str(&format!(
            "| {robot} | {} | {} | {} | {} | {} | {} | {} |\n",
            input.len(),
            mean_sd(&values(&none), 5),
            mean_sd(&values(&input), 5),
            mean_sd(&values(&output), 5),
            cells[0],
            cells[1],
            finding_cell(results, &finding),
        ));
        findings.push((robot.clone(), finding));
    }
    Claim {
        statement: "Back constraints on the input give the best fully trained model (Fig. 6)",
        rule: "for every robot, none − input and output − input (shipped test MSE, paired by run) \
               both have their 95 % interval above 0."
            .into(),
        tables,
        findings,
    }
}

/// Several comparisons that must all hold: against if any is against, else missing if any is
/// missing, else not significant if any is not.
pub(super) fn combine(parts: Vec<Finding>) -> Finding {
    let join = |pick: fn(&Finding) -> Option<&String>| {
        parts.iter().filter_map(pick).cloned().collect::<Vec<_>>()
    };
    let against = join(|f| match f {
        Finding::Against(why) => Some(why),
        _ => None,
    });
    let missing = join(|f| match f {
        Finding::Missing(why) => Some(why),
        _ => None,
    });
    let open = join(|f| match f {
        Finding::NotSignificant(what) => Some(what),
        _ => None,
    });
    if !against.is_empty() {
        Finding::Against(against.join("; "))
    } else if !missing.is_empty() {
        Finding::Missing(missing.join("; "))
    } else if !open.is_empty() {
        Finding::NotSignificant(open.join("; "))
    } else {
        Finding::Holds
    }
}

/// Claim 2: training time to the shipped model, transfer against baseline, paired by source run;
/// the shipped models' test errors beside it.
pub(super) fn claim_2(results: &Results, boot: &Bootstrap) -> Claim {
    let bc = BackConstraint::Input;
    let mut time = String::from(
        "Training until the shipped model (input back constraints; mean ± sd over source runs, a \
         run's transfers averaged; baseline − transfer paired by source run, 95 % bootstrap \
         interval). Seconds depend on the machine's load; iterations do not.\n\n\
         | robot | source runs | baseline (s) | transfer (s) | baseline − transfer (s) | iterations, baseline | iterations, transfer | finding |\n\
         |---|---|---|---|---|---|---|---|\n",
    );
    let mut error = String::from(
        "The shipped models' test MSE (rad², same pairing; transfer − baseline above 0 means \
         the transfer ships a worse model).\n\n\
         | robot | baseline | transfer | transfer − baseline |\n|---|---|---|---|\n",
    );
    let mut findings = Vec::new();
    for robot in &results.robots {
        let group = |kind, value: fn(&Shipped) -> f64| by_pair(results, robot, kind, bc, value);
        let (b_s, t_s) = paired(
            &group(ModelKind::Baseline, |s| s.seconds),
            &group(ModelKind::Transfer, |s| s.seconds),
        );
        let (b_it, t_it) = paired(
            &group(ModelKind::Baseline, |s| s.iteration as f64),
            &group(ModelKind::Transfer, |s| s.iteration as f64),
        );
        let (b_e, t_e) = paired(
            &group(ModelKind::Baseline, |s| s.test_mse),
            &group(ModelKind::Transfer, |s| s.test_mse),
        );
        let time_ci = boot.mean_difference(&b_s, &t_s);
        let error_ci = boot.mean_difference(&t_e, &b_e);
        let finding = match (&time_ci, &error_ci) {
            (Err(e), _) | (_, Err(e)) => Finding::Missing(e.to_string()),
            (Ok(t), Ok(e)) if t.above(0.0) && e.above(0.0) => Finding::Against(
                "faster, but to a significantly higher test error than the baseline's".into(),
            ),
            (Ok(t), _) if t.above(0.0) => Finding::Holds,
            (Ok(t), _) if t.below(0.0) => {
                Finding::Against("transfer significantly slower to its shipped model".into())
            }
            (Ok(_), _) => Finding::NotSignificant("time to the shipped model".into()),
        };
        time.push_str(&format!(
            "| {robot} | {} | {} | {} | {} | {} | {} | {} |\n",
            b_s.len(),
            mean_sd(&b_s, 3),
            mean_sd(&t_s, 3),
            with_interval(
                results,
                stats::mean(&b_s) - stats::mean(&t_s),
                &time_ci,
                |v| { signed(v, 3) }
            ),
            mean_sd(&b_it, 1),
            mean_sd(&t_it, 1),
            finding_cell(results, &finding),
        ));
        error.push_str(&format!(
            "| {robot} | {} | {} | {} |\n",
            mean_sd(&b_e, 5),
            mean_sd(&t_e, 5),
            with_interval(
                results,
                stats::mean(&t_e) - stats::mean(&b_e),
                &error_ci,
                |v| { signed(v, 5) }
            ),
        ));
        findings.push((robot.clone(), finding));
    }
    Claim {
        statement:
            "With input back constraints, transfer reaches the baseline's error faster (Fig. 5)",
        rule: "for every robot, baseline − transfer training seconds until the shipped model \
               (paired by source run) has its 95 % interval above 0, and the transfer's shipped \
               test MSE is not significantly above the baseline's."
            .into(),
        tables: format!("{time}\n{error}"),
        findings,
    }
}

/// Whether a ratio's interval lies within the similarity band, outside it, or across an edge.
pub(super) fn similar(ci: &Result<Interval, StatsError>, what: &str) -> Finding {
    match ci {
        Err(e) => Finding::Missing(e.to_string()),
        Ok(ci) if ci.within(1.0 / SIMILAR, SIMILAR) => Finding::Holds,
        Ok(ci) if ci.above(SIMILAR) => Finding::Against(format!("{what} significantly worse")),
        Ok(ci) if ci.below(1.0 / SIMILAR) => {
            Finding::Against(format!("{what} significantly better (not similar)"))
        }
        Ok(_) => Finding::NotSignificant("the interval crosses an edge of the band".into()),
    }
}

/// Whether a ratio's interval lies below `SIMILAR` (no worse than that factor: holds), above it
/// (against) or across it: the one-sided reading of "performs similarly to" for a model measured
/// against a yardstick, where doing better is no evidence against the claim.
pub(super) fn no_worse(ci: &Result<Interval, StatsError>, what: &str) -> Finding {
    match ci {
        Err(e) => Finding::Missing(e.to_string()),
        Ok(ci) if ci.below(SIMILAR) => Finding::Holds,
        Ok(ci) if ci.above(SIMILAR) => {
            Finding::Against(format!("{what} significantly worse than {SIMILAR}×"))
        }
        Ok(_) => Finding::NotSignificant(format!("the interval crosses {SIMILAR}")),
    }
}

/// Claim 3: multi-robot against baseline, input back constraints, paired by run.
pub(super) fn claim_3(results: &Results, boot: &Bootstrap) -> Claim {
    let bc = BackConstraint::Input;
    let mut tables = String::from(
        "Shipped test MSE with input back constraints (rad², mean ± sd over runs); ratio of \
         means paired by run seed, 95 % bootstrap interval.\n\n\
         | robot | runs | baseline | multi-robot | multi-robot ÷ baseline | finding |\n\
         |---|---|---|---|---|---|\n",
    );
    let mut findings = Vec::new();
    for robot in &results.robots {
        let (b, m) = paired(
            &by_pair(results, robot, ModelKind::Baseline, bc, |s| s.test_mse),
            &by_pair(results, robot, ModelKind::Multi, bc, |s| s.test_mse),
        );
        let ci = boot.ratio_of_means(&m, &b);
        let finding = similar(&ci, "multi-robot");
        tables.push_str(&format!(
            "| {robot} | {} | {} | {} | {} | {} |\n",
            b.len(),
            mean_sd(&b, 5),
            mean_sd(&m, 5),
            with_interval(results, stats::mean(&m) / stats::mean(&b), &ci, |v| num(
                v, 2
            )),
            finding_cell(results, &finding),
        ));
        findings.push((robot.clone(), finding));
    }
    Claim {
        statement: "The multi-robot model performs similarly to the baseline (input back constraints, Fig. 5)",
        rule: format!(
            "for every robot, the 95 % interval of multi-robot ÷ baseline mean shipped test MSE \
             (paired by run) lies within 1/{SIMILAR} … {SIMILAR}."
        ),
        tables,
        findings,
    }
}

/// Claim 4: the fully trained model with input back constraints against the direct regression.
pub(super) fn claim_4(results: &Results, boot: &Bootstrap) -> Claim {
    let mut tables = String::from(
        "Shipped test MSE (rad²): the direct GP regression (one deterministic fit) and the fully \
         trained shared GP-LVM with input back constraints (mean ± sd over runs); the ratio's \
         95 % bootstrap interval resamples the runs.\n\n\
         | robot | direct GP | shared GP-LVM, input BC | ÷ direct GP | finding |\n\
         |---|---|---|---|---|\n",
    );
    let mut findings = Vec::new();
    for robot in &results.robots {
        let gp = results.direct_mse(robot);
        let model = values(&by_pair(
            results,
            robot,
            ModelKind::Baseline,
            BackConstraint::Input,
            |s| s.test_mse,
        ));
        let (ratio, finding) = if gp.is_finite() {
            let ci = boot.ratio_of_means(&model, &vec![gp; model.len()]);
            let ratio = with_interval(results, stats::mean(&model) / gp, &ci, |v| num(v, 2));
            (ratio, no_worse(&ci, "the shared GP-LVM"))
        } else {
            let why = "no direct regression in the results";
            ("—".to_string(), Finding::Missing(why.into()))
        };
        tables.push_str(&format!(
            "| {robot} | {} | {} | {ratio} | {} |\n",
            num(gp, 5),
            mean_sd(&model, 5),
            finding_cell(results, &finding),
        ));
        findings.push((robot.clone(), finding));
    }
    Claim {
        statement: "With Q = 5 the shared GP-LVM performs similarly to a direct GP regression H → R (Section IV-B)",
        rule: format!(
            "for every robot, the 95 % interval of the input-BC model's mean shipped test MSE ÷ \
             the direct regression's lies below {SIMILAR} (no worse than {SIMILAR}×; doing better \
             than the yardstick is no evidence against it)."
        ),
        tables,
        findings,
    }
}

/// The transfers of `bc` to `target` from `source`, per source run (mean over its transfers).
pub(super) fn transfers_from(
    results: &Results,
    source: &str,
    target: &str,
    bc: BackConstraint,
) -> BTreeMap<usize, f64> {
    let mut groups: BTreeMap<usize, Vec<f64>> = BTreeMap::new();
    for run in results.select(target, ModelKind::Transfer, bc.name()) {
        if run.source_robot.as_deref() == Some(source) {
            groups
                .entry(pair_key(run, results.config.transfers_per_run))
                .or_default()
                .push(run.shipped().test_mse);
        }
    }
    groups
        .into_iter()
        .map(|(key, values)| (key, stats::mean(&values)))
        .collect()
}

/// Claim 5, the paper's conjecture (Section V): with input back constraints, transfer works
/// for a robot of a different kinematic structure. Judged for every (source, target) pair whose
/// joint counts differ; `None` when every robot has the same number of joints.
pub(super) fn claim_5(results: &Results, boot: &Bootstrap) -> Option<Claim> {
    if results.robot_joints.len() != results.robots.len()
        || results
            .robot_joints
            .iter()
            .all(|&j| j == results.robot_joints[0])
    {
        return None;
    }
    let joints = |robot: &str| {
        results
            .robots
            .iter()
            .position(|r| r == robot)
            .map(|i| results.robot_joints[i])
    };
    let mut tables = String::from(
        "Shipped test MSE (rad², mean ± sd over source runs) of transfers between robots with \
         different numbers of joints, against the target's baseline with input back constraints; \
         ratio of means paired by run, 95 % bootstrap interval. Transfers without back \
         constraints for comparison.\n\n\
         | source (joints) | target (joints) | transfer, input BC | baseline, input BC | transfer ÷ baseline | transfer, no BC | finding |\n\
         |---|---|---|---|---|---|---|\n",
    );
    let mut findings = Vec::new();
    for source in &results.robots {
        for target in &results.robots {
            if joints(source) == joints(target) {
                continue;
            }
            let input = transfers_from(results, source, target, BackConstraint::Input);
            let baseline = by_pair(
                results,
                target,
                ModelKind::Baseline,
                BackConstraint::Input,
                |s| s.test_mse,
            );
            let none = values(&transfers_from(
                results,
                source,
                target,
                BackConstraint::None,
            ));
            let (t, b) = paired(&input, &baseline);
            let ci = boot.ratio_of_means(&t, &b);
            let finding = no_worse(&ci, "the transfer");
            tables.push_str(&format!(
                "| {source} ({}) | {target} ({}) | {} | {} | {} | {} | {} |
",
                joints(source).unwrap_or(0),
                joints(target).unwrap_or(0),
                mean_sd(&t, 5),
                mean_sd(&b, 5),
                with_interval(results, stats::mean(&t) / stats::mean(&b), &ci, |v| num(
                    v, 2
                )),
                mean_sd(&none, 5),
                finding_cell(results, &finding),
            ));
            findings.push((format!("{source} → {target}"), finding));
        }
    }
    Some(Claim {
        statement: "With input back constraints, a model transfers to a robot of a different kinematic structure (the paper's conjecture, Section V)",
        rule: format!(
            "for every source and target with different numbers of joints, the 95 % interval of \
             the transfer's ÷ the target's fully trained model's mean shipped test MSE (input \
             back constraints, paired by run) lies below {SIMILAR} (no worse than {SIMILAR}×)."
        ),
        tables,
        findings,
    })
}

/// Per run, the mean test error of the less-data models of `robot`, `kind` and `fraction`.
pub(super) fn less_data_by_run(
    results: &Results,
    robot: &str,
    kind: ModelKind,
    fraction: f64,
) -> BTreeMap<usize, f64> {
    let mut groups: BTreeMap<usize, Vec<f64>> = BTreeMap::new();
    for r in &results.less_data {
        if r.robot == robot && r.model == kind && r.fraction == fraction {
            groups.entry(r.run).or_default().push(r.test_mse);
        }
    }
    groups
        .into_iter()
        .map(|(run, values)| (run, stats::mean(&values)))
        .collect()
}

/// Claim 6 (the paper's Section V): with less data, the transferred model is better than one
/// trained independently for the robot. Judged at the smallest fraction of the study below 1;
/// `None` when the study was not run.
pub(super) fn claim_6(results: &Results, boot: &Bootstrap) -> Option<Claim> {
    let mut fractions: Vec<f64> = results.less_data.iter().map(|r| r.fraction).collect();
    fractions.sort_by(f64::total_cmp);
    fractions.dedup();
    let judged_at = *fractions.iter().find(|&&f| f < 1.0)?;
    let mut tables = String::from(
        "Test MSE (rad², mean ± sd over runs) of each robot trained fully on a fraction of the \
         training frames and of the transfers to it (from every other robot's model trained on \
         all frames, averaged per run) whose mapping was learned from the same frames; \
         difference paired by run, 95 % bootstrap interval (Fig. 9).\n\n\
         | robot | fraction | frames | trained fully | transferred | transferred − trained fully | finding |\n\
         |---|---|---|---|---|---|---|\n",
    );
    let mut findings = Vec::new();
    for robot in &results.robots {
        for &fraction in &fractions {
            let frames = results
                .less_data
                .iter()
                .find(|r| r.robot == *robot && r.fraction == fraction)
                .map_or(0, |r| r.frames);
            let (t, b) = paired(
                &less_data_by_run(results, robot, ModelKind::Transfer, fraction),
                &less_data_by_run(results, robot, ModelKind::Baseline, fraction),
            );
            let ci = boot.mean_difference(&t, &b);
            let finding = match &ci {
                Err(e) => Finding::Missing(e.to_string()),
                Ok(ci) if ci.below(0.0) => Finding::Holds,
                Ok(ci) if ci.above(0.0) => {
                    Finding::Against("the transfer significantly worse".into())
                }
                Ok(_) => Finding::NotSignificant("transfer against trained fully".into()),
            };
            tables.push_str(&format!(
                "| {robot} | {fraction} | {frames} | {} | {} | {} | {} |\n",
                mean_sd(&b, 5),
                mean_sd(&t, 5),
                with_interval(results, stats::mean(&t) - stats::mean(&b), &ci, |v| signed(
                    v, 5
                )),
                finding_cell(results, &finding),
            ));
            if fraction == judged_at {
                findings.push((robot.clone(), finding));
            }
        }
    }
    Some(Claim {
        statement: "With less data, transferred models are better than models trained independently for each robot (Section V, Fig. 9)",
        rule: format!(
            "for every robot, at the smallest fraction of the training frames ({judged_at}), \
             transferred − trained fully (test MSE, paired by run) has its 95 % interval below 0."
        ),
        tables,
        findings,
    })
}

/// The finding as a table cell: "not judged" for results too small to judge.
pub(super) fn finding_cell(results: &Results, finding: &Finding) -> String {
    if judged(results) {
        finding.describe()
    } else {
        "not judged".into()
    }
}

/// The verdict of a claim and, when it is not supported, why.
pub(super) fn verdict(results: &Results, claim: &Claim) -> (String, String) {
    if !judged(results) {
        return ("not judged".into(), String::new());
    }
    if claim.findings.iter().all(|(_, f)| *f == Finding::Holds) {
        return ("supported".into(), String::new());
    }
    let mut reasons = Vec::new();
    for (label, wanted) in [
        ("against it", 0),
        ("not significant", 1),
        ("not computed", 2),
    ] {
        let robots: Vec<String> = claim
            .findings
            .iter()
            .filter_map(|(robot, f)| {
                let (kind, text) = match f {
                    Finding::Against(why) => (0, why),
                    Finding::NotSignificant(what) => (1, what),
                    Finding::Missing(why) => (2, why),
                    Finding::Holds => return None,
                };
                (kind == wanted).then(|| format!("{robot} ({text})"))
            })
            .collect();
        if !robots.is_empty() {
            reasons.push(format!("{label} for {}", robots.join(", ")));
        }
    }
    ("not supported".into(), reasons.join("; "))
}
