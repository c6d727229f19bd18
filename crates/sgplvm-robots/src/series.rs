//! One idea, three shapes: a named joint time series. Every conversion between them lives
//! here, so that no caller re-derives the clock or the row order by hand.
//!
//! | type | names | clock | positions |
//! | --- | --- | --- | --- |
//! | [`JointStates`] (MCAP topics) | `names` | `times_ns: Vec<i64>`, nanoseconds | row-major `Vec<f64>` |
//! | [`Trajectory`] (physics replay) | `joint_names` | `times: Vec<f64>`, seconds | row-major `Vec<f64>` |
//! | [`BodyData`] (a dataset's body) | `joint_names` (+ `name`, `topic`) | the dataset's `times_ns` | `DMatrix<f64>`, frames × joints |
//!
//! The clock converts as `seconds = ns as f64 * 1e-9` ([`seconds_from_ns`]) and
//! `ns = (seconds * 1e9).round()` ([`ns_from_seconds`]).

use nalgebra::DMatrix;

use crate::dataset::BodyData;
use crate::joint_state::{JointStateError, JointStates};
use crate::physics::{PhysicsError, Trajectory};

/// Nanoseconds (MCAP log time) to seconds.
pub fn seconds_from_ns(t: i64) -> f64 {
    t as f64 * 1e-9
}

/// Seconds to nanoseconds, rounded to the nearest.
pub fn ns_from_seconds(t: f64) -> i64 {
    (t * 1e9).round() as i64
}

impl Trajectory {
    /// A trajectory on a nanosecond clock (e.g. MCAP log times), converted to seconds by
    /// [`seconds_from_ns`]; checked like [`Trajectory::new`].
    pub fn from_ns(
        joint_names: Vec<String>,
        times_ns: &[i64],
        positions: Vec<f64>,
    ) -> Result<Self, PhysicsError> {
        let times = times_ns.iter().map(|&t| seconds_from_ns(t)).collect();
        Trajectory::new(joint_names, times, positions)
    }
}

impl TryFrom<&JointStates> for Trajectory {
    type Error = PhysicsError;

    /// The same columns and rows, times in seconds.
    fn try_from(states: &JointStates) -> Result<Self, PhysicsError> {
        Trajectory::from_ns(
            states.names.clone(),
            &states.times_ns,
            states.positions.clone(),
        )
    }
}

impl TryFrom<&Trajectory> for JointStates {
    type Error = JointStateError;

    /// The same columns and rows, times rounded to nanoseconds.
    fn try_from(trajectory: &Trajectory) -> Result<Self, JointStateError> {
        JointStates::new(
            trajectory
                .times
                .iter()
                .map(|&t| ns_from_seconds(t))
                .collect(),
            trajectory.joint_names.clone(),
            trajectory.positions.clone(),
        )
    }
}

impl BodyData {
    /// A body from row-major positions: `frames` rows of `joint_names.len()` values.
    pub fn from_rows(
        name: impl Into<String>,
        topic: impl Into<String>,
        joint_names: Vec<String>,
        frames: usize,
        rows: &[f64],
    ) -> Result<Self, JointStateError> {
        let name = name.into();
        let d = joint_names.len();
        if frames.checked_mul(d) != Some(rows.len()) {
            return Err(JointStateError::InvalidInput {
                what: format!("body `{name}`"),
                detail: format!("{} positions for {frames} frames × {d} joints", rows.len()),
            });
        }
        Ok(BodyData {
            name,
            topic: topic.into(),
            joint_names,
            positions: DMatrix::from_row_slice(frames, d, rows),
        })
    }

    /// The body `name` stored on `topic` whose frames are the rows of `states`.
    pub fn from_joint_states(
        name: &str,
        topic: &str,
        states: &JointStates,
    ) -> Result<Self, JointStateError> {
        BodyData::from_rows(
            name,
            topic,
            states.names.clone(),
            states.len(),
            &states.positions,
        )
    }

    /// The positions of rows `frames` (all rows for `None`), row-major.
    pub fn row_major(&self, frames: Option<&[usize]>) -> Vec<f64> {
        let d = self.positions.ncols();
        let mut out = Vec::with_capacity(frames.map_or(self.positions.nrows(), <[_]>::len) * d);
        match frames {
            Some(frames) => {
                for &r in frames {
                    out.extend(self.positions.row(r).iter());
                }
            }
            None => {
                for r in 0..self.positions.nrows() {
                    out.extend(self.positions.row(r).iter());
                }
            }
        }
        out
    }

    /// This body's frames as joint states at `times_ns` (one time per row).
    pub fn to_joint_states(&self, times_ns: &[i64]) -> JointStates {
        JointStates {
            times_ns: times_ns.to_vec(),
            names: self.joint_names.clone(),
            positions: self.row_major(None),
        }
    }

    /// Rows `frames` of this body as a trajectory at `times` (seconds, one per frame).
    pub fn to_trajectory(
        &self,
        frames: &[usize],
        times: Vec<f64>,
    ) -> Result<Trajectory, PhysicsError> {
        Trajectory::new(
            self.joint_names.clone(),
            times,
            self.row_major(Some(frames)),
        )
    }
}

/// Median of `v` (0 for none), sorting it.
pub fn median(v: &mut [f64]) -> f64 {
    if v.is_empty() {
        return 0.0;
    }
    v.sort_by(|a, b| a.total_cmp(b));
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn conversions_round_trip() {
        let states = JointStates::new(
            vec![1_000_000_000, 1_025_000_000, 1_050_000_000],
            vec!["a".into(), "b".into()],
            vec![0.0, 1.0, 2.0, 3.0, 4.0, 5.0],
        )
        .expect("valid");
        let trajectory = Trajectory::try_from(&states).expect("trajectory");
        for (t, ns) in trajectory.times.iter().zip(&states.times_ns) {
            assert_eq!(*t, *ns as f64 * 1e-9);
        }
        assert_eq!(trajectory.positions, states.positions);
        assert_eq!(JointStates::try_from(&trajectory).expect("states"), states);

        let body = BodyData::from_joint_states("arm", "/arm/joint_states", &states).expect("body");
        assert_eq!(body.positions[(1, 0)], 2.0);
        assert_eq!(body.to_joint_states(&states.times_ns), states);
        let sub = body
            .to_trajectory(&[2, 0], vec![0.0, 0.5])
            .expect("trajectory");
        assert_eq!(sub.positions, vec![4.0, 5.0, 0.0, 1.0]);
        assert!(BodyData::from_rows("x", "/x", vec!["a".into()], 2, &[0.0]).is_err());
    }
}
