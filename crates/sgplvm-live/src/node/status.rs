//! The node's status: a `diagnostic_msgs/msg/DiagnosticArray` with one entry per robot (what
//! its safety rule decided and why) and one for the input.

use ros2_client::dds::Publisher;

use super::drive::Driven;
use super::TeleopSummary;
use crate::gate::Reason;
use crate::msgs::{DiagnosticArray, DiagnosticStatus, Header, KeyValue, Time, OK, STALE, WARN};
use crate::LiveError;

/// Publishes the status: one entry per robot and one for the input.
pub(super) fn publish_status(
    status: &Publisher<DiagnosticArray>,
    driven: &[Driven],
    summary: &TeleopSummary,
    stale: bool,
    log: &mut dyn FnMut(&str),
) -> Result<(), LiveError> {
    let kv = |k: &str, v: String| KeyValue {
        key: k.into(),
        value: v,
    };
    let mut entries = Vec::with_capacity(driven.len() + 1);
    for r in driven {
        let c = r.gate.counts();
        let (level, message) = match r.last.map(|d| d.reason) {
            None => (OK, "waiting for the first human frame".to_string()),
            Some(Reason::Following) => (OK, "following".to_string()),
            Some(Reason::Stale) => (STALE, "stale input: holding the last command".to_string()),
            Some(reason) => {
                let sd = r.last.map(|d| d.sd).unwrap_or(f64::NAN);
                // The joints the model is least sure of.
                let mut by_sd: Vec<usize> = (0..r.sd.len()).collect();
                by_sd.sort_by(|&a, &b| r.sd[b].total_cmp(&r.sd[a]));
                let worst: Vec<String> = by_sd
                    .iter()
                    .take(3)
                    .map(|&k| format!("{} ({:.3} rad)", r.joints[k], r.sd[k]))
                    .collect();
                (
                    WARN,
                    format!(
                        "{}: prediction sd {sd:.4} above the trust threshold {:.4}; least certain joints: {}",
                        reason.as_str(),
                        r.gate.threshold(),
                        worst.join(", ")
                    ),
                )
            }
        };
        let limited: Vec<String> = match r.last {
            Some(d) if !d.clamped.is_none() => r
                .gate
                .clamped_joints()
                .iter()
                .map(|&k| r.joints[k].clone())
                .collect(),
            _ => Vec::new(),
        };
        entries.push(DiagnosticStatus {
            level,
            name: format!("sgplvm/{}", r.drive.robot),
            message: if limited.is_empty() {
                message
            } else {
                format!("{message}; held within its limits: {}", limited.join(", "))
            },
            hardware_id: r.drive.robot.clone(),
            values: vec![
                kv(
                    "reason",
                    r.last
                        .map(|d| d.reason.as_str())
                        .unwrap_or("waiting")
                        .to_string(),
                ),
                kv(
                    "sd",
                    r.last.map(|d| format!("{:.6}", d.sd)).unwrap_or_default(),
                ),
                kv("threshold", format!("{:.6}", r.gate.threshold())),
                kv("frames", c.frames.to_string()),
                kv("untrusted", c.untrusted.to_string()),
                kv("position_clamped", c.position_clamped.to_string()),
                kv("velocity_clamped", c.velocity_clamped.to_string()),
                kv("stale", c.stale.to_string()),
            ],
        });
    }
    let dropped: usize = summary.dropped.values().sum();
    entries.push(DiagnosticStatus {
        level: if stale {
            STALE
        } else if dropped > 0 {
            WARN
        } else {
            OK
        },
        name: "sgplvm/input".into(),
        message: if stale {
            "stale: no human frame within the timeout".into()
        } else if dropped > 0 {
            format!("{dropped} input message(s) dropped")
        } else {
            "receiving".into()
        },
        hardware_id: "human".into(),
        values: std::iter::once(kv("frames", summary.frames.to_string()))
            .chain(
                summary
                    .dropped
                    .iter()
                    .map(|(k, v)| kv(&format!("dropped: {k}"), v.to_string())),
            )
            .collect(),
    });
    let msg = DiagnosticArray {
        header: Header {
            stamp: Time::from_ns(
                std::time::SystemTime::now()
                    .duration_since(std::time::UNIX_EPOCH)
                    .map(|d| d.as_nanos() as i64)
                    .unwrap_or(0),
            ),
            frame_id: String::new(),
        },
        status: entries,
    };
    if let Err(e) = status.publish(msg) {
        log(&format!(
            "warning: the status could not be published: {e:?}"
        ));
    }
    Ok(())
}
