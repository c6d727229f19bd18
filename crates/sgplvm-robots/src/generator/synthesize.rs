//! From solved key postures to demonstrations: the recording `plan` (which pose pairs, how
//! many repetitions), the configuration check, the synthesis of every motion (robots on a
//! [`quintic`] blend, the human with delay, speed, posture change, path bend and noise) and
//! the train/test [`split`].

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

use super::{BodyPoses, GenerateError, GeneratorConfig, HumanMimic, KEY_POSES, NEUTRAL};
use crate::dataset::{BodyData, Dataset, Segment};

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

/// One pose-to-pose motion of the recording.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) struct Move {
    pub(super) from: usize,
    pub(super) to: usize,
    /// `None` for the approach to a pair's first pose (not part of any set).
    pub(super) repetition: Option<usize>,
}

/// The recording plan: for each non-neutral pose p, (neutral ↔ p) back and forth
/// `repetitions` times; then for each test pair, an approach and (a ↔ b) back and forth.
pub(super) fn plan(config: &GeneratorConfig) -> Vec<Move> {
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
    pace: &[BodyPoses],
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
    for b in std::iter::once(human).chain(robots).chain(pace) {
        if b.postures.len() != KEY_POSES.len()
            || b.postures.iter().any(|q| q.len() != b.joint_names.len())
            || b.limits.len() != b.joint_names.len()
        {
            return bad(format!("body `{}` has inconsistent key postures", b.name));
        }
    }
    Ok(())
}

/// Builds the demonstrations from solved key postures (deterministic given `config.seed`); the
/// duration of each motion follows the largest joint displacement of the human and `robots`.
pub fn synthesize(
    config: &GeneratorConfig,
    human: &BodyPoses,
    robots: &[BodyPoses],
) -> Result<Dataset, GenerateError> {
    synthesize_paced(config, human, robots, robots)
}

/// [`synthesize`] with the duration of each motion set by the human and the `pace` bodies
/// instead of the recorded `robots`: the human's data and the recorded robots' commands then do
/// not depend on which other robots are recorded.
pub fn synthesize_paced(
    config: &GeneratorConfig,
    human: &BodyPoses,
    robots: &[BodyPoses],
    pace: &[BodyPoses],
) -> Result<Dataset, GenerateError> {
    check_config(config, human, robots, pace)?;
    let mut rng = ChaCha8Rng::seed_from_u64(config.seed);
    let dt = 1.0 / config.rate_hz;
    let moves = plan(config);
    let unit = Normal::new(0.0, 1.0).expect("invariant: unit normal is valid");

    let mut human_rows: Vec<f64> = Vec::new();
    let mut robot_rows: Vec<Vec<f64>> = vec![Vec::new(); robots.len()];
    let mut segments = Vec::with_capacity(moves.len());
    // The human's current posture.
    let mut human_now = human.postures[moves.first().map_or(NEUTRAL, |mv| mv.from)].clone();
    let mut frames = 0usize;
    for mv in &moves {
        let (duration, n) = move_timing(config, human, pace, mv);
        // The human's version of this motion.
        let motion = HumanMotion::draw(
            &config.mimic,
            human,
            mv,
            &human_now,
            duration,
            n,
            dt,
            &mut rng,
        );
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
            let mut q = motion.at(t, &human.limits);
            if k + 1 == n {
                human_now = q.clone();
            }
            for v in q.iter_mut() {
                *v += config.mimic.noise_std * unit.sample(&mut rng);
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
            person: None,
        });
        frames += n;
    }
    assemble(
        config,
        human,
        robots,
        &human_rows,
        &robot_rows,
        segments,
        frames,
    )
}

/// Clamps every joint of `q` into its limits.
fn clamp(q: &mut [f64], limits: &[(f64, f64)]) {
    for (v, &(lo, hi)) in q.iter_mut().zip(limits) {
        *v = v.clamp(lo, hi);
    }
}

/// Duration of the robots' motion `mv` (from the largest joint displacement over the human
/// and the `pace` bodies at the configured peak speed, within the configured range) and its
/// frame count, hold included.
fn move_timing(
    config: &GeneratorConfig,
    human: &BodyPoses,
    pace: &[BodyPoses],
    mv: &Move,
) -> (f64, usize) {
    let mut max_disp: f64 = 0.0;
    for b in std::iter::once(human).chain(pace) {
        for (x, y) in b.postures[mv.from].iter().zip(&b.postures[mv.to]) {
            max_disp = max_disp.max((x - y).abs());
        }
    }
    let duration =
        (1.875 * max_disp / config.peak_speed).clamp(config.duration_s.0, config.duration_s.1);
    let n = ((duration + config.hold_s) * config.rate_hz)
        .round()
        .max(2.0) as usize;
    (duration, n)
}

/// The human's version of one motion: from where they are, after a delay, at their own
/// speed, to their own take on the target posture, along a bent path.
struct HumanMotion {
    delay: f64,
    duration: f64,
    start: Vec<f64>,
    target: Vec<f64>,
    bend: Vec<f64>,
}

impl HumanMotion {
    /// Draws delay, speed, target posture change and path bend, in that order, from `rng`.
    #[allow(clippy::too_many_arguments)]
    fn draw(
        m: &HumanMimic,
        human: &BodyPoses,
        mv: &Move,
        now: &[f64],
        duration: f64,
        n: usize,
        dt: f64,
        rng: &mut ChaCha8Rng,
    ) -> Self {
        let unit = Normal::new(0.0, 1.0).expect("invariant: unit normal is valid");
        let delay = rng.random_range(m.delay_s.0..=m.delay_s.1);
        let speed = rng.random_range(m.speed.0..=m.speed.1);
        let span_end = (n - 1) as f64 * dt;
        let human_duration = (duration / speed).min(span_end - delay).max(dt);
        let mut target = human.postures[mv.to].clone();
        for v in target.iter_mut() {
            *v += m.posture_std * unit.sample(rng);
        }
        clamp(&mut target, &human.limits);
        let bend: Vec<f64> = (0..human.joint_names.len())
            .map(|_| m.path_bend_std * unit.sample(rng))
            .collect();
        Self {
            delay,
            duration: human_duration,
            start: now.to_vec(),
            target,
            bend,
        }
    }

    /// The noiseless posture at time `t` of the motion, within `limits`.
    fn at(&self, t: f64, limits: &[(f64, f64)]) -> Vec<f64> {
        let sh = quintic((t - self.delay) / self.duration);
        let arc = (std::f64::consts::PI * sh).sin();
        let mut q: Vec<f64> = (0..self.start.len())
            .map(|j| self.start[j] + sh * (self.target[j] - self.start[j]) + arc * self.bend[j])
            .collect();
        clamp(&mut q, limits);
        q
    }
}

/// The dataset of the synthesized rows: times from the configured start at the configured
/// rate, one body per human/robot, the segments and their train/test split.
fn assemble(
    config: &GeneratorConfig,
    human: &BodyPoses,
    robots: &[BodyPoses],
    human_rows: &[f64],
    robot_rows: &[Vec<f64>],
    segments: Vec<Segment>,
    frames: usize,
) -> Result<Dataset, GenerateError> {
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
        human: body(human, format!("/{}/joint_states", human.name), human_rows)?,
        robots: robots
            .iter()
            .zip(robot_rows)
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
