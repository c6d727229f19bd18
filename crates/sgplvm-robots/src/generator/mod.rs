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
//! Everything is seeded: the same configuration gives the same dataset, bit for bit. Which
//! robots are recorded ([`GeneratorConfig::robots`]) changes nothing else: the clock of every
//! motion follows the human and the pace robots ([`GeneratorConfig::pace_robots`], the paper's
//! three), so a file recorded with a fourth robot holds the human's data and the other robots'
//! commands of the three-robot file, bit for bit.

//!
//! The module is laid out along these steps: `poses.rs` holds the key poses and their IK
//! solutions, `synthesize.rs` the recording plan, the configuration check, the
//! synthesis of the motions and the train/test split; this file the configuration, the error
//! and the entry points.

use std::path::{Path, PathBuf};

use crate::dataset::{write_demonstrations, Dataset};
use crate::joint_state::JointStateError;
use crate::RobotError;

mod poses;
mod synthesize;

pub use poses::{
    solve_key_poses, solve_key_poses_for, BodyPoses, KeyPose, PoseReport, KEY_POSES, NEUTRAL,
};
pub use synthesize::{quintic, quintic_derivatives, split, synthesize, synthesize_paced};

#[cfg(test)]
use crate::dataset::Segment;
#[cfg(test)]
use rand::{Rng, SeedableRng};
#[cfg(test)]
use rand_chacha::ChaCha8Rng;
#[cfg(test)]
use synthesize::plan;

/// The paper's test set: two pairs of non-neutral poses ([`GeneratorConfig::test_pairs`]'s
/// default).
pub const PAPER_TEST_PAIRS: [(usize, usize); 2] = [(2, 5), (9, 14)];

/// Every ordered pair of two different non-neutral key poses (both directions: 15 × 14 = 210),
/// in order: a test set that does not hang on two draws of the human's motion.
pub fn all_test_pairs() -> Vec<(usize, usize)> {
    let poses = (0..KEY_POSES.len()).filter(|&p| p != NEUTRAL);
    poses
        .clone()
        .flat_map(|a| poses.clone().filter(move |&b| b != a).map(move |b| (a, b)))
        .collect()
}

/// `count` of [`all_test_pairs`], drawn without replacement from `seed` (kept in their order
/// in that list); `None` when `count` is 0 or more than there are.
pub fn random_test_pairs(count: usize, seed: u64) -> Option<Vec<(usize, usize)>> {
    use rand::SeedableRng;
    let all = all_test_pairs();
    if count == 0 || count > all.len() {
        return None;
    }
    // Its own stream, apart from the motions' draws: the same seed gives the same motions
    // whatever test pairs are chosen.
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed ^ 0x7e57_9a1e_5eed);
    let mut chosen = rand::seq::index::sample(&mut rng, all.len(), count).into_vec();
    chosen.sort_unstable();
    Some(chosen.into_iter().map(|i| all[i]).collect())
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

/// The robots of the paper's experiments, in the column order of the shipped data: the default
/// [`GeneratorConfig::robots`] and [`GeneratorConfig::pace_robots`].
pub const PAPER_ROBOTS: [&str; 3] = ["walkman", "coman", "centauro"];

/// Everything that shapes a generated dataset.
#[derive(Debug, Clone, PartialEq)]
pub struct GeneratorConfig {
    /// Seed of all random draws.
    pub seed: u64,
    /// Sampling rate of the recording, Hz.
    pub rate_hz: f64,
    /// Built-in robot models to record, in column order of the dataset (at least one, each
    /// once, not the human).
    pub robots: Vec<String>,
    /// Built-in robot models whose key postures set, with the human's, the duration of every
    /// motion (the largest joint displacement at [`GeneratorConfig::peak_speed`]); they need not
    /// be recorded. Default: the paper's three ([`PAPER_ROBOTS`]), so that recording another
    /// robot leaves the clock, the human's data and the other robots' commands unchanged. A
    /// recorded robot outside this list moves on their clock: its joints may move faster than
    /// `peak_speed`.
    pub pace_robots: Vec<String>,
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
            robots: PAPER_ROBOTS.iter().map(|r| r.to_string()).collect(),
            pace_robots: PAPER_ROBOTS.iter().map(|r| r.to_string()).collect(),
            human: "human".into(),
            repetitions: 3,
            train_subsample: 12,
            test_pairs: PAPER_TEST_PAIRS.to_vec(),
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
    /// A robot name that is not one of the built-in robot models.
    #[error("unknown robot `{name}`; the built-in robots are: {}", .known.join(", "))]
    UnknownRobot {
        /// The name asked for.
        name: String,
        /// The built-in robot models (every built-in body but the human).
        known: Vec<String>,
    },
    /// The configuration is unusable.
    #[error("invalid generator configuration: {0}")]
    Config(String),
    /// Writing the dataset failed.
    #[error(transparent)]
    Demo(#[from] JointStateError),
}

/// A generated dataset and how its key poses were solved.
#[derive(Debug, Clone)]
pub struct Generated {
    /// The demonstrations.
    pub dataset: Dataset,
    /// Key postures of the human followed by each robot.
    pub bodies: Vec<BodyPoses>,
}

/// Solves the key poses of every body (the human, the recorded robots and the pace robots) and
/// synthesizes the demonstrations.
pub fn generate(config: &GeneratorConfig) -> Result<Generated, GenerateError> {
    check_robot_names(config)?;
    let human = solve_key_poses(&config.human)?;
    let mut solved: Vec<BodyPoses> = Vec::new();
    for name in config.robots.iter().chain(&config.pace_robots) {
        if !solved.iter().any(|b| &b.name == name) {
            solved.push(solve_key_poses(name)?);
        }
    }
    let pick = |names: &[String]| -> Vec<BodyPoses> {
        names
            .iter()
            .filter_map(|n| solved.iter().find(|b| &b.name == n).cloned())
            .collect()
    };
    let robots = pick(&config.robots);
    let pace = pick(&config.pace_robots);
    let dataset = synthesize_paced(config, &human, &robots, &pace)?;
    let mut bodies = vec![human];
    bodies.extend(robots);
    Ok(Generated { dataset, bodies })
}

/// Every recorded and pace robot must be a built-in robot model (not the human), and the
/// recorded ones must be at least one and each listed once.
fn check_robot_names(config: &GeneratorConfig) -> Result<(), GenerateError> {
    let known: Vec<String> = crate::Robot::builtin_names()
        .iter()
        .filter(|&&n| n != config.human)
        .map(|n| n.to_string())
        .collect();
    for name in config.robots.iter().chain(&config.pace_robots) {
        if !known.contains(name) {
            return Err(GenerateError::UnknownRobot {
                name: name.clone(),
                known,
            });
        }
    }
    if config.robots.is_empty() {
        return Err(GenerateError::Config(
            "no robot to record; name at least one".into(),
        ));
    }
    for (i, name) in config.robots.iter().enumerate() {
        if config.robots[..i].contains(name) {
            return Err(GenerateError::Config(format!(
                "robot `{name}` is listed twice; each robot is recorded once"
            )));
        }
    }
    Ok(())
}

/// Name of the file [`generate_to_dir`] writes: the paper's demonstrations.
pub const DEMO_FILE_NAME: &str = "bimanual.mcap";

/// Name of the shipped file with a fourth robot of a different kinematic structure
/// (`data/demos/fleet.mcap`: the paper's three robots and `ur5e`).
pub const FLEET_FILE_NAME: &str = "fleet.mcap";

/// Generates with `config` and writes `dir/bimanual.mcap` (zstd, ROS 2 JointState topics
/// `/human/joint_states` and `/<robot>/joint_command`, labels and split as metadata).
pub fn generate_to_dir(
    config: &GeneratorConfig,
    dir: impl AsRef<Path>,
) -> Result<(PathBuf, Generated), GenerateError> {
    let path = dir.as_ref().join(DEMO_FILE_NAME);
    let generated = generate_to_file(config, &path)?;
    Ok((path, generated))
}

/// Generates with `config` and writes the demonstrations to `path` (as [`generate_to_dir`]
/// does), creating its folder if needed.
pub fn generate_to_file(
    config: &GeneratorConfig,
    path: impl AsRef<Path>,
) -> Result<Generated, GenerateError> {
    let path = path.as_ref();
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(|source| JointStateError::Io {
            path: dir.to_path_buf(),
            action: "create the directory",
            source,
        })?;
    }
    let generated = generate(config)?;
    write_demonstrations(path, &generated.dataset)?;
    Ok(generated)
}

#[cfg(test)]
mod tests;
