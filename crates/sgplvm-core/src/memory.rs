//! The memory the exact model needs, checked before its N×N matrices are allocated (and the
//! sparse and Bayesian models', O(N M + M² Q): [`check_sparse`]).
//!
//! Every space of the exact model keeps an N×N Cholesky factor, training needs three more N×N
//! buffers per space (kernel, factor, ∂L/∂K), back constraints an N×N kernel, and the final
//! factorisations a few transient ones. At N = 20 000 one such matrix is 3.2 GB: instead of
//! failing half-way through an allocation, a call first estimates what it needs (a count of
//! N×N f64 matrices, below) and refuses with [`Error::TooLarge`] when that exceeds the limit:
//!
//! 1. the environment variable [`MEMORY_LIMIT_ENV`] (bytes, or with a `K`, `M`, `G` or `T`
//!    suffix, powers of 1024), when set;
//! 2. else the memory available to this process: `MemAvailable` of `/proc/meminfo`, lowered to
//!    what the cgroup (v2) still allows when there is a `memory.max`;
//! 3. else [`DEFAULT_MEMORY_LIMIT`].

use crate::error::{Error, Result};

/// Environment variable that sets the memory limit (bytes; `K`, `M`, `G`, `T` suffixes).
pub const MEMORY_LIMIT_ENV: &str = "SGPLVM_MEMORY_LIMIT";

/// The limit when neither [`MEMORY_LIMIT_ENV`] nor `/proc/meminfo` gives one: 8 GiB.
pub const DEFAULT_MEMORY_LIMIT: u64 = 8 << 30;

/// N×N matrices a fit or validated fit of `spaces` spaces holds at its peak: three training
/// buffers and one factor per space, and seven for the back-constraint kernel, its
/// initialisation, the transient buffers of the final factorisations and the selection run's
/// leftovers. Peak resident memory measured at N = 3000 with two spaces: 12.7–12.9 matrices
/// for `fit` (every back constraint), 14.1–14.3 for `fit_validated`; this estimate says 15.
pub(crate) fn fit_matrices(spaces: usize) -> usize {
    4 * spaces + 7
}

/// N×N matrices whitened back-constraint weights add to a fit's: P, P⁻¹ and K_bc P kept for
/// the training, and the eigenvectors and one scaled copy of them while those are built.
pub(crate) const WHITENING_MATRICES: usize = 5;

/// N×N matrices a transfer to a model of `spaces` spaces (the new one included) holds at its
/// peak besides the source model: the copied and the new factors, the new space's training
/// buffers and the transient ones (measured: 8.2 for three spaces, estimate 12).
pub(crate) fn transfer_matrices(spaces: usize) -> usize {
    2 * spaces + 6
}

/// N×N matrices loading a model of `spaces` spaces allocates: a factor per space, the
/// back-constraint kernel and one factorisation's buffers.
pub(crate) fn load_matrices(spaces: usize) -> usize {
    spaces + 4
}

/// N×N matrices of a GP regression: its training buffers and the final factorisation.
pub(crate) const REGRESSION_MATRICES: usize = 5;

/// Bytes the sparse or Bayesian model of `dims` (each space's columns) needs at its peak in
/// training, with N frames, M inducing inputs and Q latent dimensions: per space its data and
/// four N×M buffers (Φ or Ψ₁, ∂L/∂Ψ₁ and two transient products), seven N×Q (latent points,
/// variances, their gradients and copies) plus two per space, M²(Q + 8) per space for the M×M
/// algebra and the kept Ψ₂ₙ values (at most 64 MB a space; saturating). O(N M + M² Q), as the
/// model.
pub(crate) fn sparse_bytes(n: usize, m: usize, q: usize, dims: &[usize]) -> u64 {
    let (n, m, q) = (n as u128, m as u128, q as u128);
    // The Bayesian model keeps a space's Ψ₂ₙ values between its two passes when they fit in
    // PSI2_CACHE_BYTES.
    let kept = (n * m * (m + 1) / 2).min(crate::sparse::psi::PSI2_CACHE_BYTES as u128 / 8);
    let per_space: u128 = dims
        .iter()
        .map(|&d| n * d as u128 + 4 * n * m + 2 * n * q + m * m * (q + 8) + kept)
        .sum();
    u64::try_from(8 * (per_space + 7 * n * q)).unwrap_or(u64::MAX)
}

/// Refuses `what` for the sparse or Bayesian model when [`sparse_bytes`] exceeds the limit.
pub(crate) fn check_sparse(what: &str, n: usize, m: usize, q: usize, dims: &[usize]) -> Result<()> {
    let needed = sparse_bytes(n, m, q, dims);
    match over_limit(needed) {
        None => Ok(()),
        Some((available, source)) => Err(Error::TooLargeSparse {
            what: what.into(),
            n,
            m,
            needed_bytes: needed,
            available_bytes: available,
            limit_source: source,
        }),
    }
}

/// The limit and its source when `needed` bytes exceed it; `None` when they fit. Small needs
/// (64 MiB and less) always fit, without reading /proc on every call.
fn over_limit(needed: u64) -> Option<(u64, String)> {
    if needed <= 64 << 20 {
        return None;
    }
    let (available, source) = limit();
    (needed > available).then_some((available, source))
}

/// Bytes of `matrices` N×N matrices of f64 (saturating).
pub(crate) fn bytes_needed(n: usize, matrices: usize) -> u64 {
    let bytes = (n as u128) * (n as u128) * 8 * matrices as u128;
    u64::try_from(bytes).unwrap_or(u64::MAX)
}

/// Refuses `what` at `n` frames when its `matrices` N×N matrices would exceed the memory limit.
pub(crate) fn check(what: &str, n: usize, matrices: usize) -> Result<()> {
    let needed = bytes_needed(n, matrices);
    match over_limit(needed) {
        None => Ok(()),
        Some((available, source)) => Err(Error::TooLarge {
            what: what.into(),
            n,
            matrices,
            needed_bytes: needed,
            available_bytes: available,
            limit_source: source,
        }),
    }
}

/// The memory limit and where it comes from (see the module docs).
pub(crate) fn limit() -> (u64, String) {
    if let Ok(text) = std::env::var(MEMORY_LIMIT_ENV) {
        if let Some(bytes) = parse_bytes(&text) {
            return (bytes, format!("{MEMORY_LIMIT_ENV}={}", text.trim()));
        }
    }
    let meminfo = std::fs::read_to_string("/proc/meminfo").ok();
    let available = meminfo.as_deref().and_then(mem_available);
    let cgroup = cgroup_headroom();
    match (available, cgroup) {
        (Some(a), Some(c)) if c < a => (c, "the cgroup's memory.max".into()),
        (Some(a), _) => (a, "MemAvailable in /proc/meminfo".into()),
        (None, Some(c)) => (c, "the cgroup's memory.max".into()),
        (None, None) => (
            DEFAULT_MEMORY_LIMIT,
            format!("the default limit; set {MEMORY_LIMIT_ENV} to change it"),
        ),
    }
}

/// `MemAvailable` of a `/proc/meminfo` text, in bytes.
fn mem_available(meminfo: &str) -> Option<u64> {
    let line = meminfo.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    kb.checked_mul(1024)
}

/// What the process's cgroup (v2) still allows, when it has a limit.
fn cgroup_headroom() -> Option<u64> {
    let read = |name: &str| std::fs::read_to_string(format!("/sys/fs/cgroup/{name}")).ok();
    let max: u64 = read("memory.max")?.trim().parse().ok()?;
    let current: u64 = read("memory.current")?.trim().parse().ok()?;
    Some(max.saturating_sub(current))
}

/// A byte count: digits, optionally followed by `K`, `M`, `G` or `T` (powers of 1024, an
/// optional trailing `B` or `iB`).
fn parse_bytes(text: &str) -> Option<u64> {
    let t = text.trim();
    let t = t
        .strip_suffix("iB")
        .or_else(|| t.strip_suffix('B'))
        .unwrap_or(t);
    let (digits, shift) = match t.chars().last()? {
        'K' | 'k' => (&t[..t.len() - 1], 10),
        'M' | 'm' => (&t[..t.len() - 1], 20),
        'G' | 'g' => (&t[..t.len() - 1], 30),
        'T' | 't' => (&t[..t.len() - 1], 40),
        _ => (t, 0),
    };
    digits
        .trim()
        .parse::<u64>()
        .ok()?
        .checked_mul(1u64 << shift)
}

/// A byte count for people: `3.2 GB`, `640 MB` (decimal units).
pub(crate) fn human(bytes: u64) -> String {
    let b = bytes as f64;
    match bytes {
        0..1_000_000 => format!("{:.0} kB", b / 1e3),
        1_000_000..1_000_000_000 => format!("{:.0} MB", b / 1e6),
        1_000_000_000..1_000_000_000_000 => format!("{:.1} GB", b / 1e9),
        _ => format!("{:.1} TB", b / 1e12),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn byte_counts_and_limits_read_as_documented() {
        assert_eq!(parse_bytes("1024"), Some(1024));
        assert_eq!(parse_bytes(" 4G "), Some(4 << 30));
        assert_eq!(parse_bytes("512MiB"), Some(512 << 20));
        assert_eq!(parse_bytes("2TB"), Some(2 << 40));
        assert_eq!(parse_bytes("lots"), None);
        assert_eq!(parse_bytes("-1"), None);
        let meminfo = "MemTotal:       24000000 kB\nMemAvailable:   22000000 kB\n";
        assert_eq!(mem_available(meminfo), Some(22_000_000 * 1024));
        assert_eq!(mem_available("MemTotal: 1 kB\n"), None);
        assert_eq!(human(3_200_000_000), "3.2 GB");
        assert_eq!(human(640_000_000), "640 MB");
        assert_eq!(bytes_needed(20_000, 1), 3_200_000_000);
        assert_eq!(bytes_needed(usize::MAX, 10), u64::MAX);
    }

    #[test]
    fn small_problems_pass_and_huge_ones_are_refused_in_one_line() {
        assert!(check("training", 1000, fit_matrices(2)).is_ok());
        // 10⁶ frames: 8 TB per matrix, 120 TB for 15 of them.
        let e = check("training", 1_000_000, fit_matrices(2)).expect_err("refused");
        let text = e.to_string();
        assert!(matches!(e, Error::TooLarge { n: 1_000_000, .. }), "{e:?}");
        assert!(
            text.starts_with("training with N = 1000000 frames needs about 120.0 TB"),
            "{text}"
        );
        assert!(!text.contains('\n'), "{text}");
        assert!(
            text.contains("--inducing"),
            "the sparse model is suggested: {text}"
        );
    }

    #[test]
    fn the_sparse_model_is_refused_when_n_times_m_is_too_large() {
        assert!(check_sparse("training", 20_000, 100, 5, &[18, 14]).is_ok());
        // 10⁹ frames, M = 100: 4 N·M buffers per space alone are 6.4 TB.
        let e = check_sparse("training", 1_000_000_000, 100, 5, &[18, 14]).expect_err("refused");
        let text = e.to_string();
        assert!(matches!(e, Error::TooLargeSparse { m: 100, .. }), "{e:?}");
        assert!(
            text.starts_with("training with N = 1000000000 frames and M = 100"),
            "{text}"
        );
        assert!(!text.contains('\n'), "{text}");
        assert_eq!(sparse_bytes(usize::MAX, usize::MAX, 5, &[3]), u64::MAX);
    }
}
