//! The train/test split of demonstrations without pose labels (retargeted captures): each file
//! is cut into blocks of time, the blocks are the segments, and whole blocks (or whole files)
//! go to the test set, so that test motions are never in training.
//!
//! The rule is fixed before any model sees the data: every `test_every`-th block, counting
//! across files ([`SplitRule::Blocks`]), or the files named ([`SplitRule::Files`]). Frames
//! within `guard_s` of a boundary between a training and a test block belong to neither set:
//! neighbouring frames are nearly the same pose, and the test must not be a frame away from
//! training. Training frames are then subsampled (`train_subsample`, as the paper subsampled
//! its training trajectories), test frames too (`test_subsample`).

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
}

impl Default for SplitOptions {
    fn default() -> Self {
        Self {
            rule: SplitRule::Blocks { test_every: 4 },
            block_s: 4.0,
            guard_s: 0.5,
            train_subsample: 12,
            test_subsample: 3,
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
}

/// Cuts every segment of `dataset` into blocks, makes them its segments and sets its train and
/// test frames by `options`.
pub fn split_into_blocks(
    dataset: &mut Dataset,
    options: &SplitOptions,
) -> Result<SplitSummary, RetargetError> {
    let bad = |m: String| RetargetError::Invalid(m);
    if !(options.block_s.is_finite() && options.block_s > 0.0) {
        return Err(bad(format!(
            "block length {} s; expected a positive number of seconds",
            options.block_s
        )));
    }
    if !(options.guard_s.is_finite()
        && options.guard_s >= 0.0
        && options.guard_s < options.block_s / 2.0)
    {
        return Err(bad(format!(
            "guard {} s; expected at least 0 and less than half a block ({} s)",
            options.guard_s,
            options.block_s / 2.0
        )));
    }
    if options.train_subsample == 0 || options.test_subsample == 0 {
        return Err(bad("subsampling steps must be at least 1".into()));
    }
    let files = dataset.segments.len();
    match &options.rule {
        SplitRule::Blocks { test_every } if *test_every < 2 => {
            return Err(bad(format!("test every {test_every} blocks; expected 2 or more (1 would leave no training block)")));
        }
        SplitRule::Files { test } => {
            if let Some(&f) = test.iter().find(|&&f| f >= files) {
                return Err(bad(format!(
                    "test file {f} named, but there are {files} files (0-based)"
                )));
            }
            if test.is_empty() || test.len() >= files {
                return Err(bad(format!(
                    "{} of {files} files named for testing; at least one must test and one train",
                    test.len()
                )));
            }
        }
        SplitRule::Blocks { .. } => {}
    }
    let t = |i: usize| dataset.times_ns[i] as f64 * 1e-9;
    // Blocks: (start, end, file, is_test).
    let mut blocks: Vec<(usize, usize, usize, bool)> = Vec::new();
    for (file, seg) in dataset.segments.iter().enumerate() {
        if seg.is_empty() {
            continue;
        }
        let t0 = t(seg.start);
        let mut start = seg.start;
        while start < seg.end {
            let block_index = ((t(start) - t0) / options.block_s + 1e-9).floor() as usize;
            let limit = t0 + (block_index + 1) as f64 * options.block_s;
            let mut end = start;
            while end < seg.end && t(end) < limit - 1e-9 {
                end += 1;
            }
            let end = end.max(start + 1);
            // A tail shorter than half a block joins the block before it (same file).
            let tail = t(seg.end - 1) - t(end.min(seg.end - 1));
            let end = if end < seg.end && tail < options.block_s / 2.0 {
                seg.end
            } else {
                end
            };
            blocks.push((start, end, file, false));
            start = end;
        }
    }
    let test_every = match &options.rule {
        SplitRule::Blocks { test_every } => Some(*test_every),
        SplitRule::Files { .. } => None,
    };
    for (b, block) in blocks.iter_mut().enumerate() {
        block.3 = match (&options.rule, test_every) {
            (_, Some(k)) => b % k == k - 1,
            (SplitRule::Files { test }, None) => test.contains(&block.2),
            _ => false,
        };
    }
    let mut train = Vec::new();
    let mut test = Vec::new();
    let mut guard_frames = 0;
    for (b, &(start, end, file, is_test)) in blocks.iter().enumerate() {
        let other_before = b > 0 && blocks[b - 1].2 == file && blocks[b - 1].3 != is_test;
        let other_after =
            b + 1 < blocks.len() && blocks[b + 1].2 == file && blocks[b + 1].3 != is_test;
        let usable: Vec<usize> = (start..end)
            .filter(|&i| {
                let near_start = other_before && t(i) - t(start) < options.guard_s;
                let near_end = other_after && t(end - 1) - t(i) < options.guard_s;
                !(near_start || near_end)
            })
            .collect();
        guard_frames += (end - start) - usable.len();
        let step = if is_test {
            options.test_subsample
        } else {
            options.train_subsample
        };
        let kept = usable.iter().step_by(step).copied();
        if is_test {
            test.extend(kept);
        } else {
            train.extend(kept);
        }
    }
    if train.is_empty() || test.is_empty() {
        return Err(bad(format!(
            "the split leaves {} training and {} test frames; shorten the blocks (now {} s) or name other test files",
            train.len(),
            test.len(),
            options.block_s
        )));
    }
    let summary = SplitSummary {
        blocks: blocks.len(),
        test_blocks: blocks.iter().filter(|b| b.3).count(),
        train_frames: train.len(),
        test_frames: test.len(),
        guard_frames,
    };
    dataset.segments = blocks
        .iter()
        .map(|&(start, end, _, _)| Segment {
            start,
            end,
            from_pose: None,
            to_pose: None,
            repetition: None,
        })
        .collect();
    dataset.train = train;
    dataset.test = test;
    dataset.validate().map_err(|e| bad(e.to_string()))?;
    Ok(summary)
}
