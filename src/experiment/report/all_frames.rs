//! The report's answer to "does using all the data help?": the sparse model on every training
//! frame against the exact model on the subsample, per robot and paired by run, with the sparse
//! model on the subsample as the control.

use std::collections::BTreeMap;

use sgplvm_core::BackConstraint;

use crate::results::{AllFramesRecord, ModelKind, Results};
use crate::stats::{self, Bootstrap, Interval, StatsError};

use super::claims::{finding_cell, Finding};
use super::format::{mean_sd, num, signed, with_interval};
use super::judged;
use super::pairs::{by_pair, paired, values};

/// Per run, the all-frames study's records of `robot` and back constraint `bc` on every frame
/// (`full_rate`) or on the subsample, by `value`.
pub(super) fn all_frames_by_run(
    results: &Results,
    robot: &str,
    (bc, full_rate): (&str, bool),
    value: impl Fn(&AllFramesRecord) -> f64,
) -> BTreeMap<usize, f64> {
    results
        .all_frames
        .iter()
        .filter(|r| r.robot == robot && r.back_constraint == bc && r.full_rate == full_rate)
        .map(|r| (r.run, value(r)))
        .collect()
}

/// A paired difference a − b as a finding: lower is what "helps" means.
pub(super) fn lower_is_better(ci: &Result<Interval, StatsError>) -> Finding {
    match ci {
        Err(e) => Finding::Missing(e.to_string()),
        Ok(ci) if ci.below(0.0) => Finding::Holds,
        Ok(ci) if ci.above(0.0) => Finding::Against("significantly higher test error".into()),
        Ok(_) => Finding::NotSignificant("no significant difference".into()),
    }
}

/// One robot's answer: what the finding says, or, too small to judge, which way the means go.
pub(super) fn answer(results: &Results, robot: &str, finding: &Finding, difference: f64) -> String {
    if !judged(results) {
        let direction = if difference < 0.0 {
            "lower"
        } else {
            "not lower"
        };
        return format!("{robot}: not judged (too few runs), mean {direction}");
    }
    match finding {
        Finding::Holds => format!("{robot}: helps (significantly lower test error)"),
        Finding::Against(_) => format!("{robot}: hurts (significantly higher test error)"),
        Finding::NotSignificant(_) => format!("{robot}: no significant difference"),
        Finding::Missing(why) => format!("{robot}: not computed ({why})"),
    }
}

/// "Does using all the data help?": the sparse model on every training frame against the exact
/// model on the subsample, per robot, paired by run, and the sparse model on the subsample as
/// the control; `None` when the study was not run.
pub(super) fn all_frames_section(results: &Results, boot: &Bootstrap) -> Option<String> {
    let first = results.all_frames.first()?;
    let all_count = results
        .all_frames
        .iter()
        .find(|r| r.full_rate)
        .map_or(0, |r| r.frames);
    let mut out = format!(
        "## Does using all the data help? (the sparse model on every training frame)\n\n\
         Per run and robot, the sparse model (M = {} inducing inputs, input back constraints) \
         trained on every training frame at the recording's full rate ({all_count} frames) \
         beside the exact model of the same run trained on the subsampled training frames \
         ({} frames, the baseline above), and, as the control that separates the data from \
         the approximation, the sparse model on those subsampled frames: same seed, Q and \
         iteration budget, each budget chosen the same way (on the held-out training frames \
         unless `--validation none`), the same test frames. The sparse rows cover input back \
         constraints only: the sparse model refuses output back constraints; without back \
         constraints its human → latent map is a GP regression refitted at every step of a \
         budget selection (seconds per iteration); transfer and multi-robot models are not \
         trained on all frames. Test MSE in rad², mean ± sd over runs; differences paired by \
         run with their 95 % bootstrap interval; seconds are training time (budget selection \
         included), exact / sparse on the subsample / sparse on all frames. The finding is on \
         all frames − exact.\n\n\
         | robot | runs | exact, subsample | sparse, subsample | sparse, all frames | all frames − exact | all frames − subsample (both sparse) | seconds | finding |\n\
         |---|---|---|---|---|---|---|---|---|\n",
        first.inducing, first.subsampled_frames,
    );
    let bc = first.back_constraint.as_str();
    let bc_kind = bc.parse::<BackConstraint>().ok()?;
    let (mut answers, mut controls, mut helps) = (Vec::new(), Vec::new(), Vec::new());
    for robot in &results.robots {
        let all = all_frames_by_run(results, robot, (bc, true), |r| r.test_mse);
        let sub = all_frames_by_run(results, robot, (bc, false), |r| r.test_mse);
        let exact = by_pair(results, robot, ModelKind::Baseline, bc_kind, |s| s.test_mse);
        let (a, e) = paired(&all, &exact);
        let (a_c, s_c) = paired(&all, &sub);
        let ci = boot.mean_difference(&a, &e);
        let ci_control = boot.mean_difference(&a_c, &s_c);
        let difference = stats::mean(&a) - stats::mean(&e);
        let control = stats::mean(&a_c) - stats::mean(&s_c);
        let finding = lower_is_better(&ci);
        let seconds = |v: &BTreeMap<usize, f64>| num(stats::mean(&values(v)), 2);
        out.push_str(&format!(
            "| {robot} | {} | {} | {} | {} | {} | {} | {} / {} / {} | {} |\n",
            a.len(),
            mean_sd(&values(&exact), 5),
            mean_sd(&values(&sub), 5),
            mean_sd(&values(&all), 5),
            with_interval(results, difference, &ci, |v| signed(v, 5)),
            with_interval(results, control, &ci_control, |v| signed(v, 5)),
            seconds(&by_pair(
                results,
                robot,
                ModelKind::Baseline,
                bc_kind,
                |s| s.seconds
            )),
            seconds(&all_frames_by_run(results, robot, (bc, false), |r| r.seconds)),
            seconds(&all_frames_by_run(results, robot, (bc, true), |r| r.seconds)),
            finding_cell(results, &finding),
        ));
        if judged(results) && finding == Finding::Holds {
            helps.push(robot.clone());
        }
        answers.push(answer(results, robot, &finding, difference));
        controls.push(answer(
            results,
            robot,
            &lower_is_better(&ci_control),
            control,
        ));
    }
    let verdict = if !judged(results) {
        "not judged".to_string()
    } else if helps.len() == results.robots.len() {
        "**yes** for every robot".to_string()
    } else if helps.is_empty() {
        "**no** for any robot".to_string()
    } else {
        format!("**only for {}**", helps.join(", "))
    };
    out.push_str(&format!(
        "\n**Does using all the data help?** Against the exact model on the subsample: {verdict} \
         — {}. With the approximation held fixed (the sparse model on all frames against the \
         sparse model on the subsample): {}.\n",
        answers.join("; "),
        controls.join("; "),
    ));
    Some(out)
}
