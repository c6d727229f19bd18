//! The paper's figures. From an experiment's runs: test error against iterations and training
//! time for the baseline, transfer and multi-robot models (Figs. 4 and 5) and for the three
//! back constraints (Fig. 6), with less data (Fig. 9), from each robot to each other (Fig. 10)
//! and on every frame against a subsample (Fig. 11), each panel with the direct GP regression's error as a yardstick. From a trained model, the demo's pictures: the shared latent space
//! with key poses and test trajectories (Fig. 7) and predicted against desired joint
//! trajectories (Fig. 8).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use sgplvm_core::{BackConstraint, SharedGplvm};

use crate::experiment::{ModelKind, Results, RunRecord};
use sgplvm_robots::dataset::Dataset;
use sgplvm_robots::series::seconds_from_ns;

use crate::pipeline::{to_mat, Demonstrations, PipelineError};
use crate::plots::{write_figure, Markers, Panel, PlotError, Series};

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
/// and the latent trajectories of a few test motions, in the two dominant dimensions.
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
    let panel = Panel {
        title: format!("human + {robot}, latent dimensions {} and {}", a + 1, b + 1),
        x_label: format!("x{}", a + 1),
        y_label: format!("x{}", b + 1),
        log_y: false,
        series: test_motions(model, ds, (a, b))?,
        markers: vec![training, key_poses(model, ds, (a, b))?],
        ..Panel::default()
    };
    Ok(write_figure(
        stem,
        "Shared latent space (Fig. 7)",
        &[panel],
        1,
    )?)
}

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

/// Latent trajectories, in dimensions `(a, b)`, of the first three distinct pose pairs of the
/// test set.
fn test_motions(
    model: &SharedGplvm,
    ds: &Dataset,
    (a, b): (usize, usize),
) -> Result<Vec<Series>, FigureError> {
    let mut series = Vec::new();
    let mut seen = Vec::new();
    for s in ds
        .segments
        .iter()
        .filter(|s| !s.is_empty() && ds.test.binary_search(&s.start).is_ok())
    {
        let pair = (s.from_pose.min(s.to_pose), s.from_pose.max(s.to_pose));
        if seen.contains(&pair) {
            continue;
        }
        seen.push(pair);
        let frames: Vec<usize> = (s.start..s.end).collect();
        let z = model.latent(to_mat(&ds.human.rows(&frames)).as_ref())?;
        let name = |p: Option<usize>| {
            p.and_then(|p| ds.pose_names.get(p).cloned())
                .unwrap_or_else(|| "?".into())
        };
        series.push(Series {
            label: format!("test: {} → {}", name(s.from_pose), name(s.to_pose)),
            color: [0, 2, 3, 4][series.len() % 4],
            points: (0..z.nrows()).map(|i| (z[(i, a)], z[(i, b)])).collect(),
            ..Series::default()
        });
        if series.len() == 3 {
            break;
        }
    }
    Ok(series)
}

/// Fig. 8: for the test frames between two poses (all repetitions, in time order), the human's
/// left and right arm joint angles, and `robot`'s predicted (solid) against desired (dashed)
/// left and right arm joints.
pub fn trajectories(
    model: &SharedGplvm,
    demos: &Demonstrations,
    robot: &str,
    stem: &Path,
) -> Result<[PathBuf; 2], FigureError> {
    let ds = &demos.dataset;
    let body = demos.robot(robot)?;
    let frames = first_test_motion(ds);
    // Where one motion of the selection ends and the next begins: the curves jump there.
    let joins: Vec<usize> = (1..frames.len())
        .filter(|&i| ds.segment_of(frames[i]).map(|s| s.start) == Some(frames[i]))
        .collect();
    let h = to_mat(&ds.human.rows(&frames));
    let predicted = model.predict(h.as_ref(), robot, false)?.mean;
    let desired = body.rows(&frames);
    let t0 = frames.first().map(|&f| ds.times_ns[f]).unwrap_or(0);
    let time: Vec<f64> = frames
        .iter()
        .map(|&f| seconds_from_ns(ds.times_ns[f] - t0))
        .collect();
    // Plot against frame index within the selection: segments are not contiguous in time.
    let step = time.get(1).map_or(0.025, |t| t - time[0]).max(1e-6);
    let x: Vec<f64> = (0..frames.len()).map(|i| i as f64 * step).collect();
    let line = |value: &dyn Fn(usize) -> f64| -> Vec<(f64, f64)> {
        x.iter().enumerate().map(|(i, &t)| (t, value(i))).collect()
    };
    let vlines: Vec<f64> = joins.iter().map(|&i| (x[i - 1] + x[i]) / 2.0).collect();
    let mut panels = Vec::new();
    for (side, range) in ["left", "right"]
        .into_iter()
        .zip(halves(ds.human.joint_names.len()))
    {
        let names = legend_names(&ds.human.joint_names[range.clone()]);
        panels.push(arm_panel(
            format!("human {side} arm"),
            range
                .zip(names)
                .enumerate()
                .map(|(k, (j, name))| Series {
                    label: name,
                    color: k,
                    dashed: k >= PALETTE_SIZE,
                    points: line(&|i| h[(i, j)]),
                    ..Series::default()
                })
                .collect(),
            &vlines,
        ));
    }
    for (side, range) in ["left", "right"]
        .into_iter()
        .zip(halves(body.joint_names.len()))
    {
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
        panels.push(arm_panel(format!("{robot} {side} arm"), series, &vlines));
    }
    let title = format!(
        "{robot} on test motions (Fig. 8): predicted solid, desired dashed; grey lines join motions"
    );
    Ok(write_figure(stem, &title, &panels, 2)?)
}

/// The frames of the first test pose pair, both directions, every repetition (all test frames
/// if there are no segments).
fn first_test_motion(ds: &Dataset) -> Vec<usize> {
    let first = ds
        .segments
        .iter()
        .find(|s| !s.is_empty() && ds.test.binary_search(&s.start).is_ok());
    match first {
        Some(f) => ds
            .segments
            .iter()
            .filter(|s| {
                ds.test.binary_search(&s.start).is_ok()
                    && ((s.from_pose, s.to_pose) == (f.from_pose, f.to_pose)
                        || (s.from_pose, s.to_pose) == (f.to_pose, f.from_pose))
            })
            .flat_map(|s| s.start..s.end)
            .collect(),
        None => ds.test.clone(),
    }
}

/// The joints of the left arm (first half) and the right arm (second half) of `d` joints.
fn halves(d: usize) -> [std::ops::Range<usize>; 2] {
    [(0..d / 2), (d / 2..d)]
}

/// Colours in the palette: joints beyond them are drawn dashed in the human panels.
const PALETTE_SIZE: usize = 8;

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

/// A panel of joint angles against time, a legend of the joints beside it, the joins between
/// motions at `vlines`.
fn arm_panel(title: String, series: Vec<Series>, vlines: &[f64]) -> Panel {
    Panel {
        title,
        x_label: "seconds".into(),
        y_label: "joint angle (rad)".into(),
        series,
        vlines: vlines.to_vec(),
        side_legend: true,
        ..Panel::default()
    }
}

#[cfg(test)]
mod tests {
    //! The mean learning curve drawn in Figs. 4-6, on synthetic runs.

    use super::*;

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
