//! A latent space per body part (the paper's future work, §V-B): a shared GP-LVM per part —
//! e.g. the left arm's human joints with each robot's left-arm joints, likewise the right —
//! joined by a parent latent space above them, after Lawrence & Moore's hierarchical GP-LVM.
//!
//! For parts p = 1 … P, each space s (the human input, each robot) is cut into column groups
//! `Y_s = [Y_s^1 … Y_s^P]`. Part p is a [`SharedGplvm`] of its own: latent points `X^p`
//! (N × Q), back-constrained on its own human columns `X^p = K_bc(H^p, H^p) W^p` (the paper's
//! choice; free or output constraints as [`ModelConfig::back_constraint`] says) and one RBF-ARD
//! GP per space, minimising `L^p = Σ_s L_s(Y_s^p | X^p)` (the `likelihood` module's, or the
//! sparse or Bayesian bound). The parent is a shared GP-LVM whose observation spaces are the
//! parts' latent points: free latent points `Z` (N × Q_Z) and one GP per part,
//! `−log p(X^1 … X^P | Z) = Σ_p L(X^p | Z)`.
//!
//! **Two stages, not one joint optimisation.** Lawrence & Moore minimise
//! `Σ_p L^p + Σ_p L(X^p | Z)` jointly. Here the parts are trained first (each alone, each its
//! own iteration budget), then the parent on their latent points. Why:
//! - with learnt kernels, every `L^p` is unchanged when `X^p` is scaled (the lengthscales follow
//!   it), while the parent's term falls without bound as `X^p` shrinks: the joint objective has
//!   no minimum unless the parts' scale is pinned by a further choice;
//! - prediction goes human part → `X^p` → robot part, never through the parent; the parent
//!   could only change predictions by pulling each part's latent space towards the pairings of
//!   left and right motions seen in training — the entanglement a latent space per part is
//!   there to avoid (a new pairing of known arm motions is predicted as each arm's own motion);
//! - each part is then exactly a model of the kind the crate already trains, checks and stores
//!   (exact, sparse or Bayesian, with early stopping, trust thresholds and transfer).
//!
//! The parent is the whole body's latent space: the parts' latent points of every training frame
//! in one place, for figures, sampling coordinated motion or a policy learnt over both arms. It
//! is trained when asked for ([`PartsConfig::parent_latent_dim`]): it changes no prediction, and
//! its free latent points train as long as both arms' models together (4.7 s against 0.4 s on
//! the 263 frames of `captured.mcap`; 5 of the 12 minutes on 50,796 frames, BENCHMARKS.md).
//!
//! **Transfer** moves the whole structure: every part's latent points (its back-constraint
//! weights), its human kernel and the parent stay frozen; the new robot's columns are cut into
//! the same parts and each part learns only that robot's kernel ([`PartsGplvm::transfer`]).
//!
//! The core knows nothing of arms: the caller names the parts and gives their columns
//! ([`PartSpec`]); the facade derives them from joint names and robot anatomy.

use std::collections::BTreeMap;

use faer::{Mat, MatRef};
use serde::{Deserialize, Serialize};

use crate::config::ModelConfig;
use crate::error::{Error, Result};
use crate::model::SharedGplvm;
use crate::train::{Control, IterationRecord};

mod fit;
pub(crate) mod io;
mod predict;

/// What a per-part file holds, for [`Error::WrongModelKind`].
pub(crate) const PARTS_KIND: &str = "a model with a latent space per body part";
/// What a single-latent-space file holds, for [`Error::WrongModelKind`].
pub(crate) const SINGLE_KIND: &str = "a model with one shared latent space";
/// What reads a per-part file.
pub(crate) const READ_PARTS: &str = "it is read by PartsGplvm::load or AnyModel::load (Rust), \
     sgplvm.PartsGPLVM.load or sgplvm.load_model (Python), and by the commands predict, \
     transfer, joints and experiment";
/// What reads a single-latent-space file.
pub(crate) const READ_SINGLE: &str = "it is read by SharedGplvm::load or AnyModel::load \
     (Rust), sgplvm.SharedGPLVM.load or sgplvm.load_model (Python)";

/// One body part: its name and, for each space, the columns of that space it holds (0-based,
/// in the space's column order).
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct PartSpec {
    /// The part's name (e.g. `left`), unique among the parts.
    pub name: String,
    /// Space name → the columns of that space in this part.
    pub columns: BTreeMap<String, Vec<usize>>,
}

impl PartSpec {
    /// A part called `name` holding `columns` (space name, column indices) of each space.
    pub fn new<S: Into<String>>(
        name: impl Into<String>,
        columns: impl IntoIterator<Item = (S, Vec<usize>)>,
    ) -> PartSpec {
        PartSpec {
            name: name.into(),
            columns: columns.into_iter().map(|(s, c)| (s.into(), c)).collect(),
        }
    }
}

/// How a [`PartsGplvm`] is built: the model configuration every part is trained with, the
/// parts, and the parent's latent dimension.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PartsConfig {
    /// Every part's configuration (latent dimension, back constraint, seed, sparse or
    /// Bayesian): each part is a model of this kind on its own columns.
    pub model: ModelConfig,
    /// The parts, each space's columns divided among them (each column in at most one part,
    /// every output column in one, every part with at least one column of every space): a
    /// human column in no part is not an input (the other arm, for a one-armed robot).
    pub parts: Vec<PartSpec>,
    /// Latent dimension of the parent above the parts (`None`, the default: no parent; no
    /// prediction uses it, and on many frames it costs as much as the parts: see the module
    /// docs).
    pub parent_latent_dim: Option<usize>,
}

impl PartsConfig {
    /// Parts `parts` of models configured as `model`, without a parent
    /// ([`PartsConfig::with_parent_latent_dim`] adds one).
    pub fn new(model: ModelConfig, parts: Vec<PartSpec>) -> PartsConfig {
        PartsConfig {
            parent_latent_dim: None,
            model,
            parts,
        }
    }

    /// Sets the parent's latent dimension (`None`: no parent).
    pub fn with_parent_latent_dim(mut self, q: Option<usize>) -> PartsConfig {
        self.parent_latent_dim = q;
        self
    }
}

/// Which model of a per-part training an iteration belongs to ([`PartsCallback`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PartStage<'a> {
    /// Part `index` (of `count`), called `name`.
    Part {
        /// Position among the parts.
        index: usize,
        /// Number of parts.
        count: usize,
        /// The part's name.
        name: &'a str,
    },
    /// The parent above the parts, trained last.
    Parent,
}

/// Callback of a per-part training: the model being trained, each accepted iteration and a
/// snapshot of that model; [`Control::Stop`] ends that model's training (the next one starts).
pub type PartsCallback<'c> =
    &'c mut dyn FnMut(PartStage<'_>, &IterationRecord, &SharedGplvm) -> Control;

/// One space of a per-part model: its name, its number of columns, and the columns' names
/// when known.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct SpaceLayout {
    pub name: String,
    pub dim: usize,
    pub columns: Option<Vec<String>>,
}

/// One body part of a trained [`PartsGplvm`].
#[derive(Clone, Debug)]
pub(crate) struct Part {
    pub name: String,
    /// Space name → this part's columns of it (ascending positions in the whole space).
    pub columns: BTreeMap<String, Vec<usize>>,
    /// The part's shared GP-LVM over those columns (spaces named as the whole model's).
    pub model: SharedGplvm,
}

/// A shared GP-LVM per body part joined by a parent latent space (see the module docs): trained
/// by [`PartsGplvm::fit`], extended to a new robot by [`PartsGplvm::transfer`] (only that
/// robot's kernel of each part is trained), predicting per part by [`PartsGplvm::predict`] and
/// [`PartsGplvm::predict_frame`], stored by [`PartsGplvm::save`] (format
/// [`crate::PARTS_FORMAT_VERSION`]).
#[derive(Clone, Debug)]
pub struct PartsGplvm {
    /// Input first, then the robots in the order the parts' models hold them.
    pub(crate) spaces: Vec<SpaceLayout>,
    pub(crate) parts: Vec<Part>,
    pub(crate) parent: Option<SharedGplvm>,
}

impl PartsGplvm {
    /// Name of the input (human) space.
    pub fn input_name(&self) -> &str {
        &self.spaces[0].name
    }

    /// Names of the output (robot) spaces, in model order.
    pub fn output_names(&self) -> Vec<&str> {
        self.spaces[1..].iter().map(|s| s.name.as_str()).collect()
    }

    /// Number of columns of a space, if the model has it.
    pub fn space_dim(&self, name: &str) -> Option<usize> {
        self.space(name).map(|s| s.dim)
    }

    /// Column (joint) names of a space, if set.
    pub fn column_names(&self, space: &str) -> Option<&[String]> {
        self.space(space).and_then(|s| s.columns.as_deref())
    }

    /// Stores column (joint) names of a space (in the whole space's order; each part's model
    /// gets its own columns' names). Saved with the model.
    pub fn set_column_names(&mut self, space: &str, names: Vec<String>) -> Result<()> {
        let known: Vec<String> = self.spaces.iter().map(|s| s.name.clone()).collect();
        let Some(layout) = self.spaces.iter_mut().find(|s| s.name == space) else {
            return Err(Error::UnknownSpace {
                name: space.into(),
                known,
            });
        };
        if names.len() != layout.dim {
            return Err(Error::DimensionMismatch {
                what: format!("column names of '{space}'"),
                expected: layout.dim,
                found: names.len(),
            });
        }
        for part in &mut self.parts {
            let own = part.columns[space].iter().map(|&c| names[c].clone());
            part.model.set_column_names(space, own.collect())?;
        }
        layout.columns = Some(names);
        Ok(())
    }

    /// Stores the groups of training frames every part's trust thresholds hold out in turn
    /// ([`SharedGplvm::set_trust_groups`]).
    pub fn set_trust_groups(&mut self, groups: &[usize]) -> Result<()> {
        for part in &mut self.parts {
            part.model
                .set_trust_groups(groups.to_vec())
                .map_err(|e| e.in_part(&part.name))?;
        }
        Ok(())
    }

    /// The human's joint limits (one `(lower, upper)` per human column of the whole model):
    /// each part's novelty threshold is calibrated within its own columns' limits
    /// ([`SharedGplvm::set_pose_bounds`]), following 1 %^(1/P) of its random poses for P
    /// parts, so that 1 % of random whole frames (every part followed) are.
    pub fn set_pose_bounds(&mut self, bounds: &[(f64, f64)]) -> Result<()> {
        let input = self.input_name().to_string();
        let d = self.space_dim(&input).unwrap_or(0);
        if bounds.len() != d {
            return Err(Error::DimensionMismatch {
                what: "pose bounds (one per human joint)".into(),
                expected: d,
                found: bounds.len(),
            });
        }
        let followed = crate::RANDOM_PERCENTILE.powf(1.0 / self.parts.len().max(1) as f64);
        for k in 0..self.parts.len() {
            let name = self.parts[k].name.clone();
            let columns = self.part_columns(&name, &input).unwrap_or(&[]).to_vec();
            self.parts[k]
                .model
                .set_pose_bounds(columns.iter().map(|&c| bounds[c]).collect(), followed)
                .map_err(|e| e.in_part(&name))?;
        }
        Ok(())
    }

    /// The mean of each human column over the training frames ([`SharedGplvm::input_means`]),
    /// whole-space positions, each from the part that holds it.
    pub fn input_means(&self) -> Vec<f64> {
        let input = self.input_name();
        let mut out = vec![0.0; self.space_dim(input).unwrap_or(0)];
        for part in &self.parts {
            for (&c, m) in part.columns[input].iter().zip(part.model.input_means()) {
                out[c] = m;
            }
        }
        out
    }

    /// The parts' names, in order.
    pub fn part_names(&self) -> Vec<&str> {
        self.parts.iter().map(|p| p.name.as_str()).collect()
    }

    /// The shared GP-LVM of part `name` (its spaces hold the part's columns only).
    pub fn part(&self, name: &str) -> Option<&SharedGplvm> {
        self.parts.iter().find(|p| p.name == name).map(|p| &p.model)
    }

    /// The columns of `space` that part `name` holds (positions in the whole space).
    pub fn part_columns(&self, name: &str, space: &str) -> Option<&[usize]> {
        let part = self.parts.iter().find(|p| p.name == name)?;
        part.columns.get(space).map(Vec::as_slice)
    }

    /// The parts as [`PartSpec`]s (every space's columns of each part).
    pub fn part_specs(&self) -> Vec<PartSpec> {
        self.parts
            .iter()
            .map(|p| PartSpec {
                name: p.name.clone(),
                columns: p.columns.clone(),
            })
            .collect()
    }

    /// The parent above the parts: a shared GP-LVM whose spaces are the parts' latent points
    /// (named after the parts), with free latent points; `None` when trained without one.
    pub fn parent(&self) -> Option<&SharedGplvm> {
        self.parent.as_ref()
    }

    /// What users attached to the model ([`SharedGplvm::annotations`]): kept with the first
    /// part's model, so through saving, loading and transfer as a single model's are.
    pub fn annotations(&self) -> &std::collections::BTreeMap<String, serde_json::Value> {
        self.parts[0].model.annotations()
    }

    /// Attaches `value` under `key` ([`SharedGplvm::annotate`]).
    pub fn annotate(&mut self, key: &str, value: serde_json::Value) {
        self.parts[0].model.annotate(key, value);
    }

    /// The configuration the parts were trained with.
    pub fn config(&self) -> &ModelConfig {
        self.parts[0].model.config()
    }

    /// Number of training frames N.
    pub fn num_points(&self) -> usize {
        self.parts[0].model.num_points()
    }

    /// Latent dimensions over all parts (the columns of [`PartsGplvm::latent`]: each part's Q,
    /// in part order).
    pub fn latent_dim(&self) -> usize {
        self.parts.iter().map(|p| p.model.config().latent_dim).sum()
    }

    /// Training seconds of every part and the parent (selection runs included).
    pub fn training_seconds(&self) -> f64 {
        self.parts
            .iter()
            .map(|p| &p.model)
            .chain(&self.parent)
            .map(SharedGplvm::training_seconds)
            .sum()
    }

    fn space(&self, name: &str) -> Option<&SpaceLayout> {
        self.spaces.iter().find(|s| s.name == name)
    }

    /// The columns `cols` of `m`.
    pub(crate) fn columns_of(m: MatRef<'_, f64>, cols: &[usize]) -> Mat<f64> {
        Mat::from_fn(m.nrows(), cols.len(), |i, j| m[(i, cols[j])])
    }
}

/// Checks that `parts` divide the columns of every space (`dims`: name and columns) among them:
/// unique non-empty names, known spaces, every part with at least one column of every space,
/// every column in exactly one part — except that columns of space `input`, where given, may
/// be in no part (inputs the model does not use). Errors name the part, the space and the
/// column.
pub(crate) fn check_parts(
    parts: &[PartSpec],
    dims: &[(&str, usize)],
    input: Option<&str>,
) -> Result<()> {
    let bad = |reason: String| {
        Err(Error::InvalidValue {
            what: "body parts".into(),
            reason,
        })
    };
    if parts.is_empty() {
        return bad("no part given; expected at least one".into());
    }
    let known: Vec<&str> = dims.iter().map(|(n, _)| *n).collect();
    for (k, part) in parts.iter().enumerate() {
        if part.name.trim().is_empty() {
            return bad(format!("part {k} has an empty name"));
        }
        if parts[..k].iter().any(|p| p.name == part.name) {
            return bad(format!("part name '{}' is used twice", part.name));
        }
        if let Some(s) = part.columns.keys().find(|s| !known.contains(&s.as_str())) {
            return bad(format!(
                "part '{}' names space '{s}', which is not one of {known:?}",
                part.name
            ));
        }
    }
    for &(space, dim) in dims {
        let mut owner: Vec<Option<&str>> = vec![None; dim];
        for part in parts {
            let cols = part.columns.get(space).map_or(&[][..], Vec::as_slice);
            if cols.is_empty() {
                return bad(format!(
                    "part '{}' has no column of space '{space}'; every part needs at least one \
                     column of every space",
                    part.name
                ));
            }
            for &c in cols {
                let Some(slot) = owner.get_mut(c) else {
                    return bad(format!(
                        "part '{}' names column {c} of space '{space}', which has {dim} columns \
                         (0 to {})",
                        part.name,
                        dim - 1
                    ));
                };
                if let Some(other) = slot.replace(&part.name) {
                    return bad(format!(
                        "column {c} of space '{space}' is in part '{other}' and in part '{}'; \
                         expected each column in exactly one part",
                        part.name
                    ));
                }
            }
        }
        let unused_allowed = input == Some(space);
        if let Some(c) = owner
            .iter()
            .position(Option::is_none)
            .filter(|_| !unused_allowed)
        {
            return bad(format!(
                "column {c} of space '{space}' is in no part; expected each column in exactly \
                 one part"
            ));
        }
    }
    Ok(())
}

/// `spec`'s columns sorted (a part's columns keep the whole space's order).
pub(crate) fn sorted(spec: &PartSpec) -> BTreeMap<String, Vec<usize>> {
    spec.columns
        .iter()
        .map(|(s, c)| {
            let mut c = c.clone();
            c.sort_unstable();
            (s.clone(), c)
        })
        .collect()
}

impl Error {
    /// This error as part `part`'s.
    pub(crate) fn in_part(self, part: &str) -> Error {
        Error::Part {
            part: part.to_string(),
            source: Box::new(self),
        }
    }
}

#[cfg(test)]
mod tests;
