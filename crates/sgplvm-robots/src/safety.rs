//! The nearest safe command: each command a robot is sent is the configuration closest to the
//! one asked for within its joints' position limits, within each joint's velocity limit of the
//! command before (over the time between them) and with every pair of its own collision shapes
//! that can meet at least a margin apart:
//!
//! ```text
//! min_x ‖x − x_asked‖²  s.t.  lo ≤ x ≤ hi,  |x − x_last| ≤ v_max Δt,  d_ab(x) ≥ margin
//! ```
//!
//! one QP ([`crate::kinematics::qp::Step`]) over the step from the last command, the
//! distances linearised at it ([`crate::kinematics::limits`]). Unlike stopping near a collision
//! (MoveIt Servo's way), the command keeps moving wherever it can: along the obstacle, and
//! whole where nothing is near.

use nalgebra::DVector;

use crate::anatomy::Anatomy;
use crate::kinematics::collision::{CollisionModel, Proximity};
use crate::kinematics::frames::{Ancestry, RobotFrames};
use crate::kinematics::limits::{collision_limit, position_limits};
use crate::kinematics::qp::{Solved, Step};
use crate::kinematics::tasks::TaskContext;
use crate::urdf::Robot;

/// Settings of the safety step.
#[derive(Debug, Clone, PartialEq)]
pub struct SafetyOptions {
    /// How far apart every pair of shapes that can meet stays, metres.
    pub margin_m: f64,
    /// Pairs nearer than this are limited, metres (beyond it a step cannot close the gap).
    pub detect_m: f64,
    /// Keep the velocity limits (commands need times).
    pub velocity_limits: bool,
    /// Keep the shapes apart.
    pub self_collision: bool,
}

impl Default for SafetyOptions {
    fn default() -> Self {
        SafetyOptions {
            margin_m: 0.01,
            detect_m: 0.08,
            velocity_limits: true,
            self_collision: true,
        }
    }
}

/// What the safety step did to one command.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct SafetyOutcome {
    /// Whether the command differs from the one asked for (by more than 1e-9 on a joint).
    pub changed: bool,
    /// Pairs of links nearer than their margin plus 1 mm before the step (the margin, or less
    /// for a pair nearer at rest: `CollisionModel::margin_of`; the step kept them apart or moved
    /// them apart), with their distances, metres.
    pub near: Vec<(String, String, f64)>,
    /// The limits admitted no step (the last command is sent again).
    pub infeasible: bool,
}

/// The safety step of one robot's commanded joints.
#[derive(Clone)]
pub struct SafetyStep {
    robot: Robot,
    ancestry: Ancestry,
    collision: CollisionModel,
    /// The commanded joints (indices into the robot's joints) and their configuration indices.
    active: Vec<usize>,
    q_index: Vec<usize>,
    /// The whole configuration: the joints not commanded at their hold values.
    base: Vec<f64>,
    /// Each commanded joint's velocity limit, as every command keeps it
    /// ([`crate::limits::command_velocity_limits`]: assumed where the URDF states none).
    velocity: Vec<f64>,
    last: Option<(Vec<f64>, f64)>,
    options: SafetyOptions,
}

impl std::fmt::Debug for SafetyStep {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SafetyStep")
            .field("robot", &self.robot.name())
            .field("joints", &self.active.len())
            .field("pairs", &self.collision.pairs().len())
            .field("options", &self.options)
            .finish()
    }
}

impl SafetyStep {
    /// The safety step of `anatomy`'s joints `joints` (movable joints of its robot; others
    /// keep their hold values), its collision meshes found where the anatomy finds them.
    pub fn new(
        anatomy: &Anatomy,
        joints: &[String],
        options: SafetyOptions,
    ) -> Result<SafetyStep, String> {
        let robot = anatomy.robot().clone();
        let ancestry = Ancestry::of(&robot);
        let mut active = Vec::new();
        let mut q_index = Vec::new();
        for n in joints {
            let i = robot.joint_index(n).ok_or_else(|| {
                format!("`{n}` is not a movable joint of robot `{}`", robot.name())
            })?;
            q_index.push(i);
            active.push(robot.movable[i]);
        }
        let base = anatomy.hold_configuration().to_vec();
        let collision = anatomy.collision_model(&q_index, options.margin_m);
        let (velocity, _) = crate::limits::command_velocity_limits(&robot, joints);
        Ok(SafetyStep {
            robot,
            ancestry,
            collision,
            active,
            q_index,
            base,
            velocity,
            last: None,
            options,
        })
    }

    /// The collision model the step keeps apart.
    pub fn collision(&self) -> &CollisionModel {
        &self.collision
    }

    /// Each commanded joint's velocity limit as the step keeps it (assumed where the URDF
    /// states none: [`crate::limits::command_velocity_limits`]), in the order of its joints.
    pub fn velocity_limits(&self) -> &[f64] {
        &self.velocity
    }

    /// Forgets the last command (the next one is limited by position and collision only).
    pub fn reset(&mut self) {
        self.last = None;
    }

    /// The command last sent, if any.
    pub fn last(&self) -> Option<&[f64]> {
        self.last.as_ref().map(|(q, _)| q.as_slice())
    }

    /// The whole configuration for commanded values `x`.
    fn full(&self, x: &[f64]) -> Vec<f64> {
        let mut q = self.base.clone();
        for (&i, &v) in self.q_index.iter().zip(x) {
            q[i] = v;
        }
        q
    }

    /// The command to send for `asked` (commanded joints' values) at `now_s` seconds (the
    /// clock the robot receives commands by), written to `out`; the command before is the one
    /// this step sent last.
    pub fn step(&mut self, asked: &[f64], now_s: f64, out: &mut [f64]) -> SafetyOutcome {
        let last = self.last.take();
        self.step_from(
            asked,
            last.as_ref().map(|(q, t)| (q.as_slice(), *t)),
            now_s,
            out,
        )
    }

    /// Whether commanded values `x` put two of the robot's shapes into each other (always
    /// false without the self-collision limit).
    pub fn overlaps(&self, x: &[f64]) -> bool {
        if !self.options.self_collision {
            return false;
        }
        let frames = RobotFrames::new(&self.robot, &self.ancestry, &self.full(x));
        self.collision
            .proximities(&frames, 0.0)
            .iter()
            .any(|p| p.distance < 0.0)
    }

    /// The pairs of links among `near` within a millimetre of their margin
    /// ([`SafetyOutcome::near`]): one entry per pair of links (a pair of meshes may near at
    /// several parts), at its least distance.
    fn near_links(&self, near: &[Proximity]) -> Vec<(String, String, f64)> {
        let mut links: Vec<(String, String, f64)> = Vec::new();
        let margin = self.options.margin_m;
        for p in near
            .iter()
            .filter(|p| p.distance < self.collision.margin_of(p.pair, margin) + 1e-3)
        {
            let (a, b) = self.collision.pair_links(p.pair);
            let (a, b) = (&self.robot.links[a], &self.robot.links[b]);
            match links.iter_mut().find(|n| &n.0 == a && &n.1 == b) {
                Some(n) => n.2 = n.2.min(p.distance),
                None => links.push((a.clone(), b.clone(), p.distance)),
            }
        }
        links
    }

    /// Whether the posture of `ctx` (the one asked for, with no command before) is a safe
    /// command as it is: every joint within its position limits and every pair at least its
    /// margin apart, so that the step from it would be none. Then the pairs within a
    /// millimetre of their margin, as the step lists them; asked within that distance, not
    /// the detection distance a step needs (the costly part: meshes' hulls and parts).
    fn already_safe(&self, ctx: &TaskContext<'_>) -> Option<Vec<(String, String, f64)>> {
        let q = ctx.active_values();
        let within_limits = self.active.iter().zip(&q).all(|(&j, &v)| {
            let (lo, hi) = self.robot.joints[j].limits;
            lo > hi || (lo <= v && v <= hi)
        });
        if !within_limits {
            return None;
        }
        if !self.options.self_collision {
            return Some(Vec::new());
        }
        let margin = self.options.margin_m;
        let near = self.collision.proximities(ctx.frames, margin + 1e-3);
        let clear = near
            .iter()
            .all(|p| p.distance >= self.collision.margin_of(p.pair, margin));
        clear.then(|| self.near_links(&near))
    }

    /// [`SafetyStep::step`] from the command `last` sent at its time (`None`: none sent yet).
    pub fn step_from(
        &mut self,
        asked: &[f64],
        last: Option<(&[f64], f64)>,
        now_s: f64,
        out: &mut [f64],
    ) -> SafetyOutcome {
        self.last = last.map(|(q, t)| (q.to_vec(), t));
        let from: Vec<f64> = match &self.last {
            Some((q, _)) => q.clone(),
            None => asked.to_vec(),
        };
        let dt = self.last.as_ref().map(|(_, t)| (now_s - t).max(0.0));
        let full = self.full(&from);
        let frames = RobotFrames::new(&self.robot, &self.ancestry, &full);
        let ctx = TaskContext {
            robot: &self.robot,
            ancestry: &self.ancestry,
            frames: &frames,
            q: &full,
            active: &self.active,
        };
        let n = self.active.len();
        if self.last.is_none() {
            if let Some(near) = self
                .already_safe(&ctx)
                .filter(|_| std::env::var_os("OLDSAFE").is_none())
            {
                // The step from the asked posture itself would be none: it is the command.
                out[..n].copy_from_slice(asked);
                self.last = Some((asked.to_vec(), now_s));
                return SafetyOutcome {
                    near,
                    ..SafetyOutcome::default()
                };
            }
        }
        let mut step = Step::new(n, 0.0);
        let target = DVector::from_iterator(n, asked.iter().zip(&from).map(|(a, f)| a - f));
        step.add_task(&nalgebra::DMatrix::identity(n, n), &target, 1.0);
        position_limits(&mut step, &ctx, None);
        if let (true, Some(dt)) = (self.options.velocity_limits, dt) {
            for (k, v) in self.velocity.iter().enumerate() {
                step.bound(k, -v * dt, v * dt);
            }
        }
        let mut outcome = SafetyOutcome::default();
        let mut within_detect = false;
        if self.options.self_collision {
            let near = collision_limit(
                &mut step,
                &ctx,
                &self.collision,
                self.options.margin_m,
                self.options.detect_m,
                1.0,
            );
            within_detect = !near.is_empty();
            outcome.near = self.near_links(&near);
        }
        let (mut delta, free) = match step.solve() {
            Ok((d, how)) => (d, how == Solved::Unconstrained),
            Err(_) => {
                outcome.infeasible = true;
                (DVector::zeros(n), false)
            }
        };
        // The linearised distances bind only near; a long step can still pass through a
        // shape: the step is cut back until nothing overlaps (from a command that did not).
        // No shape near and a step too short to close the detection distance (a metre of
        // lever per radian, more than any arm here has): nothing can overlap.
        if std::env::var_os("OLDSAFE").is_some()
            && self.already_safe(&ctx).is_some()
            && delta.amax() > 1e-9
        {
            let near = self
                .collision
                .proximities(ctx.frames, self.options.detect_m);
            let m: Vec<(usize, f64, f64)> = near
                .iter()
                .map(|p| {
                    (
                        p.pair,
                        p.distance,
                        self.collision.margin_of(p.pair, self.options.margin_m),
                    )
                })
                .collect();
            let near2 = self
                .collision
                .proximities(ctx.frames, self.options.margin_m + 1e-3);
            let m2: Vec<(usize, f64)> = near2.iter().map(|p| (p.pair, p.distance)).collect();
            eprintln!(
                "DBG safe-but-moved {:.3e} free {free}\n detect {m:?}\n margin {m2:?}",
                delta.amax()
            );
        }
        let short = !within_detect && delta.amax() < self.options.detect_m;
        let mut cuts = 0;
        if self.options.self_collision && self.last.is_some() && !short {
            let overlaps = |d: &DVector<f64>| {
                let x: Vec<f64> = from.iter().zip(d.iter()).map(|(f, d)| f + d).collect();
                self.overlaps(&x)
            };
            let mut cut = 0;
            while cut < 12 && overlaps(&delta) {
                delta *= 0.5;
                cut += 1;
            }
            if cut == 12 {
                delta.fill(0.0);
            }
            cuts = cut;
        }
        if free && cuts == 0 {
            // No limit bound: the command asked for, exactly.
            out[..n].copy_from_slice(asked);
        } else {
            for (k, o) in out.iter_mut().enumerate().take(n) {
                *o = from[k] + delta[k];
            }
        }
        outcome.changed = out.iter().zip(asked).any(|(o, a)| (o - a).abs() > 1e-9);
        self.last = Some((out[..n].to_vec(), now_s));
        outcome
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_posture_in_collision_is_pushed_out_and_a_step_input_keeps_the_velocity_limit() {
        let anatomy = Anatomy::builtin("coman").unwrap();
        let robot = anatomy.robot().clone();
        let names = robot.joint_names();
        let mut safety = SafetyStep::new(&anatomy, &names, SafetyOptions::default()).unwrap();
        // Both hands at one point in front of the chest: in collision.
        let zero = robot.neutral_configuration();
        let mut crossed = zero.clone();
        for hand in ["left_hand", "right_hand"] {
            let chain = robot.chain("DWYTorso", hand).unwrap();
            let target = crate::IkTarget::Position(nalgebra::Vector3::new(0.22, 0.0, 0.0));
            let sol = chain.inverse_kinematics(
                &target,
                &chain.extract(&zero).unwrap(),
                &crate::IkOptions::default(),
            );
            for (k, &i) in chain.robot_indices().iter().enumerate() {
                crossed[i] = sol.q[k];
            }
        }
        let ancestry = Ancestry::of(&robot);
        let model = safety.collision().clone();
        let depth = |q: &[f64]| {
            let frames = RobotFrames::new(&robot, &ancestry, q);
            model
                .proximities(&frames, 0.0)
                .iter()
                .map(|p| p.distance)
                .fold(0.0, f64::min)
        };
        assert!(depth(&crossed) < -0.005);
        // Asked for the colliding posture again and again (1 kHz), the commands leave it.
        let mut out = vec![0.0; names.len()];
        let mut now = 0.0;
        for _ in 0..200 {
            safety.step(&crossed, now, &mut out);
            now += 0.001;
        }
        assert!(depth(&out) > -1e-4, "still {} m deep", depth(&out));
        // A step input: from hanging arms to the far end of every joint, 25 ms later.
        let mut s = SafetyStep::new(&anatomy, &names, SafetyOptions::default()).unwrap();
        let mut a = vec![0.0; names.len()];
        s.step(&zero, 0.0, &mut a);
        let far: Vec<f64> = robot.joint_limits().iter().map(|l| l.1).collect();
        let mut b = vec![0.0; names.len()];
        let outcome = s.step(&far, 0.025, &mut b);
        assert!(outcome.changed);
        for (k, v) in robot.velocity_limits().iter().enumerate() {
            assert!((b[k] - a[k]).abs() <= v * 0.025 + 1e-9, "joint {k}");
        }
    }
}
