//! `sgplvm predict`: robot joint commands from human frames — a file to a file (MCAP or CSV), or
//! CSV lines streamed from stdin to stdout for teleoperation. The commands are kept within the
//! robot's URDF position and velocity limits unless `--raw` asks for the model's output as it
//! is; every output says which it holds (CSV: the sidecar `OUT.json` beside the file, or
//! stderr for stdout; MCAP: the metadata record `sgplvm.predict`). A CSV output starts with its
//! header, so that numpy, pandas and spreadsheets read it without options.

use std::io::{BufRead, Write};
use std::path::{Path, PathBuf};

use anyhow::{anyhow, bail, Context, Result};
use clap::Args;
use sgplvm::capture::girdle::GirdleAlignment;
use sgplvm::csv::{format_line, read_header};
use sgplvm::files::atomic_write_with;
use sgplvm::provenance::other_robot;
use sgplvm::robots::joint_state::{
    write_topics, Compression, JointStates, MessageEncoding, TopicData, WriteSettings,
};
use sgplvm::robots::limits::{CommandLimits, LimitCounts, LimitedStream};
use sgplvm::robots::series::seconds_from_ns;
use sgplvm::{Mat, Predictor};

use sgplvm::robots::anatomy::{Anatomy, CommandColumns};
use sgplvm::robots::safety::{SafetyOptions, SafetyStep};
use sgplvm::robots::Robot;

use super::args::{GirdleArg, ModelFileArg};
use super::body::BodyArgs;
use super::frames::{
    advise_unnamed, column_order, model_joint_names, read_human_frames, require_robot,
};
use super::limits::{Commands, KeptApart};

pub(super) mod scene;

#[derive(Args)]
pub struct PredictArgs {
    #[command(flatten)]
    model: ModelFileArg,
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
    /// Output: .mcap (JointState on /ROBOT/joint_command, and for Foxglove the human's joint
    /// states, both robot descriptions, /tf_static, /tf, /ROBOT/prediction_std and /latent),
    /// any other name for CSV, `-` for stdout. With `--input -` an .mcap is written frame by
    /// frame (readable up to its last whole frame if the process is killed).
    #[arg(long)]
    out: String,
    /// MCAP output: only the joint command topics (no descriptions, transforms, std or latent).
    #[arg(long)]
    no_tf: bool,
    /// Also write the predictive standard deviation (CSV: `<joint>_std` columns; MCAP: topic
    /// /ROBOT/joint_command_std).
    #[arg(long)]
    std: bool,
    /// Write the model's output as it is, not kept within the robot's joint limits (for
    /// analysis; the output says so).
    #[arg(long)]
    raw: bool,
    /// The robot's URDF as its maker publishes it: its limits bound the commands, its joints
    /// outside the arms are held, and the Foxglove scene draws it [default: the built-in robot
    /// of that name].
    #[arg(long, value_name = "FILE")]
    urdf: Option<PathBuf>,
    /// How far apart the robot's own collision shapes stay, metres: each command is the
    /// nearest one that keeps them so (0: no self-collision limit; --raw: none either).
    #[arg(long, default_value_t = 0.01)]
    margin: f64,
    #[command(flatten)]
    body: BodyArgs,
    #[command(flatten)]
    girdle: GirdleArg,
}

/// The robot predicted for: its anatomy when known (built in, or `--urdf`), and how its
/// commands are made from the model's output.
pub(super) struct Target {
    /// The robot's name.
    pub robot: String,
    /// Its anatomy; `None` for a robot neither built in nor given by URDF (with `--raw`).
    pub anatomy: Option<Anatomy>,
    /// The command joints and where each comes from.
    pub columns: CommandColumns,
}

impl Target {
    /// A built-in robot's commands as the model predicts them (for drawing a model's raw
    /// output).
    pub fn builtin_raw(model: &dyn Predictor, robot: &str) -> Result<Target> {
        Ok(Target {
            robot: robot.to_string(),
            anatomy: Some(Anatomy::builtin(robot)?),
            columns: CommandColumns::identity(&model_joint_names(model, robot)),
        })
    }

    /// The joints the commands name, in order.
    pub fn names(&self) -> &[String] {
        self.columns.names()
    }

    /// Robot `robot` as the model predicts for it: its anatomy (built in, or from `urdf` with
    /// `body`'s flags) and the command joints (`raw`: the model's own columns; a robot neither
    /// built in nor given then needs no anatomy).
    pub fn load(
        model: &dyn Predictor,
        robot: &str,
        urdf: Option<&Path>,
        body: &BodyArgs,
        raw: bool,
    ) -> Result<Target> {
        let model_columns = model_joint_names(model, robot);
        let known = urdf.is_some() || Robot::builtin_urdf(robot).is_some();
        if !known && raw {
            return Ok(Target {
                robot: robot.to_string(),
                anatomy: None,
                columns: CommandColumns::identity(&model_columns),
            });
        }
        let anatomy = body.load(
            robot,
            urdf,
            "its joint limits bound the commands: give its URDF with --urdf FILE, or write --raw for the model's output as it is",
        )?;
        if let Some(warning) = other_robot(model.annotations(), robot, &anatomy) {
            eprintln!("warning: {warning}");
        }
        let columns = if raw {
            CommandColumns::identity(&model_columns)
        } else {
            advise_unnamed(
                anatomy
                    .command_columns(&model_columns)
                    .with_context(|| format!("the model's {robot} joints and the robot's URDF")),
                model,
                robot,
            )?
        };
        Ok(Target {
            robot: robot.to_string(),
            anatomy: Some(anatomy),
            columns,
        })
    }

    /// What its commands will be: raw, or within the limits of the robot's body (`timed`:
    /// whether the frames have times for the velocity limits) and, with a `margin` (metres)
    /// above 0, out of self-collision.
    pub fn commands(&self, timed: bool, margin: f64, raw: bool) -> Result<Commands> {
        if !(margin.is_finite() && margin >= 0.0) {
            bail!("--margin {margin}: expected metres ≥ 0 (0: no self-collision limit)");
        }
        match (&self.anatomy, raw) {
            (Some(anatomy), false) => {
                let limits = CommandLimits::for_joints(anatomy.robot(), self.names())?;
                if let Some(note) = limits.assumed() {
                    eprintln!("warning: {}: {note}", anatomy.robot().name());
                }
                let safety = (margin > 0.0)
                    .then(|| {
                        SafetyStep::new(
                            anatomy,
                            self.names(),
                            SafetyOptions {
                                margin_m: margin,
                                velocity_limits: timed,
                                ..SafetyOptions::default()
                            },
                        )
                    })
                    .transpose()
                    .map_err(|e| anyhow!(e))?
                    .map(Box::new);
                if let Some(step) = &safety {
                    let model = step.collision();
                    if let Some(warning) = super::report::self_collision_unchecked(
                        &self.robot,
                        model.unchecked(),
                        model.pairs().len(),
                    ) {
                        eprintln!("{warning}");
                    }
                }
                Ok(Commands::Limited {
                    limits,
                    timed,
                    safety,
                })
            }
            _ => Ok(Commands::Raw),
        }
    }
}

impl PredictArgs {
    /// The robot predicted for.
    fn target(&self, model: &dyn Predictor) -> Result<Target> {
        Target::load(
            model,
            &self.robot,
            self.urdf.as_deref(),
            &self.body,
            self.raw,
        )
    }

    /// What the commands will be (see [`Target::commands`]).
    fn commands(&self, target: &Target, timed: bool) -> Result<Commands> {
        target.commands(timed, self.margin, self.raw)
    }
}

/// Predicted joint commands of every frame, row-major, with their standard deviations.
struct Predicted {
    times_ns: Vec<i64>,
    frames: usize,
    mean: Vec<f64>,
    std: Option<Vec<f64>>,
    /// What `mean` holds, and what the limits moved.
    commands: Commands,
    counts: Option<LimitCounts>,
}

pub fn run(args: PredictArgs) -> Result<()> {
    // Either kind of model: one shared latent space, or one per body part.
    let loaded = args.model.load_any()?;
    let model = loaded.predictor();
    let robot = args.robot.as_str();
    require_robot(model, &args.model.model, robot)?;
    let target = args.target(model)?;
    let robot_joints = target.names().to_vec();
    let scene = args.out.ends_with(".mcap") && !args.no_tf;
    if args.input == "-" {
        // The person's clavicles aligned to the model's people, frame by frame (--girdle).
        let girdle = args.girdle.alignment(&loaded);
        // Times (hence velocity limits) when the stream's header has a time column: known
        // after the header; the limits are checked before reading it.
        let commands = args.commands(&target, true)?;
        if args.out.ends_with(".mcap") {
            return scene::predict_stream_mcap(
                model,
                &target,
                &args.out,
                !args.no_tf,
                commands,
                girdle,
            );
        }
        return predict_stream(model, &target, &args.out, args.std, commands, girdle);
    }
    let human = read_human_frames(model, &args.input, args.topic.as_deref())?;
    let commands = args.commands(&target, human.timed)?;
    // The person's clavicles aligned to the model's people (--girdle).
    let aligned = args.girdle.aligned_rows(&loaded, &human.frames);
    let input = aligned.as_ref().unwrap_or(&human.frames);
    // A model that cannot predict finite values for this input says so naming its file.
    let prediction = model
        .predict(input.as_ref(), robot, args.std || scene)
        .with_context(|| args.model.model.display().to_string())?;
    let rows = |m: &Mat<f64>, f: fn(f64) -> f64| -> Vec<f64> {
        (0..m.nrows())
            .flat_map(|i| (0..m.ncols()).map(move |j| (i, j)))
            .map(|(i, j)| f(m[(i, j)]))
            .collect()
    };
    let mut mean = target.columns.rows(&rows(&prediction.mean, |v| v), false);
    let mut commands = commands;
    let (counts, kept) = commands.apply(&mut mean, target.names().len(), &human.times_ns);
    let predicted = Predicted {
        frames: prediction.mean.nrows(),
        mean,
        std: prediction
            .variance
            .as_ref()
            .map(|v| target.columns.rows(&rows(v, f64::sqrt), true)),
        times_ns: human.times_ns.clone(),
        commands,
        counts,
    };
    if scene {
        mcap_times(&predicted.times_ns, &args.input, &args.out)?;
        let human_rows = rows(&human.frames, |v| v);
        let latent_rows = rows(&prediction.latent, |v| v);
        let std_topic = args.std.then(|| format!("/{robot}/joint_command_std"));
        scene::write(
            model,
            &target,
            &scene::Frames {
                times_ns: &predicted.times_ns,
                human: &human_rows,
                mean: &predicted.mean,
                std: predicted.std.as_deref().unwrap_or(&[]),
                latent: &latent_rows,
            },
            std_topic.as_deref(),
            predicted
                .commands
                .metadata(robot, predicted.counts.as_ref()),
            &args.out,
        )?;
        eprintln!(
            "wrote {} frames of {robot} joint commands to {} (topic /{robot}/joint_command, with transforms for Foxglove)",
            predicted.frames, args.out
        );
    } else if args.out.ends_with(".mcap") {
        write_mcap(&predicted, robot, &robot_joints, &args.input, &args.out)?;
    } else {
        write_csv(&predicted, robot, &robot_joints, &args.out, args.std)?;
    }
    if let Some(counts) = &predicted.counts {
        eprintln!("{}", counts.summary(robot, &robot_joints));
    }
    if let Some(k) = &kept {
        eprintln!("{}", k.summary(robot));
    }
    Ok(())
}

/// Refuses times an MCAP file cannot hold (negative), naming the output, the input and the frame.
fn mcap_times(times_ns: &[i64], input: &str, out: &str) -> Result<()> {
    if let Some(i) = times_ns.iter().position(|t| *t < 0) {
        bail!(
            "{out}: frame {} of {input} has the negative time {} s; an MCAP output needs times \
             ≥ 0 (shift the input's times, or write CSV)",
            i + 1,
            times_ns[i] as f64 * 1e-9
        );
    }
    Ok(())
}

/// Writes the prediction as JointState messages on /ROBOT/joint_command (and _std).
fn write_mcap(p: &Predicted, robot: &str, joints: &[String], input: &str, out: &str) -> Result<()> {
    mcap_times(&p.times_ns, input, out)?;
    let states =
        |values: &Vec<f64>| JointStates::new(p.times_ns.clone(), joints.to_vec(), values.clone());
    let command = states(&p.mean)?;
    let std_states = p.std.as_ref().map(states).transpose()?;
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
            metadata: vec![p.commands.metadata(robot, p.counts.as_ref())],
        },
    )?;
    eprintln!(
        "wrote {} frames of {robot} joint commands to {out} (topic {main_topic})",
        p.frames
    );
    Ok(())
}

/// The output CSV header: the time column (if any), the joints and, with `std`, their `_std`.
fn csv_header(time: Option<&str>, joints: &[String], std: bool) -> String {
    let mut header: Vec<String> = time.iter().map(|t| t.to_string()).collect();
    header.extend(joints.iter().cloned());
    if std {
        header.extend(joints.iter().map(|j| format!("{j}_std")));
    }
    header.join(",")
}

/// The sidecar of a CSV output `out`: `out.json`, what the commands are (the MCAP record
/// `sgplvm.predict`'s fields, and the sentence stderr says), so that the CSV itself is a header
/// and rows only.
pub(super) fn provenance_path(out: &str) -> PathBuf {
    PathBuf::from(format!("{out}.json"))
}

/// Writes `out`'s sidecar (atomically): the `sgplvm.predict` record of `commands` as JSON.
fn write_provenance(
    out: &str,
    commands: &Commands,
    robot: &str,
    counts: Option<&LimitCounts>,
    t0_ns: i64,
) -> Result<()> {
    let (name, fields) = commands.metadata(robot, counts);
    let json = serde_json::json!({
        "csv": Path::new(out).file_name().map(|f| f.to_string_lossy().into_owned()),
        "description": commands.describe(robot),
        "time": "seconds from the first frame",
        "first_frame_ns": t0_ns,
        name: fields,
    });
    let text = serde_json::to_string_pretty(&json)? + "\n";
    atomic_write_with(&provenance_path(out), |tmp| std::fs::write(tmp, &text))?;
    Ok(())
}

/// Writes the prediction as CSV to a file (atomically, with its sidecar `out.json` saying what
/// the commands are) or to stdout (`-`, the same said on stderr): the header first, no comment
/// lines.
fn write_csv(p: &Predicted, robot: &str, joints: &[String], out: &str, std: bool) -> Result<()> {
    let d = joints.len();
    // Seconds from the first frame (a recording's stamps are epoch times, 1.7e9 s), as
    // `import` and `export` write them; the sidecar keeps the first frame's stamp.
    let t0 = p.times_ns.first().copied().unwrap_or(0);
    let write = |w: &mut dyn Write| -> std::io::Result<()> {
        writeln!(w, "{}", csv_header(Some("time"), joints, std))?;
        for i in 0..p.frames {
            let mut values = p.mean[i * d..(i + 1) * d].to_vec();
            if let Some(s) = &p.std {
                values.extend_from_slice(&s[i * d..(i + 1) * d]);
            }
            writeln!(
                w,
                "{}",
                format_line(Some(seconds_from_ns(p.times_ns[i] - t0)), &values)
            )?;
        }
        w.flush()
    };
    if out == "-" {
        eprintln!("{}", p.commands.describe(robot));
        write(&mut std::io::stdout().lock())?;
    } else {
        atomic_write_with(Path::new(out), |tmp| {
            let mut file = std::io::BufWriter::new(std::fs::File::create(tmp)?);
            write(&mut file)
        })?;
        write_provenance(out, &p.commands, robot, p.counts.as_ref(), t0)?;
        eprintln!(
            "wrote {} frames of {robot} joint commands to {out} ({}: {})",
            p.frames,
            provenance_path(out).display(),
            p.commands.describe(robot)
        );
    }
    Ok(())
}

/// Teleoperation: CSV lines in on stdin, one prediction line out per line, flushed at once.
fn predict_stream(
    model: &dyn Predictor,
    target: &Target,
    out: &str,
    with_std: bool,
    commands: Commands,
    mut girdle: Option<GirdleAlignment>,
) -> Result<()> {
    let robot = target.robot.as_str();
    let robot_joints = target.names();
    if out != "-" {
        bail!("--input - streams to stdout or to an .mcap file: use --out - or --out FILE.mcap");
    }
    let stdin = std::io::stdin();
    let mut lines = stdin.lock().lines();
    let (header, header_line) = read_header(&mut lines, "stdin")?;
    let wanted = model_joint_names(model, model.input_name());
    let order = advise_unnamed(
        column_order(&wanted, &header.joints, "stdin"),
        model,
        model.input_name(),
    )?;
    let stdout = std::io::stdout();
    let mut w = stdout.lock();
    let time_column = header.time_column.as_deref();
    let mut limited = StreamLimits::new(commands, time_column);
    // The header first (numpy, pandas and spreadsheets read it without options); what the
    // commands are goes to stderr.
    eprintln!("{}", limited.commands.describe(robot));
    writeln!(w, "{}", csv_header(time_column, robot_joints, with_std))?;
    w.flush()?;
    let d = robot_joints.len();
    let m = target.columns.model_columns();
    let mut human = vec![0.0; wanted.len()];
    let mut model_out = vec![0.0; m];
    let mut model_std = vec![0.0; m];
    let mut out = vec![0.0; if with_std { 2 * d } else { d }];
    for (i, line) in lines.enumerate() {
        let line = line.context("stdin")?;
        if line.trim().is_empty() || line.starts_with('#') {
            continue;
        }
        let (time, values) = header.parse_line(&line, header_line + i + 1, "stdin")?;
        for (h, &k) in human.iter_mut().zip(&order) {
            *h = values[k];
        }
        if let Some(g) = girdle.as_mut() {
            g.align(&mut human);
        }
        if with_std {
            let frame = Mat::from_fn(1, human.len(), |_, j| human[j]);
            let p = model.predict(frame.as_ref(), robot, true)?;
            let variance = p.variance.ok_or_else(|| anyhow!("no variance returned"))?;
            for j in 0..m {
                model_out[j] = p.mean[(0, j)];
                model_std[j] = variance[(0, j)].sqrt();
            }
            target.columns.fill_std(&model_std, &mut out[d..]);
        } else {
            model.predict_frame(&human, robot, &mut model_out)?;
        }
        target.columns.fill(&model_out, &mut out[..d]);
        limited.push(&mut out[..d], time);
        writeln!(w, "{}", format_line(time, &out))?;
        w.flush()?;
    }
    limited.report(robot, robot_joints);
    Ok(())
}

/// The limits of a stream of commands, one frame at a time.
pub(super) struct StreamLimits {
    /// What the commands are.
    pub commands: Commands,
    stream: Option<LimitedStream>,
    /// Seconds per unit of the time column (`None`: no times).
    time_unit: Option<f64>,
    /// What the self-collision limit did.
    kept: KeptApart,
    /// Frames pushed.
    frames: usize,
    /// The first frame's time, seconds.
    t0: Option<f64>,
}

impl StreamLimits {
    /// The limits of `commands` for a stream whose time column (if any) is `time_column`.
    pub fn new(commands: Commands, time_column: Option<&str>) -> StreamLimits {
        let time_unit = time_column.map(|c| if c == "time_ns" { 1e-9 } else { 1.0 });
        let (commands, stream) = match commands {
            Commands::Limited { limits, safety, .. } => (
                Commands::Limited {
                    limits: limits.clone(),
                    timed: time_unit.is_some(),
                    safety,
                },
                Some(LimitedStream::new(limits)),
            ),
            Commands::Raw => (Commands::Raw, None),
        };
        let kept = KeptApart {
            pairs: match &commands {
                Commands::Limited {
                    safety: Some(s), ..
                } => s.collision().pairs().len(),
                _ => 0,
            },
            ..KeptApart::default()
        };
        StreamLimits {
            commands,
            stream,
            time_unit,
            kept,
            frames: 0,
            t0: None,
        }
    }

    /// Moves one frame's command within the limits (`time`: its time column's value) and out
    /// of self-collision.
    pub fn push(&mut self, command: &mut [f64], time: Option<f64>) {
        let seconds = time.zip(self.time_unit).map(|(t, u)| t * u);
        if let Some(s) = self.stream.as_mut() {
            s.push(command, seconds);
        }
        if let Commands::Limited {
            safety: Some(s), ..
        } = &mut self.commands
        {
            let asked = command.to_vec();
            // From the first frame: an absolute clock leaves too few digits for a step.
            let t0 = *self.t0.get_or_insert(seconds.unwrap_or(0.0));
            let now = seconds.map_or(self.frames as f64, |t| t - t0);
            self.kept.add(s.step(&asked, now, command));
        }
        self.frames += 1;
    }

    /// Says on stderr what the limits moved.
    pub fn report(&self, robot: &str, joints: &[String]) {
        if let Some(s) = &self.stream {
            eprintln!("{}", s.counts().summary(robot, joints));
        }
        if let Commands::Limited {
            safety: Some(_), ..
        } = &self.commands
        {
            eprintln!("{}", self.kept.summary(robot));
        }
    }
}
