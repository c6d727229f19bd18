//! The demo's figures, drawn from a trained model and the demonstrations: the shared latent
//! space with key poses and test trajectories (Fig. 7, [`latent_space`]) and predicted against
//! desired joint trajectories of every test motion (Fig. 8, [`trajectories`]).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use sgplvm_core::SharedGplvm;
use sgplvm_robots::dataset::Dataset;
use sgplvm_robots::series::seconds_from_ns;

use super::FigureError;
use crate::pipeline::{to_mat, Demonstrations};
use crate::plots::{title_height, write_figure_with, Layout, Markers, Panel, Series};

/// The two latent dimensions that matter most for `robot`: those with the shortest lengthscales.
pub fn dominant_dims(model: &SharedGplvm, robot: &str) -> (usize, usize) {
    let Some(kernel) = model.kernel(robot) else {
        return (0, 1.min(model.config().latent_dim - 1));
    };
    let mut order: Vec<usize> = (0..kernel.lengthscale.len()).collect();
    order.sort_by(|&a, &b| kernel.lengthscale[a].total_cmp(&kernel.lengthscale[b]));
    (order[0], *order.get(1).unwrap_or(&order[0]))
}

/// Pixels of Fig. 7, width and height ([`latent_space`]), whatever its subtitle's length: the
/// chart takes what the title and subtitle leave.
pub const LATENT_SPACE_SIZE: (u32, u32) = (1200, 900);

/// Fig. 7: training latent points (crosses), key poses (circles, where the human holds them)
/// and the latent paths of every test motion, in the two dominant dimensions;
/// [`LATENT_SPACE_SIZE`] (1200 × 900 pixels), every key pose's name placed so that none
/// overlaps another (a leader line where a name sits away from its circle). The subtitle says
/// what each mark is, as the legend shows it, and that the sharp hooks of a path — which look
/// like arrowheads — are the motion turning back: no direction is drawn.
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
    let (width, height) = LATENT_SPACE_SIZE;
    let subtitle = wrap(
        &format!(
            "crosses: the {} training frames; {circles}lines: the path of each of the {} test \
             motions ({} test frames), whose sharp hooks (like arrowheads) are where the motion \
             turns back — no direction is drawn",
            x.nrows(),
            motions.len(),
            ds.test.len()
        ),
        SUBTITLE_CHARS_PER_PIXEL * width as usize / 1000,
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
        panel_size: (width, height - title_height(subtitle.len())),
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
pub(super) const TEST_COLORS: [usize; 7] = [0, 2, 3, 4, 5, 8, 9];

/// Key poses in latent dimensions `(a, b)`: the last frame of every labelled segment is the human
/// holding its target pose; each pose at the mean of its frames' latent points.
pub(super) fn key_poses(
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
pub(super) const MOTION_COLUMNS: usize = 3;

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
pub(super) const SUBTITLE_CHARS_PER_PIXEL: usize = 115;

/// `text` in lines of at most about `width` characters, broken after `; ` or spaces.
pub(super) fn wrap(text: &str, width: usize) -> Vec<String> {
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
pub(super) fn halves(d: usize) -> [std::ops::Range<usize>; 2] {
    [(0..d / 2), (d / 2..d)]
}

/// Joint names for a legend: without the prefix they all share (`L`, `jLeft`: the panel's title
/// names the arm).
pub(super) fn legend_names(names: &[String]) -> Vec<String> {
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
pub(super) fn arm_panel(title: String, series: Vec<Series>) -> Panel {
    Panel {
        title,
        x_label: "seconds".into(),
        y_label: "joint angle (rad)".into(),
        series,
        ..Panel::default()
    }
}
