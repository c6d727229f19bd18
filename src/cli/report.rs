//! Everything the commands print as their result: the training line, the evaluation table, the
//! demo's table and the replay summary, each as text or JSON.

use std::path::{Path, PathBuf};

use serde_json::json;
use sgplvm::experiment::ModelKind;
use sgplvm::pipeline::{Demonstrations, Evaluation, FrameSet, StudyModel, TestTrust};
use sgplvm::robots::names::count;
use sgplvm::{PartsGplvm, SharedGplvm, StopReason};

mod replay;
pub use replay::replay;

/// The warning that robot `robot`'s self-collision is not checked for the parts `unchecked`
/// (collision elements that gave no shape, links drawn with no collision element on a body
/// without one; one line each, beginning with its link's name; `pairs`: the pairs of shapes
/// still checked), or `None` when there is no such part. Missing meshes are no detail:
/// with none left the robot is not kept off itself at all.
pub fn self_collision_unchecked(robot: &str, unchecked: &[String], pairs: usize) -> Option<String> {
    let first = unchecked.first()?;
    let n = unchecked.len();
    let how_many = if pairs == 0 {
        format!("at all (no pair of shapes is left to check); {n} part(s) give no collision shape")
    } else {
        format!("for {n} part(s) that give no collision shape")
    };
    // Each entry begins with its link's name: all the links, then the first reason.
    let mut links: Vec<&str> = unchecked
        .iter()
        .filter_map(|u| u.split(':').next())
        .collect();
    links.dedup();
    Some(format!(
        "warning: {robot}: self-collision not checked {how_many}, on link(s) {}: {first}",
        sgplvm::robots::names::few(&links, 8)
    ))
}

/// After `train`: robots, frames, seconds, iterations, objective and stop reason.
pub fn training(model: &SharedGplvm, seconds: f64, out: &Path, json: bool) {
    let what = format!(
        "trained {} on {} ({})",
        model.output_names().join(" + "),
        count(model.num_points(), "frame"),
        FrameSet::for_config(model.config()).describe()
    );
    trained(&what, model, seconds, out, json);
}

/// After `transfer`: as [`training`], saying that only `robot`'s kernel was trained, on the
/// latent space of `source`'s robots.
pub fn transfer(
    source: &SharedGplvm,
    robot: &str,
    model: &SharedGplvm,
    seconds: f64,
    out: &Path,
    json: bool,
) {
    let what = format!(
        "transferred to {robot} (its kernel only; shared latent space from {})",
        source.output_names().join(" + ")
    );
    trained(&what, model, seconds, out, json);
}

/// After `train --parts`: the parts, frames and seconds, then each part's and the parent's
/// iterations and stop reason.
pub fn parts_training(model: &PartsGplvm, out: &Path, json: bool) {
    let parent = match model.parent() {
        Some(p) => format!("; a parent of Q = {}", p.config().latent_dim),
        None => String::new(),
    };
    let what = format!(
        "trained {} with a latent space per part ({}{parent}) on {} ({})",
        model.output_names().join(" + "),
        model.part_names().join(", "),
        count(model.num_points(), "frame"),
        FrameSet::for_config(model.config()).describe()
    );
    parts_trained(&what, model, true, out, json);
}

/// After `transfer` of a per-part model: as [`parts_training`], saying that only `robot`'s
/// kernel of each part was trained (the parent, unchanged, is not reported).
pub fn parts_transfer(robot: &str, model: &PartsGplvm, out: &Path, json: bool) {
    let what = format!(
        "transferred to {robot} (its kernel of each part only; the latent spaces of {})",
        model.part_names().join(", ")
    );
    parts_trained(&what, model, false, out, json);
}

/// What one model of a per-part training did: iterations, objective, stop reason, selection.
fn one_training(model: &SharedGplvm) -> serde_json::Value {
    let history = model.history();
    json!({
        "iterations": history.last().map_or(0, |r| r.iteration),
        "objective": history.last().map(|r| r.objective),
        "stop_reason": model.stop_reason().map(StopReason::name),
        "selection": model.selection(),
    })
}

/// The result of a per-part training: `what`, then a line per part and, with `parent` (it was
/// trained), the parent's; seconds are those of the models trained.
fn parts_trained(what: &str, model: &PartsGplvm, parent: bool, out: &Path, json: bool) {
    let parent = model.parent().filter(|_| parent);
    let seconds: f64 = model
        .part_names()
        .into_iter()
        .filter_map(|name| model.part(name))
        .chain(parent)
        .map(SharedGplvm::training_seconds)
        .sum();
    let parts: serde_json::Map<String, serde_json::Value> = model
        .part_names()
        .into_iter()
        .filter_map(|name| Some((name.to_string(), one_training(model.part(name)?))))
        .collect();
    if json {
        let value = json!({
            "model": out.display().to_string(),
            "robots": model.output_names(),
            "frames": model.num_points(),
            "seconds": seconds,
            "parts": parts,
            "parent": parent.map(one_training),
        });
        println!("{value}");
        return;
    }
    println!("{what} in {seconds:.2} s; wrote {}", out.display());
    let models = model
        .part_names()
        .into_iter()
        .filter_map(|name| Some((name, model.part(name)?)))
        .chain(parent.map(|p| ("parent", p)));
    for (name, m) in models {
        let iterations = m.history().last().map_or(0, |r| r.iteration);
        let stop = m
            .stop_reason()
            .map_or("not trained".to_string(), ToString::to_string);
        let chosen = match m.selection() {
            Some(s) => format!(
                ", the budget chosen on {} held-out frames",
                s.validation_frames
            ),
            None => String::new(),
        };
        println!(
            "  {name}: {} ({stop}{chosen}), {:.2} s",
            count(iterations, "iteration"),
            m.training_seconds()
        );
    }
}

/// The result of a training: `what` was done, in `seconds`, and why it stopped, in words —
/// for a budget chosen on held-out frames, how it was chosen.
fn trained(what: &str, model: &SharedGplvm, seconds: f64, out: &Path, json: bool) {
    if json {
        let history = model.history();
        let value = json!({
            "model": out.display().to_string(),
            "robots": model.output_names(),
            "frames": model.num_points(),
            "iterations": history.last().map_or(0, |r| r.iteration),
            "seconds": seconds,
            "objective": history.last().map(|r| r.objective),
            "stop_reason": model.stop_reason().map(StopReason::name),
            "selection": model.selection(),
            "ard_weights": model.is_bayesian().then(|| ard_weights(model)),
        });
        println!("{value}");
    } else {
        print!("{}", trained_text(what, model, seconds, out));
        if model.is_bayesian() {
            print!("{}", ard_text(model));
        }
    }
}

/// Each space's ARD weights (α²/ℓ_q², in latent-dimension order), by space name.
fn ard_weights(model: &SharedGplvm) -> serde_json::Map<String, serde_json::Value> {
    std::iter::once(model.input_name())
        .chain(model.output_names())
        .filter_map(|s| Some((s.to_string(), json!(model.ard_weights(s).ok()?))))
        .collect()
}

/// A Bayesian model's ARD weights, a line per space, each relative to the space's largest:
/// which latent dimensions each space uses.
fn ard_text(model: &SharedGplvm) -> String {
    let mut out = format!(
        "ARD weights α²/ℓ² per latent dimension, relative to each space's largest (below {:.0} %: \
         switched off for that space):\n",
        100.0 * ARD_USED
    );
    for space in std::iter::once(model.input_name()).chain(model.output_names()) {
        let Ok(w) = model.ard_weights(space) else {
            continue;
        };
        let max = w.iter().copied().fold(0.0, f64::max);
        let cells: Vec<String> = w.iter().map(|v| format!("{:5.2}", v / max)).collect();
        let used = w.iter().filter(|v| **v > ARD_USED * max).count();
        out.push_str(&format!(
            "  {space:<10} {}  ({used} of {} used)\n",
            cells.join(" "),
            w.len()
        ));
    }
    out
}

/// The share of a space's largest ARD weight above which a latent dimension counts as used.
const ARD_USED: f64 = 0.05;

/// The lines [`trained`] prints: what was done, then why it stopped. Without a selection the
/// stop reason closes the first line; with one, a second line says how the budget was chosen
/// and whether the final training ran all of it (`validated budget: 7 iterations chosen on 84
/// held-out training frames (...), then retrained on all 249 frames`).
fn trained_text(what: &str, model: &SharedGplvm, seconds: f64, out: &Path) -> String {
    let history = model.history();
    let iterations = history.last().map_or(0, |r| r.iteration);
    let objective = history.last().map_or(f64::NAN, |r| r.objective);
    let stop = model
        .stop_reason()
        .map_or("not trained".to_string(), ToString::to_string);
    let Some(s) = model.selection() else {
        return format!(
            "{what} in {seconds:.2} s, {}, objective {objective:.3} ({stop}); wrote {}\n",
            count(iterations, "iteration"),
            out.display()
        );
    };
    let held_out_mse = s
        .curve
        .iter()
        .find(|r| r.iteration == s.best_iteration)
        .map_or(f64::NAN, |r| r.validation_mse);
    let last = s.curve.last().map_or(0, |r| r.iteration);
    let chosen = if s.chose_the_budget() {
        let run = if last >= s.best_iteration + s.patience {
            format!(
                "until their error had not fallen for {}",
                count(s.patience, "iteration")
            )
        } else {
            format!(
                "for {}, until it stopped (converged, or at the iteration budget or time limit)",
                count(last, "iteration")
            )
        };
        format!(
            "validated budget: {} chosen on {} held-out training frames (held-out MSE \
             {held_out_mse:.6}; the selection run trained on the other {} {run})",
            count(s.best_iteration, "iteration"),
            s.validation_frames,
            s.fit_frames,
        )
    } else {
        format!(
            "budget: {}: the selection run on {} training frames ended there (converged, or at \
             the iteration budget or time limit), at its lowest error on {} held-out frames (MSE \
             {held_out_mse:.6})",
            count(s.best_iteration, "iteration"),
            s.fit_frames,
            s.validation_frames,
        )
    };
    let ending = match model.stop_reason() {
        Some(StopReason::ValidatedBudget) => String::new(),
        _ => format!(
            ", which stopped after {}: {stop}",
            count(iterations, "iteration")
        ),
    };
    // A budget of a few iterations reads like a failure: say that it is the held-out error's
    // choice, and what it means.
    let few = if s.chose_the_budget() && s.best_iteration < FEW_ITERATIONS {
        format!(
            "  note: {} kept: the model{} predicted the held-out training motions best; \
             training on fitted the training motions at their cost (few training motions, or \
             unlike the held-out ones). `--validation none` trains the whole budget regardless\n",
            count(s.best_iteration, "iteration"),
            if s.best_iteration == 0 {
                " as initialised (latent points from the data's principal components)"
            } else {
                ", barely moved from its start,"
            }
        )
    } else {
        String::new()
    };
    format!(
        "{what} in {seconds:.2} s, {}, objective {objective:.3}; wrote {}\n  \
         {chosen}, then retrained on all {} frames{ending}\n{few}",
        count(iterations, "iteration"),
        out.display(),
        s.fit_frames + s.validation_frames,
    )
}

/// Validated budgets below this many iterations get a note saying what they mean.
const FEW_ITERATIONS: usize = 5;

/// `evaluate`: the test error overall and per joint, and the trust threshold's rates (a single
/// latent space's).
pub fn evaluation(e: &Evaluation, trust: Option<&TestTrust>) {
    println!(
        "{}: test MSE {:.6} rad² (RMSE {:.2}°) over {} frames",
        e.robot,
        e.mse,
        e.mse.sqrt().to_degrees(),
        e.frames
    );
    for (joint, mse) in &e.per_joint {
        println!("  {joint:<24} {mse:.6}  ({:.2}°)", mse.sqrt().to_degrees());
    }
    println!(
        "  the mean training pose on every frame (a model that learned nothing): test MSE {:.6} rad² (RMSE {:.2}°)",
        e.mean_pose_mse,
        e.mean_pose_mse.sqrt().to_degrees()
    );
    if e.mse >= e.mean_pose_mse {
        eprintln!(
            "warning: {}: the model predicts the test frames no better than the mean training pose ({:.6} against {:.6} rad²): it has not learned this robot's motion (jumps between postures in the robot's training data, too few frames, or test people unlike the training ones?)",
            e.robot, e.mse, e.mean_pose_mse
        );
    }
    let Some(trust) = trust else {
        return;
    };
    println!(
        "trust: {} of {} test frames ({:.1} %) above the model's trust threshold {:.4} (live, the robot would hold on them)",
        trust.untrusted,
        trust.frames,
        100.0 * trust.untrusted as f64 / trust.frames.max(1) as f64,
        trust.threshold
    );
    let rmse = |m: Option<f64>| {
        m.map_or("-".to_string(), |m| {
            format!("{:.2}°", m.sqrt().to_degrees())
        })
    };
    println!(
        "       test RMSE {} on the frames within the threshold, {} on those above it",
        rmse(trust.mse_trusted),
        rmse(trust.mse_untrusted)
    );
}

/// The demo's line about the data, before training.
pub fn demo_data(demos: &Demonstrations) {
    let ds = &demos.dataset;
    println!(
        "data: {} — {} training and {} test frames, human {} joints, robots {}",
        demos.source_name,
        ds.train.len(),
        ds.test.len(),
        ds.human.joint_names.len(),
        ds.robot_names().join(", ")
    );
}

/// How the demo's table names a kind of model.
pub fn demo_label(kind: ModelKind) -> &'static str {
    match kind {
        ModelKind::Baseline => "full",
        ModelKind::Transfer => "transfer",
        ModelKind::Multi => "multi-robot",
    }
}

/// A robot's yardstick in the demo's table: a direct GP regression human → robot.
pub struct Yardstick {
    /// Training seconds.
    pub seconds: f64,
    /// Its test error.
    pub evaluation: Evaluation,
}

/// The label of the yardstick's rows.
const YARDSTICK: &str = "direct GP";

/// One row of the demo's table.
struct DemoRow<'a> {
    robot: &'a str,
    model: &'a str,
    seconds: f64,
    iterations: Option<usize>,
    mse: f64,
}

/// The demo's rows: each robot's models, then its yardstick.
fn demo_rows<'a>(models: &'a [StudyModel], yardsticks: &'a [Yardstick]) -> Vec<DemoRow<'a>> {
    let mut rows: Vec<DemoRow<'a>> = Vec::new();
    for (i, m) in models.iter().enumerate() {
        rows.push(DemoRow {
            robot: &m.robot,
            model: demo_label(m.kind),
            seconds: m.seconds,
            iterations: Some(m.iterations),
            mse: m.evaluation.mse,
        });
        let last_of_robot = models.get(i + 1).is_none_or(|next| next.robot != m.robot);
        let yardstick = yardsticks.iter().find(|y| y.evaluation.robot == m.robot);
        if let (true, Some(y)) = (last_of_robot, yardstick) {
            rows.push(DemoRow {
                robot: &m.robot,
                model: YARDSTICK,
                seconds: y.seconds,
                iterations: None,
                mse: y.evaluation.mse,
            });
        }
    }
    rows
}

/// The demo's result: a table of the trained models and their test errors beside each robot's
/// yardstick, and the files written.
pub fn demo(
    demos: &Demonstrations,
    source: &str,
    models: &[StudyModel],
    yardsticks: &[Yardstick],
    out: &Path,
    written: &[PathBuf],
    json: bool,
) {
    let rows = demo_rows(models, yardsticks);
    if json {
        let value = json!({
            "data": demos.source_name,
            "source": source,
            "rows": rows.iter().map(|r| json!({
                "robot": r.robot, "model": r.model, "seconds": r.seconds,
                "iterations": r.iterations, "test_mse": r.mse,
            })).collect::<Vec<_>>(),
            "files": written.iter().map(|p| p.display().to_string()).collect::<Vec<_>>(),
        });
        println!("{value}");
        return;
    }
    println!(
        "\n{:<10} {:<9} {:>10} {:>11} {:>14} {:>11}",
        "robot", "model", "train (s)", "iterations", "test MSE", "RMSE (deg)"
    );
    for r in &rows {
        let iterations = r.iterations.map_or("-".to_string(), |i| i.to_string());
        println!(
            "{:<10} {:<9} {:>10.2} {:>11} {:>14.6} {:>11.2}",
            r.robot,
            r.model,
            r.seconds,
            iterations,
            r.mse,
            r.mse.sqrt().to_degrees()
        );
    }
    println!(
        "\n`full` = human + that robot trained from scratch; `transfer` = {source}'s latent space and\n\
         human mapping reused, only the robot's kernel trained; `{YARDSTICK}` = the paper's yardstick,\n\
         a GP regression straight from human to robot joints. Models and figures in {}:",
        out.display()
    );
    for path in written {
        println!("  {}", path.display());
    }
}
