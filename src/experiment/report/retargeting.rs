//! The report's answer to "is the learned mapping worth it over retargeting each frame?": per
//! robot, how far the paper's models (input back constraints) put the arms from the person on the
//! test frames, beside the retargeted postures themselves (the experiment's `retargeting`
//! module).

use crate::arms::{ArmSummary, FAR_DEG};
use crate::results::{ModelKind, Results, RunRecord};

use super::format::mean_sd;

/// Above this share of frames with an upper arm more than [`FAR_DEG`] off, the demonstrated
/// postures are said to be no retargeting of the person.
const NOT_RETARGETED_SHARE: f64 = 0.25;

/// One row: `label`, frames, the mean ± s.d. over `summaries` of each figure.
fn row(label: &str, summaries: &[&ArmSummary]) -> String {
    let figure = |f: fn(&ArmSummary) -> Option<f64>, scale: f64, digits: usize| {
        let v: Vec<f64> = summaries
            .iter()
            .filter_map(|s| f(s))
            .map(|x| scale * x)
            .collect();
        if v.is_empty() {
            "–".to_string()
        } else {
            mean_sd(&v, digits)
        }
    };
    let frames = summaries.first().map_or(0, |s| s.frames);
    format!(
        "| {label} | {} | {frames} | {}° | {}° | {}° | {}° | {} % |\n",
        summaries.len(),
        figure(|s| s.upper_arm_median_deg, 1.0, 1),
        figure(|s| s.upper_arm_p90_deg, 1.0, 1),
        figure(|s| s.forearm_median_deg, 1.0, 1),
        figure(|s| s.forearm_p90_deg, 1.0, 1),
        figure(|s| s.upper_arm_far_share, 100.0, 1),
    )
}

/// The section, or `None` when the results carry no study (or no robot had a body to measure).
pub(super) fn retargeting_section(results: &Results) -> Option<String> {
    let study = results.retargeting.as_ref()?;
    if study.retargeted.is_empty() {
        return None;
    }
    let mut out =
        String::from("## The learned mapping against retargeting each frame directly\n\n");
    let who = if study.strangers() {
        format!(
            "The test frames are of people never in training (test: {}; training: {}): \
             strangers.",
            study.test_people.join(", "),
            study.training_people.join(", ")
        )
    } else if study.test_people.is_empty() {
        "The data names nobody: the test frames are held-out blocks of the training motion."
            .to_string()
    } else {
        format!(
            "The test frames are held-out blocks of people also in training ({}): not \
             strangers (`retarget --split people --test-people …` makes such a split).",
            study.test_people.join(", ")
        )
    };
    out.push_str(&format!(
        "{who} Each arm's upper arm and forearm against the person's, on bone lines (as \
         `retarget` reports), both arms pooled; mean ± s.d. over runs of each run's median, \
         90th percentile and share of frames with an upper arm more than {FAR_DEG:.0}° off. \
         *Retargeted* is the demonstrated posture (whole-arm retargeting of the same frame, what \
         `teleop --retarget` sends, where the data was made by `retarget`): what the learned \
         mapping adds beyond it is its own error. \
         No gate: every test frame.\n\n"
    ));
    out.push_str(
        "| robot, commands | runs | frames | upper arm median | upper arm 90th | forearm median | forearm 90th | upper arm > 30° |\n|---|---|---|---|---|---|---|---|\n",
    );
    let of = |robot: &str, kind: ModelKind| -> Vec<&ArmSummary> {
        results
            .select(robot, kind, "input")
            .into_iter()
            .filter_map(|r: &RunRecord| r.arms_from_person.as_ref())
            .collect()
    };
    for (robot, retargeted) in &study.retargeted {
        out.push_str(&row(&format!("{robot}, retargeted"), &[retargeted]));
        for (kind, label) in [
            (ModelKind::Baseline, "trained on it, input BC"),
            (ModelKind::Transfer, "transferred to it, input BC"),
            (ModelKind::Multi, "multi-robot, input BC"),
        ] {
            let learned = of(robot, kind);
            if !learned.is_empty() {
                out.push_str(&row(&format!("{robot}, {label}"), &learned));
            }
        }
    }
    // Data whose robot postures were not retargeted from this person (the generator's key
    // postures, solved by hand position alone): the yardstick is then no retargeting of them.
    // Whole-arm retargeting leaves no built-in robot's upper arm 30° off in more than a few
    // frames in a hundred (none on the shipped captures).
    let far: Vec<String> = study
        .retargeted
        .iter()
        .filter_map(|(robot, s)| {
            let share = s.upper_arm_far_share?;
            (share > NOT_RETARGETED_SHARE).then(|| format!("{robot} ({:.0} %)", 100.0 * share))
        })
        .collect();
    if !far.is_empty() {
        out.push_str(&format!(
            "\n**The demonstrated postures of {} are no whole-arm retargeting of the person** (the \
             share of frames with an upper arm more than {FAR_DEG:.0}° from theirs): this data's \
             robot postures were made another way (`sgplvm generate` solves each body's key \
             postures by hand position), and the comparison above says little. Retarget the \
             file's human (`sgplvm retarget --demos FILE`) for a yardstick.\n",
            far.join(", ")
        ));
    }
    if !study.left_out.is_empty() {
        out.push_str(&format!(
            "\nLeft out (no built-in body to measure on): {}.\n",
            study.left_out.join(", ")
        ));
    }
    Some(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::experiment::RetargetingStudy;
    use crate::results::ExperimentConfig;

    fn summary(upper: f64) -> ArmSummary {
        ArmSummary {
            frames: 10,
            upper_arm_median_deg: Some(upper),
            upper_arm_p90_deg: Some(2.0 * upper),
            forearm_median_deg: Some(upper),
            forearm_p90_deg: Some(2.0 * upper),
            upper_arm_far_share: Some(0.1),
        }
    }

    fn run(robot: &str, model: ModelKind, run: usize, upper: f64) -> RunRecord {
        RunRecord {
            robot: robot.into(),
            model,
            back_constraint: "input".into(),
            run,
            source_robot: None,
            source_run: None,
            iterations: vec![1],
            seconds: vec![0.1],
            test_mse: vec![0.1],
            shipped: None,
            stop_reason: None,
            bayesian: false,
            ard_weights: Vec::new(),
            arms_from_person: Some(summary(upper)),
        }
    }

    #[test]
    fn the_section_sets_the_models_beside_retargeting_and_says_who_the_test_frames_are_of() {
        let study = |test: &[&str], training: &[&str]| RetargetingStudy {
            test_people: test.iter().map(|s| s.to_string()).collect(),
            training_people: training.iter().map(|s| s.to_string()).collect(),
            retargeted: vec![("walkman".into(), summary(1.5))],
            left_out: vec!["toy".into()],
        };
        let mut results = Results {
            robots: vec!["walkman".into()],
            config: ExperimentConfig::paper(),
            runs: vec![
                run("walkman", ModelKind::Baseline, 0, 4.0),
                run("walkman", ModelKind::Baseline, 1, 6.0),
            ],
            direct_regression: Vec::new(),
            robot_joints: Vec::new(),
            less_data: Vec::new(),
            all_frames: Vec::new(),
            parts: Vec::new(),
            retargeting: Some(study(&["s1"], &["t1", "t2"])),
        };
        let section = retargeting_section(&results).expect("section");
        assert!(
            section.contains("never in training (test: s1; training: t1, t2)"),
            "{section}"
        );
        assert!(
            section.contains("| walkman, retargeted | 1 | 10 | 1.5° |"),
            "{section}"
        );
        assert!(
            section.contains("| walkman, trained on it, input BC | 2 | 10 | 5.0 ± 1.4° |"),
            "{section}"
        );
        assert!(!section.contains("transferred"), "{section}");
        assert!(
            section.contains("Left out (no built-in body to measure on): toy."),
            "{section}"
        );
        assert!(!section.contains("no whole-arm retargeting"), "{section}");
        results.retargeting = Some(study(&["t1"], &["t1", "t2"]));
        assert!(retargeting_section(&results)
            .unwrap()
            .contains("not strangers"));
        // Postures far from the person (generated data): said, not passed off as retargeting.
        let mut generated = study(&[], &[]);
        generated.retargeted = vec![(
            "walkman".into(),
            ArmSummary {
                upper_arm_far_share: Some(0.35),
                ..summary(18.0)
            },
        )];
        results.retargeting = Some(generated);
        let said = retargeting_section(&results).unwrap();
        assert!(
            said.contains("postures of walkman (35 %) are no whole-arm retargeting of the person"),
            "{said}"
        );
        results.retargeting = None;
        assert!(retargeting_section(&results).is_none());
    }
}
