//! One requested topic's rows as they are decoded: each message's joints reordered into the
//! order asked for (the mapping cached while messages keep the same names), its time, and the
//! error that names the message when it does not fit.

use std::collections::HashMap;
use std::path::Path;

use crate::joint_state::{JointStateError, Result};

pub(super) fn log_time_ns(ctx: &MsgCtx<'_>) -> Result<i64> {
    i64::try_from(ctx.log_time)
        .map_err(|_| ctx.malformed("log time exceeds i64 nanoseconds".into()))
}

/// The time of a `header.stamp`, refused when negative (MCAP times are unsigned).
pub(super) fn stamp_time_ns(ctx: &MsgCtx<'_>, sec: i32, nanosec: u32) -> Result<i64> {
    let t = sec as i64 * 1_000_000_000 + nanosec as i64;
    if t < 0 {
        return Err(ctx.malformed(format!(
            "header.stamp {sec} s {nanosec} ns is negative, expected a time ≥ 0"
        )));
    }
    Ok(t)
}

pub(super) struct MsgCtx<'a> {
    pub(super) path: &'a Path,
    pub(super) topic: &'a str,
    pub(super) index: usize,
    pub(super) log_time: u64,
}

impl MsgCtx<'_> {
    pub(super) fn malformed(&self, detail: String) -> JointStateError {
        JointStateError::Malformed {
            path: self.path.to_path_buf(),
            topic: self.topic.to_string(),
            index: self.index,
            log_time_ns: self.log_time,
            detail,
        }
    }
}

/// Per-topic accumulation of decoded rows.
#[derive(Default)]
pub(super) struct TopicAcc {
    /// Output joint names (requested, or taken from the first message).
    pub(super) names: Vec<String>,
    /// Whether `names` came from the request.
    pub(super) fixed_names: bool,
    pub(super) times: Vec<i64>,
    pub(super) positions: Vec<f64>,
    pub(super) count: usize,
    /// Names of the last message whose mapping is cached, concatenated with NUL separators.
    pub(super) cached_names: Vec<u8>,
    pub(super) cached_count: usize,
    /// For each output joint, its index in the cached message layout.
    pub(super) mapping: Vec<usize>,
}

impl TopicAcc {
    pub(super) fn ingest<'n>(
        &mut self,
        ctx: &MsgCtx<'_>,
        time: i64,
        name_count: usize,
        name: impl Fn(usize) -> &'n [u8],
        position_len: usize,
        position: impl Fn(usize) -> f64,
    ) -> Result<()> {
        if position_len != name_count {
            return Err(ctx.malformed(format!(
                "{name_count} joint names but {position_len} positions"
            )));
        }
        if !self.same_layout(name_count, &name) {
            self.relayout(ctx, name_count, &name)?;
        }
        self.times.push(time);
        self.positions
            .extend(self.mapping.iter().map(|&i| position(i)));
        self.count += 1;
        Ok(())
    }

    fn same_layout<'n>(&self, name_count: usize, name: &impl Fn(usize) -> &'n [u8]) -> bool {
        if self.count == 0 || name_count != self.cached_count {
            return false;
        }
        let mut at = 0;
        for i in 0..name_count {
            let n = name(i);
            let end = at + n.len();
            if self.cached_names.get(at..end) != Some(n) || self.cached_names.get(end) != Some(&0) {
                return false;
            }
            at = end + 1;
        }
        at == self.cached_names.len()
    }

    fn relayout<'n>(
        &mut self,
        ctx: &MsgCtx<'_>,
        name_count: usize,
        name: &impl Fn(usize) -> &'n [u8],
    ) -> Result<()> {
        // Names are looked up by hash: a message may list tens of thousands of joints.
        let mut present = Vec::with_capacity(name_count);
        let mut position_of: HashMap<&str, usize> = HashMap::with_capacity(name_count);
        for i in 0..name_count {
            let s = std::str::from_utf8(name(i))
                .map_err(|_| ctx.malformed(format!("joint name #{i} is not UTF-8")))?;
            if position_of.insert(s, i).is_some() {
                return Err(ctx.malformed(format!("joint name `{s}` appears twice")));
            }
            present.push(s.to_string());
        }
        if self.count == 0 && !self.fixed_names {
            self.names = present.clone();
        }
        let mut mapping = Vec::with_capacity(self.names.len());
        let mut missing = Vec::new();
        for n in &self.names {
            match position_of.get(n.as_str()) {
                Some(&i) => mapping.push(i),
                None => missing.push(n.clone()),
            }
        }
        drop(position_of);
        if !missing.is_empty() {
            return Err(JointStateError::MissingJoints {
                path: ctx.path.to_path_buf(),
                topic: ctx.topic.to_string(),
                index: ctx.index,
                missing,
                present,
            });
        }
        self.mapping = mapping;
        self.cached_names.clear();
        for p in &present {
            self.cached_names.extend_from_slice(p.as_bytes());
            self.cached_names.push(0);
        }
        self.cached_count = name_count;
        Ok(())
    }
}
