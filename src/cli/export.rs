//! `sgplvm export`: one body's joint series from a demonstration file, as CSV or MCAP — the
//! human frames that `predict` and `simulate --model` take, or a robot's recorded commands.

use std::io::Write;
use std::path::Path;

use anyhow::{anyhow, Result};
use clap::{Args, ValueEnum};
use sgplvm::csv::format_line;
use sgplvm::files::atomic_write_with;
use sgplvm::robots::dataset::BodyData;
use sgplvm::robots::joint_state::{write_joint_states, Compression, JointStates};
use sgplvm::robots::series::seconds_from_ns;

use super::args::DataArg;

#[derive(Args)]
#[command(mut_arg("data", |a| a.visible_alias("demos")))]
pub struct ExportArgs {
    #[command(flatten)]
    data: DataArg,
    /// The body: `human` or one of the data's robots.
    #[arg(long, default_value = "human")]
    body: String,
    /// Which frames: the test frames (default; no model was trained on them), the training
    /// frames, or all.
    #[arg(long, value_enum, default_value = "test")]
    frames: FramesArg,
    /// Output: .mcap (JointState on the body's topic, e.g. /human/joint_states, with the
    /// recording's stamps), .bvh (the human only: its motion on an Xsens-MVN-named skeleton,
    /// for animation tools and `sgplvm import`), any other name for CSV (a `time` column,
    /// seconds from the first frame written, then one column per joint), `-` for stdout.
    #[arg(long)]
    out: String,
}

/// `--frames`: which split of the demonstrations to export.
#[derive(Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum FramesArg {
    /// The test frames: motions concatenated in recording order, times jumping at the joins.
    Test,
    /// The training frames.
    Train,
    /// Every frame.
    All,
}

pub fn run(args: ExportArgs) -> Result<()> {
    let demos = args.data.load()?;
    let ds = &demos.dataset;
    let body: &BodyData = if args.body == ds.human.name || args.body == "human" {
        &ds.human
    } else {
        ds.robot(&args.body).ok_or_else(|| {
            anyhow!(
                "{}: no body named '{}'; the data has human and {:?}",
                demos.source_name,
                args.body,
                ds.robot_names()
            )
        })?
    };
    let rows: Vec<usize> = match args.frames {
        FramesArg::Test => ds.test.clone(),
        FramesArg::Train => ds.train.clone(),
        FramesArg::All => (0..ds.len()).collect(),
    };
    let times_ns: Vec<i64> = rows.iter().map(|&i| ds.times_ns[i]).collect();
    let d = body.joint_names.len();
    let values: Vec<f64> = rows
        .iter()
        .flat_map(|&i| (0..d).map(move |j| body.positions[(i, j)]))
        .collect();
    let out = args.out.as_str();
    if out.ends_with(".bvh") {
        return write_bvh(body, &rows, &times_ns, out, args.frames);
    }
    if out.ends_with(".mcap") {
        let states = JointStates::new(times_ns, body.joint_names.clone(), values)?;
        write_joint_states(out, &body.topic, &states, Compression::Zstd)?;
    } else {
        let write = |w: &mut dyn Write| -> std::io::Result<()> {
            writeln!(w, "time,{}", body.joint_names.join(","))?;
            // Seconds from the first frame written (the recording's stamps are epoch times).
            let t0 = times_ns.first().copied().unwrap_or(0);
            for (k, &t) in times_ns.iter().enumerate() {
                let time = seconds_from_ns(t - t0);
                let line = format_line(Some(time), &values[k * d..(k + 1) * d]);
                writeln!(w, "{line}")?;
            }
            w.flush()
        };
        if out == "-" {
            write(&mut std::io::stdout().lock())?;
            return Ok(());
        }
        atomic_write_with(Path::new(out), |tmp| {
            write(&mut std::io::BufWriter::new(std::fs::File::create(tmp)?))
        })?;
    }
    let which = match args.frames {
        FramesArg::Test => "test frames",
        FramesArg::Train => "training frames",
        FramesArg::All => "frames",
    };
    eprintln!(
        "wrote {} {which} of {} ({d} joints) to {out}",
        rows.len(),
        body.name
    );
    Ok(())
}

/// The human's frames as a BVH file at the data's frame rate (the median interval between the
/// frames written; a BVH file has one rate, so the time jumps between motions are not kept).
fn write_bvh(
    body: &BodyData,
    rows: &[usize],
    times_ns: &[i64],
    out: &str,
    frames: FramesArg,
) -> Result<()> {
    let human = sgplvm::robots::Robot::builtin("human")?.joint_names();
    if body.joint_names != human {
        return Err(anyhow!(
            "{out}: a BVH file holds the human model's motion; body `{}` is not the human (its {}: {})",
            body.name,
            sgplvm::robots::names::count(body.joint_names.len(), "joint"),
            sgplvm::robots::names::few(&body.joint_names, sgplvm::robots::names::SHOWN)
        ));
    }
    if rows.len() < 2 {
        return Err(anyhow!(
            "{out}: {} frame(s) to write; a BVH file needs at least 2",
            rows.len()
        ));
    }
    let mut steps: Vec<i64> = times_ns.windows(2).map(|w| w[1] - w[0]).collect();
    steps.sort_unstable();
    let frame_time = seconds_from_ns(steps[steps.len() / 2]);
    let angles: Vec<[f64; 18]> = rows
        .iter()
        .map(|&i| std::array::from_fn(|j| body.positions[(i, j)]))
        .collect();
    sgplvm::capture::write_bvh(out, frame_time, &angles)?;
    let which = match frames {
        FramesArg::Test => "test frames (one motion after another)",
        FramesArg::Train => "training frames (one after another)",
        FramesArg::All => "frames",
    };
    eprintln!(
        "wrote {} {which} of the human to {out} at {:.0} frames/s",
        rows.len(),
        1.0 / frame_time
    );
    Ok(())
}
