//! The Bayesian study (issue 34): does a model that needs no early stopping do as well?
//!
//! The paper's model maximises the marginal likelihood over point latent positions, which
//! overfits on our data: the experiment chooses every budget on held-out training frames, and
//! the shipped models are close to their initialisation. With
//! [`ExperimentConfig::bayesian`](crate::results::ExperimentConfig::bayesian) set, the
//! experiment also trains, for each run, the Bayesian shared GP-LVM (q(X) with a KL term to its
//! prior, an RBF-ARD kernel and M inducing inputs per space): the same baselines, transfers and
//! multi-robot models as the paper's, with the same seeds, back constraints (none and input:
//! [`BACK_CONSTRAINTS`]) and test frames, each trained until it converges or reaches the
//! study's budget — never with a budget chosen on held-out frames. Its runs are recorded beside
//! the paper's ([`RunRecord::bayesian`](crate::results::RunRecord::bayesian)), with the ARD
//! weights of every space of the shipped model; Figs. 4–6 draw their curves and Fig. 12 the
//! weights.
//!
//! Not covered: output back constraints (the sparse model, and so the Bayesian one, refuses
//! them).

use sgplvm_core::{BackConstraint, ModelConfig, SharedGplvm};

use super::{ExperimentConfig, ModelKind, RunRecord, Stage};

/// The back constraints of the study: the ones the Bayesian model supports.
pub(super) const BACK_CONSTRAINTS: [BackConstraint; 2] =
    [BackConstraint::None, BackConstraint::Input];

/// The name of the study's stage that trains what the paper's stage `name` trains.
pub(super) fn stage_name(name: &str) -> String {
    format!("Bayesian {name}")
}

/// The study's stages for `robots` robots, in plan order (none when it is not run).
pub(super) fn stages(config: &ExperimentConfig, robots: usize) -> Vec<Stage> {
    let Some(study) = config.bayesian else {
        return Vec::new();
    };
    let work = |spaces: usize| (study.max_iters * spaces) as f64;
    let mut stages = Vec::new();
    for bc in BACK_CONSTRAINTS {
        stages.push(Stage {
            name: stage_name(&format!("baselines, {bc} BC")),
            model: Some(ModelKind::Baseline),
            trainings: config.runs * robots,
            work: work(2),
        });
        stages.push(Stage {
            name: stage_name(&format!("transfers, {bc} BC")),
            model: Some(ModelKind::Transfer),
            trainings: config.runs * robots * robots.saturating_sub(1) * config.transfers_per_run,
            work: work(1),
        });
        stages.push(Stage {
            name: stage_name(&format!("multi-robot, {bc} BC")),
            model: Some(ModelKind::Multi),
            trainings: config.runs,
            work: work(robots + 1),
        });
    }
    stages
}

/// `model` made the Bayesian model of the study (M inducing inputs).
pub(super) fn configure(config: &ExperimentConfig, model: ModelConfig) -> ModelConfig {
    let inducing = config.bayesian.map(|s| s.inducing);
    model.with_bayesian(true).with_inducing(inducing)
}

/// Marks `runs` as the study's and records the ARD weights of every space of `model`, the
/// model they shipped.
pub(super) fn mark(runs: &mut [RunRecord], model: &SharedGplvm) -> Result<(), sgplvm_core::Error> {
    let mut weights = Vec::new();
    let spaces = std::iter::once(model.input_name()).chain(model.output_names());
    for space in spaces {
        weights.push((space.to_string(), model.ard_weights(space)?));
    }
    for run in runs {
        run.bayesian = true;
        run.ard_weights = weights.clone();
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    //! The study on the experiment's toy problem: its stages in the plan, its records beside
    //! (and not changing) the paper's model's, Fig. 12 and the report's section.

    use super::super::tests::toy;
    use super::super::{plan, run, stages, training_count, write_outputs, BayesianStudy};
    use super::*;

    fn config(bayesian: Option<BayesianStudy>) -> ExperimentConfig {
        ExperimentConfig {
            runs: 1,
            transfers_per_run: 1,
            max_iters: 3,
            transfer_max_iters: 3,
            latent_dim: 2,
            seed: 0,
            direct_max_iters: 20,
            patience: None,
            fractions: Vec::new(),
            max_seconds: None,
            inducing: None,
            bayesian,
            parts: false,
        }
    }

    #[test]
    fn the_study_trains_every_kind_beside_the_papers_model_and_changes_none_of_its_runs() {
        let study = BayesianStudy {
            inducing: 6,
            max_iters: 12,
        };
        let with = config(Some(study));
        let stage_list = stages(&with, 2);
        let counts: Vec<usize> = stage_list.iter().map(|s| s.trainings).collect();
        // The paper's stages, then per back constraint (none, input) the Bayesian baselines
        // (2), transfers (2) and multi-robot model (1).
        assert_eq!(counts, [2, 2, 2, 1, 2, 2, 1, 2, 2, 2, 1, 2, 2, 1]);
        assert_eq!(stage_list[11].name, "Bayesian baselines, input BC");
        assert_eq!(training_count(&with, 2), 24);
        // Every Bayesian task is in its own stage and says so in its JSON; the paper's tasks'
        // JSON is as before (no `bayesian` key).
        for task in plan(&with, &toy()) {
            let json = serde_json::to_string(&task.spec).unwrap();
            let bayesian = stage_list[task.stage].name.starts_with("Bayesian");
            assert_eq!(json.contains("\"bayesian\":true"), bayesian, "{json}");
            assert!(!json.contains("\"bayesian\":false"), "{json}");
            assert_eq!(task.context.starts_with("Bayesian"), bayesian, "{task:?}");
        }
        let mut done = 0;
        let results = run(&toy(), &with, &mut |_| done += 1).unwrap();
        assert_eq!(done, 24);
        let without = run(&toy(), &config(None), &mut |_| {}).unwrap();
        let paper: Vec<&RunRecord> = results.runs.iter().filter(|r| !r.bayesian).collect();
        assert_eq!(paper.len(), without.runs.len());
        for (a, b) in paper.iter().zip(&without.runs) {
            assert_eq!(
                (&a.robot, a.model, &a.test_mse),
                (&b.robot, b.model, &b.test_mse)
            );
            assert!(a.ard_weights.is_empty());
        }
        let bayes: Vec<&RunRecord> = results.runs.iter().filter(|r| r.bayesian).collect();
        // Per back constraint: 2 baselines, 2 transfers, a multi-robot model recording 2 robots.
        assert_eq!(bayes.len(), 12);
        for r in &bayes {
            let spaces: Vec<&str> = r.ard_weights.iter().map(|(s, _)| s.as_str()).collect();
            // A transferred model holds its source's spaces and the new robot's.
            let expected: Vec<&str> = match r.model {
                ModelKind::Multi => vec!["human", "a", "b"],
                ModelKind::Transfer => vec!["human", r.source_robot.as_deref().unwrap(), &r.robot],
                ModelKind::Baseline => vec!["human", r.robot.as_str()],
            };
            assert_eq!(spaces, expected, "{r:?}");
            for (_, w) in &r.ard_weights {
                assert_eq!(w.len(), 2);
                assert!(w.iter().all(|v| v.is_finite() && *v >= 0.0), "{w:?}");
            }
            let shipped = r.shipped.expect("recorded");
            assert!(
                shipped.iteration <= 12 && shipped.test_mse.is_finite(),
                "{r:?}"
            );
            assert!(r.test_mse.iter().all(|v| v.is_finite()), "{r:?}");
        }
        // The study's records survive results.json; a results file without the study has no
        // trace of it.
        let json = serde_json::to_string(&results).unwrap();
        let back: crate::results::Results = serde_json::from_str(&json).unwrap();
        assert_eq!(back.runs.iter().filter(|r| r.bayesian).count(), 12);
        assert_eq!(back.config.bayesian, Some(study));
        let plain = serde_json::to_string(&without).unwrap();
        assert!(!plain.contains("bayesian") && !plain.contains("ard_weights"));
        // Fig. 12 and the report's section.
        let report = super::super::report(&results);
        assert!(
            report.contains("## The Bayesian shared GP-LVM (issue 34)"),
            "{report}"
        );
        assert!(report.contains("| a | baseline | input | 1 |"), "{report}");
        assert!(report.contains("| none | 1 | "), "{report}");
        assert!(!super::super::report(&without).contains("Bayesian"));
        let dir = std::env::temp_dir().join(format!("sgplvm-bayes-study-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let written = write_outputs(&results, &dir).unwrap();
        assert!(
            written.iter().any(|p| p.ends_with("fig12.svg")),
            "{written:?}"
        );
        let plain_dir = dir.join("plain");
        std::fs::create_dir_all(&plain_dir).unwrap();
        let plain_written = write_outputs(&without, &plain_dir).unwrap();
        std::fs::remove_dir_all(&dir).unwrap();
        assert!(!plain_written.iter().any(|p| p.ends_with("fig12.svg")));
    }
}
