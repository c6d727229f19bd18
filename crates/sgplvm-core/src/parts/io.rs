//! Per-part model files: format [`PARTS_FORMAT_VERSION`] (4) behind the common header (magic,
//! version, payload length, FNV-1a hash; see the `io` module). The JSON payload:
//!
//! | field | content |
//! |---|---|
//! | `spaces` | every space, input first: `name`, `dim` (columns), `columns` (joint names or null) |
//! | `parts` | every part: `name`, `columns` (space name → its columns), `version` (2 or 3) and `model`, that part's payload in that format |
//! | `parent` | null, or `version` and `model`: the parent's payload (spaces named after the parts) |
//!
//! Reading checks that the parts divide every space's columns, that each part's model has the
//! file's spaces with its share of their columns and the same training frames, and that the
//! parent's spaces are the parts' latent points; each payload is read by the single model's
//! code (the same checks, caches rebuilt the same way: predictions after a round trip are
//! bit-identical).

use std::collections::BTreeMap;
use std::path::Path;

use serde::{Deserialize, Serialize};

use super::{check_parts, Part, PartSpec, PartsGplvm, SpaceLayout};
use super::{PARTS_KIND, READ_SINGLE, SINGLE_KIND};
use crate::error::{Error, Result};
use crate::io::{read_file, split_header, with_header, write_atomically, ModelFile};
use crate::io::{FORMAT_VERSION, PARTS_FORMAT_VERSION};
use crate::model::SharedGplvm;

#[derive(Serialize, Deserialize)]
struct SpaceFile {
    name: String,
    dim: usize,
    columns: Option<Vec<String>>,
}

#[derive(Serialize, Deserialize)]
struct ModelEntry {
    /// The format the payload is of (2, or 3 for a Bayesian model).
    version: u32,
    model: ModelFile,
}

#[derive(Serialize, Deserialize)]
struct PartFile {
    name: String,
    columns: BTreeMap<String, Vec<usize>>,
    #[serde(flatten)]
    entry: ModelEntry,
}

#[derive(Serialize, Deserialize)]
struct PartsFile {
    spaces: Vec<SpaceFile>,
    parts: Vec<PartFile>,
    parent: Option<ModelEntry>,
}

fn corrupt(reason: String) -> Error {
    Error::Corrupt { reason }
}

impl ModelEntry {
    fn of(model: &SharedGplvm) -> ModelEntry {
        ModelEntry {
            version: model.file_version(),
            model: model.to_file(),
        }
    }

    fn read(self, what: &str) -> Result<SharedGplvm> {
        if !(1..PARTS_FORMAT_VERSION).contains(&self.version) {
            return Err(corrupt(format!(
                "{what}: format {} inside a per-part file; expected 1 to {}",
                self.version,
                PARTS_FORMAT_VERSION - 1
            )));
        }
        SharedGplvm::from_versioned_file(self.version, self.model).map_err(|e| match e {
            Error::Corrupt { reason } => corrupt(format!("{what}: {reason}")),
            e @ (Error::TooLarge { .. } | Error::TooLargeSparse { .. }) => e,
            e => corrupt(format!("{what}: {e}")),
        })
    }
}

impl PartsGplvm {
    /// The model as bytes (format [`PARTS_FORMAT_VERSION`]; see the module docs).
    pub fn to_bytes(&self) -> Vec<u8> {
        let file = PartsFile {
            spaces: self
                .spaces
                .iter()
                .map(|s| SpaceFile {
                    name: s.name.clone(),
                    dim: s.dim,
                    columns: s.columns.clone(),
                })
                .collect(),
            parts: self
                .parts
                .iter()
                .map(|p| PartFile {
                    name: p.name.clone(),
                    columns: p.columns.clone(),
                    entry: ModelEntry::of(&p.model),
                })
                .collect(),
            parent: self.parent.as_ref().map(ModelEntry::of),
        };
        // Plain structs of finite numbers and strings: serialising cannot fail.
        let payload = serde_json::to_vec(&file).expect("model payload serialises to JSON");
        with_header(PARTS_FORMAT_VERSION, &payload)
    }

    /// Reads a model from bytes written by [`PartsGplvm::to_bytes`]; a single-latent-space
    /// file is [`Error::WrongModelKind`], other bad input the errors of
    /// [`SharedGplvm::from_bytes`].
    pub fn from_bytes(bytes: &[u8]) -> Result<Self> {
        let (version, payload) = split_header(bytes)?;
        if version != PARTS_FORMAT_VERSION {
            return Err(Error::WrongModelKind {
                found: SINGLE_KIND,
                expected: PARTS_KIND,
                read_with: READ_SINGLE,
            });
        }
        Self::from_payload(payload)
    }

    /// Writes the model to `path` atomically (as [`SharedGplvm::save`]).
    pub fn save(&self, path: &Path) -> Result<()> {
        write_atomically(path, &self.to_bytes())
    }

    /// Reads a model file written by [`PartsGplvm::save`].
    pub fn load(path: &Path) -> Result<Self> {
        Self::from_bytes(&read_file(path)?)
    }

    /// The model of a format-4 payload, every part and its place checked.
    pub(crate) fn from_payload(payload: &[u8]) -> Result<Self> {
        let file: PartsFile = serde_json::from_slice(payload)
            .map_err(|e| corrupt(format!("per-part payload: {e}")))?;
        let spaces = read_spaces(file.spaces)?;
        let dims: Vec<(&str, usize)> = spaces.iter().map(|s| (s.name.as_str(), s.dim)).collect();
        let specs: Vec<PartSpec> = file
            .parts
            .iter()
            .map(|p| PartSpec {
                name: p.name.clone(),
                columns: p.columns.clone(),
            })
            .collect();
        let input = dims.first().map(|&(name, _)| name);
        check_parts(&specs, &dims, input).map_err(|e| corrupt(e.to_string()))?;
        let mut parts = Vec::with_capacity(file.parts.len());
        for p in file.parts {
            let model = p.entry.read(&format!("part '{}'", p.name))?;
            check_part(&p.name, &p.columns, &model, &spaces)?;
            parts.push(Part {
                name: p.name,
                columns: p.columns,
                model,
            });
        }
        let n = parts[0].model.num_points();
        if let Some(p) = parts.iter().find(|p| p.model.num_points() != n) {
            return Err(corrupt(format!(
                "part '{}' has {} training frames, part '{}' {n}",
                p.name,
                p.model.num_points(),
                parts[0].name
            )));
        }
        let parent = file
            .parent
            .map(|e| e.read("parent"))
            .transpose()?
            .map(|m| check_parent(m, &parts))
            .transpose()?;
        Ok(PartsGplvm {
            spaces,
            parts,
            parent,
        })
    }
}

/// The spaces of a file: at least two, unique names, columns ≥ 1 and as many names.
fn read_spaces(files: Vec<SpaceFile>) -> Result<Vec<SpaceLayout>> {
    if files.len() < 2 {
        return Err(corrupt(format!(
            "{} spaces; expected the input and at least one robot",
            files.len()
        )));
    }
    let mut spaces: Vec<SpaceLayout> = Vec::with_capacity(files.len());
    for s in files {
        if spaces.iter().any(|t| t.name == s.name) || s.dim == 0 {
            return Err(corrupt(format!(
                "space '{}' is repeated or has no columns",
                s.name
            )));
        }
        if s.columns.as_ref().is_some_and(|c| c.len() != s.dim) {
            return Err(corrupt(format!(
                "space '{}': column names for {} of {} columns",
                s.name,
                s.columns.as_ref().map_or(0, Vec::len),
                s.dim
            )));
        }
        spaces.push(SpaceLayout {
            name: s.name,
            dim: s.dim,
            columns: s.columns,
        });
    }
    Ok(spaces)
}

/// Checks that part `name`'s model has the file's spaces, in order, with the part's share of
/// their columns (and of their names).
fn check_part(
    name: &str,
    columns: &BTreeMap<String, Vec<usize>>,
    model: &SharedGplvm,
    spaces: &[SpaceLayout],
) -> Result<()> {
    let names: Vec<&str> = std::iter::once(model.input_name())
        .chain(model.output_names())
        .collect();
    let expected: Vec<&str> = spaces.iter().map(|s| s.name.as_str()).collect();
    if names != expected {
        return Err(corrupt(format!(
            "part '{name}' models spaces {names:?}; the file's are {expected:?}"
        )));
    }
    for s in spaces {
        let cols = &columns[&s.name];
        if model.space_dim(&s.name) != Some(cols.len()) || !cols.windows(2).all(|w| w[0] < w[1]) {
            return Err(corrupt(format!(
                "part '{name}': its model's '{}' has {:?} columns; the part holds columns {cols:?}",
                s.name,
                model.space_dim(&s.name)
            )));
        }
        if let Some(all) = &s.columns {
            let own: Vec<String> = cols.iter().map(|&c| all[c].clone()).collect();
            if model.column_names(&s.name) != Some(own.as_slice()) {
                return Err(corrupt(format!(
                    "part '{name}': its '{}' joints are not the file's columns {cols:?}",
                    s.name
                )));
            }
        }
    }
    Ok(())
}

/// The parent after checking that its spaces are the parts' latent points.
fn check_parent(parent: SharedGplvm, parts: &[Part]) -> Result<SharedGplvm> {
    let names: Vec<&str> = std::iter::once(parent.input_name())
        .chain(parent.output_names())
        .collect();
    let expected: Vec<&str> = parts.iter().map(|p| p.name.as_str()).collect();
    let shapes_agree = parts.iter().all(|p| {
        parent.space_dim(&p.name) == Some(p.model.config().latent_dim)
            && parent.num_points() == p.model.num_points()
    });
    if names != expected || !shapes_agree {
        return Err(corrupt(format!(
            "the parent models spaces {names:?} of {} frames; expected the parts' latent points \
             {expected:?}",
            parent.num_points()
        )));
    }
    Ok(parent)
}

/// Checks that [`FORMAT_VERSION`] is the version of per-part files (a newer one would need its
/// own branch in [`PartsGplvm::from_bytes`]).
const _: () = assert!(FORMAT_VERSION == PARTS_FORMAT_VERSION);
