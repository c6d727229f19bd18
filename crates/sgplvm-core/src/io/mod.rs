//! Model files.
//!
//! Format (version 3 for the Bayesian model, 4 for a per-part model, else 2; version 1 is read
//! too), all integers little-endian:
//!
//! | bytes | content |
//! |---|---|
//! | 0..8 | magic `b"SGPLVM\0\0"` |
//! | 8..12 | format version, u32 (2, 3 for a Bayesian model, 4 for a per-part model) |
//! | 12..20 | payload length L, u64 |
//! | 20..28 | FNV-1a 64-bit hash of the payload, u64 |
//! | 28..28+L | payload: UTF-8 JSON (serde_json, `float_roundtrip`) |
//!
//! Since 2026-12 the payload may hold `trust`, each robot space's trust threshold (`trust`
//! module), and `trust_groups`, the groups of training frames they were computed by: files
//! without them load as before and get the thresholds computed when asked for (by consecutive
//! blocks of training frames). Since issue 44 it may also hold `reconstruction`, the human space's
//! reconstruction threshold (`reconstruction` module), computed by the same groups; files
//! without it load as before and get it computed when asked for. Both are optional fields of
//! format 2 (and 3): a library from before them ignores them. Since issue 48 it may hold
//! `annotations`, what users attach to a model (the facade stores the capture sources of the
//! training data there, with each person's calibration); optional, ignored by older libraries.
//! Since issue 49 it may hold `novelty`, the novelty threshold (`novelty` module), and
//! `pose_bounds`, the human's joint limits it was calibrated within; optional, computed when
//! asked for where absent, ignored by older libraries.
//! The payload holds the configuration, every space (name, centred/scaled data, offsets,
//! scales, kernel, column names), the latent parameters (X, or W + bandwidth + the
//! back-constraint data), the input-map hyperparameters, the training history and, for models
//! trained with a validation split, how their iteration budget was chosen. Version 2 adds the
//! sparse model (#14): `config.inducing` and the inducing inputs Z (`inducing`); for it the
//! back-constraint weights and data are those of the M centres. A version-1 file is a version-2
//! file of an exact model. The stop reason `ValidatedBudget` (issue 38) is new within version 2:
//! files written before it hold `MaxIterations` for a final run that ran out of its validated
//! budget, and are read as `ValidatedBudget` (the selection says so); a library from before it
//! refuses files that hold it, as a corrupt payload naming the unknown variant. Version 3 is
//! version 2 plus the Bayesian model (issue 34): `config.bayesian` and the variances of q(X)
//! (`latent_variance`, N×Q; the latent block then holds q(X)'s means). Only Bayesian models
//! are written as version 3, so that a library from before it refuses them by their version
//! instead of reading them as a point-latent sparse model; every other model is still version
//! 2, readable by older libraries. Version 4 (issue 49) is a per-part model
//! ([`crate::PartsGplvm`]): its payload names the spaces and the body parts' columns and holds a
//! version-2 or -3 payload per part and one for the parent (`parts::io`); reading one as a
//! single latent space, or a single latent space as one, is [`Error::WrongModelKind`], and a
//! library from before it refuses it by its version. Caches
//! (Cholesky factors, K⁻¹Y, X = K_bc W) are not stored: they are recomputed by the same code
//! that built them after training, so predictions after a round trip are bit-identical.
//! Files are written to a temporary file next to the target and renamed into place (see
//! `tempfiles`).

use std::path::Path;

use faer::Mat;
use serde::{Deserialize, Serialize};

use crate::config::ModelConfig;
use crate::error::{Error, Result};
use crate::input_map::InputMap;
use crate::kernel::KernelParams;
use crate::memory;
use crate::model::{Latent, SharedGplvm, Space};
use crate::train::{IterationRecord, StopReason};
use crate::validation::Selection;

mod envelope;

#[cfg(test)]
pub(crate) use envelope::with_payload;
#[cfg(test)]
use envelope::HEADER;
pub(crate) use envelope::{read_file, split_header, with_header, write_atomically};

/// Magic bytes at the start of every model file.
pub const MAGIC: &[u8; 8] = b"SGPLVM\0\0";
/// The newest format version this library writes; it reads every version from 1 to this one.
pub const FORMAT_VERSION: u32 = PARTS_FORMAT_VERSION;
/// The version of per-part model files ([`crate::PartsGplvm`], issue 49): a latent space per
/// body part, each a model of format 2 or 3 inside, and the parent above them (see
/// `parts::io`). A single-latent-space model is never written with it, so libraries from
/// before it read every such model as before and refuse per-part files by their version.
pub const PARTS_FORMAT_VERSION: u32 = 4;
/// The version written for Bayesian models.
const BAYESIAN_VERSION: u32 = 3;
/// The version written for models that are not Bayesian (unchanged since the sparse model).
const POINT_LATENT_VERSION: u32 = 2;

#[derive(Serialize, Deserialize)]
struct MatData {
    rows: usize,
    cols: usize,
    /// Column-major values.
    data: Vec<f64>,
}

impl MatData {
    fn from(m: &Mat<f64>) -> Self {
        let mut data = Vec::with_capacity(m.nrows() * m.ncols());
        for j in 0..m.ncols() {
            for i in 0..m.nrows() {
                data.push(m[(i, j)]);
            }
        }
        Self {
            rows: m.nrows(),
            cols: m.ncols(),
            data,
        }
    }

    fn to_mat(&self, what: &str) -> Result<Mat<f64>> {
        if self.rows.checked_mul(self.cols) != Some(self.data.len()) {
            return Err(Error::Corrupt {
                reason: format!(
                    "{what}: {}×{} matrix holds {} values",
                    self.rows,
                    self.cols,
                    self.data.len()
                ),
            });
        }
        if let Some(v) = self.data.iter().find(|v| !v.is_finite()) {
            return Err(Error::Corrupt {
                reason: format!("{what}: non-finite value {v}"),
            });
        }
        // Training stores standardised data, latent points and weights of order 1 (fit refuses
        // data beyond these scales): larger values only make predictions overflow to NaN.
        let max = crate::preprocess::ACCEPTED_SCALES.1;
        if let Some(v) = self.data.iter().find(|v| v.abs() > max) {
            return Err(Error::Corrupt {
                reason: format!(
                    "{what}: value {v:e} beyond ±{max:e} (a trained model's are of order 1)"
                ),
            });
        }
        Ok(Mat::from_fn(self.rows, self.cols, |i, j| {
            self.data[j * self.rows + i]
        }))
    }
}

#[derive(Serialize, Deserialize)]
struct SpaceFile {
    name: String,
    data: MatData,
    offset: Vec<f64>,
    scale: Vec<f64>,
    kernel: KernelParams,
    columns: Option<Vec<String>>,
}

#[derive(Serialize, Deserialize)]
enum LatentFile {
    Free {
        x: MatData,
    },
    Back {
        weights: MatData,
        bandwidth: f64,
        data: MatData,
    },
}

#[derive(Serialize, Deserialize)]
struct MapFile {
    kernel: KernelParams,
    x_mean: Vec<f64>,
}

/// A file's inconsistency as an error.
fn corrupt(reason: String) -> Error {
    Error::Corrupt { reason }
}

/// True when `k` holds finite positive values whose squared lengthscales and their inverses are
/// finite and normal: the kernel computes −d²/(2ℓ²) from them, and a file with ℓ = 10⁻²⁰⁰ (valid
/// as a number) would otherwise predict NaN. Variance and noise are those of standardised data
/// (of order 1): beyond ±10¹⁵³ they only overflow the covariance.
fn kernel_is_usable(k: &KernelParams) -> bool {
    let max = crate::preprocess::ACCEPTED_SCALES.1;
    k.is_valid()
        && k.variance <= max
        && k.noise <= max
        && k.lengthscale
            .iter()
            .all(|l| (l * l).is_normal() && (1.0 / (l * l)).is_normal())
}

impl SpaceFile {
    /// The space, after checking its shapes against `q` latent dimensions and its values.
    fn into_space(self, q: usize) -> Result<Space> {
        let s = self;
        let data = s.data.to_mat(&format!("space '{}' data", s.name))?;
        let d = data.ncols();
        if s.offset.len() != d || s.scale.len() != d {
            return Err(corrupt(format!(
                "space '{}': offset/scale length differs from {d} columns",
                s.name
            )));
        }
        if s.kernel.lengthscale.len() != q || !kernel_is_usable(&s.kernel) {
            return Err(corrupt(format!("space '{}': invalid kernel", s.name)));
        }
        if s.scale.iter().any(|v| !(v.is_finite() && *v > 0.0))
            || s.offset.iter().any(|v| !v.is_finite())
        {
            return Err(corrupt(format!("space '{}': invalid offset/scale", s.name)));
        }
        if let Some(c) = &s.columns {
            if c.len() != d {
                return Err(corrupt(format!(
                    "space '{}': {} column names for {d} columns",
                    s.name,
                    c.len()
                )));
            }
        }
        Ok(Space {
            name: s.name,
            data,
            offset: s.offset,
            scale: s.scale,
            kernel: s.kernel,
            columns: s.columns,
        })
    }
}

impl LatentFile {
    /// The latent representation, after checking that it is N×Q (and its data N rows).
    /// For a sparse model the back-constraint weights and data have `centres` rows.
    fn into_latent(self, n: usize, q: usize, centres: usize) -> Result<Latent> {
        let latent = match self {
            LatentFile::Free { x } => Latent::Free {
                x: x.to_mat("latent x")?,
            },
            LatentFile::Back {
                weights,
                bandwidth,
                data,
            } => {
                if !(bandwidth.is_finite() && bandwidth > 0.0) {
                    return Err(corrupt(format!("bandwidth {bandwidth}")));
                }
                Latent::Back {
                    weights: weights.to_mat("weights")?,
                    bandwidth,
                    data: data.to_mat("back-constraint data")?,
                }
            }
        };
        let (shape, expected) = match &latent {
            Latent::Free { x } => ((x.nrows(), x.ncols(), n), (n, q, n)),
            Latent::Back { weights, data, .. } => (
                (weights.nrows(), weights.ncols(), data.nrows()),
                (centres, q, centres),
            ),
        };
        if shape != expected {
            return Err(corrupt("latent parameters have the wrong shape".into()));
        }
        Ok(latent)
    }
}

impl MapFile {
    /// The input map, after checking it against `dh` human columns and `q` latent dimensions.
    fn into_map(self, dh: usize, q: usize) -> Result<InputMap> {
        if self.kernel.lengthscale.len() != dh
            || !kernel_is_usable(&self.kernel)
            || self.x_mean.len() != q
            || self.x_mean.iter().any(|v| !v.is_finite())
        {
            return Err(corrupt("input map has the wrong shape or values".into()));
        }
        Ok(InputMap {
            kernel: self.kernel,
            x_mean: self.x_mean,
        })
    }
}

/// The payload of a single-latent-space model file (format 2 or 3); a per-part file holds one
/// per part and one for the parent.
#[derive(Serialize, Deserialize)]
pub(crate) struct ModelFile {
    config: ModelConfig,
    spaces: Vec<SpaceFile>,
    latent: LatentFile,
    map: Option<MapFile>,
    history: Vec<IterationRecord>,
    stop_reason: Option<StopReason>,
    /// Absent in files of models trained without a validation split (and in files written
    /// before it existed).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    selection: Option<Selection>,
    /// Inducing inputs Z of a sparse model (format 2; absent for exact models).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    inducing: Option<MatData>,
    /// Variances of q(X) (N×Q) of a Bayesian model (format 3; absent otherwise).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    latent_variance: Option<MatData>,
    /// Trust threshold per robot space (`trust` module; absent in files written before it
    /// existed, whose thresholds are computed when asked for).
    #[serde(default, skip_serializing_if = "std::collections::BTreeMap::is_empty")]
    trust: std::collections::BTreeMap<String, f64>,
    /// The groups of training frames the thresholds hold out in turn (absent: consecutive
    /// blocks).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    trust_groups: Option<Vec<usize>>,
    /// The reconstruction threshold (`reconstruction` module; absent in files written before
    /// it existed, whose threshold is computed when asked for).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    reconstruction: Option<f64>,
    /// The human's joint limits the novelty threshold's random poses were drawn within, and
    /// the novelty threshold (`novelty` module; absent in files written before them: the
    /// threshold is then computed when asked for, from the held-out frames alone).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pose_bounds: Option<Vec<(f64, f64)>>,
    /// The share of random poses within them the threshold follows (absent: 1 %).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    random_followed: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    novelty: Option<f64>,
    /// What users attached to the model ([`SharedGplvm::annotations`]; absent when nothing
    /// was).
    #[serde(default, skip_serializing_if = "std::collections::BTreeMap::is_empty")]
    annotations: std::collections::BTreeMap<String, serde_json::Value>,
}

impl SharedGplvm {
    /// The model as bytes in the documented file format (see the `io` module docs).
    pub fn to_bytes(&self) -> Vec<u8> {
        let file = self.to_file();
        // Serialising plain structs of finite numbers and strings cannot fail.
        let payload = serde_json::to_vec(&file).expect("model payload serialises to JSON");
        with_header(self.file_version(), &payload)
    }

    /// The model's payload (see the `io` module docs).
    pub(crate) fn to_file(&self) -> ModelFile {
        ModelFile {
            config: self.config.clone(),
            spaces: self
                .spaces
                .iter()
                .map(|s| SpaceFile {
                    name: s.name.clone(),
                    data: MatData::from(&s.data),
                    offset: s.offset.clone(),
                    scale: s.scale.clone(),
                    kernel: s.kernel.clone(),
                    columns: s.columns.clone(),
                })
                .collect(),
            latent: match &self.latent {
                Latent::Free { x } => LatentFile::Free {
                    x: MatData::from(x),
                },
                Latent::Back {
                    weights,
                    bandwidth,
                    data,
                } => LatentFile::Back {
                    weights: MatData::from(weights),
                    bandwidth: *bandwidth,
                    data: MatData::from(data),
                },
            },
            // After `set_params`, the refitted map (the stored one if that refit fails, when
            // the model cannot predict either).
            map: match self.current_map() {
                Ok(m) => m,
                Err(_) => self.map.as_ref(),
            }
            .map(|m| MapFile {
                kernel: m.kernel.clone(),
                x_mean: m.x_mean.clone(),
            }),
            history: self.history.clone(),
            stop_reason: self.stop_reason.clone(),
            selection: self.selection.clone(),
            inducing: self.sparse.as_ref().map(|s| MatData::from(&s.z)),
            latent_variance: self
                .sparse
                .as_ref()
                .and_then(|s| s.latent_var.as_ref())
                .map(MatData::from),
            // A space whose threshold cannot be computed (a degenerate kernel matrix) is left
            // out: it is computed, and fails, when asked for.
            trust: self
                .output_names()
                .into_iter()
                .filter_map(|name| Some((name.to_string(), self.trust_threshold(name).ok()?)))
                .collect(),
            trust_groups: self.trust_groups.clone(),
            reconstruction: self.reconstruction_threshold().ok(),
            pose_bounds: self.pose_bounds.clone(),
            random_followed: self.pose_bounds.as_ref().map(|_| self.random_followed),
            novelty: self.novelty_threshold().ok(),
            annotations: self.annotations.clone(),
        }
    }

    /// Reads a model from bytes written by [`SharedGplvm::to_bytes`]; foreign, truncated,
    /// corrupted or other-version input is a typed error, and a per-part model's file
    /// ([`PARTS_FORMAT_VERSION`]) is [`Error::WrongModelKind`].
    pub fn from_bytes(bytes: &[u8]) -> Result<Self> {
        let (version, payload) = split_header(bytes)?;
        if version == PARTS_FORMAT_VERSION {
            return Err(Error::WrongModelKind {
                found: crate::parts::PARTS_KIND,
                expected: crate::parts::SINGLE_KIND,
                read_with: crate::parts::READ_PARTS,
            });
        }
        Self::from_payload(version, payload)
    }

    /// The model of a format-2 or -3 `payload` (the file's `version`), every shape checked.
    pub(crate) fn from_payload(version: u32, payload: &[u8]) -> Result<Self> {
        let file: ModelFile = serde_json::from_slice(payload).map_err(|e| Error::Corrupt {
            reason: format!("payload: {e}"),
        })?;
        Self::from_versioned_file(version, file)
    }

    /// The model `file` describes, checked against the file `version` it came in (Bayesian
    /// models are format 3, others 2 or older).
    pub(crate) fn from_versioned_file(version: u32, file: ModelFile) -> Result<Self> {
        if file.config.bayesian != (version == BAYESIAN_VERSION) {
            return Err(Error::Corrupt {
                reason: format!(
                    "a file of format {version} with config.bayesian = {}; Bayesian models are \
                     format {BAYESIAN_VERSION}, others format {POINT_LATENT_VERSION} or older",
                    file.config.bayesian
                ),
            });
        }
        Self::from_file(file)
    }

    /// The version a model of this kind is written with (2, or 3 for a Bayesian model).
    pub(crate) fn file_version(&self) -> u32 {
        match self.config.bayesian {
            true => BAYESIAN_VERSION,
            false => POINT_LATENT_VERSION,
        }
    }
}

impl SharedGplvm {
    /// The model a parsed file describes, every shape checked, caches rebuilt.
    fn from_file(f: ModelFile) -> Result<Self> {
        f.config.check()?;
        let q = f.config.latent_dim;
        if f.spaces.len() < 2 {
            return Err(corrupt(format!(
                "{} spaces; expected at least 2",
                f.spaces.len()
            )));
        }
        let spaces = f
            .spaces
            .into_iter()
            .map(|s| s.into_space(q))
            .collect::<Result<Vec<_>>>()?;
        for (i, s) in spaces.iter().enumerate() {
            if spaces[..i].iter().any(|t| t.name == s.name) {
                return Err(corrupt(format!("space '{}' appears twice", s.name)));
            }
        }
        let n = spaces[0].data.nrows();
        if q == 0
            || q >= n
            || spaces
                .iter()
                .any(|s| s.data.nrows() != n || s.data.ncols() == 0)
        {
            return Err(corrupt("space shapes are inconsistent".into()));
        }
        let inducing = match (f.config.inducing, f.inducing) {
            (None, None) => None,
            (Some(m), Some(z)) => {
                let z = z.to_mat("inducing inputs")?;
                if z.nrows() != m || z.ncols() != q || m > n {
                    return Err(corrupt(format!(
                        "inducing inputs are {}×{}; expected {m}×{q} with {m} ≤ {n} frames",
                        z.nrows(),
                        z.ncols()
                    )));
                }
                Some(z)
            }
            _ => {
                return Err(corrupt(
                    "config.inducing and the inducing inputs must be given together".into(),
                ))
            }
        };
        let centres = match &inducing {
            Some(z) => {
                let dims: Vec<usize> = spaces.iter().map(|s| s.data.ncols()).collect();
                memory::check_sparse("loading the model", n, z.nrows(), q, &dims)?;
                z.nrows()
            }
            None => {
                memory::check("loading the model", n, memory::load_matrices(spaces.len()))?;
                n
            }
        };
        let latent = f.latent.into_latent(n, q, centres)?;
        let map = f
            .map
            .map(|m| m.into_map(spaces[0].data.ncols(), q))
            .transpose()?;
        let latent_var = match (f.config.bayesian, f.latent_variance) {
            (false, None) => None,
            (true, Some(s)) => {
                let s = s.to_mat("latent variances")?;
                let ok = s
                    .col_iter()
                    .all(|c| c.iter().all(|v| v.is_finite() && *v > 0.0));
                if s.nrows() != n || s.ncols() != q || !ok {
                    return Err(corrupt(format!(
                        "latent variances are {}×{}; expected {n}×{q} finite values > 0",
                        s.nrows(),
                        s.ncols()
                    )));
                }
                Some(s)
            }
            _ => {
                return Err(corrupt(
                    "config.bayesian and the latent variances must be given together".into(),
                ))
            }
        };
        let mut model = SharedGplvm::new(f.config, spaces, latent);
        model.sparse =
            inducing.map(|z| crate::sparse::SparseState::new(z).with_latent_var(latent_var));
        model.map = map;
        model.history = f.history;
        // Files written before `StopReason::ValidatedBudget` (issue 38) recorded a final run
        // that ran out of its validated budget as `MaxIterations`: read as what it was.
        model.stop_reason = match &f.selection {
            Some(s) => s.final_stop_reason(f.stop_reason),
            None => f.stop_reason,
        };
        model.selection = f.selection;
        for (space, t) in &f.trust {
            if model.output_index(space).is_err() || !(t.is_finite() && *t >= 0.0) {
                return Err(corrupt(format!("trust threshold {t} of space '{space}'")));
            }
        }
        if let Some(groups) = f.trust_groups {
            model
                .set_trust_groups(groups)
                .map_err(|e| corrupt(format!("trust_groups: {e}")))?;
        }
        model.trust = f.trust;
        if let Some(t) = f.reconstruction {
            if !(t.is_finite() && t >= 0.0) {
                return Err(corrupt(format!("reconstruction threshold {t}")));
            }
            model.reconstruction = Some(t);
        }
        if let Some(bounds) = f.pose_bounds {
            let followed = f
                .random_followed
                .unwrap_or(crate::novelty::RANDOM_PERCENTILE);
            model
                .set_pose_bounds(bounds, followed)
                .map_err(|e| corrupt(format!("pose_bounds: {e}")))?;
        }
        if let Some(t) = f.novelty {
            if !(t.is_finite() && t >= 0.0) {
                return Err(corrupt(format!("novelty threshold {t}")));
            }
            model.novelty = Some(t);
        }
        model.annotations = f.annotations;
        model.rebuild()?;
        Ok(model)
    }

    /// What users attached to the model under each key ([`SharedGplvm::annotate`]): opaque to
    /// the model, kept through saving and loading, transfer and new parameters.
    pub fn annotations(&self) -> &std::collections::BTreeMap<String, serde_json::Value> {
        &self.annotations
    }

    /// Attaches `value` under `key` (replacing what was there), e.g. where the training data
    /// came from; `Value::Null` removes the key.
    pub fn annotate(&mut self, key: &str, value: serde_json::Value) {
        if value.is_null() {
            self.annotations.remove(key);
        } else {
            self.annotations.insert(key.to_string(), value);
        }
    }

    /// Writes the model to `path` atomically (hidden temporary file `.NAME.tmpPID` in the same
    /// directory, then rename), so no half-written model file is ever left behind; the
    /// temporaries of earlier writers of `path` that were killed are removed first. Errors
    /// name `path`, not the temporary file.
    pub fn save(&self, path: &Path) -> Result<()> {
        write_atomically(path, &self.to_bytes())
    }

    /// Reads a model file written by [`SharedGplvm::save`].
    pub fn load(path: &Path) -> Result<Self> {
        Self::from_bytes(&read_file(path)?)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_support::*;

    /// `model`'s file with `from` replaced by `to` in its payload (the hash recomputed): a file
    /// as an older library wrote it.
    fn edited(model: &SharedGplvm, from: &str, to: &str) -> Vec<u8> {
        let bytes = model.to_bytes();
        let payload = std::str::from_utf8(&bytes[HEADER..]).expect("JSON payload");
        assert!(payload.contains(from), "{from} not in the payload");
        with_header(model.file_version(), payload.replace(from, to).as_bytes())
    }

    #[test]
    fn files_from_before_the_validated_budget_stop_reason_read_as_it() {
        let (h, r, _, _) = demo(30, 3);
        let spaces = [("human", h.as_ref()), ("walkman", r.as_ref())];
        let config = ModelConfig::default().with_latent_dim(2);
        let validation =
            crate::Validation::new((0..30).filter(|i| i % 3 == 1).collect()).with_patience(3);
        let m =
            SharedGplvm::fit_validated(&config, &spaces, "human", &quick(30), &validation, None)
                .expect("fit");
        assert_eq!(m.stop_reason(), Some(&StopReason::ValidatedBudget));
        // Written before issue 38: the same run recorded as MaxIterations.
        let old = edited(
            &m,
            r#""stop_reason":"ValidatedBudget""#,
            r#""stop_reason":"MaxIterations""#,
        );
        let read = SharedGplvm::from_bytes(&old).expect("an older file loads");
        assert_eq!(read.stop_reason(), Some(&StopReason::ValidatedBudget));
        assert_eq!(read.params(), m.params());
        // Without a selection, MaxIterations is the caller's budget and stays so.
        let plain = fit(BackConstraint::Input, 30, 5, 0);
        assert_eq!(plain.stop_reason(), Some(&StopReason::MaxIterations));
        let back = SharedGplvm::from_bytes(&plain.to_bytes()).expect("loads");
        assert_eq!(back.stop_reason(), Some(&StopReason::MaxIterations));
    }

    #[test]
    fn save_load_round_trip_is_bit_identical_and_bad_files_fail() {
        let mut m = fit(BackConstraint::Input, 30, 10, 0);
        m.set_column_names("walkman", (0..4).map(|i| format!("j{i}")).collect())
            .expect("names");
        m.annotate(
            "sgplvm.capture",
            serde_json::json!([{"file": "a.bvh", "n": 1.5}]),
        );
        let dir = std::env::temp_dir().join(format!("sgplvm-core-test-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("tmp dir");
        let path = dir.join("model.sgp");
        m.save(&path).expect("save");
        let l = SharedGplvm::load(&path).expect("load");
        let (h, _, _, _) = demo(30, 5);
        let a = m.predict(h.as_ref(), "walkman", true).expect("p");
        let b = l.predict(h.as_ref(), "walkman", true).expect("p");
        assert_eq!(a, b);
        assert_eq!(l.column_names("walkman").map(|c| c.len()), Some(4));
        assert_eq!(l.history(), m.history());
        assert_eq!(l.annotations(), m.annotations());
        assert_eq!(l.annotations()["sgplvm.capture"][0]["file"], "a.bvh");
        assert_eq!(l.to_bytes(), m.to_bytes());
        // No temporary file left behind.
        assert_eq!(std::fs::read_dir(&dir).expect("dir").count(), 1);
        let bytes = m.to_bytes();
        assert!(matches!(
            SharedGplvm::from_bytes(b"PK\x03\x04 a zip file"),
            Err(Error::BadMagic)
        ));
        assert!(matches!(
            SharedGplvm::from_bytes(&bytes[..bytes.len() - 10]),
            Err(Error::Truncated { .. })
        ));
        assert!(matches!(
            SharedGplvm::from_bytes(&bytes[..12]),
            Err(Error::Truncated { .. })
        ));
        let mut old = bytes.clone();
        old[8..12].copy_from_slice(&0u32.to_le_bytes());
        assert!(matches!(
            SharedGplvm::from_bytes(&old),
            Err(Error::UnsupportedVersion {
                found: 0,
                supported: 4
            })
        ));
        // A newer format than this library's: refused naming both versions.
        let mut newer = bytes.clone();
        newer[8..12].copy_from_slice(&5u32.to_le_bytes());
        let e = SharedGplvm::from_bytes(&newer).unwrap_err().to_string();
        assert!(
            e.contains("version 5 is not supported; expected version 1 to 4")
                && e.contains("newer sgplvm"),
            "{e}"
        );
        // A single latent space labelled as a per-part file: refused as the wrong kind.
        let mut parts = bytes.clone();
        parts[8..12].copy_from_slice(&4u32.to_le_bytes());
        assert!(matches!(
            SharedGplvm::from_bytes(&parts),
            Err(Error::WrongModelKind { .. })
        ));
        let mut bad = bytes.clone();
        let k = bytes.len() / 2;
        bad[k] = if bad[k] == b'1' { b'2' } else { b'1' };
        assert!(matches!(
            SharedGplvm::from_bytes(&bad),
            Err(Error::Corrupt { .. })
        ));
        assert!(matches!(
            SharedGplvm::load(&dir.join("missing.sgp")),
            Err(Error::Io { .. })
        ));
        std::fs::remove_dir_all(&dir).expect("cleanup");
    }

    #[test]
    fn files_with_a_valid_hash_but_unusable_contents_are_refused() {
        let m = fit(BackConstraint::None, 30, 5, 0);
        let bytes = m.to_bytes();
        // The helper itself produces loadable files.
        let same = with_payload(&bytes, |_| {});
        assert!(SharedGplvm::from_bytes(&same).is_ok());
        type Edit = Box<dyn FnOnce(&mut serde_json::Value)>;
        let cases: [(&str, Edit); 6] = [
            (
                "appears twice",
                Box::new(|j| {
                    let name = j["spaces"][0]["name"].clone();
                    j["spaces"][1]["name"] = name;
                }),
            ),
            (
                "invalid kernel",
                Box::new(|j| j["spaces"][1]["kernel"]["lengthscale"][0] = 1e-200.into()),
            ),
            (
                "input map",
                Box::new(|j| j["map"]["kernel"]["lengthscale"][0] = 1e200.into()),
            ),
            // Finite, but predictions from them overflow to NaN (they did, naming no file).
            (
                "latent x: value 1e308 beyond ±1e153",
                Box::new(|j| j["latent"]["Free"]["x"]["data"][0] = 1e308.into()),
            ),
            // Gave "not positive definite even with jitter 0e0" instead of naming the kernel.
            (
                "space 'walkman': invalid kernel",
                Box::new(|j| j["spaces"][1]["kernel"]["variance"] = 1e308.into()),
            ),
            (
                "space 'walkman' data: value -1e200 beyond",
                Box::new(|j| j["spaces"][1]["data"]["data"][3] = (-1e200).into()),
            ),
        ];
        for (expected, edit) in cases {
            match SharedGplvm::from_bytes(&with_payload(&bytes, edit)) {
                Err(Error::Corrupt { reason }) => assert!(reason.contains(expected), "{reason}"),
                other => panic!("{expected}: {other:?}"),
            }
        }
    }

    /// A file declaring N = 200 000 frames (7 MB of JSON) would need 1.6 TB of N×N matrices
    /// to load: refused before any is allocated.
    #[test]
    fn a_file_declaring_a_huge_model_is_refused_before_allocating() {
        let m = fit(BackConstraint::None, 20, 2, 0);
        let n = 200_000usize;
        let column = |c: usize| serde_json::json!({"rows": n, "cols": c, "data": vec![0.5; n * c]});
        let bytes = with_payload(&m.to_bytes(), |j| {
            for s in j["spaces"].as_array_mut().expect("spaces") {
                let c = s["data"]["cols"].as_u64().expect("cols") as usize;
                s["data"] = column(c);
            }
            let x: Vec<f64> = (0..2 * n).map(|i| i as f64 / n as f64).collect();
            j["latent"] = serde_json::json!({"Free": {"x": {"rows": n, "cols": 2, "data": x}}});
        });
        match SharedGplvm::from_bytes(&bytes) {
            Err(e @ Error::TooLarge { .. }) => {
                let text = e.to_string();
                assert!(
                    text.starts_with("loading the model with N = 200000 frames needs about 1.9 TB"),
                    "{text}"
                );
            }
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn save_removes_a_killed_writers_temporary_and_names_the_users_path() {
        let dir = std::env::temp_dir().join(format!("sgplvm-core-stale-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).expect("tmp dir");
        let path = dir.join("model.sgp");
        let mut child = std::process::Command::new("true").spawn().expect("spawn");
        let dead = child.id();
        child.wait().expect("wait");
        let stale = dir.join(format!(".model.sgp.tmp{dead}"));
        let live = dir.join(".model.sgp.tmp1");
        std::fs::write(&stale, b"half").expect("write");
        std::fs::write(&live, b"half").expect("write");
        let m = fit(BackConstraint::Input, 20, 2, 0);
        m.save(&path).expect("save");
        assert!(!stale.exists() && live.exists());
        assert_eq!(std::fs::read_dir(&dir).expect("dir").count(), 2);
        // A directory that is a file: the error names the model file, not a temporary.
        let e = m
            .save(&path.join("inside.sgp"))
            .expect_err("not a directory");
        let text = e.to_string();
        assert!(
            text.contains("model.sgp/inside.sgp") && !text.contains(".tmp"),
            "{text}"
        );
        std::fs::remove_dir_all(&dir).expect("cleanup");
    }
}
