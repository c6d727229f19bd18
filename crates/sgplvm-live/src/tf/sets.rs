//! Which frame set to fit next (module docs of [`super`]): the newest complete one not used
//! yet, the older ones given up counted as superseded (complete) or incomplete (with the
//! frames they lacked).

use std::collections::{BTreeMap, BTreeSet};

use serde::Serialize;

use super::buffer::TfBuffer;
use super::STAMP_TOLERANCE_NS;

/// What became of the frame sets seen.
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize)]
pub struct SetCounts {
    /// Complete sets handed out to be fitted.
    pub frames: u64,
    /// Complete sets a newer one replaced before they were used.
    pub superseded: u64,
    /// Sets given up because a frame the fit needs had no transform at their stamp.
    pub incomplete: u64,
    /// Per frame, the incomplete sets that lacked it.
    pub missing: BTreeMap<String, u64>,
}

impl SetCounts {
    /// Counts a set given up; returns the frames it lacked (empty: it was complete).
    fn give_up(&mut self, missing: Vec<String>) -> Vec<String> {
        if missing.is_empty() {
            self.superseded += 1;
        } else {
            self.incomplete += 1;
            for m in &missing {
                *self.missing.entry(m.clone()).or_default() += 1;
            }
        }
        missing
    }
}

/// The sets of one stream of frames (module docs).
#[derive(Debug, Clone, Default)]
pub struct FrameSets {
    last_used: Option<i64>,
    /// Stamps seen of needed frames, newer than the last set used.
    pending: BTreeSet<i64>,
    counts: SetCounts,
}

/// What [`FrameSets::next`] found.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Next {
    /// The stamp of the set to fit, if one is complete.
    pub stamp: Option<i64>,
    /// The incomplete sets given up for it: their stamps and the frames they lacked.
    pub incomplete: Vec<(i64, Vec<String>)>,
}

impl FrameSets {
    /// No set seen yet.
    pub fn new() -> FrameSets {
        FrameSets::default()
    }

    /// The newest complete set of the frames `needed` newer than the last one handed out;
    /// the older sets not used are given up and counted.
    pub fn next(&mut self, buffer: &TfBuffer, needed: &[String]) -> Next {
        let needed: Vec<&str> = needed.iter().map(String::as_str).collect();
        let last = self.last_used;
        let newer = |s: &i64| last.is_none_or(|u| *s > u + STAMP_TOLERANCE_NS);
        self.pending.extend(
            buffer
                .stamps(needed.iter().copied())
                .into_iter()
                .filter(newer),
        );
        let missing = |s: i64| buffer.missing(needed.iter().copied(), s, STAMP_TOLERANCE_NS);
        let Some(stamp) = self
            .pending
            .iter()
            .rev()
            .copied()
            .find(|&s| missing(s).is_empty())
        else {
            return Next::default();
        };
        let older: Vec<i64> = self
            .pending
            .range(..stamp - STAMP_TOLERANCE_NS)
            .copied()
            .collect();
        let mut incomplete = Vec::new();
        for s in older {
            let lacked = self.counts.give_up(missing(s));
            if !lacked.is_empty() {
                incomplete.push((s, lacked));
            }
        }
        self.pending.retain(|&s| s > stamp + STAMP_TOLERANCE_NS);
        self.last_used = Some(stamp);
        self.counts.frames += 1;
        Next {
            stamp: Some(stamp),
            incomplete,
        }
    }

    /// The counts so far, the sets still pending counted as given up (at the end of a run).
    pub fn counts(&self, buffer: &TfBuffer, needed: &[String]) -> SetCounts {
        let mut c = self.counts.clone();
        for &s in &self.pending {
            c.give_up(buffer.missing(needed.iter().map(String::as_str), s, STAMP_TOLERANCE_NS));
        }
        c
    }
}
