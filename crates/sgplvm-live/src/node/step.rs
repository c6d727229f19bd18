//! One robot's step for a human frame: its model's prediction (or its retargeting of the
//! frame) through the safety gate, the command published in its sent order, and the live view.

use std::time::Instant;

use super::drive::{Driven, LatentSlot};
use super::TeleopOptions;
use crate::commands::Command;
use crate::gate::{Decision, Frame, Reason};
use crate::msgs::Time;
use crate::LiveError;
use sgplvm_core::AnyModel;

/// What a command carries and when it is sent: the stamp of the human frame it answers, the
/// input's period (a trajectory point's time) and the node's clock.
pub(super) struct Sent {
    pub(super) stamp: Time,
    pub(super) period_s: f64,
    pub(super) start: Instant,
}

/// What a robot's target comes from in the current frame: its model (the frame's latent point
/// and the pose's reconstruction error and novelty under it), or retargeting of the human
/// frame.
pub(super) enum By<'a> {
    /// The robot's model: the frame's latent point, the pose's reconstruction error and its
    /// novelty.
    Model(&'a LatentSlot, [f64; 2]),
    /// Retargeting of the human frame.
    Retargeting(&'a [f64]),
}

/// One robot's step for the current frame: its model's prediction (or its retargeting of the
/// frame) through its safety rule, the command published unless the rule is still waiting;
/// whether its state changed (then it is logged).
pub(super) fn command(
    r: &mut Driven,
    by: By<'_>,
    options: &TeleopOptions,
    sent: Sent,
    log: &mut dyn FnMut(&str),
) -> Result<bool, LiveError> {
    // A prediction that fails (not a number) is not trusted: the robot holds.
    let (sd, [e, novelty]) = match (by, r.retargeter.as_mut()) {
        (By::Model(slot, known), _) => {
            let (robot, mean, sd) = (&r.drive.robot, &mut r.model_mean, &mut r.model_sd);
            let sd = match (slot.ok, slot.model.as_ref()) {
                (true, AnyModel::Single(m)) => m.predict_latent_sd(&slot.x, robot, mean, sd),
                (true, AnyModel::Parts(m)) => m.predict_latent_sd(&slot.x, robot, mean, sd),
                (false, _) => Ok(f64::NAN),
            }
            .unwrap_or(f64::NAN);
            (sd, known)
        }
        (By::Retargeting(h), Some(retargeter)) => {
            r.model_sd.fill(0.0);
            match retargeter.retarget(h, &mut r.model_mean) {
                Ok(()) => (0.0, [0.0; 2]),
                Err(_) => (f64::NAN, [f64::NAN; 2]),
            }
        }
        (By::Retargeting(_), None) => (f64::NAN, [f64::NAN; 2]),
    };
    r.columns.fill(&r.model_mean, &mut r.mean);
    r.columns.fill_std(&r.model_sd, &mut r.sd);
    let frame = Frame {
        sd,
        reconstruction: e,
        novelty,
    };
    // The gate's clock is the send clock: the command goes out right after this step, and the
    // velocity limits hold over the time between two sends, whatever the frames' stamps say.
    let now_s = sent.start.elapsed().as_secs_f64();
    let decision = r.gate.step(now_s, &r.mean, frame, &mut r.command);
    if decision.reason != Reason::Waiting {
        publish(r, options, sent.stamp, sent.period_s, sent.start)?;
    }
    if decision.changed {
        let t = r.gate.thresholds();
        log(&format!(
            "{}: {} (reconstruction error {e:.4}, threshold {:.4}; novelty {novelty:.4}, threshold {:.4}; sd {sd:.4}, threshold {:.4})",
            r.drive.robot,
            decision.reason.as_str(),
            t.reconstruction,
            t.novelty,
            t.sd,
        ));
    }
    r.last = Some(decision);
    Ok(decision.changed)
}

/// Publishes the robot's command (`r.command`, the gate's) in its sent order, then tells the
/// gate when the send ended (the next command's velocity limits count from then). A trajectory
/// point is reached no sooner than the velocity limits allow from the command sent before.
pub(super) fn publish(
    r: &mut Driven,
    options: &TeleopOptions,
    stamp: Time,
    period_s: f64,
    start: Instant,
) -> Result<(), LiveError> {
    let velocity = r.gate.limits().velocity();
    let mut reach_s: f64 = 0.0;
    for (k, &j) in r.order.iter().enumerate() {
        let q = r.command[j];
        if r.has_sent && velocity[j] > 0.0 {
            reach_s = reach_s.max((q - r.sent[k]).abs() / velocity[j]);
        }
        r.sent[k] = q;
    }
    let c = Command::build(
        options.form,
        &r.sent_names,
        &r.sent,
        stamp,
        period_s.max(reach_s),
    );
    r.publisher.publish(c, &r.topic)?;
    r.gate.sent(start.elapsed().as_secs_f64());
    r.has_sent = true;
    Ok(())
}

/// Sends one frame to the live view (after the commands: it is not on their path); a failure
/// is logged, the node goes on.
pub(super) fn show(
    view: &mut crate::view::LiveView,
    driven: &[Driven],
    h: &[f64],
    latent: Option<&[f64]>,
    time_ns: i64,
    log: &mut dyn FnMut(&str),
) {
    let state = |d: Option<Decision>| match d.map(|d| d.reason) {
        Some(Reason::Following) | None => 0.0,
        Some(Reason::Holding) => 1.0,
        Some(Reason::Returning) => 2.0,
        Some(Reason::Stale) => 3.0,
        Some(Reason::Waiting) => 4.0,
    };
    let robots: Vec<(&[f64], &[f64], [f64; 5])> = driven
        .iter()
        .map(|r| {
            let t = r.gate.thresholds();
            (
                r.command.as_slice(),
                r.sd.as_slice(),
                [
                    r.last.map_or(f64::NAN, |d| d.frame.reconstruction),
                    t.reconstruction,
                    r.last.map_or(f64::NAN, |d| d.frame.sd),
                    t.sd,
                    state(r.last),
                ],
            )
        })
        .collect();
    if let Err(e) = view.frame(time_ns, h, &robots, latent) {
        log(&format!("warning: {e}"));
    }
}
