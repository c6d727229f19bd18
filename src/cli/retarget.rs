//! `sgplvm retarget`: robot joint commands for recorded human motion, by inverse kinematics of
//! the hands (optionally elbows or hand orientations), and the train/test split: demonstrations
//! that `train`, `transfer` and `experiment` read like the generated ones.

use std::collections::BTreeMap;
use std::path::PathBuf;

use anyhow::{anyhow, bail, Result};
use clap::{Args, ValueEnum};
use sgplvm::robots::anatomy::Anatomy;
use sgplvm::robots::capture::{
    read_capture_sources, sources_json, CaptureSource, CAPTURE_METADATA,
};
use sgplvm::robots::dataset::{
    concatenate, load_demonstrations, write_demonstrations_with_metadata, Dataset,
};
use sgplvm::robots::joint_state::Compression;
use sgplvm::robots::retarget::split::{split_into_blocks, SplitOptions, SplitRule, SplitSummary};
use sgplvm::robots::retarget::{retarget, Match, ReachReport, Redundancy, RetargetOptions};
use sgplvm::robots::Robot;

use super::args::JsonArg;
use super::body::BodyArgs;

/// Name of the MCAP metadata record with the retargeting's settings and reach reports.
const RETARGET_METADATA: &str = "sgplvm.retarget";

#[derive(Args)]
pub struct RetargetArgs {
    /// Human demonstrations (MCAP, e.g. from `sgplvm import`); several are joined, one file
    /// after another (each stays a file for `--split files`).
    #[arg(long, required = true)]
    demos: Vec<PathBuf>,
    /// Built-in robots, comma-separated (walkman, coman, centauro, ur5e).
    #[arg(long, value_delimiter = ',')]
    robots: Vec<String>,
    /// A robot of your own, its URDF as its maker publishes it (the arms found by its names or
    /// structure, or named with --arm or in ROBOT.anatomy.json beside it: `sgplvm robot
    /// FILE.urdf` shows what is found); repeat for several. Named by --robot in the same order,
    /// else by the URDF's robot name.
    #[arg(long)]
    urdf: Vec<PathBuf>,
    /// Names of the --urdf robots, in their order.
    #[arg(long)]
    robot: Vec<String>,
    /// Output demonstrations (MCAP: the human, each robot's /NAME/joint_command, blocks as
    /// segments and the split as metadata).
    #[arg(long)]
    out: PathBuf,
    /// What the robot matches: hands (positions; the fastest, fewest misses), hands+elbows (the
    /// elbow follows the person's as far as the hand allows: about 1.1× the time), poses (hand
    /// orientation too: six constraints on seven joints, more targets out of reach, about 2×
    /// the time).
    #[arg(long = "match", value_parser = parse_match, default_value = "hands")]
    mode: Match,
    /// How each arm's redundancy (7 joints for 3 hand coordinates) is resolved: `continuous`
    /// (each frame continues the last: the hands follow closely, but one hand position may come
    /// with several postures, depending on the path) or `canonical` (the IK solution from the
    /// neutral posture, a function of the hand targets alone, as the generator's key postures:
    /// a more consistent mapping to learn, but the arm lags wherever that solution moves faster
    /// than the velocity limits, and it runs about 1.4× slower).
    #[arg(long, value_enum, default_value = "continuous")]
    redundancy: RedundancyArg,
    /// Let joints move as fast as the IK wants (the URDF velocity limits are kept by default).
    #[arg(long)]
    no_velocity_limits: bool,
    /// How to choose test motions: `blocks` (every --test-every-th block of --block-seconds) or
    /// `files` (the --test-files, whole).
    #[arg(long, value_enum, default_value = "blocks")]
    split: SplitArg,
    /// With --split files: the test files, by name (file stem) or 0-based index.
    #[arg(long, value_delimiter = ',')]
    test_files: Vec<String>,
    /// Length of a block, seconds (blocks are the segments of the output).
    #[arg(long, default_value_t = 4.0)]
    block_seconds: f64,
    /// With --split blocks: one block in this many is a test block.
    #[arg(long, default_value_t = 4)]
    test_every: usize,
    /// Frames this close (seconds) to a boundary between training and test blocks are in
    /// neither set.
    #[arg(long, default_value_t = 0.5)]
    guard_seconds: f64,
    /// Keep every k-th training frame (neighbouring 40 Hz frames are nearly the same pose).
    #[arg(long, default_value_t = 12)]
    train_subsample: usize,
    /// Keep every k-th test frame.
    #[arg(long, default_value_t = 3)]
    test_subsample: usize,
    #[command(flatten)]
    body: BodyArgs,
    #[command(flatten)]
    json: JsonArg,
}

#[derive(Clone, Copy, PartialEq, Eq, ValueEnum)]
enum RedundancyArg {
    /// Continuing the previous frame.
    Continuous,
    /// The IK solution from the neutral posture.
    Canonical,
}

#[derive(Clone, Copy, PartialEq, Eq, ValueEnum)]
enum SplitArg {
    /// Every --test-every-th block of time is a test block.
    Blocks,
    /// The files named by --test-files are test files.
    Files,
}

fn parse_match(s: &str) -> Result<Match, String> {
    Match::parse(s).ok_or_else(|| format!("unknown `{s}`; expected hands, hands+elbows or poses"))
}

pub fn run(args: RetargetArgs) -> Result<()> {
    // The robots, checked before the work starts.
    let mut robots: Vec<(String, Anatomy)> = Vec::new();
    for name in &args.robots {
        if name == "human" {
            bail!("--robots: `human` is the demonstrator, not a robot");
        }
        robots.push((
            name.clone(),
            args.body
                .load(name, None, "give its URDF with --urdf FILE")?,
        ));
    }
    if args.robot.len() > args.urdf.len() {
        bail!(
            "{} --robot names for {} --urdf files; name each URDF robot once, in order",
            args.robot.len(),
            args.urdf.len()
        );
    }
    for (k, path) in args.urdf.iter().enumerate() {
        let name = match args.robot.get(k) {
            Some(n) => n.clone(),
            None => Robot::from_urdf_file(path)?.name().to_string(),
        };
        let anatomy = args.body.load(&name, Some(path), "")?;
        for n in anatomy.notes() {
            eprintln!("{name}: note: {n}");
        }
        robots.push((name, anatomy));
    }
    let names: Vec<&str> = robots.iter().map(|(n, _)| n.as_str()).collect();
    args.body.check_robots(&names)?;
    if robots.is_empty() {
        bail!("no robot to retarget to: name built-in ones with --robots or give --urdf FILE");
    }
    for (k, (name, _)) in robots.iter().enumerate() {
        if robots[..k].iter().any(|(n, _)| n == name) {
            bail!("robot `{name}` named twice");
        }
    }
    // The human, one file after another.
    let mut parts = Vec::with_capacity(args.demos.len());
    let mut sources: Vec<CaptureSource> = Vec::new();
    let mut stems = Vec::new();
    for path in &args.demos {
        let ds = load_demonstrations(path)?;
        let mut file_sources = read_capture_sources(path)?;
        // Each input file is one part; its capture files (if it was imported from several)
        // stay its segments.
        stems.extend(file_stems(&ds, &file_sources, path));
        sources.append(&mut file_sources);
        parts.push(Dataset {
            robots: Vec::new(),
            ..ds
        });
    }
    let mut dataset = concatenate(&parts, 1_000_000_000)?;
    let options = RetargetOptions {
        mode: args.mode,
        redundancy: match args.redundancy {
            RedundancyArg::Canonical => Redundancy::Canonical,
            RedundancyArg::Continuous => Redundancy::Continuous,
        },
        velocity_limits: !args.no_velocity_limits,
        ..RetargetOptions::default()
    };
    let split = SplitOptions {
        rule: match args.split {
            SplitArg::Blocks => SplitRule::Blocks {
                test_every: args.test_every,
            },
            SplitArg::Files => SplitRule::Files {
                test: test_file_indices(&args.test_files, &stems)?,
            },
        },
        block_s: args.block_seconds,
        guard_s: args.guard_seconds,
        train_subsample: args.train_subsample,
        test_subsample: args.test_subsample,
    };
    if args.split == SplitArg::Blocks && !args.test_files.is_empty() {
        bail!("--test-files goes with --split files");
    }
    let started = std::time::Instant::now();
    let results = retarget(&dataset, &robots, &options)?;
    let seconds = started.elapsed().as_secs_f64();
    let summary = split_into_blocks(&mut dataset, &split)?;
    let reports: Vec<ReachReport> = results.iter().map(|r| r.report.clone()).collect();
    dataset.robots = results.into_iter().map(|r| r.body).collect();
    let mut extra = Vec::new();
    if !sources.is_empty() {
        let mut m = BTreeMap::new();
        m.insert("json".to_string(), sources_json(sources.iter())?);
        extra.push((CAPTURE_METADATA.to_string(), m));
    }
    let mut m = BTreeMap::new();
    m.insert(
        "json".to_string(),
        serde_json::to_string(&serde_json::json!({ "match": args.mode, "redundancy": options.redundancy, "split": split, "summary": summary, "reach": reports }))?,
    );
    extra.push((RETARGET_METADATA.to_string(), m));
    write_demonstrations_with_metadata(&args.out, &dataset, Compression::Zstd, extra)?;
    if args.json.json {
        println!(
            "{}",
            serde_json::to_string_pretty(
                &serde_json::json!({ "split": summary, "reach": reports, "seconds": seconds })
            )?
        );
    } else {
        print_reports(&reports, &summary, dataset.len(), seconds, &args);
    }
    Ok(())
}

/// Names of the files behind the segments of one input: the capture files it was imported
/// from, or the input file itself.
fn file_stems(ds: &Dataset, sources: &[CaptureSource], path: &std::path::Path) -> Vec<String> {
    let stem = |p: &str| {
        std::path::Path::new(p)
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| p.to_string())
    };
    if sources.len() == ds.segments.len() {
        sources.iter().map(|s| stem(&s.file)).collect()
    } else {
        let base = stem(&path.display().to_string());
        (0..ds.segments.len())
            .map(|k| {
                if ds.segments.len() == 1 {
                    base.clone()
                } else {
                    format!("{base}#{k}")
                }
            })
            .collect()
    }
}

/// The indices of `--test-files` among the input files `stems`.
fn test_file_indices(names: &[String], stems: &[String]) -> Result<Vec<usize>> {
    if names.is_empty() {
        bail!(
            "--split files needs --test-files NAME[,NAME...] (of: {})",
            stems.join(", ")
        );
    }
    names
        .iter()
        .map(|n| {
            stems
                .iter()
                .position(|s| s == n)
                .or_else(|| n.parse::<usize>().ok().filter(|&i| i < stems.len()))
                .ok_or_else(|| {
                    anyhow!(
                        "--test-files: no file `{n}`; the files are: {}",
                        stems.join(", ")
                    )
                })
        })
        .collect()
}

fn print_reports(
    reports: &[ReachReport],
    s: &SplitSummary,
    frames: usize,
    seconds: f64,
    args: &RetargetArgs,
) {
    let mm = |m: f64| m * 1000.0;
    println!(
        "retargeted {frames} frames to {} robot(s) in {seconds:.1} s ({:.0} frames/s per robot); match: {}",
        reports.len(),
        frames as f64 * reports.len() as f64 / seconds.max(1e-9),
        args.mode.name()
    );
    println!("robot        reached (of targets): median    worst | unreachable (worst miss) | velocity-limited (worst) | other configuration (worst)");
    for r in reports {
        let reached = match (r.median_m, r.worst_m) {
            (Some(m), Some(w)) => format!("{:>9.3} mm {:>6.2} mm", mm(m), mm(w)),
            _ => format!("{:>22}", "none reached"),
        };
        println!(
            "{:<12} {:>6} of {:<6} {reached} | {:>5} ({:>5.1} mm) | {:>6} ({:>6.1} mm)  | {:>6} ({:>6.1} mm){}",
            r.robot,
            r.reached,
            r.targets,
            r.unreachable,
            mm(r.unreachable_worst_m),
            r.velocity_limited,
            mm(r.velocity_limited_worst_m),
            r.other_configuration,
            mm(r.other_configuration_worst_m),
            match (r.elbow_median_m, r.orientation_median_rad) {
                (Some(e), _) => format!("  elbow {:.1} mm median", mm(e)),
                (_, Some(o)) => format!("  orientation {:.1}° median", o.to_degrees()),
                _ => String::new(),
            }
        );
    }
    println!(
        "split: {} blocks of {} s, {} for testing; {} training and {} test frames kept ({} guard frames left out)",
        s.blocks, args.block_seconds, s.test_blocks, s.train_frames, s.test_frames, s.guard_frames
    );
    println!("wrote {}", args.out.display());
}
