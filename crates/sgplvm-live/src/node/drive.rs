//! The robots as the node drives them: each [`Drive`] checked against its model and turned
//! into a [`Driven`] (its joint order, safety rule and command publisher), the distinct models
//! they share, and the live view that shows them.

use std::sync::Arc;

use ros2_client::dds::Node;
use sgplvm_capture::girdle::GirdleAlignment;
use sgplvm_core::{AnyModel, Predictor};
use sgplvm_robots::anatomy::CommandColumns;
use sgplvm_robots::limits::CommandLimits;
use sgplvm_robots::retarget::{FrameRetargeter, RetargetOptions};
use sgplvm_robots::safety::{SafetyOptions, SafetyStep};

use super::dds::{command_publisher, CommandPublisher};
use super::{Drive, TeleopOptions};
use crate::commands::CommandForm;
use crate::gate::{Decision, Gate, Thresholds};
use crate::LiveError;

/// One robot as the node drives it.
pub(super) struct Driven {
    pub(super) drive: Drive,
    /// The joints the robot's commands name (the anatomy's command joints).
    pub(super) joints: Vec<String>,
    /// How a command is made from the model's output columns.
    pub(super) columns: CommandColumns,
    /// Positions of the command's joints in the sent order.
    pub(super) order: Vec<usize>,
    /// The names in the sent order.
    pub(super) sent_names: Vec<String>,
    pub(super) gate: Gate,
    pub(super) publisher: CommandPublisher,
    pub(super) topic: String,
    /// The model's output (its columns) and its standard deviations.
    pub(super) model_mean: Vec<f64>,
    pub(super) model_sd: Vec<f64>,
    /// The target command (command joints) and its standard deviations (held joints: 0).
    pub(super) mean: Vec<f64>,
    pub(super) sd: Vec<f64>,
    pub(super) command: Vec<f64>,
    pub(super) sent: Vec<f64>,
    /// Whether a command was sent (`sent` holds it).
    pub(super) has_sent: bool,
    pub(super) last: Option<Decision>,
    /// Which of the distinct models (their latent points per frame) drives this robot; `None`
    /// for a robot driven by retargeting.
    pub(super) model_slot: Option<usize>,
    /// The robot's retargeting, for a robot driven without a model.
    pub(super) retargeter: Option<FrameRetargeter>,
}

/// A distinct model among the robots' and its latent point of the current frame (computed once
/// per frame for all the robots it drives; a per-part model's parts find their own).
pub(super) struct LatentSlot {
    pub(super) model: std::sync::Arc<AnyModel>,
    pub(super) x: Vec<f64>,
    pub(super) ok: bool,
    /// The person's clavicles aligned to this model's people (`TeleopOptions::align_girdle`),
    /// and the current frame as the model takes it.
    pub(super) girdle: Option<GirdleAlignment>,
    pub(super) h: Vec<f64>,
}

impl LatentSlot {
    /// The model's input for human frame `h`: as it is, or its clavicles aligned.
    pub(super) fn take(&mut self, h: &[f64]) {
        self.h.clear();
        self.h.extend_from_slice(h);
        if let Some(g) = self.girdle.as_mut() {
            g.align(&mut self.h);
        }
    }
}

/// The alignment of a person's clavicles to `model`'s people, where it names the human
/// model's arm angles.
fn girdle_of(model: &AnyModel) -> Option<GirdleAlignment> {
    let names = model.column_names(model.input_name())?;
    GirdleAlignment::new(names, &model.input_means())
}

/// The human's joint names of the models (all must agree; a robot driven by retargeting takes
/// the human model's).
pub(super) fn human_joints(drives: &[Drive]) -> Result<Vec<String>, LiveError> {
    let names = |m: &AnyModel| -> Vec<String> {
        let input = m.input_name().to_string();
        m.column_names(&input)
            .map(<[String]>::to_vec)
            .unwrap_or_else(|| {
                (0..m.space_dim(&input).unwrap_or(0))
                    .map(|j| format!("{input}_{j}"))
                    .collect()
            })
    };
    let human_model = || -> Result<Vec<String>, LiveError> {
        sgplvm_robots::Robot::builtin("human")
            .map(|h| h.joint_names())
            .map_err(|e| LiveError::Config(format!("the human model: {e}")))
    };
    let first = drives
        .first()
        .ok_or_else(|| LiveError::Config("no robot to drive".into()))?;
    let joints_of = |d: &Drive| match &d.model {
        Some(m) => Ok(names(m)),
        None => human_model(),
    };
    let h = joints_of(first)?;
    for d in &drives[1..] {
        if joints_of(d)? != h {
            return Err(LiveError::Config(format!(
                "{} and {} take different human joints (a robot driven by retargeting takes the human model's 18)",
                first.robot, d.robot
            )));
        }
    }
    Ok(h)
}

/// Every robot of `drives` as the node drives it, and the distinct models among theirs.
pub(super) fn drive_all(
    node: &mut Node,
    drives: Vec<Drive>,
    options: &TeleopOptions,
    log: &mut dyn FnMut(&str),
) -> Result<(Vec<Driven>, Vec<LatentSlot>), LiveError> {
    let shared = drives.len() > 1;
    let mut driven = Vec::with_capacity(drives.len());
    let mut slots: Vec<LatentSlot> = Vec::new();
    for drive in drives {
        let model_slot = drive
            .model
            .as_ref()
            .map(|m| slot_of(&mut slots, m, options.align_girdle));
        driven.push(drive_one(node, drive, model_slot, options, shared, log)?);
    }
    Ok((driven, slots))
}

/// The index of `model` among `slots`, added if it is not there yet.
fn slot_of(slots: &mut Vec<LatentSlot>, model: &Arc<AnyModel>, align_girdle: bool) -> usize {
    match slots
        .iter()
        .position(|s| std::sync::Arc::ptr_eq(&s.model, model))
    {
        Some(k) => k,
        None => {
            slots.push(LatentSlot {
                model: model.clone(),
                x: vec![0.0; model.latent_dim()],
                ok: false,
                girdle: align_girdle.then(|| girdle_of(model)).flatten(),
                h: Vec::new(),
            });
            slots.len() - 1
        }
    }
}

/// One robot checked against its model (or set up for retargeting), with its safety rule and
/// command publisher.
fn drive_one(
    node: &mut Node,
    drive: Drive,
    model_slot: Option<usize>,
    options: &TeleopOptions,
    shared: bool,
    log: &mut dyn FnMut(&str),
) -> Result<Driven, LiveError> {
    let (model_columns, thresholds, retargeter) = match &drive.model {
        Some(model) => {
            let columns = model_columns(model, &drive.robot)?;
            let thresholds = Thresholds::of(model, &drive.robot, &options.gate)?;
            (columns, thresholds, None)
        }
        None => {
            // The solve keeps the robot's shapes apart as the gate does (`--margin`).
            let mut retarget = RetargetOptions::default();
            match options.gate.collision_margin_m {
                Some(margin) => retarget.whole_arm.margin_m = margin,
                None => retarget.whole_arm.self_collision = false,
            }
            let retargeter = FrameRetargeter::new(&drive.anatomy, &retarget)
                .map_err(|e| LiveError::Config(format!("{}: {e}", drive.robot)))?;
            // Nothing to trust or distrust: every frame is followed (the signals are 0).
            let thresholds = Thresholds {
                signals: options.gate.signals,
                sd: f64::INFINITY,
                reconstruction: f64::INFINITY,
                novelty: f64::INFINITY,
            };
            (
                retargeter.joint_names().to_vec(),
                thresholds,
                Some(retargeter),
            )
        }
    };
    let columns = drive
        .anatomy
        .command_columns(&model_columns)
        .map_err(|e| LiveError::Config(format!("{}: {e}", drive.robot)))?;
    let joints = columns.names().to_vec();
    let (sent_names, order) = sent_order(&drive, &joints, options)?;
    let limits = CommandLimits::for_joints(drive.anatomy.robot(), &joints)
        .map_err(|e| LiveError::Config(e.to_string()))?;
    if let Some(note) = limits.assumed() {
        log(&format!("{}: {note}", drive.robot));
    }
    let topic = match &options.command_topic {
        Some(t) => t.replace("{robot}", &drive.robot),
        None => options.form.default_topic(&drive.robot, shared),
    };
    let publisher = command_publisher(node, &topic, options.form, options.command_qos)?;
    let d = joints.len();
    let m = model_columns.len();
    let mapping = match (&retargeter, drive.model.as_deref()) {
        (Some(_), _) => {
            "whole-arm retargeting of each frame (no model: nothing held for trust)".into()
        }
        // A per-part model's signals are each part's over its own threshold, the worst part's:
        // 1 is every threshold.
        (None, Some(AnyModel::Parts(_))) => format!(
            "{thresholds}: per part, each part's signal over its own threshold (the worst part's), so 1 is at the threshold"
        ),
        (None, _) => thresholds.to_string(),
    };
    log(&format!(
        "{}: {} joints as {} on {topic}; {mapping}",
        drive.robot,
        d,
        options.form.name()
    ));
    let mut gate = Gate::new(limits, thresholds, options.gate.return_speed);
    if let Some(margin) = options.gate.collision_margin_m {
        let safety = SafetyStep::new(
            &drive.anatomy,
            &joints,
            SafetyOptions {
                margin_m: margin,
                ..SafetyOptions::default()
            },
        )
        .map_err(LiveError::Config)?;
        let model = safety.collision();
        log(&format!(
            "{}: self-collision limit on {} pairs of its shapes, {:.0} mm apart{}",
            drive.robot,
            model.pairs().len(),
            margin * 1e3,
            match model.unchecked().len() {
                0 => String::new(),
                n => format!("; {n} part(s) not checked (e.g. {})", model.unchecked()[0]),
            }
        ));
        gate = gate.with_safety(safety);
    }
    Ok(Driven {
        gate,
        drive,
        joints,
        columns,
        order,
        sent_names,
        publisher,
        topic,
        model_mean: vec![0.0; m],
        model_sd: vec![0.0; m],
        mean: vec![0.0; d],
        sd: vec![0.0; d],
        command: vec![0.0; d],
        sent: vec![0.0; d],
        has_sent: false,
        last: None,
        model_slot,
        retargeter,
    })
}

/// The joints `model` predicts for `robot`, by name.
fn model_columns(model: &AnyModel, robot: &str) -> Result<Vec<String>, LiveError> {
    if !model.output_names().contains(&robot) {
        return Err(LiveError::Config(format!(
            "the model does not know robot `{robot}`; it predicts for {:?}",
            model.output_names()
        )));
    }
    model
        .column_names(robot)
        .map(<[String]>::to_vec)
        .ok_or_else(|| {
            LiveError::Config(format!("the model names no joints for `{robot}` (fit it with column names: Python fit(..., column_names=...), or train with the CLI)"))
        })
}

/// The joint names a robot's commands carry, in their order, and where each is among the
/// model's `joints`.
fn sent_order(
    drive: &Drive,
    joints: &[String],
    options: &TeleopOptions,
) -> Result<(Vec<String>, Vec<usize>), LiveError> {
    let sent_names = match (options.form, &options.joint_order) {
        (CommandForm::Forward, Some(order)) => order.clone(),
        (CommandForm::Forward, None) => drive
            .anatomy
            .robot()
            .joint_names()
            .into_iter()
            .filter(|n| joints.contains(n))
            .collect(),
        _ => joints.to_vec(),
    };
    let order: Vec<usize> = sent_names
        .iter()
        .map(|n| {
            joints.iter().position(|j| j == n).ok_or_else(|| {
                LiveError::Config(format!(
                    "--joints names `{n}`, which is not one of `{}`'s command joints: {joints:?}",
                    drive.robot
                ))
            })
        })
        .collect::<Result<_, _>>()?;
    if order.len() != joints.len() {
        return Err(LiveError::Config(format!(
            "`{}`: the controller's order names {} joints, the commands {}",
            drive.robot,
            order.len(),
            joints.len()
        )));
    }
    Ok((sent_names, order))
}

/// The live view of the driven robots, when `options` asks for one.
pub(super) fn start_view(
    options: &TeleopOptions,
    driven: &[Driven],
    human: &[String],
    log: &mut dyn FnMut(&str),
) -> Result<Option<crate::view::LiveView>, LiveError> {
    Ok(match options.view {
        Some(addr) => {
            let robots = driven
                .iter()
                .map(|r| crate::view::ViewRobot {
                    name: r.drive.robot.clone(),
                    body: r.drive.anatomy.robot().clone(),
                    joints: r.joints.clone(),
                    rest: r.drive.anatomy.hold_configuration().to_vec(),
                })
                .collect();
            // The first robot's latent point is shown (a per-part model's parts side by side;
            // none where it is retargeted).
            let q = driven
                .first()
                .and_then(|r| r.drive.model.as_deref())
                .map_or(0, AnyModel::latent_dim);
            let v = crate::view::LiveView::start(addr, human.to_vec(), robots, q)?;
            log(&format!(
                "live view: Foxglove WebSocket on ws://{}:{}",
                addr.ip(),
                v.port()
            ));
            Some(v)
        }
        None => None,
    })
}
