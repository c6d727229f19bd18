//! The paper's figures. From an experiment's runs: test error against iterations and training
//! time for the baseline, transfer and multi-robot models (Figs. 4 and 5) and for the three
//! back constraints (Fig. 6), with less data (Fig. 9), from each robot to each other (Fig. 10)
//! and on every frame against a subsample (Fig. 11), each panel with the direct GP regression's error as a yardstick. From a trained model, the demo's pictures: the shared latent space
//! with key poses and test trajectories (Fig. 7) and predicted against desired joint
//! trajectories (Fig. 8).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use sgplvm_core::{BackConstraint, SharedGplvm};

use crate::results::{ModelKind, Results, RunRecord};
use sgplvm_robots::dataset::Dataset;
use sgplvm_robots::series::seconds_from_ns;

use crate::pipeline::{to_mat, Demonstrations, PipelineError};
use crate::plots::{write_figure, write_figure_with, Layout, Markers, Panel, PlotError, Series};

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
        };
        let curves = [
            curve(ModelKind::Baseline, "baseline (fully trained)", 0),
            curve(
                ModelKind::Transfer,
                "transfer (only robot kernel trained)",
                1,
            ),
            curve(ModelKind::Multi, "multi-robot", 2),
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
    };
    let curves = [
        curve(BackConstraint::None, "no back constraints", 1),
        curve(BackConstraint::Input, "back constraints on the input", 0),
        curve(BackConstraint::Output, "back constraints on the output", 2),
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
                    let runs = results.select(robot, c.kind, c.back_constraint.name());
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

/// The two latent dimensions that matter most for `robot`: those with the shortest lengthscales.
pub fn dominant_dims(model: &SharedGplvm, robot: &str) -> (usize, usize) {
    let Some(kernel) = model.kernel(robot) else {
        return (0, 1.min(model.config().latent_dim - 1));
    };
    let mut order: Vec<usize> = (0..kernel.lengthscale.len()).collect();
    order.sort_by(|&a, &b| kernel.lengthscale[a].total_cmp(&kernel.lengthscale[b]));
    (order[0], *order.get(1).unwrap_or(&order[0]))
}

/// Fig. 7: training latent points (crosses), key poses (circles, where the human holds them)
/// and the latent paths of every test motion, in the two dominant dimensions; 1200 × 900 pixels,
/// every key pose's name placed so that none overlaps another (a leader line where a name sits
/// away from its circle).
pub fn latent_space(
    model: &SharedGplvm,
    demos: &Demonstrations,
    robot: &str,
    stem: &Path,
) -> Result<[PathBuf; 2], FigureError> {
    let ds = &demos.dataset;
    let (a, b) = dominant_dims(model, robot);
    let x = model.latent_points();
    let training = Markers {
        label: "training frames".into(),
        color: 6,
        points: (0..x.nrows()).map(|i| (x[(i, a)], x[(i, b)])).collect(),
        ..Markers::default()
    };
    let poses = key_poses(model, ds, (a, b))?;
    let motions = test_motions(ds);
    let mut series = Vec::new();
    for (k, motion) in motions.iter().enumerate() {
        let z = model.latent(to_mat(&ds.human.rows(&motion.frames)).as_ref())?;
        series.push(Series {
            label: format!("test: {}", motion.name),
            color: TEST_COLORS[k % TEST_COLORS.len()],
            points: (0..z.nrows()).map(|i| (z[(i, a)], z[(i, b)])).collect(),
            ..Series::default()
        });
    }
    let circles = if poses.points.is_empty() {
        String::new()
    } else {
        format!(
            "circles: the {} key poses, where the human holds them; ",
            poses.points.len()
        )
    };
    let subtitle = wrap(
        &format!(
            "crosses: the {} training frames; {circles}lines: the path of each of the {} test \
             motions ({} test frames)",
            x.nrows(),
            motions.len(),
            ds.test.len()
        ),
        SUBTITLE_CHARS_PER_PIXEL * 1200 / 1000,
    );
    let mut markers = vec![training];
    if !poses.points.is_empty() {
        markers.push(poses);
    }
    let panel = Panel {
        title: format!(
            "human + {robot}, latent dimensions {} and {} (the shortest lengthscales of {robot})",
            a + 1,
            b + 1
        ),
        x_label: format!("x{}", a + 1),
        y_label: format!("x{}", b + 1),
        log_y: false,
        series,
        markers,
        ..Panel::default()
    };
    let layout = Layout {
        panel_size: (1200, 900),
        subtitle,
        ..Layout::grid(1)
    };
    Ok(write_figure_with(
        stem,
        "Shared latent space (Fig. 7)",
        &[panel],
        &layout,
    )?)
}

/// Palette colours of the test motions' paths in Fig. 7: neither the key poses' (1) nor the
/// training frames' (6).
const TEST_COLORS: [usize; 7] = [0, 2, 3, 4, 5, 8, 9];

/// Key poses in latent dimensions `(a, b)`: the last frame of every labelled segment is the human
/// holding its target pose; each pose at the mean of its frames' latent points.
fn key_poses(
    model: &SharedGplvm,
    ds: &Dataset,
    (a, b): (usize, usize),
) -> Result<Markers, FigureError> {
    let mut pose_frames: BTreeMap<usize, Vec<usize>> = BTreeMap::new();
    for s in &ds.segments {
        if let (Some(to), false) = (s.to_pose, s.is_empty()) {
            pose_frames.entry(to).or_default().push(s.end - 1);
        }
    }
    let mut poses = Markers {
        label: "key poses".into(),
        color: 1,
        circles: true,
        ..Markers::default()
    };
    for (pose, frames) in &pose_frames {
        let h = to_mat(&ds.human.rows(frames));
        let z = model.latent(h.as_ref())?;
        let n = z.nrows() as f64;
        let mean = |d: usize| (0..z.nrows()).map(|i| z[(i, d)]).sum::<f64>() / n;
        poses.points.push((mean(a), mean(b)));
        poses.annotations.push(
            ds.pose_names
                .get(*pose)
                .cloned()
                .unwrap_or_else(|| format!("P{pose}")),
        );
    }
    Ok(poses)
}

/// One test motion: test frames contiguous in time, between the same two key poses.
#[derive(Debug, Clone, PartialEq)]
pub struct TestMotion {
    /// Its test frames (rows of the dataset), in time order.
    pub frames: Vec<usize>,
    /// What it is: `forward_high ↔ hands_together` (both directions), `v_up → left_across`
    /// (one), or `t = 12.0–16.0 s` (seconds of the recording) when unlabelled.
    pub name: String,
    /// Whether `name` is a span of time (the motion is not labelled with key poses).
    pub unlabelled: bool,
    /// Seconds from its first frame to its last.
    pub seconds: f64,
}

/// Every test motion of `ds`, in time order: the test frames split where time jumps (more than
/// three times the usual step between test frames) or the pair of key poses changes. Together
/// they hold every test frame once.
pub fn test_motions(ds: &Dataset) -> Vec<TestMotion> {
    let test = &ds.test;
    let time =
        |f: usize| seconds_from_ns(ds.times_ns[f] - ds.times_ns.first().copied().unwrap_or(0));
    let mut steps: Vec<f64> = test.windows(2).map(|w| time(w[1]) - time(w[0])).collect();
    steps.sort_by(f64::total_cmp);
    let usual = steps.get(steps.len() / 2).copied().unwrap_or(0.0);
    // The unordered pair of key poses of the segment holding frame `f`, when labelled.
    let pair = |f: usize| {
        ds.segment_of(f)
            .and_then(|s| match (s.from_pose, s.to_pose) {
                (Some(a), Some(b)) => Some((a.min(b), a.max(b))),
                _ => None,
            })
    };
    let mut runs: Vec<Vec<usize>> = Vec::new();
    for (i, &f) in test.iter().enumerate() {
        let joins = i > 0 && {
            let previous = test[i - 1];
            time(f) - time(previous) > 3.0 * usual || pair(f) != pair(previous)
        };
        match runs.last_mut() {
            Some(run) if i > 0 && !joins => run.push(f),
            _ => runs.push(vec![f]),
        }
    }
    let pose = |p: Option<usize>| {
        p.and_then(|p| ds.pose_names.get(p).cloned())
            .unwrap_or_else(|| "?".into())
    };
    runs.into_iter()
        .map(|frames| {
            let (first, last) = (frames[0], frames[frames.len() - 1]);
            let mut directions: Vec<(Option<usize>, Option<usize>)> = Vec::new();
            for &f in &frames {
                if let Some(s) = ds.segment_of(f) {
                    if s.from_pose.is_some() && !directions.contains(&(s.from_pose, s.to_pose)) {
                        directions.push((s.from_pose, s.to_pose));
                    }
                }
            }
            let name = match directions.as_slice() {
                [] => format!("t = {:.1}–{:.1} s", time(first), time(last)),
                [(a, b)] => format!("{} → {}", pose(*a), pose(*b)),
                [(a, b), ..] => format!("{} ↔ {}", pose(*a), pose(*b)),
            };
            TestMotion {
                seconds: time(last) - time(first),
                unlabelled: directions.is_empty(),
                frames,
                name,
            }
        })
        .collect()
}

/// Test motions side by side in Fig. 8 (more wrap onto further rows of panels).
const MOTION_COLUMNS: usize = 3;

/// Fig. 8: every test motion in a column of its own (up to three side by side, more wrap
/// below): the human's left and right arm joint angles, and `robot`'s predicted (solid) against
/// desired (dashed) left and right arm joints, against seconds from the motion's start. One
/// colour per joint, the same in every column, its name in the row's legend; dashes mean
/// "desired" and nothing else. The subtitle names the motions shown.
pub fn trajectories(
    model: &SharedGplvm,
    demos: &Demonstrations,
    robot: &str,
    stem: &Path,
) -> Result<[PathBuf; 2], FigureError> {
    let ds = &demos.dataset;
    let body = demos.robot(robot)?;
    let motions = test_motions(ds);
    let columns = motions.len().clamp(1, MOTION_COLUMNS);
    let human_names = &ds.human.joint_names;
    // Per motion its four panels: human left, human right, robot left, robot right.
    let mut per_motion: Vec<[Panel; 4]> = Vec::new();
    for motion in &motions {
        let frames = &motion.frames;
        let h = to_mat(&ds.human.rows(frames));
        let predicted = model.predict(h.as_ref(), robot, false)?.mean;
        let desired = body.rows(frames);
        let t0 = ds.times_ns[frames[0]];
        let x: Vec<f64> = frames
            .iter()
            .map(|&f| seconds_from_ns(ds.times_ns[f] - t0))
            .collect();
        let line = |value: &dyn Fn(usize) -> f64| -> Vec<(f64, f64)> {
            x.iter().enumerate().map(|(i, &t)| (t, value(i))).collect()
        };
        let human_panel = |side: &str, range: std::ops::Range<usize>| {
            let names = legend_names(&human_names[range.clone()]);
            let series = range
                .zip(names)
                .enumerate()
                .map(|(k, (j, name))| Series {
                    label: name,
                    color: k,
                    points: line(&|i| h[(i, j)]),
                    ..Series::default()
                })
                .collect();
            arm_panel(format!("human {side} arm: {}", motion.name), series)
        };
        let robot_panel = |side: &str, range: std::ops::Range<usize>| {
            let names = legend_names(&body.joint_names[range.clone()]);
            let mut series = Vec::new();
            for (k, (j, name)) in range.zip(names).enumerate() {
                series.push(Series {
                    label: name,
                    color: k,
                    points: line(&|i| predicted[(i, j)]),
                    ..Series::default()
                });
                series.push(Series {
                    color: k,
                    dashed: true,
                    points: line(&|i| desired[(i, j)]),
                    ..Series::default()
                });
            }
            arm_panel(format!("{robot} {side} arm: {}", motion.name), series)
        };
        let [hl, hr] = halves(human_names.len());
        let [rl, rr] = halves(body.joint_names.len());
        per_motion.push([
            human_panel("left", hl),
            human_panel("right", hr),
            robot_panel("left", rl),
            robot_panel("right", rr),
        ]);
    }
    // Row by row: per group of `columns` motions, four rows of panels (blank where a group
    // has fewer motions).
    let mut panels = Vec::new();
    for group in per_motion.chunks(columns) {
        for row in 0..4 {
            for c in 0..columns {
                panels.push(group.get(c).map(|p| p[row].clone()).unwrap_or_default());
            }
        }
    }
    let frames: usize = motions.iter().map(|m| m.frames.len()).sum();
    let listed: Vec<String> = motions
        .iter()
        .map(|m| match m.unlabelled {
            true => m.name.clone(),
            false => format!("{} ({:.1} s)", m.name, m.seconds),
        })
        .collect();
    let mut subtitle = wrap(
        &format!(
            "Every test motion, {frames} test frames: {}",
            listed.join("; ")
        ),
        SUBTITLE_CHARS_PER_PIXEL * (columns * 640 + 150) / 1000,
    );
    subtitle.push(format!(
        "Human: the input joint angles. {robot}: predicted solid, desired dashed. One colour per \
         joint, the same in every column; seconds from each motion's first frame"
    ));
    let layout = Layout {
        columns,
        panel_size: (640, 330),
        subtitle,
        legend_column: true,
    };
    let title = format!("{robot} on every test motion (Fig. 8)");
    Ok(write_figure_with(stem, &title, &panels, &layout)?)
}

/// Characters of a subtitle (15-pixel font) per 1,000 pixels of figure width.
const SUBTITLE_CHARS_PER_PIXEL: usize = 115;

/// `text` in lines of at most about `width` characters, broken after `; ` or spaces.
fn wrap(text: &str, width: usize) -> Vec<String> {
    let mut lines: Vec<String> = Vec::new();
    let mut line = String::new();
    for word in text.split(' ') {
        if !line.is_empty() && line.chars().count() + 1 + word.chars().count() > width {
            lines.push(std::mem::take(&mut line));
        }
        if !line.is_empty() {
            line.push(' ');
        }
        line.push_str(word);
    }
    if !line.is_empty() {
        lines.push(line);
    }
    lines
}

/// The joints of the left arm (first half) and the right arm (second half) of `d` joints.
fn halves(d: usize) -> [std::ops::Range<usize>; 2] {
    [(0..d / 2), (d / 2..d)]
}

/// Joint names for a legend: without the prefix they all share (`L`, `jLeft`: the panel's title
/// names the arm).
fn legend_names(names: &[String]) -> Vec<String> {
    let first = names.first().map_or("", String::as_str);
    let mut common = first.len();
    for n in names.iter().skip(1) {
        common = first
            .char_indices()
            .zip(n.chars())
            .take_while(|((_, a), b)| a == b)
            .last()
            .map_or(0, |((i, a), _)| i + a.len_utf8())
            .min(common);
    }
    if names.len() < 2 {
        common = 0;
    }
    names.iter().map(|n| n[common..].to_string()).collect()
}

/// A panel of joint angles against time (its legend goes in the figure's legend column).
fn arm_panel(title: String, series: Vec<Series>) -> Panel {
    Panel {
        title,
        x_label: "seconds".into(),
        y_label: "joint angle (rad)".into(),
        series,
        ..Panel::default()
    }
}

#[cfg(test)]
mod tests {
    //! The mean learning curve drawn in Figs. 4-6, on synthetic runs; the test motions that
    //! Figs. 7 and 8 draw, on the shipped data.

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
