//! Everything the commands print as their result: the training line, the evaluation table, the
//! demo's table and the replay summary, each as text or JSON.

use std::path::{Path, PathBuf};

use serde_json::json;
use sgplvm::experiment::ModelKind;
use sgplvm::pipeline::{Demonstrations, Evaluation, StudyModel};
use sgplvm::robots::physics::{Collision, LimitViolation, ReplayReport};
use sgplvm::SharedGplvm;

/// After `train` or `transfer`: robots, seconds, iterations, objective and stop reason.
pub fn training(model: &SharedGplvm, seconds: f64, out: &Path, json: bool) {
    let history = model.history();
    let objective = history.last().map(|r| r.objective);
    let stop = model
        .stop_reason()
        .map(|r| format!("{r:?}"))
        .unwrap_or_default();
    if json {
        let value = json!({
            "model": out.display().to_string(),
            "robots": model.output_names(),
            "iterations": history.last().map_or(0, |r| r.iteration),
            "seconds": seconds,
            "objective": objective,
            "stop_reason": stop,
            "selection": model.selection(),
        });
        println!("{value}");
    } else {
        println!(
            "trained {} in {:.2} s, {} iterations, objective {:.3} ({stop}); wrote {}",
            model.output_names().join(" + "),
            seconds,
            history.last().map_or(0, |r| r.iteration),
            objective.unwrap_or(f64::NAN),
            out.display()
        );
        if let Some(s) = model.selection() {
            let best = s.curve.iter().find(|r| r.iteration == s.best_iteration);
            println!(
                "  budget chosen on {} held-out training frames (trained on the other {} until \
                 their error had not fallen for {} iterations): {} iterations, held-out MSE {:.6}",
                s.validation_frames,
                s.fit_frames,
                s.patience,
                s.best_iteration,
                best.map_or(f64::NAN, |r| r.validation_mse)
            );
        }
    }
}

/// `evaluate`: the test error overall and per joint.
pub fn evaluation(e: &Evaluation, json: bool) -> serde_json::Result<()> {
    if json {
        println!("{}", serde_json::to_string_pretty(e)?);
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
fn demo_label(kind: ModelKind) -> &'static str {
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

/// `simulate`: tracking per joint, limit violations, self-collisions and warnings.
pub fn replay(source: &str, report: &ReplayReport, json: bool) -> serde_json::Result<()> {
    if json {
        println!("{}", serde_json::to_string_pretty(report)?);
        return Ok(());
    }
    println!(
        "{source}: {:.1} s of motion, {} physics steps in {:.2} s ({:.0}× real time); times below from the start",
        report.duration,
        report.physics_steps,
        report.wall_seconds,
        report.duration / report.wall_seconds.max(1e-9)
    );
    println!("\n{:<24} {:>12} {:>12}", "joint", "RMS (deg)", "max (deg)");
    for j in &report.joints {
        println!(
            "{:<24} {:>12.3} {:>12.3}",
            j.name,
            j.rms_error.to_degrees(),
            j.max_error.to_degrees()
        );
    }
    if report.limit_violations.is_empty() {
        println!("\nno joint-limit violations");
    } else {
        println!("\njoint-limit violations:");
        for v in &report.limit_violations {
            let amount = format!("{:.2}°", v.amount.to_degrees());
            println!("{}", violation(v, &amount, &format!("{:.3}", v.limit)));
        }
    }
    if !report.velocity_violations.is_empty() {
        println!("velocity-limit violations:");
        for v in &report.velocity_violations {
            let amount = format!("{:.2} rad/s", v.amount);
            println!(
                "{}",
                violation(v, &amount, &format!("{:.3} rad/s", v.limit))
            );
        }
    }
    collisions(&report.collisions);
    for w in &report.warnings {
        eprintln!("warning: {w}");
    }
    Ok(())
}

/// One line of a limit violation, its amount and limit already formatted with their unit.
fn violation(v: &LimitViolation, amount: &str, limit: &str) -> String {
    format!(
        "  {:>7.3}–{:<7.3} s  {:<20} {amount} beyond {limit} ({})",
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

fn collisions(collisions: &[Collision]) {
    if collisions.is_empty() {
        println!("no self-collisions");
        return;
    }
    println!("self-collisions:");
    for c in collisions {
        println!(
            "  {:>7.3}–{:<7.3} s  {} ↔ {} (deepest {:.1} mm)",
            c.time,
            c.end_time,
            c.link_a,
            c.link_b,
            c.max_penetration * 1e3
        );
    }
}
