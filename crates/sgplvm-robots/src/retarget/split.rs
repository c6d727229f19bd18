//! The train/test split of demonstrations without pose labels (retargeted captures): each file
//! is cut into blocks of time, the blocks are the segments, and whole blocks (or whole files)
//! go to the test set, so that test motions are never in training.
//!
//! The rule is fixed before any model sees the data: every `test_every`-th block, counting
//! across files ([`SplitRule::Blocks`]), the files named ([`SplitRule::Files`]; the files of
//! the people named are such files, so that test people are never in training), or none
//! ([`SplitRule::AllTraining`]: every frame for training, no test frames — what a capture too
//! short for a test block gets, with a warning, when every `test_every`-th block was asked
//! for; [`SplitSummary::fallback`] says so). Frames
//! within `guard_s` of a boundary between a training and a test block belong to neither set:
//! neighbouring frames are nearly the same pose, and the test must not be a frame away from
//! training. Training frames are then subsampled (`train_subsample`, as the paper subsampled
//! its training trajectories; less for a short capture, down to every frame, so that at least
//! `min_train_frames` remain), test frames too (`test_subsample`).

use serde::{Deserialize, Serialize};

use super::RetargetError;
use crate::dataset::{Dataset, Segment};

/// Which blocks are test blocks.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub enum SplitRule {
    /// Every `test_every`-th block, counting across files (blocks `test_every − 1`,
    /// `2·test_every − 1`, …).
    Blocks {
        /// One block in this many is a test block.
        test_every: usize,
    },
    /// The blocks of these segments (files, by index in the input) are test blocks.
    Files {
        /// Indices of the test files.
        test: Vec<usize>,
    },
    /// No test blocks: every frame is for training (subsampled by `train_subsample`), no guard.
    AllTraining,
}

/// How to split.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SplitOptions {
    /// Which blocks are test blocks.
    pub rule: SplitRule,
    /// Length of a block, seconds (a shorter tail of a file joins its last block).
    pub block_s: f64,
    /// Frames this close to a boundary between a training and a test block are in neither set,
    /// seconds.
    pub guard_s: f64,
    /// Keep every this-many-th training frame of a block.
    pub train_subsample: usize,
    /// Keep every this-many-th test frame of a block.
    pub test_subsample: usize,
    /// A short capture keeps at least this many training frames where it has them: the
    /// training step is lowered from `train_subsample` (down to every frame) until it does, and
    /// the summary says so (0: `train_subsample` as it is). A long capture is not affected.
    #[serde(default)]
    pub min_train_frames: usize,
}

/// The training frames a short capture keeps at least, by default ([`SplitOptions`]): a
/// model learns little from fewer (the paper trained on about 250).
pub const MIN_TRAIN_FRAMES: usize = 200;

impl Default for SplitOptions {
    fn default() -> Self {
        Self {
            rule: SplitRule::Blocks { test_every: 4 },
            block_s: 4.0,
            guard_s: 0.5,
            train_subsample: 12,
            test_subsample: 3,
            min_train_frames: MIN_TRAIN_FRAMES,
        }
    }
}

/// What a split made.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct SplitSummary {
    /// Blocks (the new segments).
    pub blocks: usize,
    /// Test blocks.
    pub test_blocks: usize,
    /// Training frames kept.
    pub train_frames: usize,
    /// Test frames kept.
    pub test_frames: usize,
    /// Frames left out as guards.
    pub guard_frames: usize,
    /// Why every frame went to training although test blocks were asked for (too few blocks
    /// for one in `test_every` to be a test block: a short capture); `None` when the split is
    /// the one asked for.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fallback: Option<String>,
    /// The training step used: `train_subsample`, or lower for a short capture (see
    /// [`SplitOptions::min_train_frames`]).
    #[serde(default)]
    pub train_step: usize,
}

/// A block of frames: `start..end` of file `file`, a test block or not.
#[derive(Debug, Clone, Copy)]
struct Block {
    start: usize,
    end: usize,
    file: usize,
    test: bool,
}

/// Cuts every segment of `dataset` into blocks, makes them its segments (each with its
/// segment's person) and sets its train and test frames by `options`.
pub fn split_into_blocks(
    dataset: &mut Dataset,
    options: &SplitOptions,
) -> Result<SplitSummary, RetargetError> {
    check_options(options, dataset.segments.len())?;
    let mut blocks = cut_blocks(dataset, options.block_s);
    let fallback = match &options.rule {
        SplitRule::Blocks { test_every } if blocks.len() < *test_every => Some(format!(
            "the frames make {} of {} s, fewer than the {test_every} it takes for one in \
             {test_every} to test: every frame is for training, none for testing (`train` \
             needs no test frames; for `evaluate`, shorter --block-seconds or a smaller \
             --test-every make test blocks)",
            crate::names::count(blocks.len(), "block"),
            options.block_s,
        )),
        _ => None,
    };
    for (b, block) in blocks.iter_mut().enumerate() {
        block.test = match &options.rule {
            _ if fallback.is_some() => false,
            SplitRule::Blocks { test_every: k } => b % k == k - 1,
            SplitRule::Files { test } => test.contains(&block.file),
            SplitRule::AllTraining => false,
        };
    }
    // A short capture: the largest training step that still keeps `min_train_frames`.
    let mut step = options.train_subsample;
    let (mut train, mut test, mut guard_frames) = select_frames(dataset, &blocks, options, step);
    while step > 1 && train.len() < options.min_train_frames {
        step -= 1;
        (train, test, guard_frames) = select_frames(dataset, &blocks, options, step);
    }
    let all_training = fallback.is_some() || options.rule == SplitRule::AllTraining;
    if train.is_empty() || (test.is_empty() && !all_training) {
        return Err(RetargetError::Invalid(format!(
            "the split leaves {} training and {} test frames; shorten the blocks (now {} s), \
             name other test files, or train on every frame (`--split none`)",
            train.len(),
            test.len(),
            options.block_s
        )));
    }
    let summary = SplitSummary {
        blocks: blocks.len(),
        test_blocks: blocks.iter().filter(|b| b.test).count(),
        train_frames: train.len(),
        test_frames: test.len(),
        guard_frames,
        fallback,
        train_step: step,
    };
    // Each block is its file's person's.
    dataset.segments = blocks
        .iter()
        .map(|b| Segment {
            start: b.start,
            end: b.end,
            from_pose: None,
            to_pose: None,
            repetition: None,
            person: dataset.segments[b.file].person.clone(),
        })
        .collect();
    dataset.train = train;
    dataset.test = test;
    dataset
        .validate()
        .map_err(|e| RetargetError::Invalid(e.to_string()))?;
    Ok(summary)
}

/// Refuses options that cannot split `files` files.
fn check_options(options: &SplitOptions, files: usize) -> Result<(), RetargetError> {
    let bad = |m: String| Err(RetargetError::Invalid(m));
    if !(options.block_s.is_finite() && options.block_s > 0.0) {
        return bad(format!(
            "block length {} s; expected a positive number of seconds",
            options.block_s
        ));
    }
    if !(options.guard_s.is_finite()
        && options.guard_s >= 0.0
        && options.guard_s < options.block_s / 2.0)
    {
        return bad(format!(
            "guard {} s; expected at least 0 and less than half a block ({} s)",
            options.guard_s,
            options.block_s / 2.0
        ));
    }
    if options.train_subsample == 0 || options.test_subsample == 0 {
        return bad("subsampling steps must be at least 1".into());
    }
    match &options.rule {
        SplitRule::Blocks { test_every } if *test_every < 2 => bad(format!(
            "test every {test_every} blocks; expected 2 or more (1 would leave no training block)"
        )),
        SplitRule::Files { test } => {
            if let Some(&f) = test.iter().find(|&&f| f >= files) {
                return bad(format!(
                    "test file {f} named, but there are {files} files (0-based)"
                ));
            }
            if test.is_empty() || test.len() >= files {
                return bad(format!(
                    "{} of {files} files named for testing; at least one must test and one train",
                    test.len()
                ));
            }
            Ok(())
        }
        SplitRule::Blocks { .. } | SplitRule::AllTraining => Ok(()),
    }
}

/// The blocks of `block_s` seconds of every segment (file) of `dataset`, none a test block yet;
/// a tail shorter than half a block joins the block before it.
fn cut_blocks(dataset: &Dataset, block_s: f64) -> Vec<Block> {
    let t = |i: usize| dataset.times_ns[i] as f64 * 1e-9;
    let mut blocks = Vec::new();
    for (file, seg) in dataset.segments.iter().enumerate() {
        if seg.is_empty() {
            continue;
        }
        let t0 = t(seg.start);
        let mut start = seg.start;
        while start < seg.end {
            let block_index = ((t(start) - t0) / block_s + 1e-9).floor() as usize;
            let limit = t0 + (block_index + 1) as f64 * block_s;
            let mut end = start;
            while end < seg.end && t(end) < limit - 1e-9 {
                end += 1;
            }
            let end = end.max(start + 1);
            // A tail shorter than half a block joins the block before it (same file).
            let tail = t(seg.end - 1) - t(end.min(seg.end - 1));
            let end = if end < seg.end && tail < block_s / 2.0 {
                seg.end
            } else {
                end
            };
            blocks.push(Block {
                start,
                end,
                file,
                test: false,
            });
            start = end;
        }
    }
    blocks
}

/// The training and test frames of `blocks` (subsampled, without the guard frames next to a
/// block of the other set in the same file), and the number of guard frames left out.
fn select_frames(
    dataset: &Dataset,
    blocks: &[Block],
    options: &SplitOptions,
    train_step: usize,
) -> (Vec<usize>, Vec<usize>, usize) {
    let t = |i: usize| dataset.times_ns[i] as f64 * 1e-9;
    let mut train = Vec::new();
    let mut test = Vec::new();
    let mut guard_frames = 0;
    for (b, block) in blocks.iter().enumerate() {
        let differs = |other: Option<&Block>| {
            other.is_some_and(|o| o.file == block.file && o.test != block.test)
        };
        let other_before = differs(b.checked_sub(1).and_then(|a| blocks.get(a)));
        let other_after = differs(blocks.get(b + 1));
        let (start, end) = (block.start, block.end);
        let usable: Vec<usize> = (start..end)
            .filter(|&i| {
                let near_start = other_before && t(i) - t(start) < options.guard_s;
                let near_end = other_after && t(end - 1) - t(i) < options.guard_s;
                !(near_start || near_end)
            })
            .collect();
        guard_frames += (end - start) - usable.len();
        let (set, step) = if block.test {
            (&mut test, options.test_subsample)
        } else {
            (&mut train, train_step)
        };
        set.extend(usable.iter().step_by(step).copied());
    }
    (train, test, guard_frames)
}
