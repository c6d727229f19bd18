//! One capture imported, in named steps: each arm's calibration from the rest pose, the span
//! of frames asked for, the fit of every frame, the calibration frame some files start with,
//! the fit's report, and the resampling onto the output clock.

use std::path::Path;

use nalgebra::DMatrix;

use crate::calibration::{
    Calibration, HandEnd, HingeEstimate, Twist, UntoldTwist, REST_MATCH_FRACTION,
};
use crate::fit::HumanArms;
use crate::mirror::{ElbowBends, SidesMirrored};
use crate::skeleton::Skeleton;
use crate::stream::PoseFitter;
use crate::{
    Bvh, CaptureError, CaptureSource, CapturedMotion, FitReport, ImportOptions, Units,
    MAX_OUTPUT_FRAMES,
};
use sgplvm_robots::series::median;
use sgplvm_robots::{Robot, Side};

/// Imports one BVH file (see the module documentation).
pub fn import_bvh(
    path: impl AsRef<Path>,
    options: &ImportOptions,
) -> Result<CapturedMotion, CaptureError> {
    let path = path.as_ref();
    let bvh = Bvh::read(path)?;
    import_parsed(&bvh, &path.display().to_string(), options)
}

/// Imports capture files one after another: BVH files, and CMU's ASF/AMC (an `.amc` motion
/// with the `.asf` skeleton given before it among `paths`, else the one beside it,
/// [`crate::asf::skeleton_beside`]). An `.asf` is no motion of its own. Takes of one person
/// share one calibration (see `shared_calibrations`).
pub fn import_files(
    paths: &[std::path::PathBuf],
    options: &ImportOptions,
) -> Result<Vec<CapturedMotion>, CaptureError> {
    let has = |p: &Path, ext: &str| p.extension().is_some_and(|e| e.eq_ignore_ascii_case(ext));
    // Each motion with the skeleton it is read with (an AMC's ASF).
    let mut motions: Vec<(&Path, Option<std::path::PathBuf>)> = Vec::new();
    let mut skeleton: Option<&Path> = None;
    for path in paths {
        if has(path, "asf") {
            skeleton = Some(path);
        } else if has(path, "amc") {
            let asf = match skeleton {
                Some(s) => s.to_path_buf(),
                None => crate::asf::skeleton_beside(path)?,
            };
            motions.push((path, Some(asf)));
        } else {
            motions.push((path, None));
        }
    }
    if motions.is_empty() && skeleton.is_some() {
        return Err(CaptureError::Options {
            file: skeleton
                .map(|s| s.display().to_string())
                .unwrap_or_default(),
            message: "an ASF file is a skeleton, no motion: give its AMC files after it".into(),
        });
    }
    let read = |(path, asf): &(&Path, Option<std::path::PathBuf>)| match asf {
        Some(asf) => crate::asf::read_asf_amc(asf, path),
        None => Bvh::read(path),
    };
    // Files are read twice where there are several (one at a time, so that many files take
    // the memory of one): for their rest poses and hinges, then to import them.
    let shared = if options.calibration.is_empty() && motions.len() > 1 {
        let model = HumanArms::new(&Robot::builtin("human")?)?;
        let mut seen = Vec::with_capacity(motions.len());
        for m in &motions {
            let file = m.0.display().to_string();
            seen.push(
                read(m)
                    .ok()
                    .and_then(|bvh| Seen::of(&bvh, &file, &model, options)),
            );
        }
        shared_calibrations(&seen, &model)
    } else {
        vec![None; motions.len()]
    };
    motions
        .iter()
        .zip(shared)
        .map(|(m, calibration)| {
            let bvh = read(m)?;
            let file = m.0.display().to_string();
            match calibration {
                Some(c) => {
                    let through = ImportOptions {
                        calibration: vec![c],
                        ..options.clone()
                    };
                    import_parsed(&bvh, &file, &through)
                }
                None => import_parsed(&bvh, &file, options),
            }
        })
        .collect()
}

/// What one file tells of its person: its rest pose, its arms' length (metres where the
/// units are known) and the elbow's hinge over its motion, with its own calibration.
struct Seen {
    file: String,
    scheme: String,
    units: Option<Units>,
    rest: [crate::skeleton::ArmPose; 2],
    has_clavicle: [bool; 2],
    arm_length: f64,
    hinge: HingeEstimate,
    calibration: Calibration,
}

impl Seen {
    /// What file `file` (read as `bvh`) tells; `None` where its skeleton is not found (its
    /// import says why).
    fn of(bvh: &Bvh, file: &str, model: &HumanArms, options: &ImportOptions) -> Option<Seen> {
        let skeleton = Skeleton::identify(bvh, options.map.as_ref(), file).ok()?;
        let units = options.units.or_else(|| Units::guess(skeleton.arm_length));
        let (calibration, hinge) = calibrate(bvh, &skeleton, model, file, units);
        Some(Seen {
            file: file.to_string(),
            scheme: skeleton.scheme.clone(),
            units,
            rest: [Side::Left, Side::Right].map(|side| skeleton.rest_pose(bvh, side)),
            has_clavicle: [0, 1].map(|s| skeleton.arms[s].clavicle.is_some()),
            arm_length: skeleton.arm_length * units.map_or(1.0, Units::metres),
            hinge,
            calibration,
        })
    }
}

/// One calibration per person among the files `seen`: files whose skeletons rest alike (every
/// rest point within [`REST_MATCH_FRACTION`] of the arm's length, the live node's own test of
/// one person, and arms as long within it) share the first one's rest pose, with an upper
/// arm's twist that the rest leaves untold read from the elbow's hinge over all their motion —
/// each take alone told it its own way (up to 27° over six 2-second takes of one subject), and
/// a stream of that person could be fitted through one of them only. `None` for a file alike
/// to no other (it calibrates itself, as imported alone) or whose skeleton is not found.
fn shared_calibrations(seen: &[Option<Seen>], model: &HumanArms) -> Vec<Option<Calibration>> {
    let mut shared = vec![None; seen.len()];
    // Each group: its first file and every member.
    let mut groups: Vec<(usize, Vec<usize>)> = Vec::new();
    for (k, s) in seen.iter().enumerate() {
        let Some(s) = s else { continue };
        let alike = groups.iter_mut().find(|(first, _)| {
            let Some(f) = &seen[*first] else { return false };
            (f.arm_length - s.arm_length).abs() <= REST_MATCH_FRACTION * f.arm_length
                && f.calibration
                    .check_rest([&s.rest[0], &s.rest[1]], s.has_clavicle, HandEnd::Measured)
                    .is_ok()
        });
        match alike {
            Some((_, members)) => members.push(k),
            None => groups.push((k, vec![k])),
        }
    }
    for (first, members) in groups.into_iter().filter(|(_, m)| m.len() > 1) {
        let Some(f) = &seen[first] else { continue };
        let mut hinge = HingeEstimate::new();
        for s in members.iter().filter_map(|&k| seen[k].as_ref()) {
            hinge.merge(&s.hinge);
        }
        let calibration = Calibration::from_rest(
            model,
            [&f.rest[0], &f.rest[1]],
            f.has_clavicle,
            UntoldTwist {
                hinge: Some(&hinge),
                otherwise: Twist::Assumed,
            },
            &format!(
                "import of {} and {} resting alike",
                f.file,
                sgplvm_robots::names::count(members.len() - 1, "more file")
            ),
            &f.scheme,
            f.units.map(Units::metres),
        );
        for k in members {
            shared[k] = Some(calibration.clone());
        }
    }
    shared
}

/// [`import_bvh`] of an already parsed file; `file` names it in reports and errors.
pub fn import_parsed(
    bvh: &Bvh,
    file: &str,
    options: &ImportOptions,
) -> Result<CapturedMotion, CaptureError> {
    let bad = |message: String| CaptureError::Options {
        file: file.to_string(),
        message,
    };
    if !(options.rate_hz.is_finite() && options.rate_hz > 0.0 && options.rate_hz <= 10_000.0) {
        return Err(bad(format!(
            "rate {} Hz; expected a positive rate up to 10 kHz (40 is the teleoperation rate)",
            options.rate_hz
        )));
    }
    let frames_in_file = bvh.frames();
    if frames_in_file < 2 {
        return Err(bad(format!(
            "{frames_in_file} frame(s); a motion needs at least 2"
        )));
    }
    let skeleton = Skeleton::identify(bvh, options.map.as_ref(), file)?;
    let human = Robot::builtin("human")?;
    let model = HumanArms::new(&human)?;
    let units = options.units.or_else(|| Units::guess(skeleton.arm_length));
    let calibration = match options.calibration.as_slice() {
        [] => calibrate(bvh, &skeleton, &model, file, units).0,
        given => given_calibration(bvh, &skeleton, given, file)?,
    };
    let mut fitter = PoseFitter::new(model, &calibration);
    let dt = bvh.frame_time;
    let (first, last) = import_span(bvh, options, &bad)?;
    let fits = fit_frames(bvh, &skeleton, &mut fitter, first, last);
    let joint_names = fitter.model().joint_names.clone();
    let start_row = calibration_frame(&fits.angles, bvh, options);
    let t0 = (first + start_row) as f64 * dt;
    let fit = fit_report(&fits, start_row, dt, &joint_names);
    // Resample onto the output clock.
    let span = (last - first - start_row) as f64 * dt;
    let (out, times_ns) = resample(&fits.angles, start_row, dt, span, options, &bad)?;
    Ok(CapturedMotion {
        times_ns,
        joint_names,
        positions: out,
        source: CaptureSource {
            file: file.to_string(),
            skeleton: skeleton.scheme.clone(),
            body_axes: format!("from the skeleton's geometry: {}", skeleton.axes_from),
            frame_rate: 1.0 / dt,
            frames_in_file,
            span_s: (t0, t0 + span),
            calibration_frame_dropped: start_row == 1,
            units: units
                .map(|u| u.name().to_string())
                .unwrap_or_else(|| "unknown".into()),
            arm_length: skeleton.arm_length * units.map(Units::metres).unwrap_or(1.0),
            rate_hz: options.rate_hz,
            fit,
            calibration: Some(calibration),
            person: None,
            notes: bvh_notes(bvh, &skeleton),
            sides_mirrored: SidesMirrored::of(&fits.bends, skeleton.swapped_map(bvh)),
        },
    })
}

/// The calibration of the file's skeleton: its rest pose, and where that leaves an upper arm's
/// twist untold, the elbow's hinge over the file's motion (at most [`HINGE_FRAMES`] frames,
/// evenly spaced); and that hinge, to be pooled with other files of the same person.
fn calibrate(
    bvh: &Bvh,
    skeleton: &Skeleton,
    model: &HumanArms,
    file: &str,
    units: Option<Units>,
) -> (Calibration, HingeEstimate) {
    let rest = [Side::Left, Side::Right].map(|side| skeleton.rest_pose(bvh, side));
    let has_clavicle = [0, 1].map(|s| skeleton.arms[s].clavicle.is_some());
    let mut hinge = HingeEstimate::new();
    if Calibration::untold(model, [&rest[0], &rest[1]], has_clavicle)
        .iter()
        .any(|u| *u)
    {
        let frames = bvh.frames();
        let step = frames.div_ceil(HINGE_FRAMES).max(1);
        for f in (0..frames).step_by(step) {
            let poses =
                [Side::Left, Side::Right].map(|side| skeleton.arm_pose(bvh, bvh.frame(f), side));
            hinge.add([&poses[0], &poses[1]]);
        }
    }
    let calibration = Calibration::from_rest(
        model,
        [&rest[0], &rest[1]],
        has_clavicle,
        UntoldTwist {
            hinge: Some(&hinge),
            otherwise: Twist::Assumed,
        },
        &format!("import of {file}"),
        &skeleton.scheme,
        units.map(Units::metres),
    );
    (calibration, hinge)
}

/// Of the calibrations given for the file, the one whose rest pose is the file's.
fn given_calibration(
    bvh: &Bvh,
    skeleton: &Skeleton,
    given: &[Calibration],
    file: &str,
) -> Result<Calibration, CaptureError> {
    let rest = [Side::Left, Side::Right].map(|side| skeleton.rest_pose(bvh, side));
    let has_clavicle = [0, 1].map(|s| skeleton.arms[s].clavicle.is_some());
    crate::calibration::choose(
        given,
        [&rest[0], &rest[1]],
        has_clavicle,
        crate::calibration::HandEnd::Measured,
    )
    .cloned()
    .map_err(|why| CaptureError::Calibration {
        file: file.to_string(),
        message: format!(
            "no calibration given is this capture's person: {}",
            why.join("; ")
        ),
    })
}

/// Most frames the elbow's hinge is read from (evenly spaced over the file).
const HINGE_FRAMES: usize = 2000;

/// The first and last frame of the span to import (at least two frames).
fn import_span(
    bvh: &Bvh,
    options: &ImportOptions,
    bad: &impl Fn(String) -> CaptureError,
) -> Result<(usize, usize), CaptureError> {
    let frames_in_file = bvh.frames();
    let dt = bvh.frame_time;
    let duration = (frames_in_file - 1) as f64 * dt;
    let from = options.from_s.unwrap_or(0.0);
    let to = options.to_s.unwrap_or(duration).min(duration);
    if !(from.is_finite() && to.is_finite() && from >= 0.0 && from < to) {
        return Err(bad(format!(
            "time range {from} s to {to} s; expected 0 ≤ from < to within the capture's {duration:.2} s"
        )));
    }
    let first = (from / dt - 1e-6).ceil().max(0.0) as usize;
    let last = ((to / dt + 1e-6).floor() as usize).min(frames_in_file - 1);
    if last <= first {
        return Err(bad(format!(
            "the range {from} s to {to} s holds fewer than 2 frames"
        )));
    }
    Ok((first, last))
}

/// Every captured frame's fit: the angles and how far they land from the capture.
struct FrameFits {
    /// Joint angles, frames × 18, radians.
    angles: DMatrix<f64>,
    /// Per frame and arm (left, then right): the elbow's distance to the capture, metres.
    elbow_res: Vec<f64>,
    /// Per frame and arm: the wrist's distance to the capture, metres.
    wrist_res: Vec<f64>,
    /// Per frame and arm: the elbow angle's difference, degrees.
    angle_res: Vec<f64>,
    /// Per frame: whether an arm is beyond the limits of a faithful frame.
    beyond: Vec<bool>,
    /// Per model joint: the frames in which it was held at a limit.
    at_limit: [usize; 18],
    /// Per model joint: whether it was held at a limit in the first frame.
    first_at_limit: [bool; 18],
    /// Which way the elbows bent (a mirror-labelled skeleton's bend backwards).
    bends: ElbowBends,
}

/// Fits every frame from `first` to `last`, both arms, each continuing from its previous
/// frame's angles.
fn fit_frames(
    bvh: &Bvh,
    skeleton: &Skeleton,
    fitter: &mut PoseFitter,
    first: usize,
    last: usize,
) -> FrameFits {
    let n = last - first + 1;
    let mut angles = DMatrix::<f64>::zeros(n, 18);
    let mut elbow_res = Vec::with_capacity(2 * n);
    let mut wrist_res = Vec::with_capacity(2 * n);
    let mut angle_res = Vec::with_capacity(2 * n);
    let mut beyond = vec![false; n];
    let mut at_limit = [0usize; 18];
    let mut first_at_limit = [false; 18];
    let mut bends = ElbowBends::new(bvh.frame_rate());
    for (row, f) in (first..=last).enumerate() {
        let values = bvh.frame(f);
        let poses = [Side::Left, Side::Right].map(|side| skeleton.arm_pose(bvh, values, side));
        bends.add([&poses[0], &poses[1]]);
        let fits = fitter.fit([&poses[0], &poses[1]]);
        for (s, fit) in fits.iter().enumerate() {
            for k in 0..9 {
                angles[(row, 9 * s + k)] = fit.angles[k];
                at_limit[9 * s + k] += usize::from(fit.clamped[k]);
                if row == 0 {
                    first_at_limit[9 * s + k] = fit.clamped[k];
                }
            }
            beyond[row] |= fit.beyond();
            elbow_res.push(fit.elbow_m);
            wrist_res.push(fit.wrist_m);
            angle_res.push(fit.elbow_angle_deg);
        }
    }
    FrameFits {
        angles,
        elbow_res,
        wrist_res,
        angle_res,
        beyond,
        at_limit,
        first_at_limit,
        bends,
    }
}

/// The first row of `angles` that is motion: 1 when the first frame is a calibration pose,
/// else 0.
fn calibration_frame(angles: &DMatrix<f64>, bvh: &Bvh, options: &ImportOptions) -> usize {
    let n = angles.nrows();
    // cgspeed's CMU conversions start with a T-pose frame: a first frame that jumps far more
    // than any later frame moves is a calibration pose, not motion.
    let mut start_row = 0;
    if options.from_s.is_none() && n >= 10 {
        let jump = |a: usize, b: usize| {
            (0..18)
                .map(|k| (angles[(a, k)] - angles[(b, k)]).abs())
                .fold(0.0, f64::max)
        };
        let first_jump = jump(0, 1);
        let mut next_second: Vec<f64> = (1..(n - 1).min(1 + bvh.frame_rate().ceil() as usize))
            .map(|r| jump(r, r + 1))
            .collect();
        let typical = median(&mut next_second);
        if first_jump > 0.35 && first_jump > 20.0 * typical {
            start_row = 1;
        }
    }
    start_row
}

/// The fit's report over the frames from `start_row` on (`joint_names`: the model's).
fn fit_report(fits: &FrameFits, start_row: usize, dt: f64, joint_names: &[String]) -> FitReport {
    let n = fits.angles.nrows();
    let angles = &fits.angles;
    let (elbow_res, wrist_res, angle_res, beyond) = if start_row == 1 {
        (
            fits.elbow_res[2..].to_vec(),
            fits.wrist_res[2..].to_vec(),
            fits.angle_res[2..].to_vec(),
            fits.beyond[1..].to_vec(),
        )
    } else {
        (
            fits.elbow_res.clone(),
            fits.wrist_res.clone(),
            fits.angle_res.clone(),
            fits.beyond.clone(),
        )
    };
    let worst = |v: &[f64]| v.iter().copied().fold(0.0, f64::max);
    let quarter = std::f64::consts::FRAC_PI_2;
    // Per side, frames where flexion or rotation jumped by more than a quarter turn.
    let shoulder_switches = (start_row + 1..n)
        .map(|r| {
            [[2usize, 4], [11, 13]]
                .iter()
                .filter(|pair| {
                    pair.iter()
                        .any(|&k| (angles[(r, k)] - angles[(r - 1, k)]).abs() > quarter)
                })
                .count()
        })
        .sum();
    FitReport {
        frames: n - start_row,
        elbow_median_m: median(&mut elbow_res.clone()),
        elbow_worst_m: worst(&elbow_res),
        wrist_median_m: median(&mut wrist_res.clone()),
        wrist_worst_m: worst(&wrist_res),
        elbow_angle_median_deg: median(&mut angle_res.clone()),
        elbow_angle_worst_deg: worst(&angle_res),
        frames_beyond: beyond.iter().filter(|b| **b).count(),
        first_beyond_s: beyond.iter().position(|b| *b).map(|r| r as f64 * dt),
        // A calibration frame left out is not counted (its share would pass 100 %).
        at_limit: joint_names
            .iter()
            .zip(fits.at_limit)
            .zip(fits.first_at_limit)
            .map(|((name, c), first)| (name, c - usize::from(start_row == 1 && first)))
            .filter(|(_, c)| *c > 0)
            .map(|(name, c)| (name.clone(), c))
            .collect(),
        shoulder_switches,
    }
}

/// The angles from `start_row` on (frames `dt` apart, `span` seconds) resampled at
/// `options.rate_hz`, and the output frames' times.
fn resample(
    angles: &DMatrix<f64>,
    start_row: usize,
    dt: f64,
    span: f64,
    options: &ImportOptions,
    bad: &impl Fn(String) -> CaptureError,
) -> Result<(DMatrix<f64>, Vec<i64>), CaptureError> {
    let n = angles.nrows();
    let quarter = std::f64::consts::FRAC_PI_2;
    // At the file's own rate (within 0.1 %: CMU's frame time .0083333 for 120 Hz) every frame
    // is taken as it is, at its own time: a stream of the file's frames (`replay --skeleton
    // source`) then carries the same frames and stamps.
    let own_rate = (options.rate_hz * dt - 1.0).abs() < 1e-3;
    // A frame time written with few digits (CMU's .0083333) must not lose the last frame.
    let out_n = match own_rate {
        true => n - start_row,
        false => (span * options.rate_hz + 1e-3).floor() as usize + 1,
    };
    if out_n > MAX_OUTPUT_FRAMES {
        return Err(bad(format!(
            "{:.0} s at {} Hz would be {out_n} frames; at most {MAX_OUTPUT_FRAMES} are written (lower --rate or cut with --from/--to)",
            span, options.rate_hz
        )));
    }
    let mut out = DMatrix::<f64>::zeros(out_n, 18);
    let mut times_ns = Vec::with_capacity(out_n);
    for k in 0..out_n {
        let (t, x) = match own_rate {
            true => (k as f64 * dt, k as f64),
            false => {
                let t = k as f64 / options.rate_hz;
                (t, (t / dt).min((n - 1 - start_row) as f64))
            }
        };
        let i = (x.floor() as usize).min(n - 2 - start_row);
        let a = x - i as f64;
        for side in 0..2 {
            let arm = 9 * side..9 * side + 9;
            // Between two frames where a shoulder switched to its other Euler solution the
            // angles do not lie on a line between the poses: the nearer frame instead.
            let switched = arm.clone().any(|j| {
                (angles[(start_row + i + 1, j)] - angles[(start_row + i, j)]).abs() > quarter
            });
            for j in arm {
                let v0 = angles[(start_row + i, j)];
                let v1 = angles[(start_row + i + 1, j)];
                out[(k, j)] = match (switched, a < 0.5) {
                    (false, _) => v0 + a * (v1 - v0),
                    (true, true) => v0,
                    (true, false) => v1,
                };
            }
        }
        times_ns.push(options.start_time_ns + (t * 1e9).round() as i64);
    }
    Ok((out, times_ns))
}

/// What the import says of `bvh` and its `skeleton` beside the figures
/// ([`CaptureSource::notes`]).
fn bvh_notes(bvh: &Bvh, skeleton: &Skeleton) -> Vec<String> {
    let mut notes = Vec::new();
    if bvh.frame_lines_left_out > 0 {
        notes.push(format!(
            "{} past the {} frames that `Frames:` declares left out (the count rules, as Blender reads a file)",
            sgplvm_robots::names::count(bvh.frame_lines_left_out, "frame line"),
            bvh.values.len() / bvh.channels.max(1)
        ));
    }
    notes.extend(skeleton.clavicle_note.clone());
    notes
}
