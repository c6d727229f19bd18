//! The paper's figures. From an experiment's runs: test error against iterations and training
//! time for the baseline, transfer and multi-robot models (Figs. 4 and 5) and for the three
//! back constraints (Fig. 6), with less data (Fig. 9), from each robot to each other (Fig. 10)
//! and on every frame against a subsample (Fig. 11), each panel with the direct GP regression's
//! error as a yardstick (the Bayesian study's curves beside the paper's model's where it was
//! run), and the Bayesian model's ARD weights per space (Fig. 12). From a trained model, the demo's pictures: the shared latent space
//! with key poses and test trajectories (Fig. 7) and predicted against desired joint
//! trajectories (Fig. 8).
//!
//! This file draws the experiment's figures; the demo's are in `demo`.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use sgplvm_core::BackConstraint;

use crate::pipeline::PipelineError;
use crate::plots::{write_figure, Markers, Panel, PlotError, Series};
use crate::results::{ModelKind, Results, RunRecord};

mod bayesian;
mod demo;

pub use bayesian::ard_weights;
pub use demo::{
    dominant_dims, latent_space, test_motions, trajectories, TestMotion, LATENT_SPACE_SIZE,
};

/// Errors while drawing the demo's figures.
#[derive(Debug, thiserror::Error)]
pub enum FigureError {
    /// The model or data failed.
    #[error(transparent)]
    Pipeline(#[from] PipelineError),
    /// The model failed.
    #[error(transparent)]
    Model(#[from] sgplvm_core::Error),
    /// Drawing failed.
    #[error(transparent)]
    Plot(#[from] PlotError),
}

/// One curve of a learning-curve panel: the runs of a kind of model with a back constraint,
/// their legend label and palette colour.
struct Curve {
    kind: ModelKind,
    back_constraint: BackConstraint,
    label: &'static str,
    color: usize,
    /// The Bayesian study's runs rather than the paper's model's.
    bayesian: bool,
}

/// Figs. 4 and 5: per robot, the mean test error (± one standard deviation) of the baseline,
/// transfer and multi-robot models without back constraints (Fig. 4) and with back constraints
/// on the input (Fig. 5), against iterations (`fig4`, `fig5`) and training seconds
/// (`fig4_seconds`, `fig5_seconds`). Returns the files written, SVG then PNG of each.
pub fn learning_curves(results: &Results, dir: &Path) -> Result<Vec<PathBuf>, PlotError> {
    let mut written = Vec::new();
    for (figure, back_constraint, title) in [
        ("fig4", BackConstraint::None, "Fig. 4: no back constraints"),
        (
            "fig5",
            BackConstraint::Input,
            "Fig. 5: back constraints on the input",
        ),
    ] {
        let curve = |kind, label, color| Curve {
            kind,
            back_constraint,
            label,
            color,
            bayesian: color >= 3,
        };
        // The Bayesian study's curves (colours 3-5) appear only when it was run.
        let curves = [
            curve(ModelKind::Baseline, "baseline (fully trained)", 0),
            curve(
                ModelKind::Transfer,
                "transfer (only robot kernel trained)",
                1,
            ),
            curve(ModelKind::Multi, "multi-robot", 2),
            curve(ModelKind::Baseline, "Bayesian baseline", 3),
            curve(ModelKind::Transfer, "Bayesian transfer", 4),
            curve(ModelKind::Multi, "Bayesian multi-robot", 5),
        ];
        for by_seconds in [false, true] {
            let panels = robot_panels(results, &curves, by_seconds);
            let stem = dir.join(if by_seconds {
                format!("{figure}_seconds")
            } else {
                figure.to_string()
            });
            written.extend(write_figure(&stem, title, &panels, panels.len())?);
        }
    }
    Ok(written)
}

/// Fig. 6: per robot, the mean test error of fully trained models with no, input and output
/// back constraints against iterations, and the direct GP regression's (dashed). Returns the SVG
/// and PNG written.
pub fn back_constraints(results: &Results, dir: &Path) -> Result<[PathBuf; 2], PlotError> {
    let curve = |back_constraint, label, color| Curve {
        kind: ModelKind::Baseline,
        back_constraint,
        label,
        color,
        bayesian: color >= 3,
    };
    let curves = [
        curve(BackConstraint::None, "no back constraints", 1),
        curve(BackConstraint::Input, "back constraints on the input", 0),
        curve(BackConstraint::Output, "back constraints on the output", 2),
        curve(BackConstraint::None, "Bayesian, no back constraints", 4),
        curve(BackConstraint::Input, "Bayesian, input back constraints", 3),
    ];
    let panels = robot_panels(results, &curves, false);
    write_figure(
        &dir.join("fig6"),
        "Fig. 6: fully trained models",
        &panels,
        panels.len(),
    )
}

/// Fig. 10: per target robot, the mean shipped test error of the transfers to it from each
/// other robot (circles: input back constraints, crosses: none; labelled with the source and
/// its number of joints), against the target's own fully trained model (input back
/// constraints, solid) and the direct GP regression (dashed). With a robot of a different
/// kinematic structure in the data, this is the paper's conjecture (Section V) at a glance.
pub fn transfers_by_source(results: &Results, dir: &Path) -> Result<[PathBuf; 2], PlotError> {
    let joints = |robot: &str| {
        results
            .robots
            .iter()
            .position(|r| r == robot)
            .and_then(|i| results.robot_joints.get(i))
            .map_or(String::new(), |j| format!(" ({j} joints)"))
    };
    let mean_shipped = |runs: Vec<&RunRecord>| {
        let values: Vec<f64> = runs.iter().map(|r| r.shipped().test_mse).collect();
        (!values.is_empty()).then(|| values.iter().sum::<f64>() / values.len() as f64)
    };
    let panels = results
        .robots
        .iter()
        .map(|target| {
            let sources: Vec<&String> = results.robots.iter().filter(|r| *r != target).collect();
            let markers = [
                (
                    BackConstraint::Input,
                    "transfer, input back constraints",
                    0,
                    true,
                ),
                (
                    BackConstraint::None,
                    "transfer, no back constraints",
                    1,
                    false,
                ),
            ]
            .into_iter()
            .map(|(bc, label, color, circles)| {
                let (points, annotations) = sources
                    .iter()
                    .enumerate()
                    .filter_map(|(k, source)| {
                        let runs = results
                            .select(target, ModelKind::Transfer, bc.name())
                            .into_iter()
                            .filter(|r| r.source_robot.as_deref() == Some(source.as_str()))
                            .collect();
                        mean_shipped(runs)
                            .map(|m| ((k as f64 + 1.0, m), format!("{source}{}", joints(source))))
                    })
                    .unzip();
                Markers {
                    label: label.into(),
                    color,
                    circles,
                    points,
                    annotations: if circles { annotations } else { Vec::new() },
                }
            })
            .collect();
            let span = (0.5, sources.len() as f64 + 0.5);
            let mut series = Vec::new();
            let baseline =
                results.select(target, ModelKind::Baseline, BackConstraint::Input.name());
            if let Some(m) = mean_shipped(baseline) {
                series.push(Series {
                    label: "fully trained on the target, input back constraints".into(),
                    color: 2,
                    points: vec![(span.0, m), (span.1, m)],
                    ..Series::default()
                });
            }
            let anchor = Series {
                points: vec![(span.0, 0.0), (span.1, 0.0)],
                ..Series::default()
            };
            series.extend(direct_line(&[anchor], results.direct_mse(target)));
            Panel {
                title: format!("to {target}{}", joints(target)),
                x_label: "source robot".into(),
                x_categories: sources.iter().map(|s| s.to_string()).collect(),
                y_label: "test MSE (rad²)".into(),
                log_y: true,
                series,
                markers,
                ..Panel::default()
            }
        })
        .collect::<Vec<_>>();
    write_figure(
        &dir.join("fig10"),
        "Fig. 10: transfer to each robot from each other robot",
        &panels,
        panels.len(),
    )
}

/// Fig. 9: per robot, the test error (mean ± one standard deviation over runs and sources)
/// against the fraction of training frames of the robot trained fully on those frames and of
/// the transfers to it that learned its mapping from them, with the direct GP regression on all
/// frames (dashed).
pub fn less_data(results: &Results, dir: &Path) -> Result<[PathBuf; 2], PlotError> {
    let panels = results
        .robots
        .iter()
        .map(|robot| {
            let mut series: Vec<Series> = [
                (ModelKind::Baseline, "trained fully on those frames", 0),
                (
                    ModelKind::Transfer,
                    "transferred, mapping learned on them",
                    1,
                ),
            ]
            .into_iter()
            .filter_map(|(kind, label, color)| {
                let mut by_fraction: BTreeMap<u64, Vec<f64>> = BTreeMap::new();
                for r in &results.less_data {
                    if r.robot == *robot && r.model == kind {
                        by_fraction
                            .entry(r.fraction.to_bits())
                            .or_default()
                            .push(r.test_mse);
                    }
                }
                let mut points = Vec::new();
                let mut band = Vec::new();
                let mut fractions: Vec<(f64, Vec<f64>)> = by_fraction
                    .into_iter()
                    .map(|(bits, v)| (f64::from_bits(bits), v))
                    .collect();
                fractions.sort_by(|a, b| a.0.total_cmp(&b.0));
                for (fraction, values) in fractions {
                    let (mean, sd) = mean_sd(&values);
                    points.push((fraction, mean));
                    band.push(positive_band(mean, sd));
                }
                (!points.is_empty()).then(|| Series {
                    label: label.into(),
                    color,
                    points,
                    band: Some(band),
                    ..Series::default()
                })
            })
            .collect();
            series.extend(direct_line(&series, results.direct_mse(robot)));
            Panel {
                title: robot.clone(),
                x_label: "fraction of the training frames".into(),
                y_label: "test MSE (rad²)".into(),
                log_y: true,
                series,
                markers: vec![],
                ..Panel::default()
            }
        })
        .collect::<Vec<_>>();
    write_figure(
        &dir.join("fig9"),
        "Fig. 9: less data (input back constraints)",
        &panels,
        panels.len(),
    )
}

/// Fig. 11 (issue 14, "does using all the data help?"): per robot, the test error (mean ± one
/// standard deviation over runs) against the number of training frames: the sparse model on the
/// subsample and on every frame (circles joined by a line, and a band), the exact model on the subsample (circle) and
/// the direct GP regression (dashed). Input back constraints.
pub fn all_frames(results: &Results, dir: &Path) -> Result<[PathBuf; 2], PlotError> {
    let panels = results
        .robots
        .iter()
        .map(|robot| {
            let mut by_frames: BTreeMap<usize, Vec<f64>> = BTreeMap::new();
            for r in results.all_frames.iter().filter(|r| r.robot == *robot) {
                by_frames.entry(r.frames).or_default().push(r.test_mse);
            }
            let (points, band): (Vec<_>, Vec<_>) = by_frames
                .iter()
                .map(|(&frames, values)| {
                    let (mean, sd) = mean_sd(values);
                    ((frames as f64, mean), positive_band(mean, sd))
                })
                .unzip();
            let inducing = results.all_frames.first().map_or(0, |r| r.inducing);
            let mut series = vec![Series {
                label: format!("sparse model, M = {inducing}"),
                color: 1,
                points,
                band: Some(band),
                ..Series::default()
            }];
            series.extend(direct_line(&series, results.direct_mse(robot)));
            let exact: Vec<f64> = results
                .select(robot, ModelKind::Baseline, BackConstraint::Input.name())
                .iter()
                .map(|r| r.shipped().test_mse)
                .collect();
            let subsampled = results
                .all_frames
                .iter()
                .find(|r| r.robot == *robot)
                .map_or(0, |r| r.subsampled_frames);
            // The sparse model is measured at two sizes only: mark them, so the line between
            // them does not read as measured in between.
            let mut markers = vec![Markers {
                label: String::new(),
                color: 1,
                circles: true,
                points: series[0].points.clone(),
                annotations: vec![],
            }];
            if !exact.is_empty() {
                markers.push(Markers {
                    label: "exact model".into(),
                    color: 0,
                    circles: true,
                    points: vec![(subsampled as f64, mean_sd(&exact).0)],
                    annotations: vec![],
                });
            }
            Panel {
                title: robot.clone(),
                x_label: "training frames".into(),
                y_label: "test MSE (rad²)".into(),
                series,
                markers,
                ..Panel::default()
            }
        })
        .collect::<Vec<_>>();
    write_figure(
        &dir.join("fig11"),
        "Fig. 11: every frame or a subsample (input back constraints)",
        &panels,
        panels.len(),
    )
}

/// One panel per robot with a mean curve for each of `curves` that has runs, and the direct GP
/// regression's test error as a dashed horizontal line across them.
fn robot_panels(results: &Results, curves: &[Curve], by_seconds: bool) -> Vec<Panel> {
    let x_label = if by_seconds {
        "training seconds"
    } else {
        "iteration"
    };
    results
        .robots
        .iter()
        .map(|robot| {
            let mut series: Vec<Series> = curves
                .iter()
                .filter_map(|c| {
                    let bc = c.back_constraint.name();
                    let runs = results.select_of(c.bayesian, robot, c.kind, bc);
                    (!runs.is_empty()).then(|| Series {
                        label: c.label.into(),
                        color: c.color,
                        ..mean_curve(&runs, by_seconds)
                    })
                })
                .collect();
            series.extend(direct_line(&series, results.direct_mse(robot)));
            Panel {
                title: robot.clone(),
                x_label: x_label.into(),
                y_label: "test MSE (rad²)".into(),
                log_y: true,
                series,
                markers: vec![],
                integer_x: !by_seconds,
                ..Panel::default()
            }
        })
        .collect()
}

/// The direct GP regression's test error `mse` as a dashed line over the horizontal extent of
/// `series` (none if `mse` is not finite).
fn direct_line(series: &[Series], mse: f64) -> Option<Series> {
    if !mse.is_finite() {
        return None;
    }
    let xs = series.iter().flat_map(|s| s.points.iter().map(|p| p.0));
    let (lo, hi) = xs.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), x| {
        (lo.min(x), hi.max(x))
    });
    let (lo, hi) = if lo.is_finite() { (lo, hi) } else { (0.0, 1.0) };
    Some(Series {
        label: "direct GP regression H → R".into(),
        color: 7,
        dashed: true,
        points: vec![(lo, mse), (hi, mse)],
        band: None,
    })
}

/// Mean and standard deviation, per iteration index, of the test error of a group of runs
/// (runs that stopped early keep their last value).
fn mean_curve(runs: &[&RunRecord], by_seconds: bool) -> Series {
    let length = runs.iter().map(|r| r.test_mse.len()).max().unwrap_or(0);
    let mut points = Vec::with_capacity(length);
    let mut band = Vec::with_capacity(length);
    for i in 0..length {
        let at = |r: &&RunRecord| r.test_mse.get(i).or(r.test_mse.last()).copied();
        let values: Vec<f64> = runs.iter().filter_map(at).collect();
        let x = if by_seconds {
            let secs: Vec<f64> = runs
                .iter()
                .filter_map(|r| r.seconds.get(i).or(r.seconds.last()).copied())
                .collect();
            secs.iter().sum::<f64>() / secs.len().max(1) as f64
        } else {
            runs.iter()
                .find_map(|r| r.iterations.get(i))
                .copied()
                .unwrap_or(i) as f64
        };
        let (mean, sd) = mean_sd(&values);
        points.push((x, mean));
        band.push(positive_band(mean, sd));
    }
    Series {
        points,
        band: Some(band),
        ..Series::default()
    }
}

/// Mean and population standard deviation (1/n) of `values`.
fn mean_sd(values: &[f64]) -> (f64, f64) {
    let n = values.len().max(1) as f64;
    let mean = values.iter().sum::<f64>() / n;
    let sd = (values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / n).sqrt();
    (mean, sd)
}

/// The band `mean ± sd`, its lower edge kept above zero for a logarithmic axis.
fn positive_band(mean: f64, sd: f64) -> (f64, f64) {
    ((mean - sd).max(mean * 0.05), mean + sd)
}

#[cfg(test)]
mod tests {
    //! The mean learning curve drawn in Figs. 4-6, on synthetic runs; the test motions that
    //! Figs. 7 and 8 draw, on the shipped data.

    use super::demo::{legend_names, wrap};
    use super::*;

    #[test]
    fn the_test_motions_are_every_test_frame_once_named_by_their_poses() {
        let demos = crate::pipeline::load(None).expect("the shipped demonstrations");
        let ds = &demos.dataset;
        let motions = test_motions(ds);
        let names: Vec<&str> = motions.iter().map(|m| m.name.as_str()).collect();
        // The shipped test set: three round trips between each of two pairs of key poses.
        assert_eq!(
            names,
            ["forward_high ↔ hands_together", "v_up ↔ left_across"]
        );
        let all: Vec<usize> = motions.iter().flat_map(|m| m.frames.clone()).collect();
        assert_eq!(all, ds.test);
        // 6 × 70 and 6 × 88 frames at 40 Hz, of which every third is a test frame: the span
        // from the first test frame to the last.
        let seconds: Vec<f64> = motions.iter().map(|m| m.seconds).collect();
        assert!(
            (seconds[0] - 10.4).abs() < 0.1 && (seconds[1] - 13.1).abs() < 0.1,
            "{seconds:?}"
        );
        assert!(motions.iter().all(|m| !m.unlabelled));
    }

    #[test]
    fn fig_7_is_its_documented_size_and_says_what_its_marks_are() {
        let demos = crate::pipeline::load(None).expect("the shipped demonstrations");
        let options = sgplvm_core::TrainOptions {
            max_iters: 2,
            ..sgplvm_core::TrainOptions::default()
        };
        let config = sgplvm_core::ModelConfig::default();
        let model = demos
            .train(&["walkman".to_string()], &config, &options, None, None)
            .unwrap();
        let dir = std::env::temp_dir().join(format!("sgplvm-fig7-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let [svg, png] =
            latent_space(&model, &demos, "walkman", &dir.join("latent_space")).unwrap();
        let png = std::fs::read(png).unwrap();
        let size = |at: usize| u32::from_be_bytes(png[at..at + 4].try_into().unwrap());
        // The PNG header: width and height at bytes 16 and 20.
        assert_eq!((size(16), size(20)), LATENT_SPACE_SIZE);
        assert_eq!(LATENT_SPACE_SIZE, (1200, 900));
        let svg = std::fs::read_to_string(svg).unwrap();
        assert!(svg.contains("width=\"1200\"") && svg.contains("height=\"900\""));
        // The subtitle explains the hooks that look like arrowheads.
        assert!(svg.contains("arrowheads"), "{svg:.600}");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn subtitles_wrap_between_words() {
        let lines = wrap("aaa bbb; ccc ddd", 8);
        assert_eq!(lines, ["aaa bbb;", "ccc ddd"]);
        assert_eq!(wrap("one", 80), ["one"]);
    }

    fn run(iterations: &[usize], seconds: &[f64], mse: &[f64]) -> RunRecord {
        RunRecord {
            robot: "r".into(),
            model: ModelKind::Baseline,
            back_constraint: "input".into(),
            run: 0,
            source_robot: None,
            source_run: None,
            iterations: iterations.to_vec(),
            seconds: seconds.to_vec(),
            test_mse: mse.to_vec(),
            shipped: None,
            stop_reason: None,
            bayesian: false,
            ard_weights: Vec::new(),
            arms_from_person: None,
        }
    }

    #[test]
    fn mean_curve_averages_per_iteration_with_a_population_sd_band() {
        let a = run(&[0, 5], &[0.0, 1.0], &[1.0, 0.5]);
        let b = run(&[0, 5], &[0.0, 3.0], &[3.0, 1.5]);
        let s = mean_curve(&[&a, &b], false);
        // x = iteration numbers (not indices); y = mean over runs.
        assert_eq!(s.points, vec![(0.0, 2.0), (5.0, 1.0)]);
        // sd over runs with 1/n: 1 and 0.5.
        assert_eq!(s.band, Some(vec![(1.0, 3.0), (0.5, 1.5)]));
        // Against seconds: x is the mean time.
        let s = mean_curve(&[&a, &b], true);
        assert_eq!(s.points, vec![(0.0, 2.0), (2.0, 1.0)]);
    }

    #[test]
    fn runs_that_stopped_early_keep_their_last_value_and_time() {
        let short = run(&[0], &[0.0], &[1.0]);
        let long = run(&[0, 1, 2], &[0.0, 2.0, 4.0], &[3.0, 2.0, 1.0]);
        let s = mean_curve(&[&short, &long], false);
        assert_eq!(s.points, vec![(0.0, 2.0), (1.0, 1.5), (2.0, 1.0)]);
        let s = mean_curve(&[&short, &long], true);
        assert_eq!(s.points, vec![(0.0, 2.0), (1.0, 1.5), (2.0, 1.0)]);
    }

    #[test]
    fn the_band_stays_positive_on_a_log_axis() {
        // mean 1, sd 1: the lower edge would be 0; it is clipped to 5% of the mean.
        let s = mean_curve(
            &[&run(&[0], &[0.0], &[0.0]), &run(&[0], &[0.0], &[2.0])],
            false,
        );
        assert_eq!(s.band, Some(vec![(0.05, 2.0)]));
        // No runs: an empty curve, no NaN points.
        let s = mean_curve(&[], false);
        assert!(s.points.is_empty());
    }

    #[test]
    fn legend_names_drop_the_prefix_the_arm_shares() {
        let names = |v: &[&str]| v.iter().map(|s| s.to_string()).collect::<Vec<_>>();
        assert_eq!(
            legend_names(&names(&["LShSag", "LShLat", "LElbj"])),
            names(&["ShSag", "ShLat", "Elbj"])
        );
        assert_eq!(
            legend_names(&names(&[
                "jLeftC7Shoulder_elevation",
                "jLeftShoulder_flexion"
            ])),
            names(&["C7Shoulder_elevation", "Shoulder_flexion"])
        );
        assert_eq!(legend_names(&names(&["only"])), names(&["only"]));
        assert!(legend_names(&[]).is_empty());
    }

    #[test]
    fn the_direct_regression_spans_the_curves_of_its_panel() {
        let a = Series {
            points: vec![(0.0, 1.0), (5.0, 0.5)],
            ..Series::default()
        };
        let b = Series {
            points: vec![(2.0, 1.0), (12.5, 0.5)],
            ..Series::default()
        };
        let line = direct_line(&[a, b], 0.04).unwrap();
        assert_eq!(line.points, vec![(0.0, 0.04), (12.5, 0.04)]);
        assert!(line.dashed && line.label.contains("direct GP"));
        // No curves: a unit span; no regression: no line.
        assert_eq!(direct_line(&[], 0.04).unwrap().points[1], (1.0, 0.04));
        assert!(direct_line(&[], f64::NAN).is_none());
    }
}
