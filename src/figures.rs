//! The demo's pictures: the shared latent space with key poses and test trajectories (the
//! paper's Fig. 7) and predicted against desired joint trajectories (Fig. 8).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use sgplvm_core::SharedGplvm;

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
    // Key poses: the last frame of every labelled segment is the human holding its target pose.
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
    // Test trajectories: the first few distinct pose pairs of the test set.
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
    let panel = Panel {
        title: format!("human + {robot}, latent dimensions {} and {}", a + 1, b + 1),
        x_label: format!("x{}", a + 1),
        y_label: format!("x{}", b + 1),
        log_y: false,
        series,
        markers: vec![training, poses],
    };
    Ok(write_figure(
        stem,
        "Shared latent space (Fig. 7)",
        &[panel],
        1,
    )?)
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
    // The first test pose pair, both directions, every repetition.
    let first = ds
        .segments
        .iter()
        .find(|s| !s.is_empty() && ds.test.binary_search(&s.start).is_ok());
    let frames: Vec<usize> = match first {
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
    };
    let h = to_mat(&ds.human.rows(&frames));
    let predicted = model.predict(h.as_ref(), robot, false)?.mean;
    let desired = body.rows(&frames);
    let t0 = frames.first().map(|&f| ds.times_ns[f]).unwrap_or(0);
    let time: Vec<f64> = frames
        .iter()
        .map(|&f| (ds.times_ns[f] - t0) as f64 * 1e-9)
        .collect();
    // Plot against frame index within the selection: segments are not contiguous in time.
    let step = time.get(1).map_or(0.025, |t| t - time[0]).max(1e-6);
    let x: Vec<f64> = (0..frames.len()).map(|i| i as f64 * step).collect();
    let half = |d: usize| [(0..d / 2), (d / 2..d)];
    let mut panels = Vec::new();
    for (side, range) in ["left", "right"]
        .into_iter()
        .zip(half(ds.human.joint_names.len()))
    {
        panels.push(Panel {
            title: format!("human {side} arm"),
            x_label: "seconds".into(),
            y_label: "joint angle (rad)".into(),
            series: range
                .map(|j| Series {
                    color: j,
                    points: x.iter().enumerate().map(|(i, &t)| (t, h[(i, j)])).collect(),
                    ..Series::default()
                })
                .collect(),
            ..Panel::default()
        });
    }
    for (side, range) in ["left", "right"]
        .into_iter()
        .zip(half(body.joint_names.len()))
    {
        let mut series = Vec::new();
        for (k, j) in range.enumerate() {
            let first = k == 0;
            series.push(Series {
                label: if first {
                    "predicted".into()
                } else {
                    String::new()
                },
                color: j,
                points: x
                    .iter()
                    .enumerate()
                    .map(|(i, &t)| (t, predicted[(i, j)]))
                    .collect(),
                ..Series::default()
            });
            series.push(Series {
                label: if first {
                    "desired".into()
                } else {
                    String::new()
                },
                color: j,
                dashed: true,
                points: x
                    .iter()
                    .enumerate()
                    .map(|(i, &t)| (t, desired[(i, j)]))
                    .collect(),
                ..Series::default()
            });
        }
        panels.push(Panel {
            title: format!("{robot} {side} arm"),
            x_label: "seconds".into(),
            y_label: "joint angle (rad)".into(),
            series,
            ..Panel::default()
        });
    }
    let title =
        format!("{robot}: predicted (solid) and desired (dashed) joints on test motions (Fig. 8)");
    Ok(write_figure(stem, &title, &panels, 2)?)
}
