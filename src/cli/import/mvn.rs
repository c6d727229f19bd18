//! `sgplvm import --mvn [ADDR:]PORT`: an Xsens MVN network stream recorded as the human's 18
//! joint angles, each frame through the same per-frame fit as `teleop --input mvn` (the
//! importer's own), on the stream's time code, resampled to `--rate` as a file's import is.

use std::net::SocketAddr;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use anyhow::{bail, Context, Result};
use nalgebra::DMatrix;
use sgplvm::capture::{
    ArmFitResult, Calibration, CaptureSource, CapturedMotion, FitReport, StreamCalibrationOptions,
};
use sgplvm::robots::series::median;
use sgplvm::robots::Robot;
use sgplvm_live::mvn::{MvnFit, MvnReceiver, ReceiverOptions, Senders, DEFAULT_PORT};

/// When to stop recording (besides Ctrl-C).
pub struct Stop {
    /// Frames fitted.
    pub max_frames: Option<usize>,
    /// Seconds since it started listening.
    pub seconds: Option<f64>,
}

/// `PORT` or `ADDR:PORT` (default address 0.0.0.0, MVN's port 9763 when empty).
pub fn parse_address(s: &str) -> Result<SocketAddr, String> {
    if s.is_empty() {
        return Ok(SocketAddr::from(([0, 0, 0, 0], DEFAULT_PORT)));
    }
    if let Ok(port) = s.parse::<u16>() {
        return Ok(SocketAddr::from(([0, 0, 0, 0], port)));
    }
    s.parse()
        .map_err(|_| format!("`{s}`: expected PORT or ADDR:PORT, e.g. 9763 or 0.0.0.0:9763"))
}

/// One fitted frame: the stream's time code (ms) and the fit.
struct Fitted {
    time_ms: u32,
    angles: [f64; 18],
    fits: [ArmFitResult; 2],
}

/// Records the stream at `addr` from the sender `from` until `stop` (or Ctrl-C) and returns it
/// as an imported capture at `rate_hz`, the person calibrated as `calibration` says.
pub fn record(
    addr: SocketAddr,
    from: Senders,
    rate_hz: f64,
    stop: &Stop,
    calibration: StreamCalibrationOptions,
) -> Result<CapturedMotion> {
    let options = ReceiverOptions {
        from,
        ..ReceiverOptions::default()
    };
    let mut receiver = MvnReceiver::bind(addr, options).with_context(|| format!("--mvn {addr}"))?;
    let interrupted = Arc::new(AtomicBool::new(false));
    let flag = interrupted.clone();
    ctrlc::set_handler(move || flag.store(true, Ordering::SeqCst))
        .context("installing the Ctrl-C / SIGTERM handler")?;
    eprintln!("recording the MVN stream on {addr} (Ctrl-C ends it)");
    let mut fit = MvnFit::new(calibration);
    let mut frames: Vec<Fitted> = Vec::new();
    let started = Instant::now();
    while !interrupted.load(Ordering::SeqCst) {
        if stop.max_frames.is_some_and(|m| frames.len() >= m)
            || stop
                .seconds
                .is_some_and(|s| started.elapsed().as_secs_f64() >= s)
        {
            break;
        }
        let Some(pose) = receiver.newest()? else {
            std::thread::sleep(Duration::from_micros(500));
            continue;
        };
        let Some((angles, fits)) = fit.angles(&pose).with_context(|| {
            format!(
                "MVN sample {}: cannot fit the human model",
                pose.sample_counter
            )
        })?
        else {
            continue;
        };
        // A time code that does not move on (or goes back: MVN restarted) cannot be resampled.
        if frames
            .last()
            .is_some_and(|f| pose.time_code_ms <= f.time_ms)
        {
            continue;
        }
        frames.push(Fitted {
            time_ms: pose.time_code_ms,
            angles,
            fits,
        });
    }
    let counts = receiver.counts();
    if frames.len() < 2 {
        bail!(
            "--mvn {addr}: {} frame(s) received ({} datagrams, {} dropped); at least 2 are needed",
            frames.len(),
            counts.datagrams,
            counts.dropped()
        );
    }
    eprintln!(
        "{} MVN frames fitted ({} datagrams, {} dropped)",
        frames.len(),
        counts.datagrams,
        counts.dropped()
    );
    if let Some(sender) = receiver.sender() {
        eprintln!("taken from {sender}");
    }
    if counts.other_sender > 0 {
        eprintln!(
            "warning: {} datagram(s) of other senders refused (e.g. {}; --mvn-from names the one to take)",
            counts.other_sender,
            receiver.refused().iter().map(ToString::to_string).collect::<Vec<_>>().join(", ")
        );
    }
    let person = fit.fitter().map(|f| f.calibration().clone());
    if let Some(p) = &person {
        eprintln!("the person was fitted through {}", p.describe());
    }
    capture(&frames, addr, rate_hz, person)
}

/// The recorded frames resampled at `rate_hz` on their time codes, with the fit's report.
fn capture(
    frames: &[Fitted],
    addr: SocketAddr,
    rate_hz: f64,
    calibration: Option<Calibration>,
) -> Result<CapturedMotion> {
    let t0 = frames[0].time_ms;
    let times: Vec<f64> = frames
        .iter()
        .map(|f| f64::from(f.time_ms - t0) * 1e-3)
        .collect();
    let span = times[times.len() - 1];
    let n = (span * rate_hz + 1e-6).floor() as usize + 1;
    let mut positions = DMatrix::zeros(n, 18);
    let mut k = 0;
    for row in 0..n {
        let t = row as f64 / rate_hz;
        while k + 2 < times.len() && times[k + 1] <= t {
            k += 1;
        }
        let (a, b) = (
            &frames[k].angles,
            &frames[(k + 1).min(frames.len() - 1)].angles,
        );
        let w = ((t - times[k]) / (times[k + 1] - times[k])).clamp(0.0, 1.0);
        for j in 0..18 {
            // Across a jump of the angles (a shoulder's other Euler solution), the nearer frame.
            positions[(row, j)] = if (b[j] - a[j]).abs() > std::f64::consts::FRAC_PI_2 {
                if w < 0.5 {
                    a[j]
                } else {
                    b[j]
                }
            } else {
                a[j] + w * (b[j] - a[j])
            };
        }
    }
    let joint_names = Robot::builtin("human")
        .context("the human model")?
        .joint_names();
    Ok(CapturedMotion {
        times_ns: (0..n)
            .map(|r| (r as f64 / rate_hz * 1e9).round() as i64)
            .collect(),
        joint_names: joint_names.clone(),
        positions,
        source: CaptureSource {
            file: format!("mvn://{addr}"),
            skeleton: "Xsens MVN network stream (23 segments)".into(),
            body_axes: "from the stream's first frame (MVN's null pose)".into(),
            frame_rate: (frames.len() - 1) as f64 / span.max(1e-9),
            frames_in_file: frames.len(),
            span_s: (0.0, span),
            calibration_frame_dropped: false,
            units: "m".into(),
            // Not measured from a stream (the report leaves it out).
            arm_length: 0.0,
            rate_hz,
            fit: report(frames, &joint_names),
            calibration,
            person: None,
            // MVN names the sides by its own specification.
            notes: Vec::new(),
            sides_mirrored: None,
        },
    })
}

/// The fit's report over the recorded frames, as a file's import reports it.
fn report(frames: &[Fitted], joint_names: &[String]) -> FitReport {
    let all = |f: fn(&ArmFitResult) -> f64| -> Vec<f64> {
        frames.iter().flat_map(|x| x.fits.iter().map(f)).collect()
    };
    let (elbow, wrist, angle) = (
        all(|f| f.elbow_m),
        all(|f| f.wrist_m),
        all(|f| f.elbow_angle_deg),
    );
    let worst = |v: &[f64]| v.iter().copied().fold(0.0, f64::max);
    let t0 = frames[0].time_ms;
    let beyond: Vec<&Fitted> = frames
        .iter()
        .filter(|f| f.fits.iter().any(ArmFitResult::beyond))
        .collect();
    let mut at_limit = std::collections::BTreeMap::new();
    for f in frames {
        for (side, fit) in f.fits.iter().enumerate() {
            for (j, clamped) in fit.clamped.iter().enumerate() {
                if *clamped {
                    *at_limit
                        .entry(joint_names[9 * side + j].clone())
                        .or_insert(0) += 1;
                }
            }
        }
    }
    FitReport {
        frames: frames.len(),
        elbow_median_m: median(&mut elbow.clone()),
        elbow_worst_m: worst(&elbow),
        wrist_median_m: median(&mut wrist.clone()),
        wrist_worst_m: worst(&wrist),
        elbow_angle_median_deg: median(&mut angle.clone()),
        elbow_angle_worst_deg: worst(&angle),
        frames_beyond: beyond.len(),
        first_beyond_s: beyond.first().map(|f| f64::from(f.time_ms - t0) * 1e-3),
        at_limit,
        shoulder_switches: frames
            .windows(2)
            .filter(|w| {
                [2usize, 4, 11, 13]
                    .iter()
                    .any(|&k| (w[1].angles[k] - w[0].angles[k]).abs() > std::f64::consts::FRAC_PI_2)
            })
            .count(),
    }
}
