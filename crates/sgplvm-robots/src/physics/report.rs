//! The last stage of a replay: what it measured. Per joint the tracking error; limit and
//! velocity excursions and self-collisions as time intervals — an event opens at the first
//! physics step that crosses, is extended while the crossing lasts and closes once it has not
//! been extended for [`ReplayOptions::merge_gap_seconds`](super::ReplayOptions::merge_gap_seconds);
//! the report lists each kind ordered by start time.

use std::collections::HashMap;
use std::hash::Hash;

use serde::Serialize;

use super::{MeshProblem, Trajectory, UncheckedMesh};

/// Tracking quality of one joint over every physics step.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct JointTracking {
    /// The joint's URDF name.
    pub name: String,
    /// Root mean square of (reference − simulated position), rad (m for prismatic joints).
    pub rms_error: f64,
    /// Largest absolute error.
    pub max_error: f64,
    /// When the largest error happened, seconds (trajectory time).
    pub max_error_time: f64,
    /// Whether the joint is prismatic: its errors, limits and violations are in metres (m/s),
    /// not radians (rad/s).
    pub prismatic: bool,
}

/// A stretch of time during which a joint was beyond one of its limits.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LimitViolation {
    /// When the excursion began, seconds (trajectory time).
    pub time: f64,
    /// The last physics step still beyond the limit, seconds.
    pub end_time: f64,
    /// The joint's URDF name.
    pub joint: String,
    /// The largest distance beyond the limit, rad (m for prismatic joints).
    pub amount: f64,
    /// The limit that was crossed (the lower or the upper one).
    pub limit: f64,
    /// True when the reference itself went beyond the limit; false when the simulated joint
    /// did (e.g. dragged by gravity or a collision, or with limits not enforced).
    pub commanded: bool,
}

/// A stretch of time during which two links of the robot touched or penetrated.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Collision {
    /// When the contact began, seconds (trajectory time).
    pub time: f64,
    /// The last physics step still in contact, seconds.
    pub end_time: f64,
    /// One link's URDF name (the pair is in URDF link order).
    pub link_a: String,
    /// The other link's URDF name.
    pub link_b: String,
    /// The deepest penetration seen, metres (0 for a touch).
    pub max_penetration: f64,
    /// Where it was: the midpoint of the two links' contact points at the deepest penetration
    /// (at the first contact for a touch), metres, in the root link's frame (the root is
    /// fixed at the world's origin).
    pub point: [f64; 3],
    /// Whether one of the links is a part the trajectory does not command (the nearest movable
    /// joint above it is held: a finger, the head, a torso lift).
    pub held_part: bool,
}

/// The moment a replay ran away: a joint turning (or sliding) far faster than its limit and
/// its reference for a while, which no motor following a trajectory does; the replay stops
/// there, for what would follow is not the robot's motion.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Divergence {
    /// When, seconds (trajectory time).
    pub time: f64,
    /// The joint's URDF name.
    pub joint: String,
    /// Its speed then, rad/s (m/s for a prismatic joint).
    pub speed: f64,
    /// The speed it was judged against: ten times its URDF velocity limit, at least 20 rad/s
    /// (2 m/s) and at least twice its reference's; it was also more than 0.35 rad (5 cm) from
    /// its reference, for 10 ms.
    pub threshold: f64,
    /// Whether the joint is prismatic.
    pub prismatic: bool,
    /// The trajectory's own jump shortly before ([`JUMP_WINDOW_SECONDS`]), if it has one: a
    /// frame-to-frame step of a commanded joint faster than half that joint's runaway speed. Then
    /// the reference flung the arm, not the physics: such a trajectory asks more than any motor
    /// gives (`predict` and `teleop` hold their commands within the velocity limits; `retarget`
    /// counts the frames where a posture jumps).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub after_jump: Option<ReferenceJump>,
}

/// How long before a runaway the trajectory's own jump is taken as its cause, seconds.
pub const JUMP_WINDOW_SECONDS: f64 = 0.5;

/// One frame-to-frame step of a trajectory's column faster than its joint could follow.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ReferenceJump {
    /// The joint's URDF name.
    pub joint: String,
    /// When the step ends, seconds (trajectory time).
    pub time: f64,
    /// How far it steps, rad (m for a prismatic joint).
    pub change: f64,
    /// Over how long, seconds.
    pub seconds: f64,
    /// Whether the joint is prismatic.
    pub prismatic: bool,
}

/// Everything a replay measured.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ReplayReport {
    /// Simulated time, seconds (last minus first frame time).
    pub duration: f64,
    /// Physics steps taken.
    pub physics_steps: usize,
    /// Wall-clock time of the trajectory's physics steps (settling excluded), seconds.
    pub wall_seconds: f64,
    /// Tracking per movable joint, in the order of the trajectory's columns (joints held
    /// still because they had no column follow).
    pub joints: Vec<JointTracking>,
    /// Limit excursions, ordered by start time.
    pub limit_violations: Vec<LimitViolation>,
    /// Stretches of time during which a joint moved faster than its URDF velocity limit,
    /// ordered by start time; `amount` and `limit` are speeds (rad/s or m/s, `limit` signed
    /// like the velocity), `commanded` as for position limits (the reference's slope, or the
    /// simulated joint's velocity).
    pub velocity_violations: Vec<LimitViolation>,
    /// Self-collisions, ordered by start time; consecutive steps in contact form one event.
    pub collisions: Vec<Collision>,
    /// Things the model loader worked around (floating roots fixed ...).
    pub warnings: Vec<String>,
    /// Collision shapes in the simulation: the URDF's primitives and its meshes' hulls.
    pub collision_shapes: usize,
    /// Collision meshes simulated as convex hulls (a concave one as its convex parts, but on a
    /// hand's fingers held still).
    pub mesh_hulls: usize,
    /// Wall-clock seconds spent finding, reading and hulling the collision meshes.
    pub mesh_seconds: f64,
    /// Collision meshes that could not be found, read or hulled, in URDF order: their links
    /// were simulated without them, and collisions with them were not checked.
    pub unchecked_meshes: Vec<UncheckedMesh>,
    /// The simulated positions at the trajectory's frame times, same columns as
    /// [`ReplayReport::joints`], when [`ReplayOptions::record_simulated`](crate::physics::ReplayOptions::record_simulated) is set.
    pub simulated: Option<Trajectory>,
    /// The joints held still by their controllers (welded at these values: see
    /// [`ReplayOptions::held`](crate::physics::ReplayOptions::held)), in URDF order.
    pub held: Vec<(String, f64)>,
    /// Link pairs that are the model's own closeness at the rest posture (every joint at its
    /// hold value): touching there, or within a centimetre with at most two moving joints
    /// between (a joint's housing next to the next link's); not checked, as retargeting leaves
    /// them out.
    pub overlapping_at_rest: Vec<(String, String)>,
    /// Where the replay ran away and stopped, if it did.
    pub diverged: Option<Divergence>,
}

/// `1 one` or `n many`.
fn plural(n: usize, one: &str, many: &str) -> String {
    if n == 1 {
        format!("1 {one}")
    } else {
        format!("{n} {many}")
    }
}

/// A physics step and its trajectory time, seconds.
#[derive(Debug, Clone, Copy)]
pub(super) struct StepTime {
    /// 1-based index of the step.
    pub(super) step: usize,
    /// Trajectory time at the end of the step.
    pub(super) t: f64,
}

/// An open limit or collision event.
pub(super) struct OpenEvent {
    start: f64,
    end: f64,
    amount: f64,
    limit: f64,
    last_step: usize,
    /// Where the event was when it was deepest (contacts only).
    point: [f64; 3],
}

/// Opens or extends the event `key` at step `at` with excess `beyond` over `limit` at
/// `point` (kept from the opening step and from each deeper step).
fn extend_event<K: Eq + Hash>(
    open: &mut HashMap<K, OpenEvent>,
    key: K,
    at: StepTime,
    (beyond, limit): (f64, f64),
    point: [f64; 3],
) {
    let StepTime { step, t } = at;
    let event = open.entry(key).or_insert(OpenEvent {
        start: t,
        end: t,
        amount: 0.0,
        limit,
        last_step: step,
        point,
    });
    event.end = t;
    event.last_step = step;
    if beyond > event.amount {
        event.amount = beyond;
        event.limit = limit;
        event.point = point;
    }
}

/// Moves every event not extended during the last `gap` steps before `step` (inclusive of
/// `step`) from `open` to `emit`.
fn close_events<K: Copy + Eq + Hash>(
    open: &mut HashMap<K, OpenEvent>,
    step: usize,
    gap: usize,
    mut emit: impl FnMut(K, OpenEvent),
) {
    if open.is_empty() {
        return;
    }
    let done: Vec<K> = open
        .iter()
        .filter(|(_, e)| step - e.last_step > gap)
        .map(|(k, _)| *k)
        .collect();
    for key in done {
        if let Some(event) = open.remove(&key) {
            emit(key, event);
        }
    }
}

/// A joint limit check: (index of the joint in report order, whether the reference or the
/// simulated joint crossed).
type JointCheck = (usize, bool);

/// The limit, velocity and collision events of a replay, open and closed.
struct Events {
    /// Joint names in report order.
    joints: Vec<String>,
    /// URDF link names, in URDF order.
    links: Vec<String>,
    /// Per link, whether it is a part the trajectory does not command.
    held_part: Vec<bool>,
    open_limits: HashMap<JointCheck, OpenEvent>,
    open_speeds: HashMap<JointCheck, OpenEvent>,
    open_contacts: HashMap<(usize, usize), OpenEvent>,
    limit_violations: Vec<LimitViolation>,
    velocity_violations: Vec<LimitViolation>,
    collisions: Vec<Collision>,
}

impl Events {
    /// Closes every event not extended during the last `gap` steps before `step`.
    fn close(&mut self, step: usize, gap: usize) {
        let joints = &self.joints;
        let violation = |(i, commanded): JointCheck, e: OpenEvent| LimitViolation {
            time: e.start,
            end_time: e.end,
            joint: joints[i].clone(),
            amount: e.amount,
            limit: e.limit,
            commanded,
        };
        close_events(&mut self.open_speeds, step, gap, |key, e| {
            self.velocity_violations.push(violation(key, e))
        });
        close_events(&mut self.open_limits, step, gap, |key, e| {
            self.limit_violations.push(violation(key, e))
        });
        let (links, held) = (&self.links, &self.held_part);
        close_events(&mut self.open_contacts, step, gap, |(a, b), e| {
            self.collisions.push(Collision {
                time: e.start,
                end_time: e.end,
                link_a: links[a].clone(),
                link_b: links[b].clone(),
                max_penetration: e.amount,
                point: e.point,
                held_part: held.get(a).copied().unwrap_or(false)
                    || held.get(b).copied().unwrap_or(false),
            })
        });
    }

    /// Closes what is still open and returns (limit violations, velocity violations,
    /// collisions), each ordered by start time.
    fn finish(mut self) -> (Vec<LimitViolation>, Vec<LimitViolation>, Vec<Collision>) {
        self.close(usize::MAX, 0);
        let by_time = |x: &LimitViolation, y: &LimitViolation| {
            x.time
                .total_cmp(&y.time)
                .then_with(|| x.joint.cmp(&y.joint))
                .then_with(|| y.commanded.cmp(&x.commanded))
        };
        self.limit_violations.sort_by(by_time);
        self.velocity_violations.sort_by(by_time);
        self.collisions.sort_by(|x, y| {
            x.time
                .total_cmp(&y.time)
                .then_with(|| x.link_a.cmp(&y.link_a))
                .then_with(|| x.link_b.cmp(&y.link_b))
        });
        (
            self.limit_violations,
            self.velocity_violations,
            self.collisions,
        )
    }
}

/// Everything measured during the physics steps, turned into a [`ReplayReport`] at the end.
pub(super) struct Recorder {
    sum_sq: Vec<f64>,
    max_err: Vec<f64>,
    max_err_time: Vec<f64>,
    /// The simulated positions of the latest step, in report order.
    actual: Vec<f64>,
    /// Per joint (report order), whether it is prismatic.
    prismatic: Vec<bool>,
    events: Events,
    /// Simulated positions at the frame times, when recorded.
    simulated: Option<Vec<f64>>,
    /// The next trajectory frame to record.
    next_frame: usize,
}

impl Recorder {
    /// A recorder for the driven joints `joints` (report order; `prismatic` says which slide)
    /// of a robot with links `links` (`held_part`: which are parts the trajectory does not
    /// command); errors start at time `t0`; with `record_simulated`, the positions at the
    /// trajectory's `frames` frame times are kept.
    pub(super) fn new(
        joints: Vec<String>,
        prismatic: Vec<bool>,
        (links, held_part): (Vec<String>, Vec<bool>),
        t0: f64,
        record_simulated: bool,
        frames: usize,
    ) -> Self {
        let n = joints.len();
        Recorder {
            sum_sq: vec![0.0f64; n],
            max_err: vec![0.0f64; n],
            max_err_time: vec![t0; n],
            actual: vec![0.0f64; n],
            prismatic,
            simulated: record_simulated.then(|| Vec::with_capacity(frames * n)),
            next_frame: 1,
            events: Events {
                joints,
                links,
                held_part,
                open_limits: HashMap::new(),
                open_speeds: HashMap::new(),
                open_contacts: HashMap::new(),
                limit_violations: Vec::new(),
                velocity_violations: Vec::new(),
                collisions: Vec::new(),
            },
        }
    }

    /// Records the first frame's simulated positions (after settling).
    pub(super) fn first_frame(&mut self, positions: impl Iterator<Item = f64>) {
        if let Some(sim) = self.simulated.as_mut() {
            sim.extend(positions);
        }
    }

    /// Records joint `i`'s simulated position `q` against its `reference` at time `t`.
    pub(super) fn track(&mut self, i: usize, reference: f64, q: f64, t: f64) {
        self.actual[i] = q;
        let e = (reference - q).abs();
        self.sum_sq[i] += e * e;
        if e > self.max_err[i] {
            self.max_err[i] = e;
            self.max_err_time[i] = t;
        }
    }

    /// Opens or extends the position-limit events of joint `i` (limits `lo`, `hi`) for the
    /// reference and the simulated position `q` that are more than `tol` beyond.
    pub(super) fn position_limits(
        &mut self,
        i: usize,
        (lo, hi): (f64, f64),
        (reference, q): (f64, f64),
        tol: f64,
        at: StepTime,
    ) {
        for (commanded, value) in [(true, reference), (false, q)] {
            let (beyond, limit) = if value > hi {
                (value - hi, hi)
            } else {
                (lo - value, lo)
            };
            if beyond > tol {
                let open = &mut self.events.open_limits;
                extend_event(open, (i, commanded), at, (beyond, limit), [0.0; 3]);
            }
        }
    }

    /// Opens or extends the velocity-limit events of joint `i` for the reference's `slope`
    /// and the simulated velocity `measured` when their speed exceeds `max_speed` by more
    /// than `tol`.
    pub(super) fn velocity_limits(
        &mut self,
        i: usize,
        max_speed: f64,
        (slope, measured): (f64, f64),
        tol: f64,
        at: StepTime,
    ) {
        for (commanded, value) in [(true, slope), (false, measured)] {
            let beyond = value.abs() - max_speed;
            if beyond > tol {
                let limit = max_speed.copysign(value);
                let open = &mut self.events.open_speeds;
                extend_event(open, (i, commanded), at, (beyond, limit), [0.0; 3]);
            }
        }
    }

    /// Opens or extends the collision event of links `a` and `b` with penetration `depth`
    /// (>= 0) at `point` (root frame).
    pub(super) fn contact(
        &mut self,
        (a, b): (usize, usize),
        depth: f64,
        point: [f64; 3],
        at: StepTime,
    ) {
        let key = (a.min(b), a.max(b));
        extend_event(&mut self.events.open_contacts, key, at, (depth, 0.0), point);
    }

    /// Closes the events not extended during the last `gap` steps before `step`.
    pub(super) fn close_events(&mut self, step: usize, gap: usize) {
        self.events.close(step, gap);
    }

    /// Keeps the simulated positions for every frame whose time is nearest to step time `t`.
    pub(super) fn frames_at(&mut self, trajectory: &Trajectory, t: f64, rate: f64) {
        if let Some(sim) = self.simulated.as_mut() {
            while self.next_frame < trajectory.frames()
                && trajectory.times[self.next_frame] <= t + 0.5 / rate
            {
                sim.extend_from_slice(&self.actual);
                self.next_frame += 1;
            }
        }
    }

    /// The report of `steps` physics steps over `duration` seconds.
    pub(super) fn finish(
        self,
        trajectory: &Trajectory,
        duration: f64,
        steps: usize,
        wall_seconds: f64,
        warnings: Vec<String>,
    ) -> ReplayReport {
        let Recorder {
            sum_sq,
            max_err,
            max_err_time,
            actual,
            events,
            simulated,
            prismatic,
            ..
        } = self;
        let joint_names = events.joints.clone();
        let (limit_violations, velocity_violations, collisions) = events.finish();
        let joints = joint_names
            .iter()
            .enumerate()
            .map(|(i, name)| JointTracking {
                name: name.clone(),
                rms_error: (sum_sq[i] / steps as f64).sqrt(),
                max_error: max_err[i],
                max_error_time: max_err_time[i],
                prismatic: prismatic.get(i).copied().unwrap_or(false),
            })
            .collect();
        let simulated = simulated.map(|mut positions| {
            // A frame the loop could not reach (only possible through rounding) repeats the last.
            while positions.len() < trajectory.frames() * joint_names.len() {
                positions.extend_from_slice(&actual);
            }
            Trajectory {
                joint_names,
                times: trajectory.times.clone(),
                positions,
            }
        });
        ReplayReport {
            duration,
            physics_steps: steps,
            wall_seconds,
            joints,
            limit_violations,
            velocity_violations,
            collisions,
            warnings,
            collision_shapes: 0,
            mesh_hulls: 0,
            mesh_seconds: 0.0,
            unchecked_meshes: Vec::new(),
            simulated,
            held: Vec::new(),
            overlapping_at_rest: Vec::new(),
            diverged: None,
        }
    }
}

impl ReplayReport {
    /// One sentence on the self-collisions and on what could not be checked, e.g. "no
    /// self-collisions among the 38 collision shapes checked; 4 collision meshes of links a, b
    /// could not be checked (not found)". It never says "no self-collisions" alone when
    /// collision meshes were left out.
    pub fn self_collision_summary(&self) -> String {
        let shapes = plural(self.collision_shapes, "collision shape", "collision shapes");
        let mut text = if self.collision_shapes == 0 {
            "self-collisions not checked: no collision shapes".to_string()
        } else if self.collisions.is_empty() {
            format!("no self-collisions among the {shapes} checked")
        } else {
            let mut pairs: Vec<(&str, &str)> = self
                .collisions
                .iter()
                .map(|c| (c.link_a.as_str(), c.link_b.as_str()))
                .collect();
            pairs.sort_unstable();
            pairs.dedup();
            let mut held: Vec<(&str, &str)> = self
                .collisions
                .iter()
                .filter(|c| c.held_part)
                .map(|c| (c.link_a.as_str(), c.link_b.as_str()))
                .collect();
            held.sort_unstable();
            held.dedup();
            let held = if held.is_empty() {
                String::new()
            } else {
                format!(
                    " ({} of them with a part held still, which the trajectory does not command)",
                    held.len()
                )
            };
            format!(
                "{} between {}{held} among the {shapes} checked",
                plural(
                    self.collisions.len(),
                    "self-collision interval",
                    "self-collision intervals"
                ),
                plural(pairs.len(), "pair of links", "pairs of links"),
            )
        };
        if let Some(unchecked) = self.unchecked_summary() {
            text.push_str("; ");
            text.push_str(&unchecked);
        }
        text
    }

    /// "4 collision meshes of links a, b could not be checked (not found)", or None when every
    /// collision mesh was simulated.
    pub fn unchecked_summary(&self) -> Option<String> {
        let meshes = &self.unchecked_meshes;
        if meshes.is_empty() {
            return None;
        }
        let mut links: Vec<String> = Vec::new();
        let mut problems: Vec<(MeshProblem, usize)> = Vec::new();
        for m in meshes {
            if !links.contains(&m.link) {
                links.push(m.link.clone());
            }
            match problems.iter_mut().find(|(p, _)| *p == m.problem) {
                Some((_, n)) => *n += 1,
                None => problems.push((m.problem, 1)),
            }
        }
        let why = if problems.len() == 1 {
            problems[0].0.describe().to_string()
        } else {
            problems
                .iter()
                .map(|(p, n)| format!("{n} {}", p.describe()))
                .collect::<Vec<_>>()
                .join(", ")
        };
        Some(format!(
            "{} of {} {} could not be checked ({why})",
            plural(meshes.len(), "collision mesh", "collision meshes"),
            if links.len() == 1 { "link" } else { "links" },
            crate::names::few(&links, crate::names::SHOWN),
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn events_close_when_not_extended() {
        let mut open = HashMap::new();
        let event = |step| OpenEvent {
            start: 0.1,
            end: 0.2,
            amount: 0.5,
            limit: 1.0,
            last_step: step,
            point: [0.0; 3],
        };
        open.insert(1usize, event(7));
        open.insert(2usize, event(8));
        let mut closed = Vec::new();
        close_events(&mut open, 8, 0, |k, e| closed.push((k, e.last_step)));
        assert_eq!(closed, vec![(1, 7)]);
        assert!(open.contains_key(&2) && open.len() == 1);
        // With a gap of 3 steps, an event last extended at step 8 stays open through step 11.
        close_events(&mut open, 11, 3, |k, e| closed.push((k, e.last_step)));
        assert_eq!(closed.len(), 1);
        close_events(&mut open, 12, 3, |k, e| closed.push((k, e.last_step)));
        assert_eq!(closed, vec![(1, 7), (2, 8)]);
    }
}
