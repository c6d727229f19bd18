//! Everything the commands print as their result: the training line, the evaluation table, the
//! demo's table and the replay summary, each as text or JSON.

use std::path::{Path, PathBuf};

use serde_json::json;
use sgplvm::experiment::ModelKind;
use sgplvm::pipeline::{Demonstrations, Evaluation, FrameSet, StudyModel, TestTrust};
use sgplvm::robots::names::count;
use sgplvm::robots::physics::{Collision, LimitViolation, ReplayReport};
use sgplvm::{PartsGplvm, SharedGplvm, StopReason};

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
            "{what} in {seconds:.2} s, {iterations} iterations, objective {objective:.3} \
             ({stop}); wrote {}\n",
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
                "for {}, to the iteration budget or time limit",
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
            "budget: {}: the selection run on {} training frames ended there (iteration budget \
             or time limit), at its lowest error on {} held-out frames (MSE {held_out_mse:.6})",
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
    format!(
        "{what} in {seconds:.2} s, {iterations} iterations, objective {objective:.3}; wrote {}\n  \
         {chosen}, then retrained on all {} frames{ending}\n",
        out.display(),
        s.fit_frames + s.validation_frames,
    )
}

/// `evaluate`: the test error overall and per joint.
pub fn evaluation(e: &Evaluation, trust: &TestTrust, json: bool) -> serde_json::Result<()> {
    if json {
        #[derive(serde::Serialize)]
        struct WithTrust<'a> {
            #[serde(flatten)]
            evaluation: &'a Evaluation,
            trust: &'a TestTrust,
        }
        let both = WithTrust {
            evaluation: e,
            trust,
        };
        println!("{}", serde_json::to_string_pretty(&both)?);
        return Ok(());
    }
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
    Ok(())
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

/// `simulate`: a summary (tracking and violations per joint, the worst cases, collisions per
/// pair of links); with `verbose` every violation and collision interval as well; with `json`
/// the whole report.
pub fn replay(
    source: &str,
    report: &ReplayReport,
    json: bool,
    verbose: bool,
) -> serde_json::Result<()> {
    if json {
        println!("{}", serde_json::to_string_pretty(report)?);
    } else {
        print!("{}", replay_text(source, report, verbose));
    }
    for w in &report.warnings {
        eprintln!("warning: {w}");
    }
    if let Some(d) = &report.diverged {
        eprintln!("warning: {source}: {}", divergence(d));
    }
    Ok(())
}

/// The first `n` of `items`, and how many more.
fn shown<S: AsRef<str>>(items: &[S], n: usize) -> String {
    let first: Vec<&str> = items.iter().take(n).map(AsRef::as_ref).collect();
    match items.len().saturating_sub(n) {
        0 => first.join(", "),
        more => format!("{}, and {more} more", first.join(", ")),
    }
}

/// The line that says a replay ran away, where and how fast.
fn divergence(d: &sgplvm::robots::physics::Divergence) -> String {
    let unit = if d.prismatic { "m/s" } else { "rad/s" };
    format!(
        "the replay DIVERGED at {:.3} s: {} moved at {:.1} {unit} (beyond {:.1} {unit}) away from its reference for 10 ms; it stopped there, and the figures cover the motion before",
        d.time, d.joint, d.speed, d.threshold
    )
}

/// A violation's amount and limit, each with its unit, for a revolute (`false`) or prismatic
/// (`true`) joint: one unit per line.
type Units = fn(&LimitViolation, bool) -> (String, String);

/// Positions in the text report: degrees, or millimetres for prismatic joints.
fn position(value: f64, prismatic: bool) -> f64 {
    if prismatic {
        value * 1e3
    } else {
        value.to_degrees()
    }
}

/// How many of the worst cases the summary lists.
const WORST: usize = 3;

/// Count and worst amount of the violations of one joint.
#[derive(Default)]
struct JointViolations {
    count: usize,
    worst: f64,
}

/// The violations of `violations` on `joint`: how many, and the largest amount.
fn per_joint(violations: &[LimitViolation], joint: &str) -> JointViolations {
    violations
        .iter()
        .filter(|v| v.joint == joint)
        .fold(JointViolations::default(), |acc, v| JointViolations {
            count: acc.count + 1,
            worst: acc.worst.max(v.amount),
        })
}

/// A count and worst amount as a table cell, `-` for none.
fn cell(v: &JointViolations, scale: f64) -> (String, String) {
    if v.count == 0 {
        ("-".into(), "-".into())
    } else {
        (v.count.to_string(), format!("{:.2}", v.worst * scale))
    }
}

/// The text `simulate` prints (see [`replay`]).
fn replay_text(source: &str, report: &ReplayReport, verbose: bool) -> String {
    use std::fmt::Write;
    let mut out = String::new();
    // Writing to a String cannot fail.
    let mut line = |text: String| {
        let _ = writeln!(out, "{text}");
    };
    let ratio = report.duration / report.wall_seconds.max(1e-9);
    let pace = if ratio >= 1.0 {
        format!("{ratio:.0}× faster than real time")
    } else {
        format!("{:.1}× slower than real time", 1.0 / ratio.max(1e-9))
    };
    line(format!(
        "{source}: {:.1} s of motion, {} physics steps in {:.2} s ({pace}); times from the start",
        report.duration, report.physics_steps, report.wall_seconds,
    ));
    if let Some(d) = &report.diverged {
        line(divergence(d));
    }
    if !report.held.is_empty() {
        let names: Vec<&str> = report.held.iter().map(|(n, _)| n.as_str()).collect();
        line(format!(
            "held still, as their controllers would: {} joint(s) without a trajectory column ({})",
            names.len(),
            shown(&names, 6)
        ));
    }
    if !report.overlapping_at_rest.is_empty() {
        let pairs: Vec<String> = report
            .overlapping_at_rest
            .iter()
            .map(|(a, b)| format!("{a} ↔ {b}"))
            .collect();
        line(format!(
            "not checked: {} pair(s) of links already touching at rest, the model's own overlap ({})",
            pairs.len(),
            shown(&pairs, 4)
        ));
    }
    line(String::new());
    line(format!(
        "{:<20} {:>9} {:>9} {:>8}  {:>10} {:>11}  {:>8} {:>13}",
        "joint",
        "RMS (deg)",
        "max (deg)",
        "at (s)",
        "over limit",
        "worst (deg)",
        "too fast",
        "worst (rad/s)"
    ));
    for j in &report.joints {
        let (lc, lw) = cell(
            &per_joint(&report.limit_violations, &j.name),
            position(1.0, j.prismatic),
        );
        let (vc, vw) = cell(&per_joint(&report.velocity_violations, &j.name), 1.0);
        let name = if j.prismatic {
            format!("{} *", j.name)
        } else {
            j.name.clone()
        };
        line(format!(
            "{name:<20} {:>9.3} {:>9.3} {:>8.2}  {lc:>10} {lw:>11}  {vc:>8} {vw:>13}",
            position(j.rms_error, j.prismatic),
            position(j.max_error, j.prismatic),
            j.max_error_time,
        ));
    }
    if report.joints.iter().any(|j| j.prismatic) {
        line("* prismatic: millimetres for degrees, m/s for rad/s".into());
    }
    line(String::new());
    let kinds: [(&str, &[LimitViolation], Units); 2] = [
        ("joint-limit", &report.limit_violations, |v, prismatic| {
            if prismatic {
                (
                    format!("{:.1} mm", v.amount * 1e3),
                    format!("{:.1} mm", v.limit * 1e3),
                )
            } else {
                (
                    format!("{:.2}°", v.amount.to_degrees()),
                    format!("{:.2}°", v.limit.to_degrees()),
                )
            }
        }),
        (
            "velocity-limit",
            &report.velocity_violations,
            |v, prismatic| {
                let unit = if prismatic { "m/s" } else { "rad/s" };
                (
                    format!("{:.2} {unit}", v.amount),
                    format!("{:.3} {unit}", v.limit),
                )
            },
        ),
    ];
    let prismatic = |joint: &str| report.joints.iter().any(|j| j.name == joint && j.prismatic);
    for (kind, violations, units) in kinds {
        if violations.is_empty() {
            line(format!("no {kind} violations"));
            continue;
        }
        let commanded = violations.iter().filter(|v| v.commanded).count();
        let mut joints: Vec<&str> = violations.iter().map(|v| v.joint.as_str()).collect();
        joints.sort_unstable();
        joints.dedup();
        let seconds: f64 = violations.iter().map(|v| v.end_time - v.time).sum();
        line(format!(
            "{kind} violations: {} intervals on {} joint(s), {seconds:.2} s in all; {commanded} \
             commanded (the trajectory itself beyond the limit), {} not",
            violations.len(),
            joints.len(),
            violations.len() - commanded
        ));
        let mut worst: Vec<&LimitViolation> = violations.iter().collect();
        if !verbose {
            worst.sort_by(|a, b| b.amount.total_cmp(&a.amount));
            worst.truncate(WORST);
            line("  worst:".into());
        }
        for v in worst {
            let (amount, limit) = units(v, prismatic(&v.joint));
            line(violation(v, &amount, &limit));
        }
    }
    if report.mesh_hulls > 0 || !report.unchecked_meshes.is_empty() {
        line(format!(
            "collision meshes: {} simulated as convex hulls (read in {:.2} s), {} not",
            report.mesh_hulls,
            report.mesh_seconds,
            report.unchecked_meshes.len()
        ));
    }
    line(report.self_collision_summary());
    // Why meshes were left out: the first (it says what to give) or, with verbose, each.
    let shown = if verbose { usize::MAX } else { 1 };
    for m in report.unchecked_meshes.iter().take(shown) {
        line(format!("  link {}: {}", m.link, m.message));
    }
    collisions(&report.collisions, verbose, &mut line);
    let details =
        report.limit_violations.len() + report.velocity_violations.len() + report.collisions.len();
    if !verbose && details > 0 {
        line(format!(
            "\n{details} intervals in all: every one with --verbose, the whole report with --json"
        ));
    }
    out
}

/// One line of a limit violation, its amount and limit already formatted with their unit.
fn violation(v: &LimitViolation, amount: &str, limit: &str) -> String {
    format!(
        "  {:>7.3}–{:<7.3} s  {:<20} {amount} beyond its limit of {limit} ({})",
        v.time,
        v.end_time,
        v.joint,
        if v.commanded {
            "commanded"
        } else {
            "not commanded"
        }
    )
}

/// Self-collisions: per pair of links, the count and the deepest; with `verbose` every one.
fn collisions(collisions: &[Collision], verbose: bool, line: &mut impl FnMut(String)) {
    if collisions.is_empty() {
        return;
    }
    let mut pairs: Vec<(&str, &str, usize, &Collision)> = Vec::new();
    for c in collisions {
        match pairs
            .iter_mut()
            .find(|p| (p.0, p.1) == (c.link_a.as_str(), c.link_b.as_str()))
        {
            Some(p) => {
                p.2 += 1;
                if c.max_penetration > p.3.max_penetration {
                    p.3 = c;
                }
            }
            None => pairs.push((&c.link_a, &c.link_b, 1, c)),
        }
    }
    pairs.sort_by(|a, b| b.3.max_penetration.total_cmp(&a.3.max_penetration));
    line("deepest self-collision per pair of links:".into());
    for (a, b, n, c) in &pairs {
        line(format!(
            "  {a} ↔ {b}: {n} time(s), deepest {:.1} mm at {:.3} s{}",
            c.max_penetration * 1e3,
            c.time,
            if c.held_part {
                " (a part held still, not commanded)"
            } else {
                ""
            }
        ));
    }
    if verbose {
        line("every self-collision:".into());
        for c in collisions {
            line(format!(
                "  {:>7.3}–{:<7.3} s  {} ↔ {} (deepest {:.1} mm)",
                c.time,
                c.end_time,
                c.link_a,
                c.link_b,
                c.max_penetration * 1e3
            ));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use sgplvm::robots::physics::JointTracking;

    fn joint(name: &str, prismatic: bool) -> JointTracking {
        JointTracking {
            name: name.into(),
            rms_error: 0.01,
            max_error: 0.02,
            max_error_time: 1.0,
            prismatic,
        }
    }

    fn beyond(joint: &str, amount: f64, limit: f64) -> LimitViolation {
        LimitViolation {
            time: 1.0,
            end_time: 1.5,
            joint: joint.into(),
            amount,
            limit,
            commanded: true,
        }
    }

    /// Each line of the summary gives its numbers in one unit and names it (issue 38: it said
    /// `1.28° beyond -0.314`, degrees beside radians).
    #[test]
    fn every_violation_line_has_one_named_unit() {
        let report = ReplayReport {
            duration: 2.0,
            physics_steps: 2000,
            wall_seconds: 0.1,
            joints: vec![joint("LShLat", false), joint("slide", true)],
            limit_violations: vec![
                beyond("LShLat", 0.0223, -0.314),
                beyond("slide", 0.0032, 0.12),
            ],
            velocity_violations: vec![beyond("LShLat", 4.95, -4.0), beyond("slide", 0.1, 0.5)],
            collisions: Vec::new(),
            warnings: Vec::new(),
            collision_shapes: 0,
            mesh_hulls: 0,
            mesh_seconds: 0.0,
            unchecked_meshes: Vec::new(),
            simulated: None,
            held: Vec::new(),
            overlapping_at_rest: Vec::new(),
            diverged: None,
        };
        let text = replay_text("test.urdf", &report, false);
        let lines: Vec<&str> = text
            .lines()
            .filter(|l| l.contains("beyond its limit of"))
            .collect();
        assert_eq!(lines.len(), 4, "{text}");
        let wanted = [
            ("LShLat", "1.28° beyond its limit of -17.99°"),
            ("slide", "3.2 mm beyond its limit of 120.0 mm"),
            ("LShLat", "4.95 rad/s beyond its limit of -4.000 rad/s"),
            ("slide", "0.10 m/s beyond its limit of 0.500 m/s"),
        ];
        for (joint, says) in wanted {
            assert!(
                lines.iter().any(|l| l.contains(joint) && l.contains(says)),
                "no line says {says}:\n{text}"
            );
        }
        for l in &lines {
            let units = ["°", " mm", "rad/s", "m/s"]
                .iter()
                .filter(|u| l.contains(*u))
                .count();
            assert_eq!(units, 1, "{l}");
        }
        // The prismatic joint's row is in millimetres, marked and explained.
        assert!(
            text.contains("slide *") && text.contains("* prismatic: millimetres"),
            "{text}"
        );
    }
}
