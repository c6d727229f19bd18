//! `sgplvm`: train a shared GP-LVM on human demonstrations, transfer it to other robots, predict
//! joint commands from human frames, and run the paper's experiments.
//!
//! Exit codes: 0 success, 2 bad usage, 1 any other error (one line naming the file and what was
//! wrong). Output files are written whole or not at all.

use std::io::{BufRead, IsTerminal, Write};
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{anyhow, bail, Context, Result};
use clap::{Parser, Subcommand, ValueEnum};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use serde_json::json;
use sgplvm::csv::{format_line, read_frames, CsvHeader};
use sgplvm::experiment::{self, ExperimentConfig};
use sgplvm::files::atomic_write_with;
use sgplvm::pipeline::{self, Evaluation};
use sgplvm::robots::joint_state::{
    read_topics, write_topics, Compression, JointStates, MessageEncoding, TopicData, TopicRequest,
    WriteSettings,
};
use sgplvm::robots::{ReplayOptions, Trajectory};
use sgplvm::{figures, BackConstraint, Mat, ModelConfig, SharedGplvm, TrainOptions};
use sgplvm_core::{Control, IterationRecord};

#[derive(Parser)]
#[command(
    name = "sgplvm",
    version,
    about = "Teach a family of robots the same motions from one set of human demonstrations",
    long_about = "Teach a family of robots the same motions from one set of human demonstrations.\n\n\
A shared GP-LVM learns one latent space behind a human's joint angles and a robot's joint \
commands; trained fully on one robot, it is transferred to others by training only their \
latent-to-joint mapping. Start with `sgplvm demo`."
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Clone, Copy, ValueEnum)]
enum BackConstraintArg {
    /// Free latent points (human → latent by GP regression after training).
    None,
    /// Latent points as a kernel mapping of the human input (the paper's choice).
    Input,
    /// Latent points as a kernel mapping of the robot output.
    Output,
}

impl From<BackConstraintArg> for BackConstraint {
    fn from(value: BackConstraintArg) -> Self {
        match value {
            BackConstraintArg::None => BackConstraint::None,
            BackConstraintArg::Input => BackConstraint::Input,
            BackConstraintArg::Output => BackConstraint::Output,
        }
    }
}

#[derive(Subcommand)]
enum Command {
    /// Train on WALK-MAN, transfer to COMAN and CENTAURO, print test errors, draw the figures.
    Demo {
        /// Demonstrations (MCAP); default: data/demos/bimanual.mcap, or the same data generated.
        #[arg(long)]
        data: Option<PathBuf>,
        /// Output folder for figures and models.
        #[arg(long, default_value = "sgplvm-demo")]
        out: PathBuf,
        /// Robot trained fully; the others in the data are transferred to.
        #[arg(long, default_value = "walkman")]
        source: String,
        /// Iteration budget of each training.
        #[arg(long, default_value_t = 500, value_parser = clap::value_parser!(u64).range(1..))]
        max_iters: u64,
        /// Latent dimension Q.
        #[arg(long, default_value_t = 5, value_parser = clap::value_parser!(u64).range(1..))]
        latent_dim: u64,
        /// Print machine-readable results (JSON) instead of a table.
        #[arg(long)]
        json: bool,
    },
    /// Generate demonstrations following the paper's protocol (defaults reproduce data/demos).
    Generate {
        /// Output folder (bimanual.mcap is written into it).
        #[arg(long, default_value = "data/demos")]
        out: PathBuf,
        /// Seed of every random draw.
        #[arg(long)]
        seed: Option<u64>,
        /// Keep every k-th frame of the training trajectories.
        #[arg(long, value_parser = clap::value_parser!(u64).range(1..))]
        subsample: Option<u64>,
    },
    /// Train a model: one robot gives the full model, several the multi-robot model.
    Train {
        /// Demonstrations (MCAP); default: the shipped data.
        #[arg(long)]
        data: Option<PathBuf>,
        /// Robot(s) to train on (repeat for the multi-robot model).
        #[arg(long = "robot", required = true)]
        robots: Vec<String>,
        /// Latent parametrisation.
        #[arg(long, value_enum, default_value = "input")]
        back_constraint: BackConstraintArg,
        /// Latent dimension Q.
        #[arg(long, default_value_t = 5, value_parser = clap::value_parser!(u64).range(1..))]
        latent_dim: u64,
        /// Iteration budget.
        #[arg(long, default_value_t = 1000)]
        max_iters: u64,
        /// Seed of the initialisation.
        #[arg(long, default_value_t = 0)]
        seed: u64,
        /// Where to write the model.
        #[arg(long)]
        out: PathBuf,
        /// Print machine-readable results.
        #[arg(long)]
        json: bool,
    },
    /// Transfer a trained model to another robot (only that robot's kernel is trained).
    Transfer {
        /// The trained model.
        #[arg(long)]
        model: PathBuf,
        /// Demonstrations with the same training frames the model was trained on.
        #[arg(long)]
        data: Option<PathBuf>,
        /// The new robot.
        #[arg(long)]
        robot: String,
        /// Iteration budget.
        #[arg(long, default_value_t = 1000)]
        max_iters: u64,
        /// Where to write the new model.
        #[arg(long)]
        out: PathBuf,
        /// Print machine-readable results.
        #[arg(long)]
        json: bool,
    },
    /// Predict robot joint commands from human frames (MCAP JointState or CSV; `-` streams CSV).
    Predict {
        /// The model.
        #[arg(long)]
        model: PathBuf,
        /// Human frames: an MCAP file, a CSV file with a header of joint names, or `-` for CSV
        /// lines on stdin (one output line per input line, flushed: for teleoperation).
        #[arg(long)]
        input: String,
        /// Topic of the human in an MCAP input (default: the one whose name contains "human").
        #[arg(long)]
        topic: Option<String>,
        /// The robot to predict for.
        #[arg(long)]
        robot: String,
        /// Output: .mcap (JointState on /ROBOT/joint_command), any other name for CSV, `-` for stdout.
        #[arg(long)]
        out: String,
        /// Also write the predictive standard deviation (CSV: `<joint>_std` columns; MCAP: topic
        /// /ROBOT/joint_command_std).
        #[arg(long)]
        std: bool,
    },
    /// Test error of a model on the test frames of a demonstration file, overall and per joint.
    Evaluate {
        /// The model.
        #[arg(long)]
        model: PathBuf,
        /// Demonstrations (MCAP); default: the shipped data.
        #[arg(long)]
        data: Option<PathBuf>,
        /// The robot.
        #[arg(long)]
        robot: String,
        /// Print machine-readable results.
        #[arg(long)]
        json: bool,
    },
    /// Replay a joint trajectory on a robot in the rapier physics engine (PD control at 1 kHz):
    /// tracking error per joint, joint-limit violations and self-collisions.
    ///
    /// Either `--trajectory FILE` (robot joint commands, MCAP JointState or CSV) on `--robot` or
    /// `--urdf`, or `--model MODEL --input HUMAN_FILE --robot NAME` to predict and then replay.
    Simulate {
        /// A built-in robot (walkman, coman, centauro, human) or the robot of the model.
        #[arg(long, required_unless_present = "urdf")]
        robot: Option<String>,
        /// A URDF file instead of a built-in robot.
        #[arg(long, conflicts_with = "model")]
        urdf: Option<PathBuf>,
        /// Joint trajectory to replay (MCAP or CSV with a header of joint names and a time column).
        #[arg(long, required_unless_present = "model", conflicts_with = "model")]
        trajectory: Option<String>,
        /// Topic of the trajectory (or of the human, with --model) in an MCAP file.
        #[arg(long)]
        topic: Option<String>,
        /// Predict the trajectory with this model from --input human frames, then replay it.
        #[arg(long, requires = "input")]
        model: Option<PathBuf>,
        /// Human frames (MCAP or CSV) for --model.
        #[arg(long, requires = "model")]
        input: Option<String>,
        /// Print the report as JSON.
        #[arg(long)]
        json: bool,
    },
    /// The paper's Section IV-B: Figs. 4, 5 and 6, results.json and report.md.
    Experiment {
        /// Fewer runs and iterations: a few minutes.
        #[arg(long)]
        quick: bool,
        /// Output folder.
        #[arg(long, default_value = "experiment-out")]
        out: PathBuf,
        /// Demonstrations (MCAP); default: the shipped data.
        #[arg(long)]
        data: Option<PathBuf>,
        /// Override the number of runs.
        #[arg(long, value_parser = clap::value_parser!(u64).range(1..))]
        runs: Option<u64>,
        /// Override the iteration budget of every training.
        #[arg(long, value_parser = clap::value_parser!(u64).range(1..))]
        max_iters: Option<u64>,
        /// Print the results JSON to stdout as well.
        #[arg(long)]
        json: bool,
    },
}

fn main() {
    let cli = Cli::parse();
    if let Err(e) = run(cli) {
        // One line: the chain of causes, outermost first, leaving out causes that the message
        // before them already quotes.
        let mut message = String::new();
        for cause in e.chain().map(|c| c.to_string()) {
            if !message.contains(&cause) {
                message = if message.is_empty() {
                    cause
                } else {
                    format!("{message}: {cause}")
                };
            }
        }
        eprintln!("error: {message}");
        std::process::exit(1);
    }
}

fn run(cli: Cli) -> Result<()> {
    match cli.command {
        Command::Demo {
            data,
            out,
            source,
            max_iters,
            latent_dim,
            json,
        } => demo(
            data.as_deref(),
            &out,
            &source,
            max_iters as usize,
            latent_dim as usize,
            json,
        ),
        Command::Generate {
            out,
            seed,
            subsample,
        } => generate(&out, seed, subsample),
        Command::Train {
            data,
            robots,
            back_constraint,
            latent_dim,
            max_iters,
            seed,
            out,
            json,
        } => {
            let demos = pipeline::load(data.as_deref())?;
            let config = ModelConfig::default()
                .with_latent_dim(latent_dim as usize)
                .with_back_constraint(back_constraint.into())
                .with_seed(seed);
            let options = TrainOptions::default().with_max_iters(max_iters as usize);
            let (model, seconds) = train_with_progress(
                &format!("training {}", robots.join(" + ")),
                max_iters,
                |cb| demos.train(&robots, &config, &options, cb),
            )?;
            model.save(&out)?;
            report_training(&model, seconds, &out, json);
            Ok(())
        }
        Command::Transfer {
            model,
            data,
            robot,
            max_iters,
            out,
            json,
        } => {
            let source = SharedGplvm::load(&model).with_context(|| model.display().to_string())?;
            let demos = pipeline::load(data.as_deref())?;
            let options = TrainOptions::default().with_max_iters(max_iters as usize);
            let (model, seconds) =
                train_with_progress(&format!("transfer to {robot}"), max_iters, |cb| {
                    demos.transfer(&source, &robot, &options, cb)
                })?;
            model.save(&out)?;
            report_training(&model, seconds, &out, json);
            Ok(())
        }
        Command::Predict {
            model,
            input,
            topic,
            robot,
            out,
            std,
        } => predict(&model, &input, topic.as_deref(), &robot, &out, std),
        Command::Evaluate {
            model,
            data,
            robot,
            json,
        } => {
            let model = SharedGplvm::load(&model).with_context(|| model.display().to_string())?;
            let demos = pipeline::load(data.as_deref())?;
            let evaluation = demos.evaluate(&model, &robot)?;
            if json {
                println!("{}", serde_json::to_string_pretty(&evaluation)?);
            } else {
                print_evaluation(&evaluation);
            }
            Ok(())
        }
        Command::Simulate {
            robot,
            urdf,
            trajectory,
            topic,
            model,
            input,
            json,
        } => simulate(
            robot.as_deref(),
            urdf.as_deref(),
            trajectory.as_deref(),
            topic.as_deref(),
            model.as_deref().zip(input.as_deref()),
            json,
        ),
        Command::Experiment {
            quick,
            out,
            data,
            runs,
            max_iters,
            json,
        } => {
            let mut config = if quick {
                ExperimentConfig::quick()
            } else {
                ExperimentConfig::paper()
            };
            if let Some(r) = runs {
                config.runs = r as usize;
                config.transfers_per_run = config.transfers_per_run.min(r as usize);
            }
            if let Some(m) = max_iters {
                config.max_iters = m as usize;
                config.transfer_max_iters = m as usize;
            }
            let demos = pipeline::load(data.as_deref())?;
            let data = demos.experiment_data()?;
            let bar = progress_bar(
                experiment::training_count(&config, data.robots.len()) as u64,
                "experiment",
            );
            let results = experiment::run(&data, &config, &mut |p| {
                bar.set_position(p.done as u64);
                bar.set_message(p.message.clone());
            })?;
            bar.finish_and_clear();
            let written = experiment::write_outputs(&results, &out)?;
            if json {
                println!("{}", serde_json::to_string(&results)?);
            } else {
                println!("{}", experiment::report(&results));
                for path in written {
                    eprintln!("wrote {}", path.display());
                }
            }
            Ok(())
        }
    }
}

/// A progress bar on a terminal, nothing otherwise.
fn progress_bar(length: u64, prefix: &str) -> ProgressBar {
    let bar = ProgressBar::with_draw_target(
        Some(length),
        if std::io::stderr().is_terminal() {
            ProgressDrawTarget::stderr()
        } else {
            ProgressDrawTarget::hidden()
        },
    );
    bar.set_style(
        ProgressStyle::with_template("{prefix:>20} [{bar:30}] {pos}/{len} {msg}")
            .expect("valid template")
            .progress_chars("=> "),
    );
    bar.set_prefix(prefix.to_string());
    bar
}

/// Runs a training with a progress bar; returns the model and its training seconds.
fn train_with_progress(
    label: &str,
    max_iters: u64,
    train: impl FnOnce(
        Option<sgplvm_core::Callback<'_>>,
    ) -> std::result::Result<SharedGplvm, pipeline::PipelineError>,
) -> Result<(SharedGplvm, f64)> {
    let bar = progress_bar(max_iters, label);
    let started = Instant::now();
    let mut on_iteration = |record: &IterationRecord, _: &SharedGplvm| {
        bar.set_position(record.iteration as u64);
        bar.set_message(format!("objective {:.2}", record.objective));
        Control::Continue
    };
    // The snapshot the core builds for a callback costs time: only ask for it on a terminal.
    let callback: Option<sgplvm_core::Callback<'_>> = if bar.is_hidden() {
        None
    } else {
        Some(&mut on_iteration)
    };
    let model = train(callback)?;
    bar.finish_and_clear();
    let seconds = model
        .history()
        .last()
        .map_or(started.elapsed().as_secs_f64(), |r| r.seconds);
    Ok((model, seconds))
}

fn report_training(model: &SharedGplvm, seconds: f64, out: &Path, json: bool) {
    let history = model.history();
    let objective = history.last().map(|r| r.objective);
    let stop = model
        .stop_reason()
        .map(|r| format!("{r:?}"))
        .unwrap_or_default();
    if json {
        let value = json!({
            "model": out.display().to_string(),
            "robots": model.output_names(),
            "iterations": history.last().map_or(0, |r| r.iteration),
            "seconds": seconds,
            "objective": objective,
            "stop_reason": stop,
        });
        println!("{value}");
    } else {
        println!(
            "trained {} in {:.2} s, {} iterations, objective {:.3} ({stop}); wrote {}",
            model.output_names().join(" + "),
            seconds,
            history.last().map_or(0, |r| r.iteration),
            objective.unwrap_or(f64::NAN),
            out.display()
        );
    }
}

fn print_evaluation(e: &Evaluation) {
    println!(
        "{}: test MSE {:.6} rad² (RMSE {:.2}°) over {} frames",
        e.robot,
        e.mse,
        e.mse.sqrt().to_degrees(),
        e.frames
    );
    for (joint, mse) in &e.per_joint {
        println!("  {joint:<24} {mse:.6}  ({:.2}°)", mse.sqrt().to_degrees());
    }
}

fn generate(out: &Path, seed: Option<u64>, subsample: Option<u64>) -> Result<()> {
    let mut config = sgplvm::robots::generator::GeneratorConfig::default();
    if let Some(seed) = seed {
        config.seed = seed;
    }
    if let Some(k) = subsample {
        config.train_subsample = k as usize;
    }
    let (path, generated) = sgplvm::robots::generator::generate_to_dir(&config, out)?;
    let ds = &generated.dataset;
    println!(
        "wrote {}: {} frames ({} training, {} test), robots {}",
        path.display(),
        ds.len(),
        ds.train.len(),
        ds.test.len(),
        ds.robot_names().join(", ")
    );
    Ok(())
}

fn demo(
    data: Option<&Path>,
    out: &Path,
    source: &str,
    max_iters: usize,
    q: usize,
    json: bool,
) -> Result<()> {
    let demos = pipeline::load(data)?;
    let ds = &demos.dataset;
    if !json {
        println!(
            "data: {} — {} training and {} test frames, human {} joints, robots {}",
            demos.source_name,
            ds.train.len(),
            ds.test.len(),
            ds.human.joint_names.len(),
            ds.robot_names().join(", ")
        );
    }
    let config = ModelConfig::default()
        .with_latent_dim(q)
        .with_back_constraint(BackConstraint::Input);
    let options = TrainOptions::default().with_max_iters(max_iters);
    let source_robots = vec![source.to_string()];
    let (full, full_seconds) =
        train_with_progress(&format!("training {source}"), max_iters as u64, |cb| {
            demos.train(&source_robots, &config, &options, cb)
        })?;
    std::fs::create_dir_all(out).with_context(|| format!("cannot create {}", out.display()))?;
    full.save(&out.join(format!("{source}.sgp")))?;

    struct Row {
        robot: String,
        model: &'static str,
        seconds: f64,
        iterations: usize,
        evaluation: Evaluation,
    }
    let iterations = |m: &SharedGplvm| m.history().last().map_or(0, |r| r.iteration);
    let mut rows = vec![Row {
        robot: source.to_string(),
        model: "full",
        seconds: full_seconds,
        iterations: iterations(&full),
        evaluation: demos.evaluate(&full, source)?,
    }];
    let mut coman_model = None;
    for target in ds.robot_names().into_iter().filter(|r| *r != source) {
        let (transferred, seconds) =
            train_with_progress(&format!("transfer to {target}"), max_iters as u64, |cb| {
                demos.transfer(&full, target, &options, cb)
            })?;
        transferred.save(&out.join(format!("{source}_to_{target}.sgp")))?;
        rows.push(Row {
            robot: target.to_string(),
            model: "transfer",
            seconds,
            iterations: iterations(&transferred),
            evaluation: demos.evaluate(&transferred, target)?,
        });
        // For comparison: the same robot trained fully from scratch.
        let targets = vec![target.to_string()];
        let (baseline, seconds) =
            train_with_progress(&format!("training {target}"), max_iters as u64, |cb| {
                demos.train(&targets, &config, &options, cb)
            })?;
        rows.push(Row {
            robot: target.to_string(),
            model: "full",
            seconds,
            iterations: iterations(&baseline),
            evaluation: demos.evaluate(&baseline, target)?,
        });
        if target == "coman" || coman_model.is_none() {
            coman_model = Some((target.to_string(), transferred));
        }
    }
    let mut written = Vec::new();
    written.extend(figures::latent_space(
        &full,
        &demos,
        source,
        &out.join("latent_space"),
    )?);
    if let Some((target, model)) = &coman_model {
        written.extend(figures::trajectories(
            model,
            &demos,
            target,
            &out.join(format!("{target}_trajectories")),
        )?);
    }
    if json {
        let value = json!({
            "data": demos.source_name,
            "source": source,
            "rows": rows.iter().map(|r| json!({
                "robot": r.robot, "model": r.model, "seconds": r.seconds,
                "iterations": r.iterations, "test_mse": r.evaluation.mse,
            })).collect::<Vec<_>>(),
            "files": written.iter().map(|p| p.display().to_string()).collect::<Vec<_>>(),
        });
        println!("{value}");
        return Ok(());
    }
    println!(
        "\n{:<10} {:<9} {:>10} {:>11} {:>14} {:>11}",
        "robot", "model", "train (s)", "iterations", "test MSE", "RMSE (deg)"
    );
    for r in &rows {
        println!(
            "{:<10} {:<9} {:>10.2} {:>11} {:>14.6} {:>11.2}",
            r.robot,
            r.model,
            r.seconds,
            r.iterations,
            r.evaluation.mse,
            r.evaluation.mse.sqrt().to_degrees()
        );
    }
    println!(
        "\n`full` = human + that robot trained from scratch; `transfer` = {source}'s latent space and\n\
         human mapping reused, only the robot's kernel trained. Models and figures in {}:",
        out.display()
    );
    for path in written {
        println!("  {}", path.display());
    }
    Ok(())
}

/// Human frames read for prediction: times (ns) and rows in the model's human joint order.
struct HumanFrames {
    times_ns: Vec<i64>,
    frames: Mat<f64>,
}

fn model_joint_names(model: &SharedGplvm, space: &str) -> Vec<String> {
    match model.column_names(space) {
        Some(names) => names.to_vec(),
        None => (0..model.space_dim(space).unwrap_or(0))
            .map(|j| format!("{space}_{j}"))
            .collect(),
    }
}

/// Positions of the model's joints among the file's columns; missing ones are an error.
fn column_order(wanted: &[String], found: &[String], source: &str) -> Result<Vec<usize>> {
    let missing: Vec<&String> = wanted.iter().filter(|w| !found.contains(w)).collect();
    if !missing.is_empty() {
        bail!("{source}: missing human joint column(s) {missing:?}; the model expects {wanted:?}");
    }
    Ok(wanted
        .iter()
        .map(|w| found.iter().position(|f| f == w).expect("checked above"))
        .collect())
}

fn read_human_frames(model: &SharedGplvm, input: &str, topic: Option<&str>) -> Result<HumanFrames> {
    let wanted = model_joint_names(model, model.input_name());
    let path = Path::new(input);
    if input.ends_with(".mcap") {
        let topic = match topic {
            Some(t) => t.to_string(),
            None => {
                let channels = sgplvm::robots::joint_state::list_channels(path)?;
                let human: Vec<_> = channels
                    .iter()
                    .filter(|c| c.topic.contains("human"))
                    .collect();
                match human.as_slice() {
                    [one] => one.topic.clone(),
                    _ => bail!(
                        "{input}: cannot tell the human topic among {:?}; name it with --topic",
                        channels.iter().map(|c| &c.topic).collect::<Vec<_>>()
                    ),
                }
            }
        };
        let read = read_topics(path, &[TopicRequest::joints(topic, &wanted)])?;
        let states = &read.states[0];
        let frames = Mat::from_fn(states.len(), wanted.len(), |i, j| states.row(i)[j]);
        return Ok(HumanFrames {
            times_ns: states.times_ns.clone(),
            frames,
        });
    }
    let file = std::fs::File::open(path).with_context(|| format!("{input}: cannot open"))?;
    let table = read_frames(std::io::BufReader::new(file), input)?;
    let order = column_order(&wanted, &table.header.joints, input)?;
    let d = table.header.joints.len();
    let frames = Mat::from_fn(table.rows, wanted.len(), |i, j| {
        table.values[i * d + order[j]]
    });
    let times_ns = match (&table.times, table.header.time_column.as_deref()) {
        (Some(t), Some("time_ns")) => t.iter().map(|&v| v as i64).collect(),
        (Some(t), _) => t.iter().map(|&v| (v * 1e9).round() as i64).collect(),
        (None, _) => (0..table.rows as i64).map(|i| i * 25_000_000).collect(),
    };
    Ok(HumanFrames { times_ns, frames })
}

fn predict(
    model_path: &Path,
    input: &str,
    topic: Option<&str>,
    robot: &str,
    out: &str,
    with_std: bool,
) -> Result<()> {
    let model = SharedGplvm::load(model_path).with_context(|| model_path.display().to_string())?;
    if !model.output_names().contains(&robot) {
        bail!(
            "{}: the model does not know robot '{robot}'; it predicts for {:?}",
            model_path.display(),
            model.output_names()
        );
    }
    let robot_joints = model_joint_names(&model, robot);
    if input == "-" {
        return predict_stream(&model, robot, &robot_joints, out, with_std);
    }
    let human = read_human_frames(&model, input, topic)?;
    let prediction = model.predict(human.frames.as_ref(), robot, with_std)?;
    let n = prediction.mean.nrows();
    let d = robot_joints.len();
    let rows = |m: &Mat<f64>, f: fn(f64) -> f64| -> Vec<f64> {
        (0..n)
            .flat_map(|i| (0..d).map(move |j| (i, j)))
            .map(|(i, j)| f(m[(i, j)]))
            .collect()
    };
    let mean = rows(&prediction.mean, |v| v);
    let std = prediction.variance.as_ref().map(|v| rows(v, f64::sqrt));
    if out.ends_with(".mcap") {
        let command = JointStates::new(human.times_ns.clone(), robot_joints.clone(), mean)?;
        let std_states = std
            .map(|s| JointStates::new(human.times_ns.clone(), robot_joints.clone(), s))
            .transpose()?;
        let main_topic = format!("/{robot}/joint_command");
        let std_topic = format!("/{robot}/joint_command_std");
        let mut topics = vec![TopicData {
            topic: &main_topic,
            states: &command,
            encoding: MessageEncoding::Cdr,
        }];
        if let Some(s) = &std_states {
            topics.push(TopicData {
                topic: &std_topic,
                states: s,
                encoding: MessageEncoding::Cdr,
            });
        }
        write_topics(
            out,
            &topics,
            &WriteSettings {
                compression: Compression::Zstd,
                metadata: Vec::new(),
            },
        )?;
        eprintln!("wrote {n} frames of {robot} joint commands to {out} (topic {main_topic})");
        return Ok(());
    }
    let mut header = vec!["time".to_string()];
    header.extend(robot_joints.iter().cloned());
    if with_std {
        header.extend(robot_joints.iter().map(|j| format!("{j}_std")));
    }
    let write_csv = |w: &mut dyn Write| -> std::io::Result<()> {
        writeln!(w, "{}", header.join(","))?;
        for i in 0..n {
            let mut values = mean[i * d..(i + 1) * d].to_vec();
            if let Some(s) = &std {
                values.extend_from_slice(&s[i * d..(i + 1) * d]);
            }
            writeln!(
                w,
                "{}",
                format_line(Some(human.times_ns[i] as f64 * 1e-9), &values)
            )?;
        }
        w.flush()
    };
    if out == "-" {
        write_csv(&mut std::io::stdout().lock())?;
    } else {
        atomic_write_with(Path::new(out), |tmp| {
            let mut file = std::io::BufWriter::new(std::fs::File::create(tmp)?);
            write_csv(&mut file)
        })?;
        eprintln!("wrote {n} frames of {robot} joint commands to {out}");
    }
    Ok(())
}

/// Teleoperation: CSV lines in on stdin, one prediction line out per line, flushed at once.
fn predict_stream(
    model: &SharedGplvm,
    robot: &str,
    robot_joints: &[String],
    out: &str,
    with_std: bool,
) -> Result<()> {
    if out != "-" {
        bail!("--input - streams to stdout: use --out - as well");
    }
    let stdin = std::io::stdin();
    let mut lines = stdin.lock().lines();
    let header_line = loop {
        match lines.next() {
            None => bail!("stdin: empty input, expected a header line of joint names"),
            Some(line) => {
                let line = line.context("stdin")?;
                if !line.trim().is_empty() {
                    break line;
                }
            }
        }
    };
    let header = CsvHeader::parse(&header_line);
    let wanted = model_joint_names(model, model.input_name());
    let order = column_order(&wanted, &header.joints, "stdin")?;
    let stdout = std::io::stdout();
    let mut w = stdout.lock();
    let mut out_header: Vec<String> = header.time_column.iter().cloned().collect();
    out_header.extend(robot_joints.iter().cloned());
    if with_std {
        out_header.extend(robot_joints.iter().map(|j| format!("{j}_std")));
    }
    writeln!(w, "{}", out_header.join(","))?;
    w.flush()?;
    let mut human = vec![0.0; wanted.len()];
    let mut joints = vec![0.0; robot_joints.len()];
    for (i, line) in lines.enumerate() {
        let line = line.context("stdin")?;
        if line.trim().is_empty() {
            continue;
        }
        let (time, values) = header.parse_line(&line, i + 2, "stdin")?;
        for (h, &k) in human.iter_mut().zip(&order) {
            *h = values[k];
        }
        if with_std {
            let frame = Mat::from_fn(1, human.len(), |_, j| human[j]);
            let p = model.predict(frame.as_ref(), robot, true)?;
            let variance = p.variance.ok_or_else(|| anyhow!("no variance returned"))?;
            let mut out: Vec<f64> = (0..joints.len()).map(|j| p.mean[(0, j)]).collect();
            out.extend((0..joints.len()).map(|j| variance[(0, j)].sqrt()));
            writeln!(w, "{}", format_line(time, &out))?;
        } else {
            model.predict_frame(&human, robot, &mut joints)?;
            writeln!(w, "{}", format_line(time, &joints))?;
        }
        w.flush()?;
    }
    Ok(())
}

/// Reads a robot trajectory from an MCAP JointState topic or a CSV file.
fn read_trajectory(path: &str, topic: Option<&str>, robot: &str) -> Result<Trajectory> {
    if path.ends_with(".mcap") {
        let topic = match topic {
            Some(t) => t.to_string(),
            None => {
                let channels = sgplvm::robots::joint_state::list_channels(path)?;
                let matching: Vec<_> = channels
                    .iter()
                    .filter(|c| c.topic.contains(robot))
                    .collect();
                match (matching.as_slice(), channels.as_slice()) {
                    ([one], _) => one.topic.clone(),
                    ([], [one]) => one.topic.clone(),
                    _ => bail!(
                        "{path}: cannot tell the trajectory topic among {:?}; name it with --topic",
                        channels.iter().map(|c| &c.topic).collect::<Vec<_>>()
                    ),
                }
            }
        };
        let states = &read_topics(path, &[TopicRequest::all(topic)])?.states[0];
        let times = states.times_ns.iter().map(|&t| t as f64 * 1e-9).collect();
        return Ok(Trajectory::new(
            states.names.clone(),
            times,
            states.positions.clone(),
        )?);
    }
    let file = std::fs::File::open(path).with_context(|| format!("{path}: cannot open"))?;
    let table = read_frames(std::io::BufReader::new(file), path)?;
    let times = match (table.times, table.header.time_column.as_deref()) {
        (Some(t), Some("time_ns")) => t.iter().map(|v| v * 1e-9).collect(),
        (Some(t), _) => t,
        (None, _) => (0..table.rows).map(|i| i as f64 / 40.0).collect(),
    };
    Trajectory::new(table.header.joints, times, table.values).with_context(|| path.to_string())
}

fn simulate(
    robot: Option<&str>,
    urdf: Option<&Path>,
    trajectory: Option<&str>,
    topic: Option<&str>,
    predict_from: Option<(&Path, &str)>,
    json: bool,
) -> Result<()> {
    let (xml, source) = match (urdf, robot) {
        (Some(path), _) => {
            let xml = std::fs::read_to_string(path)
                .with_context(|| format!("{}: cannot read", path.display()))?;
            (xml, path.display().to_string())
        }
        (None, Some(name)) => {
            let xml = sgplvm::Robot::builtin_urdf(name).ok_or_else(|| {
                anyhow!(
                    "unknown robot '{name}'; expected one of {:?} or --urdf FILE",
                    sgplvm::Robot::builtin_names()
                )
            })?;
            (xml.to_string(), format!("builtin:{name}"))
        }
        (None, None) => bail!("name the robot with --robot or --urdf"),
    };
    let robot_name = robot.unwrap_or("robot");
    let trajectory = match (predict_from, trajectory) {
        (Some((model_path, input)), _) => {
            let model =
                SharedGplvm::load(model_path).with_context(|| model_path.display().to_string())?;
            if !model.output_names().contains(&robot_name) {
                bail!(
                    "{}: the model does not know robot '{robot_name}'; it predicts for {:?}",
                    model_path.display(),
                    model.output_names()
                );
            }
            let human = read_human_frames(&model, input, topic)?;
            let mean = model
                .predict(human.frames.as_ref(), robot_name, false)?
                .mean;
            let d = mean.ncols();
            let positions = (0..mean.nrows())
                .flat_map(|i| (0..d).map(move |j| (i, j)))
                .map(|(i, j)| mean[(i, j)])
                .collect();
            let times = human.times_ns.iter().map(|&t| t as f64 * 1e-9).collect();
            Trajectory::new(model_joint_names(&model, robot_name), times, positions)?
        }
        (None, Some(path)) => read_trajectory(path, topic, robot_name)?,
        (None, None) => bail!("give --trajectory FILE, or --model MODEL with --input FILE"),
    };
    // Report times from the start of the trajectory (recordings carry wall-clock stamps).
    let mut trajectory = trajectory;
    let t0 = trajectory.times.first().copied().unwrap_or(0.0);
    trajectory.times.iter_mut().for_each(|t| *t -= t0);
    let report = sgplvm::robots::replay(&xml, &source, &trajectory, &ReplayOptions::default())?;
    if json {
        println!("{}", serde_json::to_string_pretty(&report)?);
        return Ok(());
    }
    println!(
        "{source}: {:.1} s of motion, {} physics steps in {:.2} s ({:.0}× real time); times below from the start",
        report.duration,
        report.physics_steps,
        report.wall_seconds,
        report.duration / report.wall_seconds.max(1e-9)
    );
    println!("\n{:<24} {:>12} {:>12}", "joint", "RMS (deg)", "max (deg)");
    for j in &report.joints {
        println!(
            "{:<24} {:>12.3} {:>12.3}",
            j.name,
            j.rms_error.to_degrees(),
            j.max_error.to_degrees()
        );
    }
    if report.limit_violations.is_empty() {
        println!("\nno joint-limit violations");
    } else {
        println!("\njoint-limit violations:");
        for v in &report.limit_violations {
            println!(
                "  {:>7.3}–{:<7.3} s  {:<20} {:.2}° beyond {:.3} ({})",
                v.time,
                v.end_time,
                v.joint,
                v.amount.to_degrees(),
                v.limit,
                if v.commanded {
                    "commanded"
                } else {
                    "not commanded"
                }
            );
        }
    }
    if !report.velocity_violations.is_empty() {
        println!("velocity-limit violations:");
        for v in &report.velocity_violations {
            println!(
                "  {:>7.3}–{:<7.3} s  {:<20} {:.2} rad/s beyond {:.3} rad/s ({})",
                v.time,
                v.end_time,
                v.joint,
                v.amount,
                v.limit,
                if v.commanded {
                    "commanded"
                } else {
                    "not commanded"
                }
            );
        }
    }
    if report.collisions.is_empty() {
        println!("no self-collisions");
    } else {
        println!("self-collisions:");
        for c in &report.collisions {
            println!(
                "  {:>7.3}–{:<7.3} s  {} ↔ {} (deepest {:.1} mm)",
                c.time,
                c.end_time,
                c.link_a,
                c.link_b,
                c.max_penetration * 1e3
            );
        }
    }
    for w in &report.warnings {
        eprintln!("warning: {w}");
    }
    Ok(())
}
