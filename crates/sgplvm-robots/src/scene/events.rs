//! A physics replay's events as Foxglove markers: every joint-limit and velocity-limit
//! excursion a sphere at the offending joint (the origin of its child link, so it moves with
//! the robot) and every self-collision a sphere at the contact point (in the root link's
//! frame, where rapier reported it), each with a text label, published at the event's start
//! and lasting until its end.

use super::{MarkerShape, SceneBody, SceneMarker, TimedMarkers};
use crate::physics::{LimitViolation, ReplayReport};

/// Shortest lifetime of a marker, nanoseconds: an event of one physics step stays visible
/// for about two 40 Hz frames.
pub const MIN_MARKER_LIFETIME_NS: i64 = 50_000_000;

/// Marker namespaces, one per kind of event (labels in `<ns>_label`).
pub const JOINT_LIMIT_NS: &str = "joint_limit";
/// Namespace of velocity-limit markers.
pub const VELOCITY_LIMIT_NS: &str = "velocity_limit";
/// Namespace of collision markers.
pub const COLLISION_NS: &str = "collision";

/// The markers of `report`'s events on `topic`, for `body` (the replayed robot), one
/// [`TimedMarkers`] per event at `t0_ns` plus its start time. A limit event of a joint that
/// `body` does not have is drawn at its root link.
pub fn replay_markers(
    body: &SceneBody,
    report: &ReplayReport,
    t0_ns: i64,
    topic: &str,
) -> Vec<TimedMarkers> {
    let robot = &body.robot;
    let root = body.frame(robot.root);
    let at = |t: f64| t0_ns.saturating_add((t * 1e9).round() as i64);
    let lifetime =
        |start: f64, end: f64| (((end - start) * 1e9).round() as i64).max(MIN_MARKER_LIFETIME_NS);
    let mut out = Vec::new();
    let mut event = |ns: &str,
                     id: i32,
                     (time, end): (f64, f64),
                     (frame, position): (String, [f64; 3]),
                     (size, color): (f64, [f32; 4]),
                     label: String| {
        let lifetime_ns = lifetime(time, end);
        let above = [position[0], position[1], position[2] + size];
        out.push(TimedMarkers {
            topic: topic.to_string(),
            time_ns: at(time),
            markers: vec![
                SceneMarker {
                    frame: frame.clone(),
                    ns: ns.to_string(),
                    id,
                    shape: MarkerShape::Sphere,
                    position,
                    scale: [size; 3],
                    color,
                    lifetime_ns,
                },
                SceneMarker {
                    frame,
                    ns: format!("{ns}_label"),
                    id,
                    shape: MarkerShape::Text(label),
                    position: above,
                    scale: [0.0, 0.0, 0.04],
                    color: [1.0, 1.0, 1.0, 1.0],
                    lifetime_ns,
                },
            ],
        });
    };
    let joint_frame = |v: &LimitViolation| {
        let link = robot
            .joints()
            .iter()
            .find(|j| j.name == v.joint)
            .map_or(robot.root, |j| j.child);
        (body.frame(link), [0.0; 3])
    };
    let who = |v: &LimitViolation| {
        if v.commanded {
            "commanded"
        } else {
            "simulated"
        }
    };
    for (k, v) in report.limit_violations.iter().enumerate() {
        let color = if v.commanded {
            [1.0, 0.55, 0.0, 0.8]
        } else {
            [1.0, 0.0, 0.0, 0.8]
        };
        let label = format!(
            "{} {:.3} rad beyond {:.3} ({})",
            v.joint,
            v.amount,
            v.limit,
            who(v)
        );
        let id = k as i32;
        event(
            JOINT_LIMIT_NS,
            id,
            (v.time, v.end_time),
            joint_frame(v),
            (0.06, color),
            label,
        );
    }
    for (k, v) in report.velocity_violations.iter().enumerate() {
        let label = format!(
            "{} {:.2} rad/s over {:.2} ({})",
            v.joint,
            v.amount,
            v.limit.abs(),
            who(v)
        );
        let color = [1.0, 1.0, 0.0, 0.6];
        let id = k as i32;
        event(
            VELOCITY_LIMIT_NS,
            id,
            (v.time, v.end_time),
            joint_frame(v),
            (0.05, color),
            label,
        );
    }
    for (k, c) in report.collisions.iter().enumerate() {
        let label = format!(
            "{} – {} {:.1} mm",
            c.link_a,
            c.link_b,
            c.max_penetration * 1e3
        );
        let color = [1.0, 0.0, 1.0, 0.9];
        let id = k as i32;
        event(
            COLLISION_NS,
            id,
            (c.time, c.end_time),
            (root.clone(), c.point),
            (0.04, color),
            label,
        );
    }
    out
}
