//! Training a per-part model: each part's shared GP-LVM on its own columns, then the parent on
//! the parts' latent points (see the module docs for why in two stages); and the transfer of the
//! whole structure to a new robot, each part learning only that robot's kernel.

use std::collections::BTreeMap;

use faer::{Mat, MatRef};

use super::{check_parts, sorted, Part, PartStage, PartsCallback, PartsConfig, PartsGplvm};
use super::{PartSpec, SpaceLayout};
use crate::config::{BackConstraint, ModelConfig};
use crate::error::{Error, Result};
use crate::model::{Callback, SharedGplvm};
use crate::preprocess::checked_order;
use crate::train::{Control, IterationRecord, TrainOptions};
use crate::validation::Validation;

impl PartsGplvm {
    /// Trains a shared GP-LVM per part of `config.parts` on its columns of `spaces` (named data
    /// matrices with the same rows; `input` the human), each with `config.model`, then the
    /// parent on their latent points. With `validation`, each part's iteration budget is chosen
    /// on the held-out rows ([`SharedGplvm::fit_validated`]); the parent is trained to
    /// convergence or `options.max_iters`. `options` (its budget and time limit) apply to each
    /// training. `callback` sees every iteration of each, with the model it belongs to.
    pub fn fit(
        config: &PartsConfig,
        spaces: &[(&str, MatRef<'_, f64>)],
        input: &str,
        options: &TrainOptions,
        validation: Option<&Validation>,
        mut callback: Option<PartsCallback<'_>>,
    ) -> Result<Self> {
        config.model.check()?;
        options.check_for(&config.model)?;
        let order = checked_order(spaces, input, config.model.latent_dim)?;
        let dims: Vec<(&str, usize)> = order
            .iter()
            .map(|&i| (spaces[i].0, spaces[i].1.ncols()))
            .collect();
        check_parts(&config.parts, &dims, Some(input))?;
        if config.parent_latent_dim == Some(0) {
            return Err(Error::InvalidValue {
                what: "PartsConfig::parent_latent_dim".into(),
                reason: "0; expected at least 1, or no parent (None)".into(),
            });
        }
        let count = config.parts.len();
        let mut parts = Vec::with_capacity(count);
        for (index, spec) in config.parts.iter().enumerate() {
            let columns = sorted(spec);
            let data: Vec<Mat<f64>> = spaces
                .iter()
                .map(|(name, m)| Self::columns_of(*m, &columns[*name]))
                .collect();
            let part_spaces: Vec<(&str, MatRef<'_, f64>)> = spaces
                .iter()
                .zip(&data)
                .map(|((name, _), m)| (*name, m.as_ref()))
                .collect();
            let stage = PartStage::Part {
                index,
                count,
                name: &spec.name,
            };
            let model = with_stage(&mut callback, stage, |cb| match validation {
                Some(v) => {
                    SharedGplvm::fit_validated(&config.model, &part_spaces, input, options, v, cb)
                }
                None => SharedGplvm::fit(&config.model, &part_spaces, input, options, cb),
            })
            .map_err(|e| e.in_part(&spec.name))?;
            parts.push(Part {
                name: spec.name.clone(),
                columns,
                model,
            });
        }
        let parent = match config.parent_latent_dim {
            Some(q) => Some(fit_parent(
                &parts,
                &config.model,
                q,
                options,
                &mut callback,
            )?),
            None => None,
        };
        let spaces = dims
            .iter()
            .map(|&(name, dim)| SpaceLayout {
                name: name.to_string(),
                dim,
                columns: None,
            })
            .collect();
        Ok(PartsGplvm {
            spaces,
            parts,
            parent,
        })
    }

    /// A new model that also predicts robot `name` from `data` (its rows the training frames):
    /// `columns` gives each part's columns of `data` (part name → column indices, every column
    /// in exactly one part). Every part's latent points, human kernel and existing robots, and
    /// the parent, stay frozen; each part learns only the new robot's kernel on its columns
    /// ([`SharedGplvm::transfer`], or with `validation` [`SharedGplvm::transfer_validated`]).
    /// `self` is not changed.
    pub fn transfer(
        &self,
        name: &str,
        data: MatRef<'_, f64>,
        columns: &BTreeMap<String, Vec<usize>>,
        options: &TrainOptions,
        validation: Option<&Validation>,
        mut callback: Option<PartsCallback<'_>>,
    ) -> Result<Self> {
        if self.spaces.iter().any(|s| s.name == name) {
            return Err(Error::DuplicateSpace { name: name.into() });
        }
        let specs: Vec<PartSpec> = self
            .parts
            .iter()
            .map(|p| PartSpec {
                name: p.name.clone(),
                columns: columns
                    .get(&p.name)
                    .map(|c| BTreeMap::from([(name.to_string(), c.clone())]))
                    .unwrap_or_default(),
            })
            .collect();
        if let Some(unknown) = columns.keys().find(|k| self.part(k).is_none()) {
            return Err(Error::InvalidValue {
                what: "body parts".into(),
                reason: format!(
                    "columns given for part '{unknown}', which the model does not have; its \
                     parts are {:?}",
                    self.part_names()
                ),
            });
        }
        check_parts(&specs, &[(name, data.ncols())], None)?;
        let count = self.parts.len();
        let mut out = self.clone();
        for (index, (part, spec)) in out.parts.iter_mut().zip(&specs).enumerate() {
            let cols = sorted(spec).remove(name).unwrap_or_default();
            let own = Self::columns_of(data, &cols);
            let stage = PartStage::Part {
                index,
                count,
                name: &part.name,
            };
            let source = &part.model;
            let transferred = with_stage(&mut callback, stage, |cb| match validation {
                Some(v) => source.transfer_validated(name, own.as_ref(), None, options, v, cb),
                None => source.transfer(name, own.as_ref(), options, cb),
            })
            .map_err(|e| e.in_part(&part.name))?;
            part.model = transferred;
            part.columns.insert(name.to_string(), cols);
        }
        out.spaces.push(SpaceLayout {
            name: name.to_string(),
            dim: data.ncols(),
            columns: None,
        });
        Ok(out)
    }
}

/// Runs `train` with a [`Callback`] that hands `stage` to the per-part `callback` (none when
/// there is none).
fn with_stage<T>(
    callback: &mut Option<PartsCallback<'_>>,
    stage: PartStage<'_>,
    train: impl FnOnce(Option<Callback<'_>>) -> Result<T>,
) -> Result<T> {
    match callback {
        Some(cb) => {
            let mut inner =
                |rec: &IterationRecord, m: &SharedGplvm| -> Control { cb(stage, rec, m) };
            train(Some(&mut inner))
        }
        None => train(None),
    }
}

/// The parent: a shared GP-LVM whose spaces are the parts' latent points (named after the
/// parts; the first is its input, whose GP regression to the parent's latent points it fits as
/// every model without input back constraints does), free latent points of dimension `q`
/// started from their PCA, sparse with the parts' inducing count when the parts are.
fn fit_parent(
    parts: &[Part],
    model: &ModelConfig,
    q: usize,
    options: &TrainOptions,
    callback: &mut Option<PartsCallback<'_>>,
) -> Result<SharedGplvm> {
    let latent: Vec<Mat<f64>> = parts
        .iter()
        .map(|p| p.model.latent_points().to_owned())
        .collect();
    let n = latent[0].nrows();
    let spaces: Vec<(&str, MatRef<'_, f64>)> = parts
        .iter()
        .zip(&latent)
        .map(|(p, x)| (p.name.as_str(), x.as_ref()))
        .collect();
    if spaces.len() < 2 {
        return Err(Error::InvalidValue {
            what: "PartsConfig::parent_latent_dim".into(),
            reason: "a parent joins two or more parts; with one part, give None".into(),
        });
    }
    let config = ModelConfig::default()
        .with_latent_dim(q)
        .with_back_constraint(BackConstraint::None)
        .with_seed(model.seed)
        .with_inducing(model.inducing.map(|m| m.min(n)));
    with_stage(callback, PartStage::Parent, |cb| {
        SharedGplvm::fit(&config, &spaces, &parts[0].name, options, cb)
    })
    .map_err(|e| e.in_part("parent"))
}
