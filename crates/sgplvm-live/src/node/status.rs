//! The node's status: a `diagnostic_msgs/msg/DiagnosticArray` with one entry per robot (what
//! its safety rule decided and why) and one for the input.

use ros2_client::dds::Publisher;

use super::drive::Driven;
use super::TeleopSummary;
use crate::gate::{Frame, Reason};
use crate::msgs::{DiagnosticArray, DiagnosticStatus, Header, KeyValue, Time, OK, STALE, WARN};
use crate::LiveError;

/// Publishes the status: one entry per robot and one for the input (with the input's own
/// `input` values).
pub(super) fn publish_status(
    status: &Publisher<DiagnosticArray>,
    driven: &[Driven],
    summary: &TeleopSummary,
    stale: bool,
    input: &[(String, String)],
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
            Some(reason) => (WARN, format!("{}: {}", reason.as_str(), why_untrusted(r))),
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
            message: {
                let mut m = message;
                if !limited.is_empty() {
                    m = format!("{m}; held within its limits: {}", limited.join(", "));
                }
                if let Some((a, b, d)) = r.gate.near() {
                    m = format!("{m}; kept {a} and {b} apart ({:.1} mm)", d * 1e3);
                }
                m
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
                    r.last
                        .map(|d| format!("{:.6}", d.frame.sd))
                        .unwrap_or_default(),
                ),
                kv("threshold", format!("{:.6}", r.gate.threshold())),
                kv(
                    "reconstruction",
                    r.last
                        .map(|d| format!("{:.6}", d.frame.reconstruction))
                        .unwrap_or_default(),
                ),
                kv(
                    "reconstruction_threshold",
                    format!("{:.6}", r.gate.thresholds().reconstruction),
                ),
                kv(
                    "novelty",
                    r.last
                        .map(|d| format!("{:.6}", d.frame.novelty))
                        .unwrap_or_default(),
                ),
                kv(
                    "novelty_threshold",
                    format!("{:.6}", r.gate.thresholds().novelty),
                ),
                kv("gate", r.gate.thresholds().signals.names().into()),
                kv("frames", c.frames.to_string()),
                kv("untrusted", c.untrusted.to_string()),
                kv("position_clamped", c.position_clamped.to_string()),
                kv("velocity_clamped", c.velocity_clamped.to_string()),
                kv("stale", c.stale.to_string()),
                kv("collision_limited", c.collision_limited.to_string()),
                kv(
                    "near",
                    r.gate
                        .near()
                        .map(|(a, b, d)| format!("{a} {b} {d:.4}"))
                        .unwrap_or_default(),
                ),
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
            .chain(input.iter().map(|(k, v)| kv(k, v.clone())))
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

/// Why the last frame of `r` was not trusted: each signal beyond its threshold (or not a
/// number), the standard deviation's with the joints the model is least sure of.
fn why_untrusted(r: &Driven) -> String {
    let frame = r.last.map(|d| d.frame).unwrap_or(Frame::NONE);
    let t = r.gate.thresholds();
    let beyond = t.beyond(frame);
    let mut why = Vec::with_capacity(3);
    if beyond.reconstruction {
        why.push(format!(
            "pose reconstruction error {:.4} above its threshold {:.4} (not a pose the model learned)",
            frame.reconstruction, t.reconstruction
        ));
    }
    if beyond.novelty {
        why.push(format!(
            "pose {:.4} from the nearest training pose, beyond the novelty threshold {:.4} (no one in the training data stood like this)",
            frame.novelty, t.novelty
        ));
    }
    if beyond.sd {
        // The joints the model is least sure of.
        let mut by_sd: Vec<usize> = (0..r.sd.len()).collect();
        by_sd.sort_by(|&a, &b| r.sd[b].total_cmp(&r.sd[a]));
        let worst: Vec<String> = by_sd
            .iter()
            .take(3)
            .map(|&k| format!("{} ({:.3} rad)", r.joints[k], r.sd[k]))
            .collect();
        why.push(format!(
            "prediction sd {:.4} above the trust threshold {:.4}; least certain joints: {}",
            frame.sd,
            t.sd,
            worst.join(", ")
        ));
    }
    why.join("; ")
}
