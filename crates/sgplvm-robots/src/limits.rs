//! Joint commands kept within a robot's limits: each joint within its URDF position limits,
//! and within its velocity limit of the previous command over the time between them.
//!
//! The rule every command path applies (`sgplvm predict`, `sgplvm teleop`): first the velocity
//! bound (from the previous command sent), then the position limits; each joint that had to be
//! moved is counted, so that a report can say how often the model asked for more than the robot
//! can do.

use crate::{JointKind, Robot, RobotError};

/// The velocity limit a command keeps for a revolute joint whose URDF gives none (`velocity`
/// absent, 0 or negative) when no other commanded joint of its kind states one, rad/s: a
/// command is never unbounded in speed, and a person's arm (up to 5 rad/s) is followed slowly
/// rather than a robot swung at whatever a model asks.
pub const UNSTATED_REVOLUTE_RAD_S: f64 = 1.0;

/// [`UNSTATED_REVOLUTE_RAD_S`] for a prismatic joint, m/s.
pub const UNSTATED_PRISMATIC_M_S: f64 = 0.1;

/// The velocity limit every command keeps for joints `joints` (names) of `robot`, in their
/// order: the URDF's, or where it states none (0, negative or absent), the median of the limits
/// the other named joints of its kind state, else [`UNSTATED_REVOLUTE_RAD_S`] /
/// [`UNSTATED_PRISMATIC_M_S`]. Also a note naming the joints so assumed and the limit taken
/// (none where every joint states its own). Names that are not movable joints are skipped (the
/// callers check them).
pub fn command_velocity_limits(robot: &Robot, joints: &[String]) -> (Vec<f64>, Option<String>) {
    let stated = robot.velocity_limits();
    let found: Vec<Option<(f64, bool)>> = joints
        .iter()
        .map(|n| {
            let i = robot.joint_index(n)?;
            let prismatic = robot.joints[robot.movable[i]].kind == JointKind::Prismatic;
            Some((stated[i], prismatic))
        })
        .collect();
    let median_of = |prismatic: bool| {
        let mut v: Vec<f64> = found
            .iter()
            .flatten()
            .filter(|(v, p)| *p == prismatic && *v > 0.0)
            .map(|(v, _)| *v)
            .collect();
        v.sort_by(f64::total_cmp);
        v.get(v.len() / 2).copied()
    };
    let mut assumed: Vec<String> = Vec::new();
    let limits = found
        .iter()
        .zip(joints)
        .map(|(f, name)| match *f {
            Some((v, _)) if v > 0.0 => v,
            Some((_, prismatic)) => {
                let (fallback, unit) = if prismatic {
                    (UNSTATED_PRISMATIC_M_S, "m/s")
                } else {
                    (UNSTATED_REVOLUTE_RAD_S, "rad/s")
                };
                let v = median_of(prismatic).unwrap_or(fallback);
                assumed.push(format!("{name} {v:.2} {unit}"));
                v
            }
            None => f64::INFINITY,
        })
        .collect();
    let note = (!assumed.is_empty()).then(|| {
        format!(
            "{} commanded joint(s) state no velocity limit in the URDF (velocity absent, 0 or negative); commands keep {}: the median of the other joints' stated limits, else {UNSTATED_REVOLUTE_RAD_S} rad/s ({UNSTATED_PRISMATIC_M_S} m/s prismatic). State the robot's own in its URDF's <limit velocity=...>",
            assumed.len(),
            crate::names::few(&assumed, 4)
        )
    });
    (limits, note)
}

/// A robot's position and velocity limits for the joints of a command, in the command's order.
#[derive(Debug, Clone, PartialEq)]
pub struct CommandLimits {
    names: Vec<String>,
    position: Vec<(f64, f64)>,
    /// rad/s (m/s for prismatic joints); where the URDF gives none, as
    /// [`command_velocity_limits`] assumes.
    velocity: Vec<f64>,
    /// What was assumed for joints whose URDF gives no velocity limit, if any.
    assumed: Option<String>,
}

/// Which joints of one command had to be moved, and by how much at most.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Clamped {
    /// Joints moved back within a position limit.
    pub position: usize,
    /// Joints slowed to their velocity limit.
    pub velocity: usize,
    /// Largest distance a joint was moved (rad).
    pub largest: f64,
}

impl Clamped {
    /// Whether nothing was moved.
    pub fn is_none(&self) -> bool {
        self.position == 0 && self.velocity == 0
    }
}

/// Counts over many commands, per joint.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct LimitCounts {
    /// Commands seen.
    pub commands: usize,
    /// Commands in which some joint was moved.
    pub commands_clamped: usize,
    /// Per joint (command order): times moved within a position limit.
    pub position: Vec<usize>,
    /// Per joint: times slowed to the velocity limit.
    pub velocity: Vec<usize>,
    /// Per joint: the largest distance moved (rad).
    pub largest: Vec<f64>,
}

impl CommandLimits {
    /// The limits of `robot`'s joints named `joints` (a command's columns, in its order). Every
    /// name must be a movable joint of the robot.
    pub fn for_joints(robot: &Robot, joints: &[String]) -> Result<CommandLimits, RobotError> {
        let names = robot.joint_names();
        let limits = robot.joint_limits();
        let (speed, assumed) = command_velocity_limits(robot, joints);
        let mut position = Vec::with_capacity(joints.len());
        for j in joints {
            let Some(k) = names.iter().position(|n| n == j) else {
                return Err(RobotError::Invalid {
                    file: format!("robot {}", robot.name()),
                    element: format!("joint \"{j}\""),
                    message: format!(
                        "not a movable joint of the robot (it has {} movable joints: {}{})",
                        names.len(),
                        names.iter().take(8).cloned().collect::<Vec<_>>().join(", "),
                        if names.len() > 8 { ", …" } else { "" }
                    ),
                });
            };
            position.push(limits[k]);
        }
        Ok(CommandLimits {
            names: joints.to_vec(),
            position,
            velocity: speed,
            assumed,
        })
    }

    /// What was assumed for joints whose URDF states no velocity limit (a note for the user),
    /// if any.
    pub fn assumed(&self) -> Option<&str> {
        self.assumed.as_deref()
    }

    /// The joints' names, in command order.
    pub fn names(&self) -> &[String] {
        &self.names
    }

    /// Position limits per joint.
    pub fn position(&self) -> &[(f64, f64)] {
        &self.position
    }

    /// Velocity limits per joint (assumed where the URDF states none).
    pub fn velocity(&self) -> &[f64] {
        &self.velocity
    }

    /// Moves `q` within the limits: within `velocity · dt` of `previous` (when given with the
    /// seconds since it), then within the position limits. Returns what was moved.
    pub fn apply(&self, q: &mut [f64], previous: Option<(&[f64], f64)>) -> Clamped {
        let mut out = Clamped::default();
        for (k, v) in q.iter_mut().enumerate() {
            let wanted = *v;
            if let Some((prev, dt)) = previous {
                let step = self.velocity[k] * dt.max(0.0);
                let (lo, hi) = (prev[k] - step, prev[k] + step);
                if *v < lo || *v > hi {
                    *v = v.clamp(lo, hi);
                    out.velocity += 1;
                }
            }
            let (lo, hi) = self.position[k];
            if lo <= hi && (*v < lo || *v > hi) {
                *v = v.clamp(lo, hi);
                out.position += 1;
            }
            out.largest = out.largest.max((wanted - *v).abs());
        }
        out
    }

    /// Applies the limits to every row of `rows` (row-major, one command a row, at `times_s`
    /// seconds), each row bounded by the one before as sent; returns the counts. Without a time
    /// per row only the position limits apply.
    pub fn apply_all(&self, rows: &mut [f64], times_s: &[f64]) -> LimitCounts {
        let d = self.names.len();
        let mut stream = LimitedStream::new(self.clone());
        if d == 0 {
            return stream.counts;
        }
        let timed = times_s.len() * d == rows.len();
        for (r, row) in rows.chunks_exact_mut(d).enumerate() {
            stream.push(row, timed.then(|| times_s[r]));
        }
        stream.counts
    }
}

/// Commands limited one at a time as they are sent, each bounded by the one sent before.
#[derive(Debug, Clone)]
pub struct LimitedStream {
    limits: CommandLimits,
    previous: Option<(Vec<f64>, Option<f64>)>,
    counts: LimitCounts,
}

impl LimitedStream {
    /// A stream of commands within `limits`.
    pub fn new(limits: CommandLimits) -> LimitedStream {
        let counts = LimitCounts::new(limits.names.len());
        LimitedStream {
            limits,
            previous: None,
            counts,
        }
    }

    /// Moves the next command `q` within the limits: its position limits, and, when it and the
    /// command before have times (seconds), the velocity limits between them.
    pub fn push(&mut self, q: &mut [f64], time_s: Option<f64>) -> Clamped {
        let wanted = q.to_vec();
        let prev = match (&self.previous, time_s) {
            (Some((p, Some(t0))), Some(t)) => Some((p.as_slice(), t - t0)),
            _ => None,
        };
        let clamped = self.limits.apply(q, prev);
        self.counts.record(&wanted, q, &clamped, &self.limits, prev);
        self.previous = Some((q.to_vec(), time_s));
        clamped
    }

    /// The counts so far.
    pub fn counts(&self) -> &LimitCounts {
        &self.counts
    }

    /// The limits.
    pub fn limits(&self) -> &CommandLimits {
        &self.limits
    }
}

impl LimitCounts {
    /// Empty counts for `joints` joints.
    pub fn new(joints: usize) -> LimitCounts {
        LimitCounts {
            position: vec![0; joints],
            velocity: vec![0; joints],
            largest: vec![0.0; joints],
            ..LimitCounts::default()
        }
    }

    /// Adds one command: `wanted` before the limits, `sent` after.
    pub fn record(
        &mut self,
        wanted: &[f64],
        sent: &[f64],
        clamped: &Clamped,
        limits: &CommandLimits,
        previous: Option<(&[f64], f64)>,
    ) {
        self.commands += 1;
        if clamped.is_none() {
            return;
        }
        self.commands_clamped += 1;
        for k in 0..sent.len() {
            let moved = (wanted[k] - sent[k]).abs();
            if moved == 0.0 {
                continue;
            }
            let (lo, hi) = limits.position[k];
            if wanted[k] < lo || wanted[k] > hi {
                self.position[k] += 1;
            }
            if let Some((p, dt)) = previous {
                if (wanted[k] - p[k]).abs() > limits.velocity[k] * dt.max(0.0) {
                    self.velocity[k] += 1;
                }
            }
            self.largest[k] = self.largest[k].max(moved);
        }
    }

    /// One line for a report: how many commands were limited and by which joints most.
    pub fn summary(&self, robot: &str, names: &[String]) -> String {
        if self.commands_clamped == 0 {
            return format!(
                "all {} commands within {robot}'s position and velocity limits",
                self.commands
            );
        }
        let mut worst: Vec<usize> = (0..names.len())
            .filter(|&k| self.largest[k] > 0.0)
            .collect();
        let times = |k: usize| self.position[k] + self.velocity[k];
        worst.sort_by(|&a, &b| {
            times(b)
                .cmp(&times(a))
                .then(self.largest[b].total_cmp(&self.largest[a]))
        });
        let shown: Vec<String> = worst
            .iter()
            .take(3)
            .map(|&k| {
                format!(
                    "{} {}× (moved up to {:.1}° from the command asked)",
                    names[k],
                    times(k),
                    self.largest[k].to_degrees()
                )
            })
            .collect();
        format!(
            "{} of {} commands moved within {robot}'s limits ({} joint positions beyond a position limit, {} joint steps beyond a velocity limit; most often: {})",
            self.commands_clamped,
            self.commands,
            self.position.iter().sum::<usize>(),
            self.velocity.iter().sum::<usize>(),
            shown.join(", ")
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_joint_without_a_stated_velocity_limit_is_held_to_an_assumed_one() {
        // Elephant Robotics' Mercury and AgileX's Piper write velocity="0": a command must not
        // then move the joint at any speed.
        let joint = |n: usize, velocity: f64, kind: &str| {
            format!(
                r#"<link name="l{n}"/><joint name="j{n}" type="{kind}"><parent link="l{p}"/><child link="l{n}"/><axis xyz="0 0 1"/><limit lower="-1" upper="1" velocity="{velocity}" effort="1"/></joint>"#,
                p = n - 1
            )
        };
        let urdf = format!(
            r#"<robot name="r"><link name="l0"/>{}{}{}{}</robot>"#,
            joint(1, 0.0, "revolute"),
            joint(2, 2.0, "revolute"),
            joint(3, 3.0, "revolute"),
            joint(4, 0.0, "prismatic")
        );
        let robot = Robot::from_urdf_str(&urdf, "r.urdf").unwrap();
        let names: Vec<String> = ["j1", "j2", "j3", "j4"].map(String::from).to_vec();
        let limits = CommandLimits::for_joints(&robot, &names).unwrap();
        // j1 takes the median of j2 and j3 (the upper of two), j4 the prismatic default.
        assert_eq!(limits.velocity(), &[3.0, 2.0, 3.0, UNSTATED_PRISMATIC_M_S]);
        let note = limits.assumed().unwrap();
        assert!(
            note.contains(r#""j1 3.00 rad/s""#) && note.contains("j4"),
            "{note}"
        );
        let mut q = [1.0, 0.0, 0.0, 1.0];
        let c = limits.apply(&mut q, Some((&[0.0; 4], 0.1)));
        assert_eq!(c.velocity, 2);
        assert!(
            (q[0] - 0.3).abs() < 1e-12 && (q[3] - 0.01).abs() < 1e-12,
            "{q:?}"
        );
        // No joint stating one: the revolute default.
        let alone = CommandLimits::for_joints(&robot, &names[..1]).unwrap();
        assert_eq!(alone.velocity(), &[UNSTATED_REVOLUTE_RAD_S]);
        // Every joint stating its own: nothing assumed.
        assert!(CommandLimits::for_joints(&robot, &names[1..3])
            .unwrap()
            .assumed()
            .is_none());
    }

    #[test]
    fn positions_and_velocities_are_held_and_counted() {
        let robot = Robot::builtin("coman").unwrap();
        let names: Vec<String> = robot.joint_names()[..3].to_vec(); // LShSag, LShLat, LShYaw
        let limits = CommandLimits::for_joints(&robot, &names).unwrap();
        // LShLat's limits are [-0.31415, 2.094]; COMAN's joints 4 rad/s.
        let mut q = [0.0, 2.5, 0.1];
        let c = limits.apply(&mut q, None);
        assert_eq!(q, [0.0, 2.094, 0.1]);
        assert_eq!((c.position, c.velocity), (1, 0));
        assert!((c.largest - 0.406).abs() < 1e-12);
        // From [0, 0, 0] in 25 ms at most 0.1 rad.
        let mut q = [0.5, -0.05, 0.02];
        let c = limits.apply(&mut q, Some((&[0.0, 0.0, 0.0], 0.025)));
        assert!((q[0] - 0.1).abs() < 1e-12 && q[1] == -0.05 && q[2] == 0.02);
        assert_eq!((c.position, c.velocity), (0, 1));
        // A whole trajectory: the step back into range is itself bounded.
        let mut rows = vec![0.0, 0.0, 0.0, 0.0, 3.0, 0.0, 0.0, 3.0, 0.0];
        let counts = limits.apply_all(&mut rows, &[0.0, 0.025, 0.05]);
        assert_eq!(rows[4], 0.1);
        assert!((rows[7] - 0.2).abs() < 1e-12);
        assert_eq!(counts.commands, 3);
        assert_eq!(counts.commands_clamped, 2);
        assert_eq!(counts.position[1], 2);
        assert_eq!(counts.velocity[1], 2);
        let line = counts.summary("coman", &names);
        assert!(
            line.starts_with("2 of 3 commands moved within coman's limits"),
            "{line}"
        );
        // Joints listed by how often they were moved, each with how far at most (Sawyer's
        // report listed the joint moved farthest first, 1340× before 2311×).
        let counts = LimitCounts {
            commands: 10,
            commands_clamped: 9,
            position: vec![0, 1, 0],
            velocity: vec![2, 7, 0],
            largest: vec![3.0, 0.5, 0.0],
        };
        let line = counts.summary("coman", &names);
        assert!(
            line.ends_with(
                "most often: LShLat 8× (moved up to 28.6° from the command asked), \
                 LShSag 2× (moved up to 171.9° from the command asked))"
            ),
            "{line}"
        );
        let e = CommandLimits::for_joints(&robot, &["elbow".to_string()])
            .unwrap_err()
            .to_string();
        assert!(e.contains("\"elbow\"") && e.contains("LShSag"), "{e}");
    }
}
