//! The node's Xsens MVN input (`teleop --input mvn`): the suit's UDP stream, each newest frame
//! fitted by the importer's per-frame fit into the human model's angles, in the models' human
//! joint order.

use serde::Serialize;
use sgplvm_capture::StreamCalibrationOptions;

use super::tf_input::calibration_said;
use crate::mvn::{MvnFit, MvnReceiver, ReceiverOptions};
use crate::LiveError;

/// What the MVN input did, for the summary.
#[derive(Debug, Clone, Default, Serialize)]
pub struct MvnSummary {
    /// Datagrams read.
    pub datagrams: u64,
    /// Frames fitted and used.
    pub frames: u64,
    /// Datagrams that could not be used, by kind.
    pub bad: std::collections::BTreeMap<String, u64>,
    /// The fit's elbow and wrist distance to the scaled capture, median over the frames used,
    /// metres (as `sgplvm import` reports it).
    pub elbow_median_m: f64,
    /// The same for the wrist.
    pub wrist_median_m: f64,
    /// The largest of either, metres.
    pub worst_m: f64,
    /// What the fit goes through (the person's calibration), or how the calibration stands.
    pub calibration: Option<String>,
    /// Frames seen while the person was being calibrated (not commanded).
    pub calibrating_frames: u64,
    /// The person's calibration the frames were fitted through, once there is one.
    pub person: Option<sgplvm_capture::Calibration>,
}

/// For each of the models' human joints `human`, its index among the human model's 18 (the
/// fit's output); `what` names the input in the error.
pub(super) fn human_order(human: &[String], what: &str) -> Result<Vec<usize>, LiveError> {
    let model = sgplvm_robots::Robot::builtin("human")
        .map_err(|e| LiveError::Config(e.to_string()))?
        .joint_names();
    human
        .iter()
        .map(|n| {
            model.iter().position(|m| m == n).ok_or_else(|| {
                LiveError::Config(format!(
                    "{what}: the models take human joint `{n}`, which the human model the input is fitted to does not have (it has {})",
                    sgplvm_robots::names::few(&model, 4)
                ))
            })
        })
        .collect()
}

/// The MVN input of a node.
pub(super) struct MvnInput {
    pub(super) receiver: MvnReceiver,
    fit: MvnFit,
    /// For each of the models' human joints, its index among the human model's 18.
    order: Vec<usize>,
    elbow: Vec<f64>,
    wrist: Vec<f64>,
    calibration: Option<String>,
    calibrating_frames: u64,
}

impl MvnInput {
    /// Listens on `addr` for the models whose human joints are `human`.
    pub(super) fn bind(
        addr: std::net::SocketAddr,
        human: &[String],
        calibration: StreamCalibrationOptions,
    ) -> Result<MvnInput, LiveError> {
        let order = human_order(human, "--input mvn")?;
        let receiver = MvnReceiver::bind(addr, ReceiverOptions::default())
            .map_err(|e| LiveError::Config(format!("--input mvn: {e}")))?;
        Ok(MvnInput {
            receiver,
            fit: MvnFit::new(calibration),
            order,
            elbow: Vec::new(),
            wrist: Vec::new(),
            calibration: None,
            calibrating_frames: 0,
        })
    }

    /// The newest frame since the last call, fitted, written into `h` (the models' order);
    /// whether there was one. A frame the fit cannot use is counted and skipped.
    pub(super) fn newest(&mut self, h: &mut [f64], log: &mut dyn FnMut(&str)) -> bool {
        let pose = match self.receiver.newest() {
            Ok(Some(pose)) => pose,
            Ok(None) => return false,
            Err(e) => {
                log(&format!("--input mvn: {e}"));
                return false;
            }
        };
        match self.fit.angles(&pose) {
            Ok(None) => {
                self.calibrating_frames += 1;
                let said = calibration_said(self.fit.progress());
                if self.calibration.is_none() {
                    log(&format!("--input mvn: {said}"));
                }
                self.calibration = Some(said);
                false
            }
            Ok(Some((angles, fits))) => {
                if self
                    .calibration
                    .as_deref()
                    .is_none_or(|c| c.starts_with("calibrating"))
                {
                    let said = calibration_said(self.fit.progress());
                    log(&format!("--input mvn: the person is fitted through {said}"));
                    self.calibration = Some(said);
                }
                for (hv, &k) in h.iter_mut().zip(&self.order) {
                    *hv = angles[k];
                }
                for f in &fits {
                    self.elbow.push(f.elbow_m);
                    self.wrist.push(f.wrist_m);
                }
                true
            }
            Err(e) => {
                log(&format!(
                    "--input mvn: frame {} not used: {e}",
                    pose.sample_counter
                ));
                false
            }
        }
    }

    /// What the input did.
    pub(super) fn summary(&self) -> MvnSummary {
        let counts = self.receiver.counts();
        let median = |v: &[f64]| -> f64 {
            let mut s = v.to_vec();
            sgplvm_robots::series::median(&mut s)
        };
        MvnSummary {
            datagrams: counts.datagrams,
            frames: counts.frames,
            bad: counts
                .bad
                .iter()
                .map(|(k, v)| (k.to_string(), *v))
                .collect(),
            elbow_median_m: median(&self.elbow),
            wrist_median_m: median(&self.wrist),
            worst_m: self
                .elbow
                .iter()
                .chain(&self.wrist)
                .copied()
                .fold(0.0, f64::max),
            calibration: self.calibration.clone(),
            calibrating_frames: self.calibrating_frames,
            person: self.fit.fitter().map(|f| f.calibration().clone()),
        }
    }
}
