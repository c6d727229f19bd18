//! The node's TF input (`teleop --input tf`): `/tf` and `/tf_static` into a [`TfBuffer`], the
//! arms found by the importer's naming schemes (or map), and each newest complete frame set
//! fitted by the importer's per-frame fit into the human model's angles, in the models' human
//! joint order.

use std::collections::BTreeSet;

use ros2_client::dds::{Node, Subscription};
use ros2_client::qos::{Durability, History, WhenFull};
use ros2_client::QosProfile;
use serde::Serialize;
use sgplvm_capture::{ArmMap, CalibrationProgress, StreamCalibrationOptions};

use super::dds::{dds, type_of};
use super::topic_name;
use crate::msgs::{types, TFMessage, Time};
use crate::tf::{
    identify, Fitted, FrameSets, SetCounts, SetNotFitted, TfBuffer, STAMP_TOLERANCE_NS,
    TF_STATIC_TOPIC, TF_TOPIC,
};
use crate::LiveError;

/// What the TF input did, for the summary.
#[derive(Debug, Clone, Default, Serialize)]
pub struct TfSummary {
    /// TFMessages read (`/tf` and `/tf_static`).
    pub messages: u64,
    /// Transforms taken.
    pub transforms: u64,
    /// Transforms refused (not finite, not a unit quaternion, unnamed frames).
    pub bad_transforms: u64,
    /// Frame sets fitted and used, superseded, incomplete, and the frames the incomplete ones
    /// lacked.
    #[serde(flatten)]
    pub sets: SetCounts,
    /// The naming scheme that found the arms (or `map file`), once found.
    pub skeleton: Option<String>,
    /// The frame the arms hang from.
    pub torso: Option<String>,
    /// What the fit goes through (the person's calibration), or how the calibration stands.
    pub calibration: Option<String>,
    /// Frame sets seen while the person was being calibrated (not commanded).
    pub calibrating_sets: u64,
    /// The person's calibration the sets were fitted through, once there is one.
    pub person: Option<sgplvm_capture::Calibration>,
    /// Why the arms were not found in the frames received (while they are not).
    pub error: Option<String>,
    /// The fit's elbow distance to the scaled capture, median over the frames used, metres
    /// (as `sgplvm import` reports it).
    pub elbow_median_m: f64,
    /// The same for the wrist.
    pub wrist_median_m: f64,
    /// The largest of either, metres.
    pub worst_m: f64,
}

/// How a stream's calibration stands, as the node says it.
pub(super) fn calibration_said(progress: CalibrationProgress) -> String {
    match progress {
        CalibrationProgress::Waiting => "waiting for the first frame to calibrate the person".into(),
        CalibrationProgress::Watching {
            seconds_left,
            bent_frames,
        } => format!(
            "calibrating the person: {seconds_left:.1} s of motion left, bend both elbows (bent so far in {} left and {} right frames); no commands until then",
            bent_frames[0], bent_frames[1]
        ),
        CalibrationProgress::Done(what) => what,
    }
}

/// The TF input of a node.
pub(super) struct TfInput {
    pub(super) dynamic: Subscription<TFMessage>,
    pub(super) statics: Subscription<TFMessage>,
    buffer: TfBuffer,
    map: Option<ArmMap>,
    calibration: StreamCalibrationOptions,
    fitted: Option<Fitted>,
    /// For each of the models' human joints, its index among the human model's 18.
    order: Vec<usize>,
    /// The tree's shape at the last attempt to find the arms.
    tried: Option<u64>,
    sets: FrameSets,
    summary: TfSummary,
    elbow: Vec<f64>,
    wrist: Vec<f64>,
    warned: BTreeSet<String>,
    /// When transforms last arrived (during the calibration too, when no frame is fitted).
    pub(super) heard: Option<std::time::Instant>,
    /// Why the arms were not found in the tree as it last was, and since when (not said until
    /// the tree has kept that shape for [`UNFOUND_PATIENCE`]).
    unfound: Option<(String, std::time::Instant)>,
}

/// How long a tree without arms must keep its shape before the node says so.
const UNFOUND_PATIENCE: std::time::Duration = std::time::Duration::from_secs(1);

/// `/tf`: as tf2's listener, many transforms kept (a publisher may send them one by one);
/// best effort, so that reliable and best-effort publishers both match.
fn dynamic_qos() -> QosProfile {
    QosProfile::subscription_default()
        .reliability_best_effort()
        .durability(Durability::Volatile)
        .history(History::KeepLast { depth: 1000 })
}

/// `/tf_static`: reliable and transient local (latched), as tf2's static broadcaster publishes.
fn static_qos() -> QosProfile {
    QosProfile::subscription_default()
        .reliability_reliable(WhenFull::DEFAULT)
        .durability(Durability::TransientLocal)
        .history(History::KeepLast { depth: 1000 })
}

impl TfInput {
    /// The calibration under way (`calibrating the person: …`), if the stream is being
    /// calibrated.
    pub(super) fn calibrating(&self) -> Option<&str> {
        self.summary
            .calibration
            .as_deref()
            .filter(|c| c.starts_with("calibrating"))
    }

    /// How the stream's person is calibrated, for the status.
    pub(super) fn calibration_status(&self) -> String {
        self.summary
            .calibration
            .clone()
            .unwrap_or_else(|| "waiting for the first frame set".into())
    }

    /// Subscribes to `/tf` and `/tf_static` for the models whose human joints are `human`.
    pub(super) fn subscribe(
        node: &mut Node,
        human: &[String],
        map: Option<ArmMap>,
        calibration: StreamCalibrationOptions,
    ) -> Result<TfInput, LiveError> {
        let order = super::mvn_input::human_order(human, "--input tf")?;
        let mut sub = |topic: &str, q: QosProfile| -> Result<Subscription<TFMessage>, LiveError> {
            let t = node
                .create_topic(&topic_name(topic)?, type_of(types::TF_MESSAGE), &q)
                .map_err(|e| dds(format!("{e:?}")))?;
            node.create_subscription(&t, Some(q))
                .map_err(|e| dds(format!("{e:?}")))
        };
        Ok(TfInput {
            dynamic: sub(TF_TOPIC, dynamic_qos())?,
            statics: sub(TF_STATIC_TOPIC, static_qos())?,
            buffer: TfBuffer::new(),
            map,
            calibration,
            fitted: None,
            order,
            tried: None,
            sets: FrameSets::new(),
            summary: TfSummary::default(),
            elbow: Vec::new(),
            wrist: Vec::new(),
            warned: BTreeSet::new(),
            heard: None,
            unfound: None,
        })
    }

    /// Every waiting message into the buffer; whether there was one.
    fn take(&mut self, log: &mut dyn FnMut(&str)) -> bool {
        let mut any = false;
        for is_static in [true, false] {
            loop {
                let sub = if is_static {
                    &self.statics
                } else {
                    &self.dynamic
                };
                match sub.take() {
                    Ok(Some((msg, _))) => {
                        any = true;
                        self.summary.messages += 1;
                        let (taken, errors) = self.buffer.insert(&msg, is_static);
                        self.summary.transforms += taken as u64;
                        self.summary.bad_transforms += errors.len() as u64;
                        for e in errors {
                            self.warn(
                                "bad transform",
                                &format!("--input tf: {e}: not used (counted; said once)"),
                                log,
                            );
                        }
                    }
                    Ok(None) => break,
                    Err(e) => {
                        self.warn(
                            "malformed",
                            &format!("--input tf: a TFMessage could not be decoded ({e:?})"),
                            log,
                        );
                        break;
                    }
                }
            }
        }
        any
    }

    fn warn(&mut self, key: &str, line: &str, log: &mut dyn FnMut(&str)) {
        if self.warned.insert(key.to_string()) {
            log(line);
        }
    }

    /// The newest complete frame set since the last call, fitted, written into `h` (the
    /// models' order); its stamp, if there was one.
    pub(super) fn newest(&mut self, h: &mut [f64], log: &mut dyn FnMut(&str)) -> Option<Time> {
        if !self.take(log) {
            self.say_unfound(log);
            return None;
        }
        self.heard = Some(std::time::Instant::now());
        // The arms are found again whenever the tree changes shape (latched frames arriving
        // after the first dynamic ones, a tracker adding a person's frames).
        if self.tried != Some(self.buffer.generation()) {
            self.find_arms(log);
        }
        self.say_unfound(log);
        let fitted = self.fitted.as_mut()?;
        let next = self.sets.next(&self.buffer, fitted.needed());
        for (stamp, missing) in next.incomplete {
            let line = format!(
                "--input tf: the frame set stamped {:.3} s is incomplete, no transform of {} within {} ms of it: skipped (counted; said once per frame)",
                stamp as f64 * 1e-9,
                missing.iter().map(|m| format!("`{m}`")).collect::<Vec<_>>().join(", "),
                STAMP_TOLERANCE_NS as f64 * 1e-6,
            );
            if self.warned.insert(format!("missing {missing:?}")) {
                log(&line);
            }
        }
        let stamp = next.stamp?;
        // Complete by `next`'s own check, so the fit has every transform it needs.
        let (angles, fits) = match fitted.fit(&self.buffer, stamp, STAMP_TOLERANCE_NS) {
            Ok(Some(fit)) => {
                if self
                    .summary
                    .calibration
                    .as_deref()
                    .is_none_or(|c| c.starts_with("calibrating"))
                {
                    let said = calibration_said(fitted.calibration().progress());
                    log(&format!("--input tf: the person is fitted through {said}"));
                    self.summary.calibration = Some(said);
                }
                fit
            }
            Ok(None) => {
                self.summary.calibrating_sets += 1;
                let said = calibration_said(fitted.calibration().progress());
                if self.summary.calibration.is_none() {
                    log(&format!("--input tf: {said}"));
                }
                self.summary.calibration = Some(said);
                return None;
            }
            Err(SetNotFitted::Calibration(e)) => {
                self.warn(
                    "calibration",
                    &format!("--input tf: {e}: frames not used"),
                    log,
                );
                self.summary.error = Some(e);
                return None;
            }
            Err(SetNotFitted::Missing(_)) => return None,
        };
        for (hv, &k) in h.iter_mut().zip(&self.order) {
            *hv = angles[k];
        }
        for f in &fits {
            self.elbow.push(f.elbow_m);
            self.wrist.push(f.wrist_m);
        }
        Some(Time::from_ns(stamp))
    }

    /// Finds the arms in the frames received and calibrates the fit on the tree's rest pose;
    /// where they are not found, an earlier fit stays.
    fn find_arms(&mut self, log: &mut dyn FnMut(&str)) {
        self.tried = Some(self.buffer.generation());
        match identify(&self.buffer, self.map.as_ref(), self.calibration.clone()) {
            // The tree grew (latched frames after the first dynamic ones) and the arms are the
            // same: the fit and its calibration under way go on.
            Ok(f)
                if self.fitted.as_ref().is_some_and(|old| {
                    old.scheme() == f.scheme()
                        && old.torso() == f.torso()
                        && old.needed() == f.needed()
                }) => {}
            Ok(f) => {
                self.unfound = None;
                log(&format!(
                    "--input tf: arms found by {} hanging from `{}`; the fit needs {}",
                    f.scheme(),
                    f.torso(),
                    f.needed().join(", ")
                ));
                self.summary.skeleton = Some(f.scheme().to_string());
                self.summary.torso = Some(f.torso().to_string());
                self.summary.error = None;
                self.summary.calibration = None;
                self.fitted = Some(f);
            }
            Err(e) => {
                let message = format!("--input tf: {e}");
                if self.fitted.is_none() {
                    self.summary.error = Some(message.clone());
                }
                // Said once the tree has kept its shape a while: the first dynamic frames often
                // arrive before the latched ones that hold the arms.
                self.unfound = Some((message, std::time::Instant::now()));
            }
        }
    }

    /// Says why no arms were found, once, when the tree has not changed for
    /// [`UNFOUND_PATIENCE`].
    fn say_unfound(&mut self, log: &mut dyn FnMut(&str)) {
        if let Some((message, since)) = &self.unfound {
            if since.elapsed() >= UNFOUND_PATIENCE {
                log(message);
                self.unfound = None;
            }
        }
    }

    /// What the input did (the sets still pending counted as given up).
    pub(super) fn summary(&self) -> TfSummary {
        let mut s = self.summary.clone();
        if let Some(f) = &self.fitted {
            s.sets = self.sets.counts(&self.buffer, f.needed());
            s.person = f.fitter().map(|p| p.calibration().clone());
        }
        let median = |v: &[f64]| -> f64 {
            let mut v = v.to_vec();
            sgplvm_robots::series::median(&mut v)
        };
        s.elbow_median_m = median(&self.elbow);
        s.wrist_median_m = median(&self.wrist);
        s.worst_m = self
            .elbow
            .iter()
            .chain(&self.wrist)
            .copied()
            .fold(0.0, f64::max);
        s
    }
}
