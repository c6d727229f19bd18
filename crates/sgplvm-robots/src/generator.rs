//! The demonstration generator, after Section IV-A of the paper.
//!
//! 1. Sixteen key bimanual poses ([`KEY_POSES`], pose 0 the neutral one) are defined once as
//!    hand targets relative to each shoulder, in units of the body's arm length, and solved by
//!    inverse kinematics within joint limits for every robot and for the human
//!    ([`solve_key_poses`]). Each pose is solved from a posture seed (the body's neutral
//!    solution, then its zero configuration); a pose that no seed reaches takes the closest
//!    configuration found and is reported ([`PoseReport`]).
//! 2. The robots move between key poses with quintic Hermite interpolation (zero velocity and
//!    acceleration at both ends, [`quintic`]), all robots together, sampled at 40 Hz, then hold
//!    the pose briefly.
//! 3. A simulated human mimics each motion ([`HumanMimic`]): with a reaction delay, their own
//!    speed, a different posture at each repetition, a curved rather than straight joint path,
//!    and sensor noise. Every pose pair is recorded going back and forth three times.
//! 4. Training set: the trajectories that start from the neutral pose, subsampled; test set: the
//!    trajectories between two non-neutral poses ([`GeneratorConfig::test_pairs`]).
//!
//! Everything is seeded: the same configuration gives the same dataset, bit for bit.

use std::path::{Path, PathBuf};

use nalgebra::Vector3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

use crate::dataset::{write_demonstrations, BodyData, Dataset, Segment};
use crate::joint_state::JointStateError;
use crate::{IkOptions, IkTarget, Robot, RobotError, Side};

/// Index of the neutral pose in [`KEY_POSES`].
pub const NEUTRAL: usize = 0;

/// A key bimanual pose: hand targets relative to the shoulder joint centres, in units of arm
/// length, in the torso frame (x forward, y left, z up).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct KeyPose {
    /// Short name.
    pub name: &'static str,
    /// Left hand relative to the left shoulder.
    pub left: [f64; 3],
    /// Right hand relative to the right shoulder.
    pub right: [f64; 3],
}

const fn sym(name: &'static str, x: f64, y: f64, z: f64) -> KeyPose {
    KeyPose {
        name,
        left: [x, y, z],
        right: [x, -y, z],
    }
}

const fn asym(name: &'static str, left: [f64; 3], right: [f64; 3]) -> KeyPose {
    KeyPose { name, left, right }
}

/// The sixteen key poses; index [`NEUTRAL`] is the neutral pose (arms down, slightly forward).
pub const KEY_POSES: [KeyPose; 16] = [
    sym("neutral", 0.15, 0.05, -0.85),
    sym("forward", 0.85, 0.0, -0.15),
    sym("forward_high", 0.6, 0.05, 0.55),
    sym("lateral", 0.05, 0.85, -0.15),
    sym("overhead", 0.1, 0.1, 0.85),
    sym("hands_together", 0.6, -0.35, -0.2),
    sym("chest", 0.35, -0.15, -0.3),
    sym("forward_low", 0.55, 0.15, -0.6),
    sym("hug", 0.55, 0.55, -0.1),
    sym("v_up", 0.1, 0.55, 0.6),
    asym("left_forward", [0.85, 0.0, -0.15], [0.15, -0.05, -0.85]),
    asym("right_forward", [0.15, 0.05, -0.85], [0.85, 0.0, -0.15]),
    asym("left_up_right_side", [0.1, 0.1, 0.85], [0.05, -0.85, -0.15]),
    asym("right_up_left_side", [0.05, 0.85, -0.15], [0.1, -0.1, 0.85]),
    asym("left_across", [0.55, -0.55, -0.2], [0.15, -0.05, -0.85]),
    sym("box_low", 0.45, -0.1, -0.55),
];

/// Quintic Hermite blend s(τ) = 10τ³ − 15τ⁴ + 6τ⁵ on τ ∈ [0, 1] (clamped outside): s(0) = 0,
/// s(1) = 1, and zero first and second derivatives at both ends.
pub fn quintic(tau: f64) -> f64 {
    let t = tau.clamp(0.0, 1.0);
    t * t * t * (10.0 + t * (-15.0 + 6.0 * t))
}

/// First and second derivatives of [`quintic`] with respect to τ (zero outside [0, 1]).
pub fn quintic_derivatives(tau: f64) -> (f64, f64) {
    if !(0.0..=1.0).contains(&tau) {
        return (0.0, 0.0);
    }
    let t = tau;
    (
        30.0 * t * t * (1.0 - t) * (1.0 - t),
        60.0 * t * (1.0 - t) * (1.0 - 2.0 * t),
    )
}

/// How the simulated human deviates from the robots' motion.
#[derive(Debug, Clone, PartialEq)]
pub struct HumanMimic {
    /// Reaction delay range, seconds (uniform per segment).
    pub delay_s: (f64, f64),
    /// Speed factor range relative to the robots (uniform per segment; >1 is faster).
    pub speed: (f64, f64),
    /// Standard deviation of the per-repetition posture change at each key pose, radians.
    pub posture_std: f64,
    /// Standard deviation of the mid-motion bend away from the straight joint path, radians.
    pub path_bend_std: f64,
    /// Standard deviation of the per-frame sensor noise, radians (Xsens-like, ~0.3°).
    pub noise_std: f64,
}

impl Default for HumanMimic {
    fn default() -> Self {
        Self {
            delay_s: (0.12, 0.30),
            speed: (0.85, 1.2),
            posture_std: 0.04,
            path_bend_std: 0.05,
            noise_std: 0.005,
        }
    }
}

/// Everything that shapes a generated dataset.
#[derive(Debug, Clone, PartialEq)]
pub struct GeneratorConfig {
    /// Seed of all random draws.
    pub seed: u64,
    /// Sampling rate of the recording, Hz.
    pub rate_hz: f64,
    /// Built-in robot models to record, in column order of the dataset.
    pub robots: Vec<String>,
    /// Built-in model of the demonstrator.
    pub human: String,
    /// How many times the human goes back and forth between the two poses of a pair.
    pub repetitions: usize,
    /// Keep every `train_subsample`-th frame of the trajectories that start from the neutral pose.
    pub train_subsample: usize,
    /// Pose pairs recorded for the test set (both poses non-neutral).
    pub test_pairs: Vec<(usize, usize)>,
    /// Keep every `test_subsample`-th frame of the test trajectories (1 keeps all).
    pub test_subsample: usize,
    /// Timestamp of the first frame, ns (fixed, so that files are reproducible).
    pub start_time_ns: i64,
    /// Seconds the robots hold each key pose after reaching it.
    pub hold_s: f64,
    /// Peak joint speed of the fastest-moving joint over all bodies, rad/s; sets durations.
    pub peak_speed: f64,
    /// Shortest and longest duration of one pose-to-pose motion, seconds.
    pub duration_s: (f64, f64),
    /// The human's deviations.
    pub mimic: HumanMimic,
}

impl Default for GeneratorConfig {
    fn default() -> Self {
        Self {
            seed: 0,
            rate_hz: 40.0,
            robots: vec!["walkman".into(), "coman".into(), "centauro".into()],
            human: "human".into(),
            repetitions: 3,
            train_subsample: 12,
            test_pairs: vec![(2, 5), (9, 14)],
            test_subsample: 3,
            start_time_ns: 1_700_000_000_000_000_000,
            hold_s: 0.25,
            peak_speed: 2.0,
            duration_s: (0.8, 2.0),
            mimic: HumanMimic::default(),
        }
    }
}

/// Errors of the generator.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum GenerateError {
    /// A body model could not be loaded or queried.
    #[error("body `{body}`: {source}")]
    Robot {
        /// Body name.
        body: String,
        /// The robot error.
        source: RobotError,
    },
    /// A body model lacks the shoulder/hand links of the arm convention.
    #[error("body `{body}` has no left/right arm (links left_shoulder, left_hand, right_shoulder, right_hand expected)")]
    NoArms {
        /// Body name.
        body: String,
    },
    /// The configuration is unusable.
    #[error("invalid generator configuration: {0}")]
    Config(String),
    /// Writing the dataset failed.
    #[error(transparent)]
    Demo(#[from] JointStateError),
}

/// How well IK reached one hand target of one key pose.
#[derive(Debug, Clone, PartialEq)]
pub struct PoseReport {
    /// Key pose index.
    pub pose: usize,
    /// Which hand.
    pub side: Side,
    /// Whether IK converged onto the target.
    pub converged: bool,
    /// Distance from the hand to its target, metres.
    pub residual: f64,
}

/// A body's key postures.
#[derive(Debug, Clone, PartialEq)]
pub struct BodyPoses {
    /// Body name (`human`, `walkman`, ...).
    pub name: String,
    /// Joint names (columns).
    pub joint_names: Vec<String>,
    /// Joint limits, one per joint.
    pub limits: Vec<(f64, f64)>,
    /// One configuration per key pose.
    pub postures: Vec<Vec<f64>>,
    /// IK outcome per pose and hand.
    pub reports: Vec<PoseReport>,
}

impl BodyPoses {
    /// Reports of hands that did not reach their target (the closest configuration was used).
    pub fn unreached(&self) -> impl Iterator<Item = &PoseReport> {
        self.reports.iter().filter(|r| !r.converged)
    }
}

/// Gain of the IK posture task that keeps key postures close to the neutral one.
const POSTURE_GAIN: f64 = 0.5;

/// Solves every key pose for the built-in body `name` by position IK of each arm.
pub fn solve_key_poses(name: &str) -> Result<BodyPoses, GenerateError> {
    let robot_err = |source| GenerateError::Robot {
        body: name.to_string(),
        source,
    };
    let robot = Robot::builtin(name).map_err(robot_err)?;
    solve_key_poses_for(&robot, name)
}

/// [`solve_key_poses`] for any robot following the arm convention.
pub fn solve_key_poses_for(robot: &Robot, name: &str) -> Result<BodyPoses, GenerateError> {
    let robot_err = |source| GenerateError::Robot {
        body: name.to_string(),
        source,
    };
    let arms = robot.arms().ok_or_else(|| GenerateError::NoArms {
        body: name.to_string(),
    })?;
    let zero = robot.neutral_configuration();
    let limits = robot.joint_limits();
    let seeded = IkOptions {
        restarts: 0,
        tolerance: 1e-6,
        max_iters: 200,
        ..IkOptions::default()
    };
    let fallback = IkOptions {
        tolerance: 1e-6,
        max_iters: 200,
        restarts: 16,
        ..IkOptions::default()
    };
    let mut postures = vec![zero.clone(); KEY_POSES.len()];
    let mut reports = Vec::new();
    for arm in &arms {
        let shoulder = robot
            .forward_kinematics(&zero, &arm.shoulder_link)
            .map_err(robot_err)?
            .translation
            .vector;
        let idx = arm.chain.robot_indices().to_vec();
        let arm_zero: Vec<f64> = idx.iter().map(|&i| zero[i]).collect();
        let mut neutral_q: Option<Vec<f64>> = None;
        // Solve the neutral pose first: it seeds the others, so postures stay alike.
        let order = std::iter::once(NEUTRAL).chain((0..KEY_POSES.len()).filter(|&p| p != NEUTRAL));
        for p in order {
            let rel = match arm.side {
                Side::Left => KEY_POSES[p].left,
                Side::Right => KEY_POSES[p].right,
            };
            let target = shoulder + arm.length * Vector3::new(rel[0], rel[1], rel[2]);
            let mut seeds: Vec<&[f64]> = Vec::new();
            if let Some(n) = &neutral_q {
                seeds.push(n);
            }
            seeds.push(&arm_zero);
            let anchor: &[f64] = neutral_q.as_deref().unwrap_or(&arm_zero);
            let mut best: Option<Candidate> = None;
            // A null-space posture task pulls every solution towards the anchor (the neutral
            // posture; the hanging arm for the neutral pose itself): natural, continuous postures.
            let with_posture = IkOptions {
                posture_gain: POSTURE_GAIN,
                rest: Some(anchor.to_vec()),
                ..seeded.clone()
            };
            for seed in &seeds {
                let sol =
                    arm.chain
                        .inverse_kinematics(&IkTarget::Position(target), seed, &with_posture);
                keep_better(&mut best, sol, anchor);
            }
            if !best.as_ref().is_some_and(|b| b.converged) {
                let sol =
                    arm.chain
                        .inverse_kinematics(&IkTarget::Position(target), anchor, &fallback);
                keep_better(&mut best, sol, anchor);
            }
            let Candidate {
                converged,
                residual,
                q,
                ..
            } = best.expect("invariant: at least one IK attempt was considered");
            for (k, &i) in idx.iter().enumerate() {
                postures[p][i] = q[k].clamp(limits[i].0, limits[i].1);
            }
            if p == NEUTRAL {
                neutral_q = Some(q);
            }
            reports.push(PoseReport {
                pose: p,
                side: arm.side,
                converged,
                residual,
            });
        }
    }
    reports.sort_by_key(|r| (r.pose, r.side == Side::Right));
    Ok(BodyPoses {
        name: name.to_string(),
        joint_names: robot.joint_names(),
        limits,
        postures,
        reports,
    })
}

/// An IK outcome considered for a key pose.
struct Candidate {
    converged: bool,
    /// Squared distance to the anchor posture (the neutral solution).
    dist: f64,
    residual: f64,
    q: Vec<f64>,
}

/// Keeps the better of `best` and `sol`: converged beats not converged; among converged ones
/// the closer to `anchor` wins (posture continuity); otherwise the smaller residual.
fn keep_better(best: &mut Option<Candidate>, sol: crate::IkSolution, anchor: &[f64]) {
    let dist: f64 = sol
        .q
        .iter()
        .zip(anchor)
        .map(|(a, b)| (a - b) * (a - b))
        .sum();
    let better = match best {
        None => true,
        Some(b) => match (sol.converged, b.converged) {
            (true, false) => true,
            (false, true) => false,
            (true, true) => dist < b.dist,
            (false, false) => sol.residual < b.residual,
        },
    };
    if better {
        *best = Some(Candidate {
            converged: sol.converged,
            dist,
            residual: sol.residual,
            q: sol.q,
        });
    }
}

/// A generated dataset and how its key poses were solved.
#[derive(Debug, Clone)]
pub struct Generated {
    /// The demonstrations.
    pub dataset: Dataset,
    /// Key postures of the human followed by each robot.
    pub bodies: Vec<BodyPoses>,
}

/// Solves the key poses of every body and synthesizes the demonstrations.
pub fn generate(config: &GeneratorConfig) -> Result<Generated, GenerateError> {
    let human = solve_key_poses(&config.human)?;
    let robots = config
        .robots
        .iter()
        .map(|r| solve_key_poses(r))
        .collect::<Result<Vec<_>, _>>()?;
    let dataset = synthesize(config, &human, &robots)?;
    let mut bodies = vec![human];
    bodies.extend(robots);
    Ok(Generated { dataset, bodies })
}

/// Name of the file [`generate_to_dir`] writes.
pub const DEMO_FILE_NAME: &str = "bimanual.mcap";

/// Generates with `config` and writes `dir/bimanual.mcap` (zstd, ROS 2 JointState topics
/// `/human/joint_states` and `/<robot>/joint_command`, labels and split as metadata).
pub fn generate_to_dir(
    config: &GeneratorConfig,
    dir: impl AsRef<Path>,
) -> Result<(PathBuf, Generated), GenerateError> {
    let dir = dir.as_ref();
    std::fs::create_dir_all(dir).map_err(|source| JointStateError::Io {
        path: dir.to_path_buf(),
        action: "create the directory",
        source,
    })?;
    let generated = generate(config)?;
    let path = dir.join(DEMO_FILE_NAME);
    write_demonstrations(&path, &generated.dataset)?;
    Ok((path, generated))
}

/// One pose-to-pose motion of the recording.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Move {
    from: usize,
    to: usize,
    /// `None` for the approach to a pair's first pose (not part of any set).
    repetition: Option<usize>,
}

/// The recording plan: for each non-neutral pose p, (neutral ↔ p) back and forth
/// `repetitions` times; then for each test pair, an approach and (a ↔ b) back and forth.
fn plan(config: &GeneratorConfig) -> Vec<Move> {
    let mut moves = Vec::new();
    let mut at = NEUTRAL;
    let pair = |a: usize, b: usize, moves: &mut Vec<Move>, at: &mut usize| {
        if *at != a {
            moves.push(Move {
                from: *at,
                to: a,
                repetition: None,
            });
        }
        for r in 0..config.repetitions {
            moves.push(Move {
                from: a,
                to: b,
                repetition: Some(r),
            });
            moves.push(Move {
                from: b,
                to: a,
                repetition: Some(r),
            });
        }
        *at = a;
    };
    for p in (0..KEY_POSES.len()).filter(|&p| p != NEUTRAL) {
        pair(NEUTRAL, p, &mut moves, &mut at);
    }
    for &(a, b) in &config.test_pairs {
        pair(a, b, &mut moves, &mut at);
    }
    moves
}

fn check_config(
    config: &GeneratorConfig,
    human: &BodyPoses,
    robots: &[BodyPoses],
) -> Result<(), GenerateError> {
    let bad = |m: String| Err(GenerateError::Config(m));
    if !(config.rate_hz.is_finite() && config.rate_hz > 0.0) {
        return bad(format!("rate_hz must be positive, got {}", config.rate_hz));
    }
    if config.repetitions == 0 || config.train_subsample == 0 || config.test_subsample == 0 {
        return bad("repetitions, train_subsample and test_subsample must be at least 1".into());
    }
    let (lo, hi) = config.duration_s;
    if !(lo > 0.0 && hi >= lo && config.peak_speed > 0.0 && config.hold_s >= 0.0) {
        return bad(format!(
            "durations ({lo}, {hi}) s, peak speed {} rad/s and hold {} s must be positive and ordered",
            config.peak_speed, config.hold_s
        ));
    }
    let m = &config.mimic;
    if !(m.delay_s.0 >= 0.0
        && m.delay_s.1 >= m.delay_s.0
        && m.speed.0 > 0.0
        && m.speed.1 >= m.speed.0)
        || [m.posture_std, m.path_bend_std, m.noise_std]
            .iter()
            .any(|s| s.is_nan() || *s < 0.0)
    {
        return bad("human mimic ranges must be ordered and non-negative".into());
    }
    if m.delay_s.1 >= lo + config.hold_s {
        return bad(format!(
            "the human's largest delay {} s must be shorter than the shortest motion plus hold {} s",
            m.delay_s.1,
            lo + config.hold_s
        ));
    }
    for &(a, b) in &config.test_pairs {
        if a == NEUTRAL || b == NEUTRAL || a == b || a >= KEY_POSES.len() || b >= KEY_POSES.len() {
            return bad(format!(
                "test pair ({a}, {b}) must name two different non-neutral poses below {}",
                KEY_POSES.len()
            ));
        }
    }
    for b in std::iter::once(human).chain(robots) {
        if b.postures.len() != KEY_POSES.len()
            || b.postures.iter().any(|q| q.len() != b.joint_names.len())
            || b.limits.len() != b.joint_names.len()
        {
            return bad(format!("body `{}` has inconsistent key postures", b.name));
        }
    }
    Ok(())
}

/// Builds the demonstrations from solved key postures (deterministic given `config.seed`).
pub fn synthesize(
    config: &GeneratorConfig,
    human: &BodyPoses,
    robots: &[BodyPoses],
) -> Result<Dataset, GenerateError> {
    check_config(config, human, robots)?;
    let mut rng = ChaCha8Rng::seed_from_u64(config.seed);
    let dt = 1.0 / config.rate_hz;
    let dh = human.joint_names.len();
    let moves = plan(config);
    let unit = Normal::new(0.0, 1.0).expect("invariant: unit normal is valid");
    let m = &config.mimic;

    let mut human_rows: Vec<f64> = Vec::new();
    let mut robot_rows: Vec<Vec<f64>> = vec![Vec::new(); robots.len()];
    let mut segments = Vec::with_capacity(moves.len());
    // The human's current posture and, per (pose, repetition), the posture they adopt there.
    let clamp = |q: &mut [f64], limits: &[(f64, f64)]| {
        for (v, &(lo, hi)) in q.iter_mut().zip(limits) {
            *v = v.clamp(lo, hi);
        }
    };
    let mut human_now = human.postures[moves.first().map_or(NEUTRAL, |mv| mv.from)].clone();
    let mut frames = 0usize;
    for mv in &moves {
        // Duration from the largest joint displacement over all bodies.
        let mut max_disp: f64 = 0.0;
        for b in std::iter::once(human).chain(robots) {
            for (x, y) in b.postures[mv.from].iter().zip(&b.postures[mv.to]) {
                max_disp = max_disp.max((x - y).abs());
            }
        }
        let duration =
            (1.875 * max_disp / config.peak_speed).clamp(config.duration_s.0, config.duration_s.1);
        let n = ((duration + config.hold_s) * config.rate_hz)
            .round()
            .max(2.0) as usize;

        // The human's version of this motion.
        let delay = rng.random_range(m.delay_s.0..=m.delay_s.1);
        let speed = rng.random_range(m.speed.0..=m.speed.1);
        let span_end = (n - 1) as f64 * dt;
        let human_duration = (duration / speed).min(span_end - delay).max(dt);
        let mut human_target = human.postures[mv.to].clone();
        for v in human_target.iter_mut() {
            *v += m.posture_std * unit.sample(&mut rng);
        }
        clamp(&mut human_target, &human.limits);
        let bend: Vec<f64> = (0..dh)
            .map(|_| m.path_bend_std * unit.sample(&mut rng))
            .collect();
        let start = human_now.clone();

        for k in 0..n {
            let t = k as f64 * dt;
            let s = quintic(t / duration);
            for (rows, b) in robot_rows.iter_mut().zip(robots) {
                let (qa, qb) = (&b.postures[mv.from], &b.postures[mv.to]);
                // Clamped: a + s (b − a) can overshoot a limit-clamped end posture by an ulp.
                rows.extend(
                    qa.iter()
                        .zip(qb)
                        .zip(&b.limits)
                        .map(|((a, b), &(lo, hi))| (a + s * (b - a)).clamp(lo, hi)),
                );
            }
            let sh = quintic((t - delay) / human_duration);
            let arc = (std::f64::consts::PI * sh).sin();
            let mut q: Vec<f64> = (0..dh)
                .map(|j| start[j] + sh * (human_target[j] - start[j]) + arc * bend[j])
                .collect();
            clamp(&mut q, &human.limits);
            if k + 1 == n {
                human_now = q.clone();
            }
            for v in q.iter_mut() {
                *v += m.noise_std * unit.sample(&mut rng);
            }
            clamp(&mut q, &human.limits);
            human_rows.extend_from_slice(&q);
        }
        segments.push(Segment {
            start: frames,
            end: frames + n,
            from_pose: Some(mv.from),
            to_pose: Some(mv.to),
            repetition: mv.repetition,
        });
        frames += n;
    }

    let (train, test) = split(&segments, config.train_subsample, config.test_subsample);
    let period = 1e9 / config.rate_hz;
    let times_ns = (0..frames)
        .map(|k| config.start_time_ns + (k as f64 * period).round() as i64)
        .collect();
    let body = |b: &BodyPoses, topic: String, rows: &[f64]| {
        BodyData::from_rows(b.name.clone(), topic, b.joint_names.clone(), frames, rows)
    };
    let dataset = Dataset {
        times_ns,
        human: body(human, format!("/{}/joint_states", human.name), &human_rows)?,
        robots: robots
            .iter()
            .zip(&robot_rows)
            .map(|(b, rows)| body(b, format!("/{}/joint_command", b.name), rows))
            .collect::<Result<_, _>>()?,
        pose_names: KEY_POSES.iter().map(|p| p.name.to_string()).collect(),
        segments,
        train,
        test,
    };
    dataset.validate()?;
    Ok(dataset)
}

/// Training frames: every `train_subsample`-th frame of the labelled segments that start at
/// the neutral pose; test frames: every `test_subsample`-th frame of the labelled segments
/// between two non-neutral poses. Approach moves (no repetition) belong to neither set.
pub fn split(
    segments: &[Segment],
    train_subsample: usize,
    test_subsample: usize,
) -> (Vec<usize>, Vec<usize>) {
    let step = train_subsample.max(1);
    let train_pool = segments
        .iter()
        .filter(|s| s.repetition.is_some() && s.from_pose == Some(NEUTRAL))
        .flat_map(|s| s.start..s.end);
    let train = train_pool.step_by(step).collect();
    let test = segments
        .iter()
        .filter(|s| {
            s.repetition.is_some()
                && s.from_pose.is_some_and(|p| p != NEUTRAL)
                && s.to_pose.is_some_and(|p| p != NEUTRAL)
        })
        .flat_map(|s| s.start..s.end)
        .step_by(test_subsample.max(1))
        .collect();
    (train, test)
}

#[cfg(test)]
mod tests;
