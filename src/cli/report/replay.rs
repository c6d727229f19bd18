//! `simulate`'s report: tracking per joint, limit excursions and self-collisions of a physics
//! replay, each line in one named unit.

use sgplvm::robots::physics::{Collision, LimitViolation, ReplayReport};

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
    let stopped = format!(
        "{} moved at {:.1} {unit} (beyond {:.1} {unit}) away from its reference for 10 ms; it stopped there, and the figures cover the motion before",
        d.joint, d.speed, d.threshold
    );
    match &d.after_jump {
        Some(j) => format!(
            "the replay ran away at {:.3} s, flung by the trajectory itself: at {:.3} s it asks {} to move {:.2} {} in {:.0} ms ({:.0} {}/s, faster than any motor follows: a posture jump in the demonstrations, see `retarget`'s report; `predict` and `teleop` keep their commands within the velocity limits); {stopped}",
            d.time,
            j.time,
            j.joint,
            j.change,
            if j.prismatic { "m" } else { "rad" },
            1e3 * j.seconds,
            j.change.abs() / j.seconds,
            if j.prismatic { "m" } else { "rad" },
        ),
        None => format!("the replay DIVERGED at {:.3} s: {stopped}", d.time),
    }
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

/// How long the intervals `(start, end)` cover together, seconds: the time with at least one
/// of them open (intervals of several joints overlap; their sum can exceed the motion).
fn covered_seconds(intervals: impl Iterator<Item = (f64, f64)>) -> f64 {
    let mut spans: Vec<(f64, f64)> = intervals.collect();
    spans.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut total = 0.0;
    let mut open: Option<(f64, f64)> = None;
    for (start, end) in spans {
        open = match open {
            Some((s, e)) if start <= e => Some((s, e.max(end))),
            Some((s, e)) => {
                total += e - s;
                Some((start, end))
            }
            None => Some((start, end)),
        };
    }
    total + open.map_or(0.0, |(s, e)| e - s)
}

/// The lines saying what the replay held still and which pairs of links it left unchecked.
fn held_and_unchecked(report: &ReplayReport) -> Vec<String> {
    let mut lines = Vec::new();
    if !report.held.is_empty() {
        let names: Vec<&str> = report.held.iter().map(|(n, _)| n.as_str()).collect();
        lines.push(format!(
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
        lines.push(format!(
            "not checked: {} pair(s) of links touching at rest or a joint housing's width apart (within 1 cm, at most two joints between), the model's own closeness ({})",
            pairs.len(),
            shown(&pairs, 4)
        ));
    }
    lines
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
    let pace = if ratio >= 10.0 {
        format!("{ratio:.0}× faster than real time")
    } else if ratio >= 1.0 {
        // "1× faster" for 78 s of work on 110 s of motion said nothing.
        format!("{ratio:.1}× faster than real time")
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
    held_and_unchecked(report).into_iter().for_each(&mut line);
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
        let seconds = covered_seconds(violations.iter().map(|v| (v.time, v.end_time)));
        line(format!(
            "{kind} violations: {} intervals on {} joint(s), {seconds:.2} s of the {:.2} s with a \
             joint beyond; {commanded} commanded (the trajectory itself beyond the limit), {} not",
            violations.len(),
            joints.len(),
            report.duration,
            violations.len() - commanded
        ));
        if commanded > 0 && kind.starts_with("velocity") {
            line(
                "  the trajectory itself is faster than the joints may move: demonstrations \
                 retargeted without velocity limits (as training data is made) or a posture \
                 jump flings the arm; `retarget --velocity-limits`, `predict` and `simulate \
                 --model` send commands within them"
                    .into(),
            );
        }
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
            "collision meshes: {} simulated as convex hulls or, concave, as their convex parts (read in {:.2} s), {} not",
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
        "  {:>7.3}–{:<7.3} s  {:<20} past its limit of {limit} by up to {amount} ({})",
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

    /// Overlapping intervals of several joints count once (a replay had "109.62 s in all" of
    /// a 110 s motion, summed over joints).
    #[test]
    fn violation_time_is_the_time_covered_not_the_sum() {
        let spans = [(1.0, 2.0), (1.5, 3.0), (5.0, 5.5), (0.0, 0.5)];
        assert!((covered_seconds(spans.into_iter()) - 3.0).abs() < 1e-12);
        assert_eq!(covered_seconds(std::iter::empty()), 0.0);
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
            .filter(|l| l.contains("past its limit of"))
            .collect();
        assert_eq!(lines.len(), 4, "{text}");
        let wanted = [
            ("LShLat", "past its limit of -17.99° by up to 1.28°"),
            ("slide", "past its limit of 120.0 mm by up to 3.2 mm"),
            (
                "LShLat",
                "past its limit of -4.000 rad/s by up to 4.95 rad/s",
            ),
            ("slide", "past its limit of 0.500 m/s by up to 0.10 m/s"),
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
