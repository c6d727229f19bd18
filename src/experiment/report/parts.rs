//! The report's answer to "does a latent space per arm serve new pairings of arm motions?": the
//! single shared latent space against a latent space per arm on the recombined frames (see the
//! experiment's `parts` module), paired by run, with the GP regressions as yardsticks.

use std::collections::BTreeMap;

use crate::experiment::PartsRecord;
use crate::results::Results;
use crate::stats::{self, Bootstrap};

use super::all_frames::lower_is_better;
use super::claims::{finding_cell, Finding};
use super::format::{mean_sd, num, signed, with_interval};
use super::judged;
use super::pairs::{paired, values};

/// Which error of a record.
#[derive(Clone, Copy)]
enum Set {
    Test,
    RecombinedTest,
    RecombinedTrain,
}

impl Set {
    fn of(self, r: &PartsRecord) -> f64 {
        match self {
            Set::Test => r.test_mse,
            Set::RecombinedTest => r.recombined_test_mse,
            Set::RecombinedTrain => r.recombined_train_mse,
        }
    }
}

/// The study's records of `model` for `robot`, trained on it (`source` `None`) or transferred
/// from `source`, by run: `value` of each.
fn by_run(
    results: &Results,
    (robot, model, source): (&str, &str, Option<&str>),
    value: impl Fn(&PartsRecord) -> f64,
) -> BTreeMap<usize, f64> {
    results
        .parts
        .iter()
        .filter(|r| r.robot == robot && r.model == model && r.source_robot.as_deref() == source)
        .map(|r| (r.run, value(r)))
        .collect()
}

/// The rows of one robot's models (trained on it, or transferred from `source`).
fn rows(results: &Results, robot: &str, source: Option<&str>, models: &[&str]) -> String {
    let mut out = String::new();
    for &model in models {
        let test = by_run(results, (robot, model, source), |r| Set::Test.of(r));
        if test.is_empty() {
            continue;
        }
        let recombined = by_run(results, (robot, model, source), |r| {
            Set::RecombinedTest.of(r)
        });
        let train = by_run(results, (robot, model, source), |r| {
            Set::RecombinedTrain.of(r)
        });
        let seconds = by_run(results, (robot, model, source), |r| r.seconds);
        let ratio = stats::mean(&values(&recombined)) / stats::mean(&values(&test));
        let what = match source {
            Some(s) => format!("{model}, from {s}"),
            None => model.to_string(),
        };
        out.push_str(&format!(
            "| {robot} | {what} | {} | {} | {} | {} | {} | {} |\n",
            test.len(),
            mean_sd(&values(&test), 4),
            mean_sd(&values(&recombined), 4),
            num(ratio, 2),
            mean_sd(&values(&train), 4),
            num(stats::mean(&values(&seconds)), 2),
        ));
    }
    out
}

/// The per-arm model minus the single one on `set`, paired by run, for `robot` trained on it or
/// transferred from `source`: the mean difference, its interval and what it finds.
fn comparison(
    results: &Results,
    boot: &Bootstrap,
    (robot, source): (&str, Option<&str>),
    set: Set,
) -> (String, Finding, f64) {
    let parts = by_run(results, (robot, "parts", source), |r| set.of(r));
    let single = by_run(results, (robot, "single", source), |r| set.of(r));
    let (p, s) = paired(&parts, &single);
    let ci = boot.mean_difference(&p, &s);
    let difference = stats::mean(&p) - stats::mean(&s);
    let cell = with_interval(results, difference, &ci, |v| signed(v, 4));
    (cell, lower_is_better(&ci), difference)
}

/// The section: what was compared, the errors of every model, and the per-arm model against the
/// single one paired by run; `None` when the study was not run.
pub(super) fn parts_section(results: &Results, boot: &Bootstrap) -> Option<String> {
    results.parts.first()?;
    let mut out = String::from(
        "## A latent space per arm on recombined motions (issue 49)\n\n\
         A *recombined* frame is one frame's left arm with another frame's right arm, the human \
         and the robot columns alike (whole-arm retargeting solves each robot arm from its own \
         human arm): each arm's pose is one the data holds, the pair is not. *Recombined test*: \
         every test frame's left arm with the right arm of the test frame half the test set \
         further on (another block), each arm of each test frame used once — the arms are test \
         poses, only the pairing differs from the test frames, so a model predicting each arm \
         from that arm alone makes its test error exactly (÷ = 1). *Recombined training*: the \
         same from the training frames — both arms seen in training, the pair not. Per run (seed) and robot: the single shared latent space (human + robot) \
         and a latent space per arm (each arm's shared GP-LVM on its 9 human and its robot \
         joints, back-constrained on its own human arm; no parent, which no prediction uses), \
         the same configuration, seed and budget selection as the experiment's input-back-\
         constrained baselines, each transferred to every other robot (its kernels only). \
         Yardsticks: the direct GP regression on all 18 human joints, and one per arm. MSE in \
         rad², mean ± sd over runs; \"÷\" is recombined test over test; seconds are training \
         time (budget selection included).\n\n\
         | robot | model | runs | test MSE | recombined test MSE | ÷ | recombined training MSE | seconds |\n\
         |---|---|---|---|---|---|---|---|\n",
    );
    let models = ["single", "parts", "direct", "direct_per_arm"];
    for robot in &results.robots {
        out.push_str(&rows(results, robot, None, &models));
    }
    for robot in &results.robots {
        for source in results.robots.iter().filter(|s| *s != robot) {
            out.push_str(&rows(results, robot, Some(source), &models[..2]));
        }
    }
    out.push_str(
        "\nThe per-arm model minus the single one, paired by run (transfers: by the run of \
         their source models), with the 95 % bootstrap interval; the finding is on the \
         recombined test frames (lower is better).\n\n\
         | robot | trained on | recombined test | test | recombined training | finding |\n\
         |---|---|---|---|---|---|\n",
    );
    let (mut beats, mut answers) = (Vec::new(), Vec::new());
    for robot in &results.robots {
        let sources = std::iter::once(None).chain(
            results
                .robots
                .iter()
                .filter(|s| *s != robot)
                .map(|s| Some(s.as_str())),
        );
        for source in sources {
            let key = (robot.as_str(), source);
            if by_run(results, (robot, "parts", source), |r| r.run as f64).is_empty() {
                continue;
            }
            let (recombined, finding, difference) =
                comparison(results, boot, key, Set::RecombinedTest);
            let (test, _, _) = comparison(results, boot, key, Set::Test);
            let (train, _, _) = comparison(results, boot, key, Set::RecombinedTrain);
            out.push_str(&format!(
                "| {robot} | {} | {recombined} | {test} | {train} | {} |\n",
                source.unwrap_or(robot),
                finding_cell(results, &finding),
            ));
            let label = match source {
                Some(s) => format!("{robot} (transferred from {s})"),
                None => robot.clone(),
            };
            if judged(results) && finding == Finding::Holds {
                beats.push(label.clone());
            }
            answers.push(answer(results, &label, &finding, difference));
        }
    }
    let total = answers.len();
    let verdict = if !judged(results) {
        "not judged (too few runs)".to_string()
    } else if beats.len() == total {
        "**yes**, for every robot, trained and transferred".to_string()
    } else if beats.is_empty() {
        "**no**, for no robot".to_string()
    } else {
        format!("**only for {}** of {total} cases", beats.join(", "))
    };
    out.push_str(&format!(
        "\n**Does a latent space per arm beat the single latent space on recombined motions?** \
         {verdict} — {}.\n",
        answers.join("; ")
    ));
    Some(out)
}

/// One case's answer in words.
fn answer(results: &Results, label: &str, finding: &Finding, difference: f64) -> String {
    if !judged(results) {
        let direction = if difference < 0.0 {
            "lower"
        } else {
            "not lower"
        };
        return format!(
            "{label}: not judged, mean {direction} by {}",
            signed(difference, 4)
        );
    }
    match finding {
        Finding::Holds => format!("{label}: lower by {}", num(-difference, 4)),
        Finding::Against(_) => format!("{label}: higher by {}", num(difference, 4)),
        Finding::NotSignificant(_) => format!("{label}: no significant difference"),
        Finding::Missing(why) => format!("{label}: not computed ({why})"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::results::{ExperimentConfig, ModelKind};

    fn record(robot: &str, model: &str, run: usize, recombined: f64) -> PartsRecord {
        PartsRecord {
            robot: robot.into(),
            model: model.into(),
            kind: ModelKind::Baseline,
            source_robot: None,
            run,
            test_mse: 0.05,
            recombined_test_mse: recombined,
            recombined_train_mse: recombined,
            seconds: 1.0,
        }
    }

    /// The verdict follows the paired difference: lower for the per-arm model on every robot is
    /// "yes", on one robot "only for" it.
    #[test]
    fn the_verdict_follows_the_paired_difference() {
        let results = |coman_parts: f64| Results {
            robots: vec!["walkman".into(), "coman".into()],
            config: ExperimentConfig::paper(),
            runs: Vec::new(),
            direct_regression: Vec::new(),
            robot_joints: Vec::new(),
            less_data: Vec::new(),
            all_frames: Vec::new(),
            parts: (0..6)
                .flat_map(|run| {
                    let jitter = 0.001 * run as f64;
                    [
                        record("walkman", "single", run, 0.2 + jitter),
                        record("walkman", "parts", run, 0.05 + jitter),
                        record("coman", "single", run, 0.1 + jitter),
                        record("coman", "parts", run, coman_parts + 2.0 * jitter),
                    ]
                })
                .collect(),
            retargeting: None,
        };
        let boot = Bootstrap::default();
        let yes = parts_section(&results(0.03), &boot).expect("section");
        assert!(yes.contains("**yes**, for every robot"), "{yes}");
        assert!(yes.contains("| walkman | single | 6 |"), "{yes}");
        let only = parts_section(&results(0.3), &boot).expect("section");
        assert!(only.contains("**only for walkman** of 2 cases"), "{only}");
        assert!(only.contains("coman: higher by"), "{only}");
        let none = Results {
            parts: Vec::new(),
            ..results(0.03)
        };
        assert!(parts_section(&none, &boot).is_none());
    }
}
