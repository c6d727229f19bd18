//! `sgplvm evaluate`: a model's test error on a demonstration file, overall and per joint, and
//! how often the live safety rule (`sgplvm teleop`'s gate) would hold a robot: on the test
//! frames, on poses far from them and on random poses within the human's joint limits, with the
//! test error of the frames it would hold and of those it would follow; and, for a robot whose
//! URDF is known, how far the model's commands put its arms from the demonstrated posture
//! (`arms`), per person where the data names them.

use anyhow::{anyhow, Result};
use clap::{Args, ValueEnum};
use rand_chacha::rand_core::{RngCore, SeedableRng};
use serde::Serialize;
use sgplvm::girdle::{aligned_dataset, PersonShifts};
use sgplvm::pipeline::{
    human_pose_bounds, mean_squared_error, to_mat, Demonstrations, Evaluation, TestTrust,
};
use sgplvm::provenance::other_robot;
use sgplvm::{AnyModel, Mat, Predictor, Robot};

use super::args::{DataArg, Girdle, GirdleArg, JsonArg, ModelFileArg};
use super::body::BodyArgs;
use super::frames::require_robot;
use super::report;

mod arms;

#[derive(Args)]
pub struct EvaluateArgs {
    #[command(flatten)]
    model: ModelFileArg,
    #[command(flatten)]
    data: DataArg,
    /// The robot.
    #[arg(long)]
    robot: String,
    /// Radians added to every human joint of every test frame to make the far poses.
    #[arg(long, default_value_t = 1.0)]
    far_offset: f64,
    /// How many random poses (each joint uniform within the built-in human's limits,
    /// data/urdf/human.urdf).
    #[arg(long, default_value_t = 1000)]
    random_poses: usize,
    /// Seed of the random poses.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// The robot's URDF, for a robot not built in: the arms' angles to the demonstrated
    /// posture are measured on it (without it, and not built in, they are left out).
    #[arg(long)]
    urdf: Option<std::path::PathBuf>,
    #[command(flatten)]
    body: BodyArgs,
    #[command(flatten)]
    girdle: GirdleArg,
    #[command(flatten)]
    json: JsonArg,
}

/// Which signals hold a robot (as `teleop --gate`).
#[derive(Clone, Copy, PartialEq, Eq, ValueEnum, Serialize)]
#[serde(rename_all = "kebab-case")]
enum Gate {
    /// The robot prediction's standard deviation against the trust threshold.
    Sd,
    /// The human frame's reconstruction error against the reconstruction threshold.
    Reconstruction,
    /// The standard deviation or the reconstruction error.
    Both,
    /// The human frame's distance to the nearest training pose against the novelty threshold.
    Novelty,
    /// The reconstruction error or the novelty: a pose the model does not know (teleop's
    /// default).
    Known,
}

impl Gate {
    /// Every gate, in the order printed.
    const ALL: [Gate; 5] = [
        Gate::Sd,
        Gate::Reconstruction,
        Gate::Both,
        Gate::Novelty,
        Gate::Known,
    ];
    /// teleop's default.
    const DEFAULT: Gate = Gate::Known;

    /// Which of the standard deviation, the reconstruction error and the novelty gate.
    fn gates(self) -> [bool; 3] {
        match self {
            Gate::Sd => [true, false, false],
            Gate::Reconstruction => [false, true, false],
            Gate::Both => [true, true, false],
            Gate::Novelty => [false, false, true],
            Gate::Known => [false, true, true],
        }
    }
}

/// How many frames of a set a gate holds.
#[derive(Clone, Copy, Serialize)]
struct Held {
    held: usize,
    frames: usize,
}

impl Held {
    fn percent(self) -> f64 {
        100.0 * self.held as f64 / self.frames.max(1) as f64
    }
}

/// One gate's rates and the test error on either side of it.
#[derive(Serialize)]
struct GateRates {
    gate: Gate,
    test: Held,
    far: Held,
    random: Held,
    /// Mean squared error (rad², over joints and frames) of the test frames followed.
    mse_followed: Option<f64>,
    /// The same of the test frames held.
    mse_held: Option<f64>,
}

/// The signals of a set of human frames: the prediction's standard deviation, the
/// reconstruction error and the distance to the nearest training pose.
struct Signals {
    values: [Vec<f64>; 3],
}

impl Signals {
    /// The signals of the frames `h` for `robot`: a single latent space's own values, a
    /// per-part model's as the largest part's ratio to its threshold
    /// ([`sgplvm::PartsGplvm::gate_ratios`]).
    fn of(model: &AnyModel, robot: &str, h: &Mat<f64>) -> Result<Signals> {
        let values = match model {
            AnyModel::Single(m) => [
                m.prediction_sd(h.as_ref(), robot)?,
                m.reconstruction_errors(h.as_ref())?,
                m.novelties(h.as_ref())?,
            ],
            AnyModel::Parts(m) => m.gate_ratios(h.as_ref(), robot)?,
        };
        Ok(Signals { values })
    }

    /// Whether `gate` holds frame `i` against `thresholds` (the live rule,
    /// `sgplvm_live::gate::Thresholds::trusts`: a gating signal beyond its threshold, or any
    /// signal not a number).
    fn held(&self, i: usize, gate: Gate, thresholds: &[f64; 3]) -> bool {
        let gates = gate.gates();
        (0..3).any(|k| {
            let v = self.values[k][i];
            !v.is_finite() || (gates[k] && v > thresholds[k])
        })
    }

    fn count(&self, gate: Gate, thresholds: &[f64; 3]) -> Held {
        let frames = self.values[0].len();
        Held {
            held: (0..frames)
                .filter(|&i| self.held(i, gate, thresholds))
                .count(),
            frames,
        }
    }
}

/// Everything `evaluate` prints about the gate.
#[derive(Serialize)]
struct GateReport {
    /// Whether the signals are a per-part model's ratios to the parts' thresholds (then every
    /// threshold is 1 and the calibrations are left out).
    per_part: bool,
    /// The trust threshold (standardised standard deviation).
    sd_threshold: f64,
    /// The reconstruction threshold and the held-out errors it comes from (the per-frame
    /// errors are left out).
    reconstruction_threshold: f64,
    reconstruction_percentile: Option<f64>,
    reconstruction_mean_pose: Option<f64>,
    /// The novelty threshold and the distances it comes from.
    novelty_threshold: f64,
    novelty_percentile: Option<f64>,
    novelty_random: Option<f64>,
    far_offset: f64,
    random_seed: u64,
    rates: Vec<GateRates>,
}

pub fn run(args: EvaluateArgs) -> Result<()> {
    let model = args.model.load_any()?;
    // Before the data: "the model does not know coman; it predicts for [...]" says more than a
    // mismatch of joint lists would.
    require_robot(&model, &args.model.model, &args.robot)?;
    let demos = args.data.load()?;
    // The model's input: each person's clavicles aligned to the model's people (--girdle).
    let aligned = match args.girdle.girdle {
        Girdle::Aligned => aligned_dataset(&model, &demos.dataset),
        Girdle::AsCaptured => None,
    };
    // Said of the people whose frames are tested (the training people's shifts are not).
    let tested: std::collections::BTreeSet<Option<&str>> = demos
        .dataset
        .test
        .iter()
        .map(|&f| {
            demos
                .dataset
                .segment_of(f)
                .and_then(|s| s.person.as_deref())
        })
        .collect();
    let (aligned, mut shifts) = match aligned {
        Some((dataset, shifts)) => (
            Some(Demonstrations {
                dataset,
                source_name: demos.source_name.clone(),
            }),
            shifts,
        ),
        None => (None, Vec::new()),
    };
    // The model's input: the aligned frames, or the demonstrations as they are (not copied).
    let input = aligned.as_ref().unwrap_or(&demos);
    shifts.retain(|(person, _)| tested.contains(&person.as_deref()));
    let evaluation = input.evaluate(&model, &args.robot)?;
    let trust = match &model {
        AnyModel::Single(m) => Some(input.test_trust(m, &args.robot)?),
        AnyModel::Parts(_) => None,
    };
    let (gate, held) = gate_report(&model, input, &args)?;
    let arms = match (&args.urdf, Robot::builtin_urdf(&args.robot)) {
        (None, None) => None,
        (urdf, _) => {
            let anatomy = args.body.load(&args.robot, urdf.as_deref(), "")?;
            if let Some(warning) = other_robot(model.annotations(), &args.robot, &anatomy) {
                eprintln!("warning: {warning}");
            }
            let test = to_mat(&input.dataset.human.rows(&input.dataset.test));
            let predicted = model.predict(test.as_ref(), &args.robot, false)?.mean;
            Some(arms::report(
                &anatomy,
                &demos,
                &args.robot,
                &predicted,
                &held,
            )?)
        }
    };
    if args.json.json {
        #[derive(Serialize)]
        struct All<'a> {
            #[serde(flatten)]
            evaluation: &'a Evaluation,
            #[serde(skip_serializing_if = "Option::is_none")]
            trust: Option<&'a TestTrust>,
            gate: &'a GateReport,
            arms: Option<&'a arms::ArmsReport>,
            girdle_shifts: Vec<GirdleShift<'a>>,
        }
        let all = All {
            evaluation: &evaluation,
            trust: trust.as_ref(),
            gate: &gate,
            arms: arms.as_ref(),
            girdle_shifts: girdle_shifts(&shifts),
        };
        println!("{}", serde_json::to_string_pretty(&all)?);
        return Ok(());
    }
    report::evaluation(&evaluation, trust.as_ref());
    print_girdle(&shifts, args.girdle.girdle);
    print_gate(&gate);
    if let Some(arms) = &arms {
        arms::print(arms, &args.robot);
    }
    Ok(())
}

/// The test frames' human poses, the far poses and the random ones, and each gate's rates; and
/// which test frames teleop's default gate holds.
fn gate_report(
    model: &AnyModel,
    demos: &Demonstrations,
    args: &EvaluateArgs,
) -> Result<(GateReport, Vec<bool>)> {
    if !(args.far_offset.is_finite()) {
        return Err(anyhow!(
            "--far-offset {}: expected a number of radians",
            args.far_offset
        ));
    }
    let ds = &demos.dataset;
    let test = to_mat(&ds.human.rows(&ds.test));
    let far = Mat::from_fn(test.nrows(), test.ncols(), |i, j| {
        test[(i, j)] + args.far_offset
    });
    let random = random_poses(&ds.human.joint_names, args.random_poses, args.seed)?;
    // The model's thresholds as teleop uses them (a file's stored ones); a per-part model's
    // signals are ratios to its parts' thresholds.
    let (thresholds, calibrations) = match model {
        AnyModel::Single(m) => (
            [
                m.trust_threshold(&args.robot)?,
                m.reconstruction_threshold()?,
                m.novelty_threshold()?,
            ],
            Some((m.reconstruction_calibration()?, m.novelty_calibration()?)),
        ),
        AnyModel::Parts(_) => ([1.0; 3], None),
    };
    let signals = [&test, &far, &random]
        .map(|h| Signals::of(model, &args.robot, h))
        .into_iter()
        .collect::<Result<Vec<_>>>()?;
    let errors = test_frame_errors(model, demos, &args.robot, &test)?;
    let rates = Gate::ALL
        .into_iter()
        .map(|gate| {
            let (mut sums, mut counts) = ([0.0; 2], [0usize; 2]);
            for (i, &e) in errors.iter().enumerate() {
                let side = usize::from(signals[0].held(i, gate, &thresholds));
                sums[side] += e;
                counts[side] += 1;
            }
            let mean = |k: usize| (counts[k] > 0).then(|| sums[k] / counts[k] as f64);
            GateRates {
                gate,
                test: signals[0].count(gate, &thresholds),
                far: signals[1].count(gate, &thresholds),
                random: signals[2].count(gate, &thresholds),
                mse_followed: mean(0),
                mse_held: mean(1),
            }
        })
        .collect();
    let held = (0..test.nrows())
        .map(|i| signals[0].held(i, Gate::DEFAULT, &thresholds))
        .collect();
    let report = GateReport {
        per_part: calibrations.is_none(),
        sd_threshold: thresholds[0],
        reconstruction_threshold: thresholds[1],
        reconstruction_percentile: calibrations.as_ref().map(|c| c.0.percentile),
        reconstruction_mean_pose: calibrations.as_ref().map(|c| c.0.mean_pose),
        novelty_threshold: thresholds[2],
        novelty_percentile: calibrations.as_ref().map(|c| c.1.percentile),
        novelty_random: calibrations.as_ref().and_then(|c| c.1.random),
        far_offset: args.far_offset,
        random_seed: args.seed,
        rates,
    };
    Ok((report, held))
}

/// Each test frame's mean squared error over the robot's joints (rad²).
fn test_frame_errors(
    model: &AnyModel,
    demos: &Demonstrations,
    robot: &str,
    test: &Mat<f64>,
) -> Result<Vec<f64>> {
    let ds = &demos.dataset;
    let desired = to_mat(&demos.robot(robot)?.rows(&ds.test));
    let predicted = model.predict(test.as_ref(), robot, false)?.mean;
    Ok((0..test.nrows())
        .map(|i| {
            mean_squared_error(
                predicted.as_ref().subrows(i, 1),
                desired.as_ref().subrows(i, 1),
            )
        })
        .collect())
}

/// `n` poses of the human joints `names`, each joint uniform within the built-in human's
/// limits (ChaCha8 from `seed`).
fn random_poses(names: &[String], n: usize, seed: u64) -> Result<Mat<f64>> {
    let bounds = human_pose_bounds(names).map_err(|e| anyhow!(e))?;
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    // Uniform on [0, 1) from the top 53 bits.
    let mut uniform = move || (rng.next_u64() >> 11) as f64 / (1u64 << 53) as f64;
    let mut poses = Mat::zeros(n, names.len());
    for i in 0..n {
        for (j, &(lo, hi)) in bounds.iter().enumerate() {
            poses[(i, j)] = lo + (hi - lo) * uniform();
        }
    }
    Ok(poses)
}

/// One person's clavicle shifts, for `--json`: per arm (left, right) elevation and
/// protraction, degrees.
#[derive(Serialize)]
struct GirdleShift<'a> {
    person: Option<&'a str>,
    degrees: Vec<[f64; 2]>,
}

fn girdle_shifts(shifts: &PersonShifts) -> Vec<GirdleShift<'_>> {
    shifts
        .iter()
        .map(|(person, arms)| GirdleShift {
            person: person.as_deref(),
            degrees: arms
                .iter()
                .map(|s| [s[0].to_degrees(), s[1].to_degrees()])
                .collect(),
        })
        .collect()
}

/// The line saying how each test person's clavicles reached the model.
fn print_girdle(shifts: &PersonShifts, girdle: Girdle) {
    if girdle == Girdle::AsCaptured {
        println!("clavicles as captured (--girdle as-captured)");
        return;
    }
    if shifts.is_empty() {
        return;
    }
    let people: Vec<String> = shifts
        .iter()
        .map(|(person, arms)| {
            let arms: Vec<String> = arms
                .iter()
                .map(|s| format!("{:+.1}°/{:+.1}°", s[0].to_degrees(), s[1].to_degrees()))
                .collect();
            format!(
                "{} {}",
                person.as_deref().unwrap_or("(unnamed)"),
                arms.join(" ")
            )
        })
        .collect();
    println!(
        "clavicles aligned to the model's people (--girdle; each tested person's mean elevation/protraction shifted by, per arm): {}",
        people.join("; ")
    );
}

fn print_gate(g: &GateReport) {
    match (
        g.reconstruction_percentile,
        g.reconstruction_mean_pose,
        g.novelty_percentile,
    ) {
        (Some(percentile), Some(mean_pose), Some(novelty)) => {
            println!(
                "gate: thresholds — sd {:.4}; reconstruction {:.4} (the larger of the held-out errors' 99th percentile {percentile:.4} and the mean pose's held-out error {mean_pose:.4})",
                g.sd_threshold, g.reconstruction_threshold,
            );
            let source = match g.novelty_random {
                Some(_) => "random poses' 1st percentile",
                None => "the human's joint limits unknown: the held-out distances' 99th percentile",
            };
            println!(
                "      novelty {:.4} ({source}; the training people's (groups') distances to the others: 99th percentile {novelty:.4})",
                g.novelty_threshold
            );
        }
        _ => println!(
            "gate (a latent space per part): each signal is the largest of the parts' signals over their own thresholds; a frame is held where one is beyond 1"
        ),
    }
    println!(
        "  {:<16} {:>19} {:>19} {:>19}   test RMSE followed / held",
        "--gate",
        "test frames held",
        format!("far (+{} rad) held", g.far_offset),
        "random poses held"
    );
    let rmse = |m: Option<f64>| {
        m.map_or("-".to_string(), |m| {
            format!("{:.2}°", m.sqrt().to_degrees())
        })
    };
    for r in &g.rates {
        let name = match r.gate {
            Gate::Sd => "sd",
            Gate::Reconstruction => "reconstruction",
            Gate::Both => "both",
            Gate::Novelty => "novelty",
            Gate::Known => "known *",
        };
        let cell = |h: Held| format!("{}/{} ({:.1} %)", h.held, h.frames, h.percent());
        println!(
            "  {name:<16} {:>19} {:>19} {:>19}   {} / {}",
            cell(r.test),
            cell(r.far),
            cell(r.random),
            rmse(r.mse_followed),
            rmse(r.mse_held)
        );
    }
    println!(
        "  (* teleop's default; random poses: each human joint uniform within its limits, seed {})",
        g.random_seed
    );
}
