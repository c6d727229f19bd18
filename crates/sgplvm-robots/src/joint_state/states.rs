//! [`JointStates`]: a time series of named joint positions, one row per message, as the
//! reader returns it and the writer takes it.

use super::{JointStateError, Result};

/// A time series of joint positions: one row per message.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct JointStates {
    /// Timestamps in nanoseconds (MCAP log time), one per row.
    pub times_ns: Vec<i64>,
    /// Joint names, one per column.
    pub names: Vec<String>,
    /// Positions, row-major: `positions[row * names.len() + col]`.
    pub positions: Vec<f64>,
}

impl JointStates {
    /// Builds a series after checking that `positions` has `times.len() × names.len()` values,
    /// names are unique and times are non-negative.
    pub fn new(times_ns: Vec<i64>, names: Vec<String>, positions: Vec<f64>) -> Result<Self> {
        let s = Self {
            times_ns,
            names,
            positions,
        };
        s.validate("joint states")?;
        Ok(s)
    }

    /// Number of rows (messages).
    pub fn len(&self) -> usize {
        self.times_ns.len()
    }

    /// Whether there are no rows.
    pub fn is_empty(&self) -> bool {
        self.times_ns.is_empty()
    }

    /// Number of joints (columns).
    pub fn dof(&self) -> usize {
        self.names.len()
    }

    /// Row `i` (panics if `i >= len()`, like slice indexing).
    pub fn row(&self, i: usize) -> &[f64] {
        let d = self.dof();
        &self.positions[i * d..(i + 1) * d]
    }

    /// Checks the invariants listed in [`JointStates::new`]; `what` names the data in errors.
    pub fn validate(&self, what: &str) -> Result<()> {
        let bad = |detail: String| JointStateError::InvalidInput {
            what: what.to_string(),
            detail,
        };
        let expected = self.times_ns.len().checked_mul(self.names.len());
        if expected != Some(self.positions.len()) {
            return Err(bad(format!(
                "{} positions for {} times × {} joints",
                self.positions.len(),
                self.times_ns.len(),
                self.names.len()
            )));
        }
        if let Some(t) = self.times_ns.iter().find(|t| **t < 0) {
            return Err(bad(format!(
                "negative timestamp {t} ns (MCAP times are unsigned)"
            )));
        }
        // By hash: a series may have tens of thousands of joints.
        let mut seen = std::collections::HashSet::with_capacity(self.names.len());
        for n in &self.names {
            if !seen.insert(n.as_str()) {
                return Err(bad(format!("joint name `{n}` appears twice")));
            }
        }
        Ok(())
    }

    /// Sorts rows by time (stable), as messages may be logged out of order.
    pub(super) fn sort_by_time(&mut self) {
        if self.times_ns.windows(2).all(|w| w[0] <= w[1]) {
            return;
        }
        let d = self.dof();
        let mut order: Vec<usize> = (0..self.len()).collect();
        order.sort_by_key(|&i| self.times_ns[i]);
        let times = order.iter().map(|&i| self.times_ns[i]).collect();
        let mut pos = Vec::with_capacity(self.positions.len());
        for &i in &order {
            pos.extend_from_slice(&self.positions[i * d..(i + 1) * d]);
        }
        self.times_ns = times;
        self.positions = pos;
    }
}

#[cfg(test)]
mod tests {
    use super::super::tests::names;
    use super::*;

    #[test]
    fn invalid_inputs_are_rejected() {
        assert!(JointStates::new(vec![0, 1], names(&["a"]), vec![0.0]).is_err());
        assert!(JointStates::new(vec![-1], names(&["a"]), vec![0.0]).is_err());
        assert!(JointStates::new(vec![0], names(&["a", "a"]), vec![0.0, 0.0]).is_err());
    }
}
