//! The replay's input: a [`Trajectory`] of named joint columns over strictly increasing times
//! in seconds, and its validation.

use std::collections::HashMap;

use serde::Serialize;

use super::PhysicsError;

/// A joint trajectory: one row of positions per time, columns named after the model's joints.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Trajectory {
    /// Column names: the URDF names of the joints, in the order of the columns.
    pub joint_names: Vec<String>,
    /// Frame times in seconds, strictly increasing (40 Hz for the paper's data).
    pub times: Vec<f64>,
    /// Positions (rad, or m for prismatic joints), row-major: frame `i`, joint `j` at
    /// `positions[i * joint_names.len() + j]`.
    pub positions: Vec<f64>,
}

impl Trajectory {
    /// Builds a trajectory and checks it (see [`Trajectory::validate`]).
    pub fn new(
        joint_names: Vec<String>,
        times: Vec<f64>,
        positions: Vec<f64>,
    ) -> Result<Self, PhysicsError> {
        let trajectory = Trajectory {
            joint_names,
            times,
            positions,
        };
        trajectory.validate()?;
        Ok(trajectory)
    }

    /// Number of frames (rows).
    pub fn frames(&self) -> usize {
        self.times.len()
    }

    /// The positions of frame `i`, in column order, or `None` past the end.
    pub fn row(&self, i: usize) -> Option<&[f64]> {
        let n = self.joint_names.len();
        self.positions.get(i * n..(i + 1) * n)
    }

    /// Checks that there is at least one named, distinct column, at least two frames with
    /// finite strictly increasing times, one position per frame and column, all finite.
    pub fn validate(&self) -> Result<(), PhysicsError> {
        let n = self.joint_names.len();
        if n == 0 {
            return Err(PhysicsError::Trajectory {
                message: "no joint columns; expected at least one joint name".into(),
            });
        }
        let mut seen = HashMap::new();
        for (j, name) in self.joint_names.iter().enumerate() {
            if name.trim().is_empty() {
                return Err(PhysicsError::Trajectory {
                    message: format!("column {j} has an empty joint name"),
                });
            }
            if let Some(first) = seen.insert(name.as_str(), j) {
                return Err(PhysicsError::Trajectory {
                    message: format!(
                        "joint \"{name}\" names both column {first} and column {j}; expected each joint once"
                    ),
                });
            }
        }
        let frames = self.times.len();
        if frames < 2 {
            return Err(PhysicsError::Trajectory {
                message: format!("{frames} frame(s); expected at least 2 to define a motion"),
            });
        }
        for (i, t) in self.times.iter().enumerate() {
            if !t.is_finite() {
                return Err(PhysicsError::Trajectory {
                    message: format!("frame {i} has time {t}; expected a finite time in seconds"),
                });
            }
            if i > 0 && *t <= self.times[i - 1] {
                return Err(PhysicsError::Trajectory {
                    message: format!(
                        "frame {i} has time {t} s, not after frame {} at {} s; expected strictly increasing times",
                        i - 1,
                        self.times[i - 1]
                    ),
                });
            }
        }
        if self.positions.len() != frames * n {
            let rows = if self.positions.len().is_multiple_of(n) {
                format!(" ({} rows of {n})", self.positions.len() / n)
            } else {
                format!(" (not a whole number of rows of {n})")
            };
            return Err(PhysicsError::Trajectory {
                message: format!(
                    "{} position values{rows}; expected {frames} frames × {n} joint columns = {}",
                    self.positions.len(),
                    frames * n
                ),
            });
        }
        for (k, value) in self.positions.iter().enumerate() {
            if !value.is_finite() {
                let (frame, j) = (k / n, k % n);
                return Err(PhysicsError::NonFinitePosition {
                    frame,
                    time: self.times[frame],
                    joint: self.joint_names[j].clone(),
                    value: *value,
                });
            }
        }
        Ok(())
    }
}
