//! A robot's commands made from a model's output: each command joint is one of the model's
//! columns or a joint held at its hold value, so that a model of the arms drives a whole
//! robot, and a model of every joint can command the arms alone.

use super::{Anatomy, AnatomyError, AnatomyResult};

/// Where one command joint's value comes from.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Source {
    /// The model's output column.
    Column(usize),
    /// A joint held at this value.
    Held(f64),
}

/// How a robot's commands are made from a model's output columns.
#[derive(Debug, Clone, PartialEq)]
pub struct CommandColumns {
    names: Vec<String>,
    sources: Vec<Source>,
    model_columns: usize,
}

impl CommandColumns {
    /// The model's columns as they are (no anatomy known: e.g. raw output).
    pub fn identity(model_columns: &[String]) -> CommandColumns {
        CommandColumns {
            names: model_columns.to_vec(),
            sources: (0..model_columns.len()).map(Source::Column).collect(),
            model_columns: model_columns.len(),
        }
    }

    /// The command joints' names, in order.
    pub fn names(&self) -> &[String] {
        &self.names
    }

    /// How many columns a model's output row has.
    pub fn model_columns(&self) -> usize {
        self.model_columns
    }

    /// Whether the commands are the model's columns as they are.
    pub fn is_identity(&self) -> bool {
        self.sources.len() == self.model_columns
            && self
                .sources
                .iter()
                .enumerate()
                .all(|(k, s)| *s == Source::Column(k))
    }

    /// One command from one model output row (`out` as long as [`CommandColumns::names`]).
    pub fn fill(&self, model_row: &[f64], out: &mut [f64]) {
        for (o, s) in out.iter_mut().zip(&self.sources) {
            *o = match *s {
                Source::Column(c) => model_row.get(c).copied().unwrap_or(f64::NAN),
                Source::Held(v) => v,
            };
        }
    }

    /// One command's standard deviations from the model's (held joints: 0).
    pub fn fill_std(&self, model_std: &[f64], out: &mut [f64]) {
        for (o, s) in out.iter_mut().zip(&self.sources) {
            *o = match *s {
                Source::Column(c) => model_std.get(c).copied().unwrap_or(f64::NAN),
                Source::Held(_) => 0.0,
            };
        }
    }

    /// Many rows (row-major, the model's columns) as commands (row-major).
    pub fn rows(&self, model_rows: &[f64], std: bool) -> Vec<f64> {
        let d = self.model_columns.max(1);
        let mut out = vec![0.0; model_rows.len() / d * self.names.len()];
        for (row, o) in model_rows
            .chunks_exact(d)
            .zip(out.chunks_exact_mut(self.names.len().max(1)))
        {
            if std {
                self.fill_std(row, o);
            } else {
                self.fill(row, o);
            }
        }
        out
    }
}

impl Anatomy {
    /// The commands of this robot from a model whose output columns are `model_columns`: each
    /// command joint a model column, else held at its hold value. A command joint the model
    /// does not predict and the anatomy does not hold (an arm joint the model lacks) is an
    /// error naming it.
    pub fn command_columns(&self, model_columns: &[String]) -> AnatomyResult<CommandColumns> {
        let names = self.command_joint_names();
        let robot_names = self.robot.joint_names();
        // A model column that is no joint of the robot is a model of another robot.
        if let Some(stray) = model_columns.iter().find(|m| !robot_names.contains(m)) {
            return Err(AnatomyError::Joint {
                file: self.robot.source().to_string(),
                what: format!("model column {stray}"),
                message: format!(
                    "is not a movable joint of robot `{}`: the model was trained for another robot",
                    self.robot.name()
                ),
            });
        }
        let sources = names
            .iter()
            .map(|n| {
                if let Some(c) = model_columns.iter().position(|m| m == n) {
                    return Ok(Source::Column(c));
                }
                let i = self.robot.joint_index(n).unwrap_or(usize::MAX);
                if self.held.contains(&i) {
                    Ok(Source::Held(self.hold[i]))
                } else {
                    Err(AnatomyError::Joint {
                        file: self.robot.source().to_string(),
                        what: format!("command joint {n}"),
                        message: format!(
                            "is an arm joint here, one the model does not predict (it predicts {}): name the arms as retarget had them (--arm SIDE=FROM_LINK:TO_LINK, or robot --arm … --write to keep them beside the URDF), leave it out with --command-joints, or train on data that has it",
                            crate::names::few(model_columns, 6)
                        ),
                    })
                }
            })
            .collect::<AnatomyResult<Vec<_>>>()?;
        Ok(CommandColumns {
            names,
            sources,
            model_columns: model_columns.len(),
        })
    }
}
