//! Typed errors of the core crate.

use std::path::PathBuf;

/// Result type of the core crate.
pub type Result<T, E = Error> = std::result::Result<T, E>;

/// Everything that can go wrong when building, training, using or storing a model.
/// Every variant names what was given and what was expected.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// A space's values vary on a scale (root mean square after centring) that floating point
    /// cannot train on, even after standardising it by a power of two.
    #[error(
        "space '{space}': its values vary on a scale of {scale:.3e} (root mean square after \
         centring); expected a scale between {min:e} and {max:e}: change the data's units"
    )]
    DataScale {
        /// Offending space.
        space: String,
        /// Its scale (infinite when centring overflowed).
        scale: f64,
        /// Smallest scale accepted.
        min: f64,
        /// Largest scale accepted.
        max: f64,
    },
    /// The exact model would need more memory than the limit (see the `memory` module);
    /// refused before allocating.
    #[error(
        "{what} with N = {n} frames needs about {} ({matrices} N×N matrices of 8-byte floats); \
         {} is available ({limit_source}): the exact model's memory grows with N²; train the \
         sparse model on every frame (`--inducing M`, e.g. 100; Python `inducing=`) or use \
         fewer frames (e.g. subsample the demonstrations)",
        crate::memory::human(*needed_bytes),
        crate::memory::human(*available_bytes)
    )]
    TooLarge {
        /// What was refused (training, transfer, loading a model, …).
        what: String,
        /// Number of frames N.
        n: usize,
        /// N×N matrices estimated.
        matrices: usize,
        /// Bytes those matrices need.
        needed_bytes: u64,
        /// The memory limit in bytes.
        available_bytes: u64,
        /// Where the limit comes from.
        limit_source: String,
    },
    /// The sparse (or Bayesian) model would need more memory than the limit (see the `memory`
    /// module); refused before allocating.
    #[error(
        "{what} with N = {n} frames and M = {m} inducing inputs needs about {} (its memory grows \
         with N·M); {} is available ({limit_source}): use fewer frames or inducing inputs",
        crate::memory::human(*needed_bytes),
        crate::memory::human(*available_bytes)
    )]
    TooLargeSparse {
        /// What was refused (training, transfer, loading a model, …).
        what: String,
        /// Number of frames N.
        n: usize,
        /// Inducing inputs M.
        m: usize,
        /// Bytes estimated.
        needed_bytes: u64,
        /// The memory limit in bytes.
        available_bytes: u64,
        /// Where the limit comes from.
        limit_source: String,
    },
    /// A value of the data is NaN or infinite.
    #[error(
        "space '{space}': value at row {row}, column {col} is {value}; expected a finite number"
    )]
    NonFinite {
        /// Space (or input) holding the value.
        space: String,
        /// Row of the value.
        row: usize,
        /// Column of the value.
        col: usize,
        /// The offending value.
        value: f64,
    },
    /// A prediction came out NaN or infinite (parameters at the edge of what floating point
    /// holds); it is refused rather than handed on as joint commands.
    #[error(
        "prediction for '{space}' at frame {row}, column {col} is {value}; the model's parameters \
         do not give finite predictions for this input"
    )]
    NonFinitePrediction {
        /// Space predicted (or `latent` for the latent points).
        space: String,
        /// Frame (row of the input).
        row: usize,
        /// Column of the output.
        col: usize,
        /// The value computed.
        value: f64,
    },
    /// Spaces have different numbers of rows (frames).
    #[error("space '{space}' has {found} rows; expected {expected} (the same N for every space)")]
    RowCountMismatch {
        /// Offending space.
        space: String,
        /// Rows of the first space.
        expected: usize,
        /// Rows found.
        found: usize,
    },
    /// A space has no rows or no columns.
    #[error("space '{space}' is empty ({rows}×{cols}); expected at least one row and one column")]
    EmptySpace {
        /// Offending space.
        space: String,
        /// Rows found.
        rows: usize,
        /// Columns found.
        cols: usize,
    },
    /// The latent dimension is zero or not smaller than the number of points.
    #[error("latent dimension Q = {latent_dim} is invalid for N = {n} points; expected 1 ≤ Q < N")]
    InvalidLatentDim {
        /// Requested Q.
        latent_dim: usize,
        /// Number of points.
        n: usize,
    },
    /// A space name is not part of the model / of the given data.
    #[error("unknown space '{name}'; expected one of {known:?}")]
    UnknownSpace {
        /// Name asked for.
        name: String,
        /// Names available.
        known: Vec<String>,
    },
    /// A robot (output) space was asked for but the name is the input space or unknown.
    #[error("'{name}' is not an output (robot) space of the model; expected one of {known:?}")]
    NotAnOutput {
        /// Name asked for.
        name: String,
        /// Output spaces of the model.
        known: Vec<String>,
    },
    /// Two spaces share a name, or a transfer target already exists.
    #[error("space name '{name}' is used twice; expected unique names")]
    DuplicateSpace {
        /// Offending name.
        name: String,
    },
    /// No output space was given to `fit`.
    #[error("no output (robot) space given; expected the input space plus at least one robot")]
    NoOutputSpace,
    /// Wrong number of columns (prediction input, transfer data, column names, parameters).
    #[error("{what}: found {found} columns/values; expected {expected}")]
    DimensionMismatch {
        /// What was checked.
        what: String,
        /// Expected count.
        expected: usize,
        /// Count found.
        found: usize,
    },
    /// A parameter or option is out of its domain.
    #[error("invalid {what}: {reason}")]
    InvalidValue {
        /// Parameter or option name.
        what: String,
        /// What was expected.
        reason: String,
    },
    /// A kernel matrix stayed non-positive-definite even with the largest jitter.
    #[error(
        "kernel matrix of space '{space}' is not positive definite even with jitter {jitter:e}"
    )]
    NotPositiveDefinite {
        /// Space whose matrix failed.
        space: String,
        /// Largest jitter tried.
        jitter: f64,
    },
    /// An I/O error on a model file.
    #[error("model file {path}: {source}")]
    Io {
        /// File concerned.
        path: PathBuf,
        /// Underlying error.
        source: std::io::Error,
    },
    /// The bytes do not start with the model magic.
    #[error("not an sgplvm model file: expected the magic bytes \"SGPLVM\\0\\0\" at the start")]
    BadMagic,
    /// The file was written by another format version.
    #[error(
        "model file format version {found} is not supported; expected version 1 to {supported} \
         (a later version is written by a newer sgplvm: update sgplvm to read it)"
    )]
    UnsupportedVersion {
        /// Version in the file.
        found: u32,
        /// Newest version this library reads (it reads every version from 1 to this one).
        supported: u32,
    },
    /// The file is shorter than its header says.
    #[error("model file truncated: expected {expected} bytes, found {found}")]
    Truncated {
        /// Bytes expected.
        expected: usize,
        /// Bytes present.
        found: usize,
    },
    /// The file holds another kind of model than the one asked for: a per-part model
    /// ([`crate::PartsGplvm`]) where a single latent space was expected, or the reverse.
    #[error("the model file holds {found}, where {expected} is expected; {read_with}")]
    WrongModelKind {
        /// What the file holds.
        found: &'static str,
        /// What was asked for.
        expected: &'static str,
        /// How to read what it holds.
        read_with: &'static str,
    },
    /// A body part of a [`crate::PartsGplvm`] failed: the error, with the part named.
    #[error("body part '{part}': {source}")]
    Part {
        /// The part.
        part: String,
        /// What failed.
        source: Box<Error>,
    },
    /// The payload is damaged or inconsistent.
    #[error("model file corrupt: {reason}")]
    Corrupt {
        /// What is wrong.
        reason: String,
    },
}

/// Checks that a caller's buffer for space `space` holds `expected` values: `what` names the
/// buffer ("output", "mean", "standard deviation").
pub(crate) fn check_buffer(what: &str, space: &str, expected: usize, found: usize) -> Result<()> {
    if found == expected {
        return Ok(());
    }
    Err(Error::DimensionMismatch {
        what: format!("{what} buffer for '{space}'"),
        expected,
        found,
    })
}
