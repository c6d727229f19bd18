//! A stream's person calibrated as a file's is ([`Calibration`]): what the live inputs (an
//! Xsens MVN suit, a ROS 2 TF tree) and `import --mvn` do before they fit a frame.
//!
//! On the stream's first frame its rest pose is known (MVN's null pose, the tree's identity
//! rotations). Then, in this order:
//!
//! 1. a calibration **offered** (the user's `--calibration` file, or those of the models'
//!    training data) whose rest pose is the stream's ([`Calibration::check_rest`]) is used as
//!    it is: the stream is fitted as that data's files were;
//! 2. if the user named the calibration and it is not the stream's, the stream is refused (a
//!    calibration of someone else would fit every frame wrongly);
//! 3. otherwise the stream calibrates itself: at once where its rest pose tells both upper
//!    arms' twists (or a specification defines them: MVN's null pose); else it **watches** the
//!    motion for [`StreamCalibrationOptions::watch_seconds`] of the stream's own time, reading
//!    the elbows' hinge as `import` reads a file's ([`HingeEstimate`]), and then calibrates —
//!    the node says it is calibrating and how long is left ([`StreamCalibration::progress`]).

use crate::calibration::{choose, Calibration, HandEnd, HingeEstimate, Twist, UntoldTwist};
use crate::fit::HumanArms;
use crate::skeleton::ArmPose;
use crate::stream::PoseFitter;
use crate::CaptureError;

/// Seconds of motion a stream whose rest pose leaves a twist untold is watched for by default.
pub const DEFAULT_WATCH_SECONDS: f64 = 5.0;

/// How a stream's person is calibrated.
#[derive(Debug, Clone, PartialEq)]
pub struct StreamCalibrationOptions {
    /// Calibrations to fit through when the stream's rest pose is one of theirs.
    pub offered: Vec<Calibration>,
    /// Whether `offered` is the user's own choice: a stream whose rest pose is none of theirs
    /// is then refused instead of calibrated on itself.
    pub required: bool,
    /// Seconds of the stream's motion to watch where its rest pose leaves an upper arm's twist
    /// untold (0: none; the twist is then assumed palms down).
    pub watch_seconds: f64,
}

impl Default for StreamCalibrationOptions {
    fn default() -> Self {
        StreamCalibrationOptions {
            offered: Vec::new(),
            required: false,
            watch_seconds: DEFAULT_WATCH_SECONDS,
        }
    }
}

/// Where a stream's calibration stands.
#[derive(Debug, Clone, PartialEq)]
pub enum CalibrationProgress {
    /// No frame yet.
    Waiting,
    /// Watching the motion: seconds of stream time left, and the frames so far in which each
    /// elbow (left, right) bent enough to tell its hinge.
    Watching {
        /// Seconds of the stream's time still to watch.
        seconds_left: f64,
        /// Frames with a bent elbow so far, left and right.
        bent_frames: [usize; 2],
    },
    /// Calibrated: what the fit goes through, as a noun phrase ("the calibration of …", "a
    /// calibration made on …").
    Done(String),
}

/// The calibration of one stream (module docs).
#[derive(Debug)]
pub struct StreamCalibration {
    options: StreamCalibrationOptions,
    /// What an untold twist is without a hinge: [`Twist::NullPose`] for a stream that
    /// specifies its null pose, [`Twist::Assumed`] otherwise.
    untold: Twist,
    source: String,
    /// Whether the stream's rest pose says where the hands end.
    hand_end: HandEnd,
    started_s: Option<f64>,
    seconds_left: f64,
    hinge: HingeEstimate,
    done: Option<String>,
}

impl StreamCalibration {
    /// The calibration of the stream named `source` (for reports); `untold` as above.
    pub fn new(options: StreamCalibrationOptions, untold: Twist, source: &str) -> Self {
        StreamCalibration {
            untold,
            source: source.to_string(),
            hand_end: HandEnd::Measured,
            started_s: None,
            seconds_left: options.watch_seconds,
            hinge: HingeEstimate::new(),
            done: None,
            options,
        }
    }

    /// The same, for a stream whose rest pose does not say where the hands end (MVN's segments
    /// end at the wrist): a calibration offered is matched without them.
    pub fn hand_end_unmeasured(mut self) -> Self {
        self.hand_end = HandEnd::Unmeasured;
        self
    }

    /// Where the calibration stands.
    pub fn progress(&self) -> CalibrationProgress {
        match (&self.done, self.started_s) {
            (Some(d), _) => CalibrationProgress::Done(d.clone()),
            (None, None) => CalibrationProgress::Waiting,
            (None, Some(_)) => CalibrationProgress::Watching {
                seconds_left: self.seconds_left,
                bent_frames: [
                    self.hinge.bent_frames(sgplvm_robots::Side::Left),
                    self.hinge.bent_frames(sgplvm_robots::Side::Right),
                ],
            },
        }
    }

    /// One frame of the stream at `time_s` (its own clock, seconds): the source's rest poses
    /// (left, right), whether each arm has a clavicle segment, the skeleton's naming scheme
    /// and units, and the frame's arm poses. Gives the fitter once calibrated (the frame
    /// itself is then fitted by the caller), `None` while watching; `Err` when the user's
    /// calibration is not the stream's.
    #[allow(clippy::too_many_arguments)]
    pub fn offer(
        &mut self,
        model: &HumanArms,
        time_s: f64,
        rest: [&ArmPose; 2],
        has_clavicle: [bool; 2],
        scheme: &str,
        metres_per_unit: Option<f64>,
        poses: [&ArmPose; 2],
    ) -> Result<Option<PoseFitter>, CaptureError> {
        let first = *self.started_s.get_or_insert(time_s);
        if !self.options.offered.is_empty() {
            match choose(&self.options.offered, rest, has_clavicle, self.hand_end) {
                Ok(c) => {
                    self.done = Some(format!("the calibration of {}", c.describe()));
                    return Ok(Some(PoseFitter::new(model.clone(), c)));
                }
                Err(why) if self.options.required => {
                    return Err(CaptureError::Calibration {
                        file: self.source.clone(),
                        message: format!(
                            "the calibration given is not this stream's person: {}",
                            why.join("; ")
                        ),
                    });
                }
                Err(_) => {}
            }
        }
        let untold = Calibration::untold(model, rest, has_clavicle);
        let watch = untold.iter().any(|u| *u)
            && self.untold == Twist::Assumed
            && self.options.watch_seconds > 0.0;
        let elapsed = time_s - first;
        if watch {
            self.hinge.add(poses);
            // The whole time asked for, unless the stream's time runs backwards (a replay
            // restarting): then calibrate on what was seen.
            if (0.0..self.options.watch_seconds).contains(&elapsed) {
                self.seconds_left = self.options.watch_seconds - elapsed;
                return Ok(None);
            }
        }
        let hinge = watch.then_some(&self.hinge);
        let made_from = if watch {
            format!("{}: {:.1} s of motion", self.source, elapsed.max(0.0))
        } else {
            self.source.clone()
        };
        let calibration = Calibration::from_rest(
            model,
            rest,
            has_clavicle,
            UntoldTwist {
                hinge,
                otherwise: self.untold,
            },
            &made_from,
            scheme,
            metres_per_unit,
        );
        self.done = Some(format!("a calibration made on {}", calibration.describe()));
        Ok(Some(PoseFitter::new(model.clone(), &calibration)))
    }
}
