//! A latent space per arm against the single shared latent space, on recombined motions (issue
//! 49): does a model whose arms have latent spaces of their own serve a new pairing of arm
//! motions that a single latent space, which learnt the pairings of its training frames, does
//! not?
//!
//! **Recombined frames.** A recombined frame is one frame's left arm with another frame's right
//! arm, human and robot columns alike (the robot's left-arm joints with the human's left arm
//! they were retargeted from; whole-arm retargeting solves each arm from its own human arm, so
//! the recombined robot frame is the retargeting of the recombined human frame, up to the
//! self-collision limit): each arm's pose is one the data holds, the pair is not. Two sets, both
//! from the data's split and fixed before any model sees them ([`pairs`]):
//! - *recombined test frames*: every test frame's left arm with the right arm of the test frame
//!   half the test set further on (another block), each test frame's arms used once each. Each
//!   arm is a test pose (no model trained on it): against the ordinary test frames only the
//!   pairing changes, so a model that predicts each arm from that arm alone makes exactly its
//!   test error on them;
//! - *recombined training frames*: the same from the training frames — both arms seen in
//!   training, the pair not (how issue 49 measured the single model's rise).
//!
//! **Models**, per run (seed) and robot, the paper's setting (input back constraints, the
//! experiment's Q, budgets chosen on held-out training frames as the rest of the experiment):
//! the single shared latent space (human + robot), and a latent space per arm
//! ([`PartsGplvm`], each arm's model with the same configuration and seed, no parent: no
//! prediction goes through it); each transferred to every other robot (only that robot's
//! kernels trained). Yardsticks, per robot: the direct GP regression on all 18 human joints and
//! one GP regression per arm. Nothing is chosen by looking at the test frames.

use std::time::Instant;

use serde::{Deserialize, Serialize};
use sgplvm_core::{
    BackConstraint, GpRegression, Mat, MatRef, PartSpec, PartsConfig, PartsGplvm, Predictor,
    SharedGplvm, TrainOptions,
};

use super::{
    fit, mean_squared_error, model_config, validation, ExperimentConfig, ExperimentData,
    ExperimentError, ModelKind,
};
use crate::pipeline::ARM_PARTS;

/// The study's data beside the experiment's: which columns of each body are its arms, and
/// which frames' arms are recombined.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PartsData {
    /// The human's left-arm and right-arm columns.
    pub human_arms: [Vec<usize>; 2],
    /// Each robot's (in the order of [`ExperimentData::robots`]) left-arm and right-arm columns.
    pub robot_arms: Vec<[Vec<usize>; 2]>,
    /// Recombined test frames: (frame giving the left arm, frame giving the right arm), rows of
    /// the test matrices.
    pub test_pairs: Vec<(usize, usize)>,
    /// Recombined training frames: the same, rows of the training matrices.
    pub train_pairs: Vec<(usize, usize)>,
}

/// One model's errors in the study (rad², mean over joints and frames).
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct PartsRecord {
    /// The robot predicted.
    pub robot: String,
    /// `single` (one shared latent space), `parts` (a latent space per arm), `direct` (GP
    /// regression on all human joints) or `direct_per_arm` (a GP regression per arm).
    pub model: String,
    /// Trained on this robot ([`ModelKind::Baseline`]) or transferred to it from
    /// `source_robot`'s model of the same run ([`ModelKind::Transfer`]).
    pub kind: ModelKind,
    /// The robot the transferred model was trained on.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub source_robot: Option<String>,
    /// Run (seed) index; 0 for the regressions (no seed).
    pub run: usize,
    /// On the ordinary test frames.
    pub test_mse: f64,
    /// On the recombined test frames.
    pub recombined_test_mse: f64,
    /// On the recombined training frames.
    pub recombined_train_mse: f64,
    /// Training seconds (budget selection included; a transfer's own).
    pub seconds: f64,
}

/// Name of the study's stage.
pub(super) const STAGE: &str = "latent space per arm, recombined motions";

/// Name of the stage of the study's regressions.
pub(super) const DIRECT_STAGE: &str = "GP regressions per arm, recombined motions";

/// Pairs for recombining the frames `frames` (increasing frame numbers) grouped into `blocks`
/// (start, end of each segment): the k-th of the T frames gives its left arm, the
/// ((k + ⌊T/2⌋) mod T)-th its right arm — every frame's left arm once and every frame's right
/// arm once, each pair from two blocks (no block holds more than ⌊T/2⌋ of the frames, so the
/// two are never in one). Positions in `frames`; empty when a block holds more than half of
/// them (or there are fewer than two frames).
pub fn pairs(frames: &[usize], blocks: &[(usize, usize)]) -> Vec<(usize, usize)> {
    let t = frames.len();
    let shift = t / 2;
    let largest = blocks
        .iter()
        .map(|&(start, end)| frames.iter().filter(|&&f| start <= f && f < end).count())
        .max()
        .unwrap_or(t);
    if shift == 0 || largest > shift {
        return Vec::new();
    }
    (0..t).map(|k| (k, (k + shift) % t)).collect()
}

/// The frames of `m` recombined by `pairs`: the left-arm columns (`arms[0]`) of each pair's
/// first row, everything else of its second.
pub fn recombine(m: MatRef<'_, f64>, arms: &[Vec<usize>; 2], pairs: &[(usize, usize)]) -> Mat<f64> {
    Mat::from_fn(pairs.len(), m.ncols(), |i, j| {
        let (left, right) = pairs[i];
        if arms[0].contains(&j) {
            m[(left, j)]
        } else {
            m[(right, j)]
        }
    })
}

/// The study's sets of one robot: ordinary test, recombined test and recombined training
/// frames, each (human, robot).
struct Sets {
    sets: [(Mat<f64>, Mat<f64>); 3],
}

impl Sets {
    fn of(data: &ExperimentData, parts: &PartsData, r: usize) -> Sets {
        let split = &data.robots[r].1;
        let (h, arms) = (&data.human, &parts.robot_arms[r]);
        let ha = &parts.human_arms;
        Sets {
            sets: [
                (h.test.clone(), split.test.clone()),
                (
                    recombine(h.test.as_ref(), ha, &parts.test_pairs),
                    recombine(split.test.as_ref(), arms, &parts.test_pairs),
                ),
                (
                    recombine(h.train.as_ref(), ha, &parts.train_pairs),
                    recombine(split.train.as_ref(), arms, &parts.train_pairs),
                ),
            ],
        }
    }

    /// `predict`'s errors on the three sets.
    fn errors(
        &self,
        predict: impl Fn(MatRef<'_, f64>) -> sgplvm_core::Result<Mat<f64>>,
    ) -> sgplvm_core::Result<[f64; 3]> {
        let mut out = [0.0; 3];
        for (o, (h, r)) in out.iter_mut().zip(&self.sets) {
            *o = mean_squared_error(predict(h.as_ref())?.as_ref(), r.as_ref());
        }
        Ok(out)
    }
}

/// The arm parts of the human and robot `r` as the core takes them.
fn arm_specs(data: &ExperimentData, parts: &PartsData, robots: &[usize]) -> Vec<PartSpec> {
    (0..2)
        .map(|side| {
            let mut columns = vec![(data.input_name.clone(), parts.human_arms[side].clone())];
            for &r in robots {
                columns.push((data.robots[r].0.clone(), parts.robot_arms[r][side].clone()));
            }
            PartSpec::new(ARM_PARTS[side], columns)
        })
        .collect()
}

/// A record of `model`'s errors `e` on robot `robot`.
fn record(
    robot: &str,
    model: &str,
    (kind, source, run): (ModelKind, Option<&str>, usize),
    e: [f64; 3],
    seconds: f64,
) -> PartsRecord {
    PartsRecord {
        robot: robot.to_string(),
        model: model.to_string(),
        kind,
        source_robot: source.map(str::to_string),
        run,
        test_mse: e[0],
        recombined_test_mse: e[1],
        recombined_train_mse: e[2],
        seconds,
    }
}

/// Errors of the study, naming the task.
fn failed(context: &str) -> impl Fn(sgplvm_core::Error) -> ExperimentError + '_ {
    move |source| ExperimentError::Model {
        context: context.to_string(),
        source,
    }
}

/// The study's data, or an error saying it is missing.
fn need(data: &ExperimentData, context: &str) -> Result<PartsData, ExperimentError> {
    data.parts.clone().ok_or_else(|| ExperimentError::Task {
        context: context.to_string(),
        problem: "the experiment data holds no arm columns and recombined frames (parts)".into(),
    })
}

/// Task: run `run` of robot `r` — the single latent space and a latent space per arm, trained
/// on `r` and transferred from it to every other robot — and their errors.
pub(super) fn run_task(
    data: &ExperimentData,
    config: &ExperimentConfig,
    (run, r): (usize, usize),
    context: &str,
) -> Result<Vec<PartsRecord>, ExperimentError> {
    let parts = need(data, context)?;
    let fail = failed(context);
    let name = data.robots[r].0.as_str();
    let options = config.options(config.max_iters);
    let spaces = [
        (data.input_name.as_str(), data.human.train.as_ref()),
        (name, data.robots[r].1.train.as_ref()),
    ];
    let single = fit(
        config,
        data,
        (BackConstraint::Input, run, false),
        &spaces,
        &options,
        None,
    )
    .map_err(&fail)?;
    let parts_config = PartsConfig::new(
        model_config(config, BackConstraint::Input, run),
        arm_specs(data, &parts, &[r]),
    )
    .with_parent_latent_dim(None);
    let v = validation(config, data);
    let per_arm = PartsGplvm::fit(
        &parts_config,
        &spaces,
        &data.input_name,
        &options,
        v.as_ref(),
        None,
    )
    .map_err(&fail)?;
    let mut records = Vec::new();
    let sets = Sets::of(data, &parts, r);
    let models: [(&str, &dyn Predictor, f64); 2] = [
        ("single", &single, single.training_seconds()),
        ("parts", &per_arm, per_arm.training_seconds()),
    ];
    for (label, model, seconds) in models {
        let e = sets
            .errors(|h| Ok(model.predict(h, name, false)?.mean))
            .map_err(&fail)?;
        records.push(record(
            name,
            label,
            (ModelKind::Baseline, None, run),
            e,
            seconds,
        ));
    }
    let transfer_options = config.options(config.transfer_max_iters);
    for (t, (target, split)) in data.robots.iter().enumerate() {
        if t == r {
            continue;
        }
        let sets = Sets::of(data, &parts, t);
        let moved = transfer_single(
            &single,
            target,
            split.train.as_ref(),
            &transfer_options,
            config,
            data,
        )
        .map_err(&fail)?;
        let cols = std::collections::BTreeMap::from([
            (ARM_PARTS[0].to_string(), parts.robot_arms[t][0].clone()),
            (ARM_PARTS[1].to_string(), parts.robot_arms[t][1].clone()),
        ]);
        let started = Instant::now();
        let moved_parts = per_arm
            .transfer(
                target,
                split.train.as_ref(),
                &cols,
                &transfer_options,
                v.as_ref(),
                None,
            )
            .map_err(&fail)?;
        let parts_seconds = started.elapsed().as_secs_f64();
        let kind = (ModelKind::Transfer, Some(name), run);
        let e = sets
            .errors(|h| Ok(moved.predict(h, target, false)?.mean))
            .map_err(&fail)?;
        records.push(record(target, "single", kind, e, moved.training_seconds()));
        let e = sets
            .errors(|h| Ok(moved_parts.predict(h, target, false)?.mean))
            .map_err(&fail)?;
        records.push(record(target, "parts", kind, e, parts_seconds));
    }
    Ok(records)
}

/// The single model transferred to `target`, its budget chosen as the experiment's transfers.
fn transfer_single(
    model: &SharedGplvm,
    target: &str,
    train: MatRef<'_, f64>,
    options: &TrainOptions,
    config: &ExperimentConfig,
    data: &ExperimentData,
) -> sgplvm_core::Result<SharedGplvm> {
    match validation(config, data) {
        Some(v) => model.transfer_validated(target, train, None, options, &v, None),
        None => model.transfer(target, train, options, None),
    }
}

/// Task: the direct GP regression of robot `r` on all human joints, and one per arm.
pub(super) fn direct_task(
    data: &ExperimentData,
    config: &ExperimentConfig,
    r: usize,
    context: &str,
) -> Result<Vec<PartsRecord>, ExperimentError> {
    let parts = need(data, context)?;
    let fail = failed(context);
    let (name, split) = &data.robots[r];
    let options = config.options(config.direct_max_iters);
    let sets = Sets::of(data, &parts, r);
    let started = Instant::now();
    let whole = GpRegression::fit(data.human.train.as_ref(), split.train.as_ref(), &options)
        .map_err(&fail)?;
    let whole_seconds = started.elapsed().as_secs_f64();
    let started = Instant::now();
    let arms: Vec<GpRegression> = (0..2)
        .map(|side| {
            let h = columns(data.human.train.as_ref(), &parts.human_arms[side]);
            let y = columns(split.train.as_ref(), &parts.robot_arms[r][side]);
            GpRegression::fit(h.as_ref(), y.as_ref(), &options)
        })
        .collect::<sgplvm_core::Result<_>>()
        .map_err(&fail)?;
    let arms_seconds = started.elapsed().as_secs_f64();
    let kind = (ModelKind::Baseline, None, 0);
    let e = sets.errors(|h| whole.predict(h)).map_err(&fail)?;
    let mut records = vec![record(name, "direct", kind, e, whole_seconds)];
    let e = sets
        .errors(|h| {
            let mut out = Mat::zeros(h.nrows(), split.train.ncols());
            for (side, gp) in arms.iter().enumerate() {
                let p = gp.predict(columns(h, &parts.human_arms[side]).as_ref())?;
                for (k, &c) in parts.robot_arms[r][side].iter().enumerate() {
                    out.as_mut().col_mut(c).copy_from(p.col(k));
                }
            }
            Ok(out)
        })
        .map_err(&fail)?;
    records.push(record(name, "direct_per_arm", kind, e, arms_seconds));
    Ok(records)
}

/// The columns `cols` of `m`.
fn columns(m: MatRef<'_, f64>, cols: &[usize]) -> Mat<f64> {
    Mat::from_fn(m.nrows(), cols.len(), |i, j| m[(i, cols[j])])
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every frame's left arm once and right arm once, each pair from two blocks; none when a
    /// block holds more than half of the frames.
    #[test]
    fn pairs_use_each_arm_once_from_two_blocks() {
        let frames: Vec<usize> = (0..30).map(|k| 3 * k).collect();
        let blocks = [(0, 20), (20, 50), (50, 65), (65, 90)];
        let p = pairs(&frames, &blocks);
        assert_eq!(p.len(), 30);
        let mut left: Vec<usize> = p.iter().map(|x| x.0).collect();
        let mut right: Vec<usize> = p.iter().map(|x| x.1).collect();
        left.sort_unstable();
        right.sort_unstable();
        assert_eq!(left, (0..30).collect::<Vec<_>>());
        assert_eq!(right, left);
        let block = |pos: usize| {
            blocks
                .iter()
                .position(|&(a, b)| a <= frames[pos] && frames[pos] < b)
        };
        assert!(p.iter().all(|&(a, b)| block(a) != block(b)));
        assert!(pairs(&frames, &[(0, 50), (50, 90)]).is_empty());
        assert!(pairs(&[4], &blocks).is_empty());
        // Recombined rows: left columns from the first frame, the rest from the second.
        let m = Mat::from_fn(4, 3, |i, j| (10 * i + j) as f64);
        let r = recombine(m.as_ref(), &[vec![0], vec![1, 2]], &[(0, 3), (2, 1)]);
        assert_eq!((r[(0, 0)], r[(0, 1)], r[(0, 2)]), (0.0, 31.0, 32.0));
        assert_eq!((r[(1, 0)], r[(1, 1)]), (20.0, 11.0));
    }
}
