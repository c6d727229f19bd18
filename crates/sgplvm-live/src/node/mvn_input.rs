//! The node's Xsens MVN input (`teleop --input mvn`): the suit's UDP stream, each newest frame
//! fitted by the importer's per-frame fit into the human model's angles, in the models' human
//! joint order.

use serde::Serialize;
use sgplvm_capture::StreamCalibrationOptions;

use super::tf_input::calibration_said;
use crate::mvn::{MvnFit, MvnReceiver, PoseType, ReceiverOptions, Senders};
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
    /// Frames and datagrams dropped, by why: `superseded` (a newer frame in the same read),
    /// `late` (a sample counter no newer than one used: repeated or reordered), `incomplete`
    /// (a split frame whose parts did not all come), `other character`, `other kind`, `other
    /// sender`.
    pub dropped: std::collections::BTreeMap<String, u64>,
    /// Times the sample counter went far back and was followed (MVN started again).
    pub restarts: u64,
    /// Whose datagrams are taken (`--mvn-from`, or the first sender, locked).
    pub accepts: String,
    /// The sender taken, once seen.
    pub sender: Option<String>,
    /// The first few senders refused.
    pub refused: Vec<String>,
    /// What the positions were read in, and from what (the person's proportions).
    pub units: String,
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
    /// What was last said of the sender, refusals and units (a change is logged and
    /// published).
    said: (Option<std::net::IpAddr>, usize, String),
    /// When a pose datagram last arrived (during the calibration too, when no frame is fitted).
    pub(super) heard: Option<std::time::Instant>,
}

impl MvnInput {
    /// Listens on `addr` for the models whose human joints are `human`, taking datagrams from
    /// `from` only.
    pub(super) fn bind(
        addr: std::net::SocketAddr,
        from: Senders,
        human: &[String],
        calibration: StreamCalibrationOptions,
    ) -> Result<MvnInput, LiveError> {
        let order = human_order(human, "--input mvn")?;
        let options = ReceiverOptions {
            from,
            ..ReceiverOptions::default()
        };
        let receiver = MvnReceiver::bind(addr, options)
            .map_err(|e| LiveError::Config(format!("--input mvn: {e}")))?;
        Ok(MvnInput {
            receiver,
            fit: MvnFit::new(calibration),
            order,
            elbow: Vec::new(),
            wrist: Vec::new(),
            calibration: None,
            calibrating_frames: 0,
            said: (None, 0, String::new()),
            heard: None,
        })
    }

    /// The calibration under way (`calibrating the person: …`), if the stream is being
    /// calibrated.
    pub(super) fn calibrating(&self) -> Option<&str> {
        self.calibration
            .as_deref()
            .filter(|c| c.starts_with("calibrating"))
    }

    /// Whose datagrams are taken, in words.
    fn accepts(&self) -> String {
        match self.receiver.options().from {
            Senders::First => "the first sender's host, locked".into(),
            named => format!("{named} (--mvn-from)"),
        }
    }

    /// What the positions are read in, in words.
    fn units(&self) -> String {
        let kinds = [PoseType::Quaternion, PoseType::Euler];
        let told: Vec<String> = kinds
            .iter()
            .filter_map(|&k| {
                self.receiver.units(k).map(|(u, span)| {
                    let read = match u {
                        crate::mvn::Units::AsDecoded => "read as metres",
                        crate::mvn::Units::Centimetres => "centimetres, scaled to metres",
                        crate::mvn::Units::Metres => "metres, scaled from centimetres",
                    };
                    format!("type {}: {read} (the person's span {span:.2} m)", k.code())
                })
            })
            .collect();
        match (told.is_empty(), self.receiver.counts().frames) {
            (true, 0) => "not told yet: type 02 taken as metres, 01 as centimetres".into(),
            // A stream of the upper body alone (a replay of arm angles, a suit's partial
            // configuration), or of a span no person has, never says.
            (true, _) => "not told by the stream: no frame has given a person's span (pelvis to neck, arms and legs, each a person's size in metres or centimetres): type 02 taken as metres, 01 as centimetres".into(),
            (false, _) => told.join("; "),
        }
    }

    /// The input's values for the status's `sgplvm/input` entry.
    pub(super) fn status_values(&self) -> Vec<(String, String)> {
        let c = self.receiver.counts();
        vec![
            ("mvn_accepts".into(), self.accepts()),
            (
                "mvn_sender".into(),
                self.receiver
                    .sender()
                    .map_or_else(|| "none yet".into(), |a| a.to_string()),
            ),
            ("mvn_refused".into(), c.other_sender.to_string()),
            (
                "mvn_refused_from".into(),
                addresses(self.receiver.refused()),
            ),
            ("mvn_late".into(), c.late.to_string()),
            ("mvn_incomplete".into(), c.incomplete.to_string()),
            ("mvn_units".into(), self.units()),
            (
                "calibration".into(),
                self.calibration
                    .clone()
                    .unwrap_or_else(|| "waiting for the first frame".into()),
            ),
        ]
    }

    /// Logs what changed since it last said: the sender taken, senders refused, the units;
    /// whether anything did (the status is then due).
    pub(super) fn report(&mut self, log: &mut dyn FnMut(&str)) -> bool {
        let sender = self.receiver.sender();
        let refused = self.receiver.refused().len();
        let units = self.units();
        let mut changed = false;
        if sender.map(|a| a.ip()) != self.said.0 {
            if let Some(a) = sender {
                log(&format!(
                    "input: MVN pose datagrams taken from {a} ({})",
                    self.accepts()
                ));
            }
            changed = true;
        }
        if refused != self.said.1 {
            log(&format!(
                "warning: --input mvn: datagrams from {} refused: only {} drives (counted)",
                addresses(&self.receiver.refused()[self.said.1..]),
                self.accepts()
            ));
            changed = true;
        }
        if units != self.said.2 {
            log(&format!("input: MVN positions: {units}"));
            changed = true;
        }
        self.said = (sender.map(|a| a.ip()), refused, units);
        changed
    }

    /// The newest frame since the last call, fitted, written into `h` (the models' order);
    /// whether there was one. A frame the fit cannot use is counted and skipped.
    pub(super) fn newest(&mut self, h: &mut [f64], log: &mut dyn FnMut(&str)) -> bool {
        let pose = match self.receiver.newest() {
            Ok(Some(pose)) => {
                self.heard = Some(std::time::Instant::now());
                pose
            }
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
        let dropped = [
            ("superseded", counts.superseded),
            ("late", counts.late),
            ("incomplete", counts.incomplete),
            ("other character", counts.other_character),
            ("other kind", counts.other_kind),
            ("other sender", counts.other_sender),
        ];
        MvnSummary {
            datagrams: counts.datagrams,
            frames: counts.frames,
            bad: counts
                .bad
                .iter()
                .map(|(k, v)| (k.to_string(), *v))
                .collect(),
            dropped: dropped
                .into_iter()
                .filter(|(_, v)| *v > 0)
                .map(|(k, v)| (k.to_string(), v))
                .collect(),
            restarts: counts.restarts,
            accepts: self.accepts(),
            sender: self.receiver.sender().map(|a| a.to_string()),
            refused: self
                .receiver
                .refused()
                .iter()
                .map(ToString::to_string)
                .collect(),
            units: self.units(),
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

/// Addresses, comma-separated (`none` for none).
fn addresses(a: &[std::net::SocketAddr]) -> String {
    match a.is_empty() {
        true => "none".into(),
        false => a
            .iter()
            .map(ToString::to_string)
            .collect::<Vec<_>>()
            .join(", "),
    }
}
