//! The control loop of a replay: the robot settles on the first frame, then every physics
//! step moves each motor's target to the reference at the end of the step (the frames
//! interpolated linearly) with the slope of the current segment as target velocity, steps
//! the world and hands the measured joints and contacts to the [`Recorder`].

use std::time::Instant;

use rapier3d::math::Real;

use super::build::Scene;
use super::model::PreparedModel;
use super::report::{Divergence, Recorder, ReferenceJump, StepTime, JUMP_WINDOW_SECONDS};
use super::{PhysicsError, ReplayOptions, ReplayReport, Trajectory};

/// The replay's clock: physics steps over the trajectory's time span.
struct Clock {
    /// Time of the first frame, seconds.
    t0: f64,
    /// Time of the last frame, seconds.
    t_end: f64,
    /// Physics steps per second.
    rate: f64,
    /// Physics steps over the trajectory (at least 1).
    steps: usize,
    /// Physics steps of settling before the trajectory starts.
    settle_steps: usize,
    /// Steps without extension after which an event closes.
    merge_gap: usize,
}

impl Clock {
    /// The clock of `trajectory` at the options' rate; refuses more than `max_steps` steps.
    fn new(trajectory: &Trajectory, options: &ReplayOptions) -> Result<Clock, PhysicsError> {
        let t0 = trajectory.times[0];
        let t_end = trajectory.times[trajectory.frames() - 1];
        let duration = t_end - t0;
        let rate = options.physics_rate_hz;
        let steps_f = (duration * rate).round().max(1.0);
        let settle_steps = (options.settle_seconds * rate).round();
        if steps_f + settle_steps > options.max_steps as f64 {
            return Err(PhysicsError::Trajectory {
                message: format!(
                    "{duration} s at {rate} Hz (after {} s of settling) needs {} physics steps; expected at most max_steps = {}",
                    options.settle_seconds,
                    steps_f + settle_steps,
                    options.max_steps
                ),
            });
        }
        Ok(Clock {
            t0,
            t_end,
            rate,
            steps: steps_f as usize,
            settle_steps: settle_steps as usize,
            merge_gap: (options.merge_gap_seconds * rate).round() as usize,
        })
    }

    /// Simulated time, seconds.
    fn duration(&self) -> f64 {
        self.t_end - self.t0
    }

    /// Trajectory time at the end of physics step `step`.
    fn at(&self, step: usize) -> StepTime {
        StepTime {
            step,
            t: (self.t0 + step as f64 / self.rate).min(self.t_end),
        }
    }
}

/// The motors' gains, as rapier takes them.
#[derive(Clone, Copy)]
struct Gains {
    stiffness: Real,
    damping: Real,
}

/// The reference of every driven joint at one step: position and the current segment's slope.
struct Reference {
    /// The frame the current segment starts at.
    segment: usize,
    /// Reference positions, in report order.
    position: Vec<f64>,
    /// Reference velocities (the segment's slope), in report order.
    slope: Vec<f64>,
}

impl Reference {
    /// Moves to time `t` (never backwards) and interpolates every joint's reference.
    fn advance(&mut self, scene: &Scene, trajectory: &Trajectory, t: f64) {
        let n_cols = trajectory.joint_names.len();
        while self.segment + 2 < trajectory.frames() && trajectory.times[self.segment + 1] < t {
            self.segment += 1;
        }
        let segment = self.segment;
        let (ta, tb) = (trajectory.times[segment], trajectory.times[segment + 1]);
        let w = ((t - ta) / (tb - ta)).clamp(0.0, 1.0);
        let row_a = &trajectory.positions[segment * n_cols..(segment + 1) * n_cols];
        let row_b = &trajectory.positions[(segment + 1) * n_cols..(segment + 2) * n_cols];
        for (i, d) in scene.driven.iter().enumerate() {
            let (q, v) = match d.column {
                Some(c) => (
                    row_a[c] + w * (row_b[c] - row_a[c]),
                    (row_b[c] - row_a[c]) / (tb - ta),
                ),
                None => (d.hold, 0.0),
            };
            self.position[i] = q;
            self.slope[i] = v;
        }
    }
}

/// Runs the replay of `trajectory` on `model` (the caller has validated both and `options`).
pub(super) fn simulate(
    model: &PreparedModel,
    file: &str,
    trajectory: &Trajectory,
    options: &ReplayOptions,
) -> Result<ReplayReport, PhysicsError> {
    let mut scene = Scene::build(model, file, trajectory, options)?;
    let clock = Clock::new(trajectory, options)?;
    let gains = Gains {
        stiffness: options.stiffness as Real,
        damping: options.damping as Real,
    };
    let mut recorder = Recorder::new(
        scene.driven.iter().map(|d| d.name.clone()).collect(),
        scene.driven.iter().map(|d| d.prismatic()).collect(),
        (
            model.robot.links.iter().map(|l| l.name.clone()).collect(),
            model.held_part.clone(),
        ),
        clock.t0,
        options.record_simulated,
        trajectory.frames(),
    );
    let mut watch = Runaway::new(&scene, clock.rate);
    let mut diverged = None;
    let mut steps_taken = clock.steps;
    settle(&mut scene, clock.settle_steps, gains);
    recorder.first_frame(scene.driven.iter().map(|d| d.position(&scene.world)));
    let n = scene.driven.len();
    let mut reference = Reference {
        segment: 0,
        position: vec![0.0; n],
        slope: vec![0.0; n],
    };
    let started = Instant::now();
    for step in 1..=clock.steps {
        let at = clock.at(step);
        reference.advance(&scene, trajectory, at.t);
        drive(&mut scene, &reference, gains, options.velocity_feedforward);
        scene.world.step_with_events(&scene.hooks, &());
        measure_joints(&scene, &reference, at, options, file, &mut recorder)?;
        measure_contacts(&scene, at, options, &mut recorder);
        recorder.close_events(step, clock.merge_gap);
        recorder.frames_at(trajectory, at.t, clock.rate);
        if let Some(mut d) = watch.check(&scene, &reference, at.t) {
            d.after_jump = jump_before(&scene, trajectory, d.time);
            diverged = Some(d);
            steps_taken = step;
            break;
        }
    }
    let wall_seconds = started.elapsed().as_secs_f64();
    let duration = match &diverged {
        Some(d) => d.time - clock.t0,
        None => clock.duration(),
    };
    let collision_shapes = scene.world.colliders.len();
    let mut report = recorder.finish(
        trajectory,
        duration,
        steps_taken,
        wall_seconds,
        scene.warnings,
    );
    let links = &model.robot.links;
    report.held = model.held.clone();
    report.overlapping_at_rest = scene
        .overlapping_at_rest
        .iter()
        .map(|&(a, b)| (links[a].name.clone(), links[b].name.clone()))
        .collect();
    report.diverged = diverged;
    report.collision_shapes = collision_shapes;
    report.mesh_hulls = model.hulls.len();
    report.mesh_seconds = model.mesh_seconds;
    report.unchecked_meshes = model.unchecked_meshes.clone();
    Ok(report)
}

/// How much faster than its velocity limit a joint may turn before the replay counts as run
/// away (and at least twice its reference's speed).
const RUNAWAY_FACTOR: f64 = 10.0;
/// The least speed that counts as running away, whatever the limit (makers write placeholder
/// limits of 0.5 rad/s): rad/s, or m/s when the joint slides.
const RUNAWAY_SPEEDS: (f64, f64) = (20.0, 2.0);
/// And only this far from the reference: rad, or m when the joint slides (a motor catching up
/// with a fast reference is no runaway).
const RUNAWAY_ERRORS: (f64, f64) = (0.35, 0.05);
/// How long a joint must run away, seconds (a contact's impulse lasts a step or two).
const RUNAWAY_SECONDS: f64 = 0.01;

/// One joint's motion at one step, as a runaway is judged.
struct Motion {
    /// Its speed.
    speed: f64,
    /// How far it is from its reference.
    off: f64,
    /// Its URDF velocity limit.
    limit: Option<f64>,
    /// Its reference's speed.
    slope: f64,
    /// Whether it slides.
    prismatic: bool,
}

impl Motion {
    /// The speed it ran away beyond, if it does: faster than [`RUNAWAY_FACTOR`] times its limit,
    /// [`RUNAWAY_SPEEDS`] and twice its reference, further than [`RUNAWAY_ERRORS`] from it.
    fn running_away(&self) -> Option<f64> {
        let error = if self.prismatic {
            RUNAWAY_ERRORS.1
        } else {
            RUNAWAY_ERRORS.0
        };
        let threshold = self.runaway_speed().max(2.0 * self.slope.abs());
        (self.speed > threshold && self.off > error).then_some(threshold)
    }

    /// The speed beyond which the joint runs away whatever its reference does:
    /// [`RUNAWAY_FACTOR`] times its limit, at least [`RUNAWAY_SPEEDS`].
    fn runaway_speed(&self) -> f64 {
        let least = if self.prismatic {
            RUNAWAY_SPEEDS.1
        } else {
            RUNAWAY_SPEEDS.0
        };
        (RUNAWAY_FACTOR * self.limit.unwrap_or(0.0)).max(least)
    }
}

/// Watches every driven joint for a runaway: faster than [`RUNAWAY_FACTOR`] times its limit
/// (and [`RUNAWAY_SPEEDS`]) and further than [`RUNAWAY_ERRORS`] from its reference, for
/// [`RUNAWAY_SECONDS`].
struct Runaway {
    /// Consecutive steps each joint has been too fast.
    steps: Vec<usize>,
    /// Steps that make a runaway.
    needed: usize,
}

impl Runaway {
    fn new(scene: &Scene, rate: f64) -> Runaway {
        Runaway {
            steps: vec![0; scene.driven.len()],
            needed: ((RUNAWAY_SECONDS * rate).round() as usize).max(1),
        }
    }

    /// The divergence at time `t`, if a joint has now been running away long enough.
    fn check(&mut self, scene: &Scene, reference: &Reference, t: f64) -> Option<Divergence> {
        for (i, d) in scene.driven.iter().enumerate() {
            let speed = d.velocity(&scene.world).abs();
            let off = (d.position(&scene.world) - reference.position[i]).abs();
            let motion = Motion {
                speed,
                off,
                limit: d.velocity_limit,
                slope: reference.slope[i],
                prismatic: d.prismatic(),
            };
            if let Some(threshold) = motion.running_away() {
                self.steps[i] += 1;
                if self.steps[i] >= self.needed {
                    return Some(Divergence {
                        time: t,
                        joint: d.name.clone(),
                        speed,
                        threshold,
                        prismatic: d.prismatic(),
                        after_jump: None,
                    });
                }
            } else {
                self.steps[i] = 0;
            }
        }
        None
    }
}

/// The trajectory's fastest step, relative to its joint's runaway speed, of the
/// [`JUMP_WINDOW_SECONDS`] before `t`, among those faster than half of it (a joint runs away
/// only beyond twice its reference's speed: a reference that fast can fling it there): the
/// reference's own jump.
fn jump_before(scene: &Scene, trajectory: &Trajectory, t: f64) -> Option<ReferenceJump> {
    let n = trajectory.joint_names.len();
    let mut worst: Option<(f64, ReferenceJump)> = None;
    for f in 1..trajectory.frames() {
        let (ta, tb) = (trajectory.times[f - 1], trajectory.times[f]);
        if tb < t - JUMP_WINDOW_SECONDS || ta > t {
            continue;
        }
        for d in &scene.driven {
            let Some(c) = d.column else { continue };
            let change = trajectory.positions[f * n + c] - trajectory.positions[(f - 1) * n + c];
            let runaway = Motion {
                speed: 0.0,
                off: 0.0,
                limit: d.velocity_limit,
                slope: 0.0,
                prismatic: d.prismatic(),
            }
            .runaway_speed();
            let ratio = 2.0 * change.abs() / (tb - ta) / runaway;
            if ratio > 1.0 && worst.as_ref().is_none_or(|w| ratio > w.0) {
                let jump = ReferenceJump {
                    joint: d.name.clone(),
                    time: tb,
                    change,
                    seconds: tb - ta,
                    prismatic: d.prismatic(),
                };
                worst = Some((ratio, jump));
            }
        }
    }
    worst.map(|w| w.1)
}

/// Holds every joint at its initial position for `steps` physics steps.
fn settle(scene: &mut Scene, steps: usize, gains: Gains) {
    for _ in 0..steps {
        for (d, q0) in scene.driven.iter().zip(&scene.initial) {
            d.set_motor(
                &mut scene.world,
                *q0 as Real,
                0.0,
                gains.stiffness,
                gains.damping,
            );
        }
        scene.world.step_with_events(&scene.hooks, &());
    }
}

/// Points every motor at the reference (and its slope, with velocity feed-forward).
fn drive(scene: &mut Scene, reference: &Reference, gains: Gains, feedforward: bool) {
    for (i, d) in scene.driven.iter().enumerate() {
        let velocity = if feedforward { reference.slope[i] } else { 0.0 };
        d.set_motor(
            &mut scene.world,
            reference.position[i] as Real,
            velocity as Real,
            gains.stiffness,
            gains.damping,
        );
    }
}

/// Records every joint's tracking error and limit crossings; a non-finite position means the
/// simulation diverged.
fn measure_joints(
    scene: &Scene,
    reference: &Reference,
    at: StepTime,
    options: &ReplayOptions,
    file: &str,
    recorder: &mut Recorder,
) -> Result<(), PhysicsError> {
    for (i, d) in scene.driven.iter().enumerate() {
        let q = d.position(&scene.world);
        if !q.is_finite() {
            return Err(PhysicsError::Diverged {
                file: file.to_string(),
                time: at.t,
                joint: d.name.clone(),
                value: q,
            });
        }
        let r = reference.position[i];
        recorder.track(i, r, q, at.t);
        if let Some(limits) = d.limits {
            recorder.position_limits(i, limits, (r, q), options.limit_tolerance, at);
        }
        if let Some(max_speed) = d.velocity_limit {
            let measured = d.velocity(&scene.world);
            let speeds = (reference.slope[i], measured);
            recorder.velocity_limits(i, max_speed, speeds, options.velocity_tolerance, at);
        }
    }
    Ok(())
}

/// Records the contacts between links that the filter checks and that are closer than
/// [`ReplayOptions::contact_distance`], each with the midpoint of its deepest contact's two
/// points.
fn measure_contacts(scene: &Scene, at: StepTime, options: &ReplayOptions, recorder: &mut Recorder) {
    let world = &scene.world;
    let (n_links, skip) = (scene.hooks.n_links, &scene.hooks.skip);
    for pair in world.narrow_phase.contact_pairs() {
        let Some((manifold, contact)) = pair.find_deepest_contact() else {
            continue;
        };
        if (contact.dist as f64) > options.contact_distance {
            continue;
        }
        let link_of = |h| world.colliders.get(h).map(|c| c.user_data as usize);
        let (Some(a), Some(b)) = (link_of(pair.collider1), link_of(pair.collider2)) else {
            continue;
        };
        if a == b || a >= n_links || b >= n_links || skip[a * n_links + b] {
            continue;
        }
        let depth = (-contact.dist as f64).max(0.0);
        // The contact's two points in the world (= the fixed root link's frame): each is in
        // its collider's frame, or its sub-shape's for a composite shape.
        let (Some(c1), Some(c2)) = (
            world.colliders.get(pair.collider1),
            world.colliders.get(pair.collider2),
        ) else {
            continue;
        };
        let local = |sub: Option<&rapier3d::math::Pose>, p| sub.map_or(p, |s| *s * p);
        let p1 = *c1.position() * local(manifold.subshape_pos1(), contact.local_p1);
        let p2 = *c2.position() * local(manifold.subshape_pos2(), contact.local_p2);
        let mid = (p1 + p2) * 0.5;
        let point = [mid.x as f64, mid.y as f64, mid.z as f64];
        recorder.contact((a, b), depth, point, at);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_runaway_is_fast_beyond_limit_and_reference_and_far_from_the_reference() {
        // The mobile manipulator: a forearm roll (limit 3.6 rad/s) spinning at 122.
        let spin = Motion {
            speed: 122.0,
            off: 3.0,
            limit: Some(3.6),
            slope: 0.5,
            prismatic: false,
        };
        assert_eq!(spin.running_away(), Some(36.0));
        // Close to its reference it is a motor following: no runaway.
        assert_eq!(Motion { off: 0.05, ..spin }.running_away(), None);
        // A placeholder limit of 0.5 rad/s: 20 rad/s at least.
        let placeholder = Motion {
            speed: 6.0,
            limit: Some(0.5),
            ..spin
        };
        assert_eq!(placeholder.running_away(), None);
        assert_eq!(
            Motion {
                speed: 25.0,
                ..placeholder
            }
            .running_away(),
            Some(20.0)
        );
        // A fast reference raises the bar: twice its speed.
        assert_eq!(
            Motion {
                slope: 80.0,
                ..spin
            }
            .running_away(),
            None
        );
        // A torso lift drifting away at 3 m/s, 20 cm from its reference.
        let lift = Motion {
            speed: 3.0,
            off: 0.2,
            limit: Some(0.07),
            slope: 0.0,
            prismatic: true,
        };
        assert_eq!(lift.running_away(), Some(2.0));
    }
}
