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
use sgplvm::core::ReconstructionCalibration;
use sgplvm::pipeline::{mean_squared_error, to_mat, Demonstrations, Evaluation, TestTrust};
use sgplvm::{Mat, Robot, SharedGplvm};

use super::args::{DataArg, JsonArg, ModelFileArg};
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
    json: JsonArg,
}

/// Which signals hold a robot (as `teleop --gate`).
#[derive(Clone, Copy, PartialEq, Eq, ValueEnum, Serialize)]
#[serde(rename_all = "kebab-case")]
enum Gate {
    /// The robot prediction's standard deviation against the trust threshold.
    Sd,
    /// The human frame's reconstruction error against the reconstruction threshold (teleop's
    /// default).
    Reconstruction,
    /// Either.
    Both,
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
/// reconstruction error.
struct Signals {
    sd: Vec<f64>,
    reconstruction: Vec<f64>,
}

impl Signals {
    fn of(model: &SharedGplvm, robot: &str, h: &Mat<f64>) -> Result<Signals> {
        Ok(Signals {
            sd: model.prediction_sd(h.as_ref(), robot)?,
            reconstruction: model.reconstruction_errors(h.as_ref())?,
        })
    }

    /// Whether `gate` holds frame `i` (the live rule, `sgplvm_live::gate::Thresholds::trusts`:
    /// a gating signal beyond its threshold, or either signal not a number).
    fn held(&self, i: usize, gate: Gate, sd: f64, reconstruction: f64) -> bool {
        let (s, e) = (self.sd[i], self.reconstruction[i]);
        let beyond_sd = matches!(gate, Gate::Sd | Gate::Both) && s > sd;
        let beyond_e = matches!(gate, Gate::Reconstruction | Gate::Both) && e > reconstruction;
        !(s.is_finite() && e.is_finite()) || beyond_sd || beyond_e
    }

    fn count(&self, gate: Gate, sd: f64, reconstruction: f64) -> Held {
        Held {
            held: (0..self.sd.len())
                .filter(|&i| self.held(i, gate, sd, reconstruction))
                .count(),
            frames: self.sd.len(),
        }
    }
}

/// Everything `evaluate` prints about the gate.
#[derive(Serialize)]
struct GateReport {
    /// The trust threshold (standardised standard deviation).
    sd_threshold: f64,
    /// The reconstruction threshold and the held-out errors it comes from (the per-frame
    /// errors are left out).
    reconstruction_threshold: f64,
    reconstruction_percentile: f64,
    reconstruction_mean_pose: f64,
    far_offset: f64,
    random_seed: u64,
    rates: Vec<GateRates>,
}

pub fn run(args: EvaluateArgs) -> Result<()> {
    let model = args.model.load()?;
    // Before the data: "the model does not know coman; it predicts for [...]" says more than a
    // mismatch of joint lists would.
    require_robot(&model, &args.model.model, &args.robot)?;
    let demos = args.data.load()?;
    let evaluation = demos.evaluate(&model, &args.robot)?;
    let trust = demos.test_trust(&model, &args.robot)?;
    let (gate, held) = gate_report(&model, &demos, &args)?;
    let arms = match (&args.urdf, Robot::builtin_urdf(&args.robot)) {
        (None, None) => None,
        (urdf, _) => {
            let anatomy = args.body.load(&args.robot, urdf.as_deref(), "")?;
            let test = to_mat(&demos.dataset.human.rows(&demos.dataset.test));
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
            trust: &'a TestTrust,
            gate: &'a GateReport,
            arms: Option<&'a arms::ArmsReport>,
        }
        let all = All {
            evaluation: &evaluation,
            trust: &trust,
            gate: &gate,
            arms: arms.as_ref(),
        };
        println!("{}", serde_json::to_string_pretty(&all)?);
        return Ok(());
    }
    report::evaluation(&evaluation, &trust, false)?;
    print_gate(&gate);
    if let Some(arms) = &arms {
        arms::print(arms, &args.robot);
    }
    Ok(())
}

/// The test frames' human poses, the far poses and the random ones, and each gate's rates; and
/// which test frames teleop's default gate holds.
fn gate_report(
    model: &SharedGplvm,
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
    let calibration: ReconstructionCalibration = model.reconstruction_calibration()?;
    // The model's thresholds as teleop uses them (a file's stored ones).
    let (sd, reconstruction) = (
        model.trust_threshold(&args.robot)?,
        model.reconstruction_threshold()?,
    );
    let signals = [&test, &far, &random]
        .map(|h| Signals::of(model, &args.robot, h))
        .into_iter()
        .collect::<Result<Vec<_>>>()?;
    let errors = test_frame_errors(model, demos, &args.robot, &test)?;
    let rates = [Gate::Sd, Gate::Reconstruction, Gate::Both]
        .into_iter()
        .map(|gate| {
            let (mut sums, mut counts) = ([0.0; 2], [0usize; 2]);
            for (i, &e) in errors.iter().enumerate() {
                let side = usize::from(signals[0].held(i, gate, sd, reconstruction));
                sums[side] += e;
                counts[side] += 1;
            }
            let mean = |k: usize| (counts[k] > 0).then(|| sums[k] / counts[k] as f64);
            GateRates {
                gate,
                test: signals[0].count(gate, sd, reconstruction),
                far: signals[1].count(gate, sd, reconstruction),
                random: signals[2].count(gate, sd, reconstruction),
                mse_followed: mean(0),
                mse_held: mean(1),
            }
        })
        .collect();
    let held = (0..test.nrows())
        .map(|i| signals[0].held(i, Gate::Reconstruction, sd, reconstruction))
        .collect();
    let report = GateReport {
        sd_threshold: sd,
        reconstruction_threshold: reconstruction,
        reconstruction_percentile: calibration.percentile,
        reconstruction_mean_pose: calibration.mean_pose,
        far_offset: args.far_offset,
        random_seed: args.seed,
        rates,
    };
    Ok((report, held))
}

/// Each test frame's mean squared error over the robot's joints (rad²).
fn test_frame_errors(
    model: &SharedGplvm,
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
    let human = Robot::builtin("human")?;
    let (known, limits) = (human.joint_names(), human.joint_limits());
    let bounds = names
        .iter()
        .map(|name| match known.iter().position(|k| k == name) {
            Some(k) => Ok(limits[k]),
            None => Err(anyhow!(
                "the data's human joint `{name}` is not a joint of the built-in human \
                 (data/urdf/human.urdf), whose limits bound the random poses"
            )),
        })
        .collect::<Result<Vec<(f64, f64)>>>()?;
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

fn print_gate(g: &GateReport) {
    println!(
        "gate: thresholds — sd {:.4}; reconstruction {:.4} (the larger of the held-out errors' 99th percentile {:.4} and the mean pose's held-out error {:.4})",
        g.sd_threshold,
        g.reconstruction_threshold,
        g.reconstruction_percentile,
        g.reconstruction_mean_pose
    );
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
            Gate::Reconstruction => "reconstruction *",
            Gate::Both => "both",
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
