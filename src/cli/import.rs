//! `sgplvm import`: motion-capture files (BVH) become the human's 18 joint angles, as the MCAP
//! demonstrations `retarget` takes (or CSV), with a report of how faithfully the angles
//! reproduce the capture.

use std::collections::BTreeMap;
use std::io::Write;
use std::path::{Path, PathBuf};

use anyhow::{bail, Result};
use clap::Args;
use sgplvm::capture::{
    captures_to_dataset, import_files, ArmMap, CaptureSource, ImportOptions, Units,
    CAPTURE_METADATA, ELBOW_ANGLE_LIMIT_DEG, MEDIAN_RESIDUAL_LIMIT_M, WORST_RESIDUAL_LIMIT_M,
};
use sgplvm::csv::format_line;
use sgplvm::files::atomic_write_with;
use sgplvm::robots::dataset::write_demonstrations_with_metadata;
use sgplvm::robots::joint_state::Compression;
use sgplvm::robots::series::seconds_from_ns;

use super::args::JsonArg;
use super::calibration::CalibrationArgs;

mod mvn;

#[derive(Args)]
pub struct ImportArgs {
    /// BVH files (CMU/cgspeed, Xsens MVN, Mixamo, Rokoko, Motive, Blender, ... exports), or
    /// CMU's ASF/AMC (`13.asf 13_26.amc`, or the .amc alone with its subject's .asf beside
    /// it; 120 frames a second), one segment each, joined one after another.
    #[arg(required_unless_present = "mvn")]
    files: Vec<PathBuf>,
    /// Or record an Xsens MVN network stream (pose datagrams 01 or 02) arriving on
    /// [ADDR:]PORT [default: 0.0.0.0:9763], each frame fitted as `teleop --input mvn` fits it,
    /// on the stream's time code; until Ctrl-C, --max-frames or --seconds.
    #[arg(long, value_name = "[ADDR:]PORT", num_args = 0..=1, default_missing_value = "",
          value_parser = mvn::parse_address, conflicts_with_all = ["files", "map", "units", "from", "to"])]
    mvn: Option<std::net::SocketAddr>,
    /// With --mvn: take pose datagrams only from this sender, IP (any of its ports) or
    /// IP:PORT [default: the host of the first datagram of MVN pose data, locked].
    #[arg(long, value_name = "IP[:PORT]", requires = "mvn", value_parser = sgplvm_live::mvn::Senders::parse)]
    mvn_from: Option<sgplvm_live::mvn::Senders>,
    /// With --mvn: stop after this many frames.
    #[arg(long, requires = "mvn")]
    max_frames: Option<usize>,
    /// With --mvn: stop this many seconds after it starts listening.
    #[arg(long, requires = "mvn")]
    seconds: Option<f64>,
    /// Output: .mcap (sensor_msgs/JointState on /human/joint_states, one segment per file, the
    /// captures' provenance and fit as metadata: the input of `retarget`), any other name for
    /// CSV (a `time` column, then the 18 joints).
    #[arg(long)]
    out: PathBuf,
    /// Rate of the imported frames, Hz (40 is the teleoperation rate of the paper).
    #[arg(long, default_value_t = 40.0)]
    rate: f64,
    /// A JSON map of the human model's joints to the capture's segments, for skeletons whose
    /// names are not recognised, e.g. {"jLeftC7Shoulder": "L_Clav", "jLeftShoulder":
    /// "L_UpArm", "jLeftElbow": "L_LowArm", "jLeftWrist": "L_Hand", "jRightShoulder": ...}
    /// (the clavicles may be left out).
    #[arg(long)]
    map: Option<PathBuf>,
    /// Length units of the files (m, dm, cm, mm, in, cmu); default: guessed from the arm's length.
    /// Only reports use them: positions are scaled to the human model either way.
    #[arg(long, value_parser = parse_units)]
    units: Option<Units>,
    /// Import from this second of each file on.
    #[arg(long, value_name = "SECONDS")]
    from: Option<f64>,
    /// Import up to this second of each file.
    #[arg(long, value_name = "SECONDS")]
    to: Option<f64>,
    /// Who was captured (e.g. a CMU subject number): stored with each file's frames, so that
    /// `retarget --split people` can test on people never in training and a model's gate is
    /// calibrated on people it held out.
    #[arg(long, value_name = "NAME")]
    person: Option<String>,
    #[command(flatten)]
    calibration: CalibrationArgs,
    #[command(flatten)]
    json: JsonArg,
}

fn parse_units(s: &str) -> Result<Units, String> {
    Units::parse(s).ok_or_else(|| format!("unknown units `{s}`; expected {}", Units::choices()))
}

pub fn run(args: ImportArgs) -> Result<()> {
    let map = args.map.as_deref().map(ArmMap::read).transpose()?;
    let options = ImportOptions {
        rate_hz: args.rate,
        map,
        units: args.units,
        from_s: args.from,
        to_s: args.to,
        calibration: args.calibration.options(&[])?.offered,
        ..ImportOptions::default()
    };
    if !(args.rate.is_finite() && args.rate > 0.0) {
        bail!("--rate {}: expected a positive rate in Hz", args.rate);
    }
    let mut captures = Vec::with_capacity(args.files.len().max(1));
    if let Some(addr) = args.mvn {
        let stop = mvn::Stop {
            max_frames: args.max_frames,
            seconds: args.seconds,
        };
        captures.push(mvn::record(
            addr,
            args.mvn_from.unwrap_or_default(),
            args.rate,
            &stop,
            args.calibration.options(&[])?,
        )?);
    }
    captures.extend(import_files(&args.files, &options)?);
    if let Some(person) = &args.person {
        if person.trim().is_empty() {
            bail!("--person: expected a name, got an empty one");
        }
        captures
            .iter_mut()
            .for_each(|c| c.source.person = Some(person.clone()));
    }
    if !args.json.json {
        for capture in &captures {
            summary(&capture.source, capture.times_ns.len());
        }
    }
    let (dataset, sources) = captures_to_dataset(&captures)?;
    let out = args.out.as_path();
    if out.extension().is_some_and(|e| e == "mcap") {
        let mut meta = BTreeMap::new();
        meta.insert("json".to_string(), sources);
        write_demonstrations_with_metadata(
            out,
            &dataset,
            Compression::Zstd,
            vec![(CAPTURE_METADATA.to_string(), meta)],
        )?;
    } else if out.as_os_str() == "-" {
        bail!("--out -: write the human frames to a file (.mcap or .csv)");
    } else {
        write_csv(
            out,
            &dataset.human.joint_names,
            &dataset.times_ns,
            &dataset.human.positions,
        )?;
    }
    if let Some(out) = args.calibration.out() {
        // One calibration, whether of one capture or shared by captures of one person.
        let mut all = captures.iter().map(|c| c.source.calibration.as_ref());
        match all.next().flatten() {
            None => bail!("--calibration-out: the capture holds no calibration"),
            Some(first) if all.all(|c| c == Some(first)) => first.write(out)?,
            Some(_) => bail!(
                "--calibration-out {}: {} captures of more than one person (their skeletons rest differently), each with its calibration; import one person at a time (the MCAP keeps every one: --calibration takes it)",
                out.display(),
                captures.len()
            ),
        }
    }
    if args.json.json {
        let sources: Vec<&CaptureSource> = captures.iter().map(|c| &c.source).collect();
        println!("{}", serde_json::to_string_pretty(&sources)?);
    } else {
        println!(
            "wrote {} frames of the human ({} joints, {} Hz, {} file{}) to {}",
            dataset.len(),
            dataset.human.joint_names.len(),
            args.rate,
            captures.len(),
            if captures.len() == 1 { "" } else { "s" },
            out.display()
        );
    }
    Ok(())
}

/// One file's import, in a few lines; warnings where the model could not follow.
fn summary(s: &CaptureSource, frames_out: usize) {
    let f = &s.fit;
    let cm = |m: f64| m * 100.0;
    println!(
        "{}: {} skeleton, {} frames at {:.0} Hz, {:.2}–{:.2} s imported as {frames_out} frames at {} Hz{}",
        s.file,
        s.skeleton,
        s.frames_in_file,
        s.frame_rate,
        s.span_s.0,
        s.span_s.1,
        s.rate_hz,
        if s.calibration_frame_dropped { " (first frame left out: a calibration pose)" } else { "" }
    );
    if !s.body_axes.is_empty() {
        println!("  body axes {}", s.body_axes);
    }
    if let Some(c) = &s.calibration {
        println!("  calibration: {}", c.describe());
    }
    let units = if s.units == "unknown" {
        "units unknown".to_string()
    } else if s.arm_length <= 0.0 {
        format!("units {}", s.units)
    } else {
        format!("units {}, arm {:.1} cm", s.units, cm(s.arm_length))
    };
    println!(
        "  fit to the human model ({units}): elbow {:.2} cm median, {:.2} cm worst; wrist {:.2} cm median, {:.2} cm worst; elbow angle {:.2}° median, {:.2}° worst",
        cm(f.elbow_median_m),
        cm(f.elbow_worst_m),
        cm(f.wrist_median_m),
        cm(f.wrist_worst_m),
        f.elbow_angle_median_deg,
        f.elbow_angle_worst_deg
    );
    if f.elbow_median_m > MEDIAN_RESIDUAL_LIMIT_M || f.wrist_median_m > MEDIAN_RESIDUAL_LIMIT_M {
        eprintln!(
            "warning: {}: the median residual exceeds {:.0} cm: is the arm map right (--map), or the skeleton's rest pose unusual?",
            s.file,
            cm(MEDIAN_RESIDUAL_LIMIT_M)
        );
    }
    for note in &s.notes {
        eprintln!("note: {}: {note}", s.file);
    }
    if let Some(mirrored) = &s.sides_mirrored {
        eprintln!("warning: {}: {}", s.file, mirrored.describe());
    }
    if f.frames_beyond > 0 {
        eprintln!(
            "warning: {}: {} of {} frames beyond {:.0} cm or {:.0}° (first at {:.2} s): poses the human model cannot take within its joint limits",
            s.file,
            f.frames_beyond,
            f.frames,
            cm(WORST_RESIDUAL_LIMIT_M),
            ELBOW_ANGLE_LIMIT_DEG,
            f.first_beyond_s.unwrap_or(0.0)
        );
    }
    let mut at_limit: Vec<(&String, &usize)> = f.at_limit.iter().collect();
    at_limit.sort_by(|a, b| b.1.cmp(a.1));
    if let Some((joint, n)) = at_limit.first() {
        let shown: Vec<String> = at_limit
            .iter()
            .take(4)
            .map(|(j, n)| format!("{j} {:.0} %", 100.0 * **n as f64 / f.frames as f64))
            .collect();
        println!("  at a joint limit (share of frames): {}", shown.join(", "));
        if (**n as f64) > 0.5 * f.frames as f64 && joint.contains("pronation") {
            eprintln!(
                "warning: {}: {joint} is at its limit in most frames: the skeleton's rest pose may not be twist-free (palms down or towards the body)",
                s.file
            );
        }
    }
    if f.shoulder_switches > 0 {
        println!(
            "  {} shoulder angle switch(es) to the other Euler solution of the same pose (the arm passing abduction ±90° or a joint limit)",
            f.shoulder_switches
        );
    }
}

/// The human's frames as CSV: `time` (seconds from the first frame) then one column a joint.
fn write_csv(
    path: &Path,
    names: &[String],
    times_ns: &[i64],
    positions: &nalgebra::DMatrix<f64>,
) -> Result<()> {
    atomic_write_with(path, |tmp| {
        let mut w = std::io::BufWriter::new(std::fs::File::create(tmp)?);
        writeln!(w, "time,{}", names.join(","))?;
        let t0 = times_ns.first().copied().unwrap_or(0);
        for (k, &t) in times_ns.iter().enumerate() {
            let row: Vec<f64> = positions.row(k).iter().copied().collect();
            writeln!(w, "{}", format_line(Some(seconds_from_ns(t - t0)), &row))?;
        }
        w.flush()
    })?;
    Ok(())
}
