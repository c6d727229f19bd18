//! Temporary files of atomic writes. Every writer of sgplvm writes a hidden temporary file
//! beside its target, named after the target and the writing process (`.NAME.tmpPID`, or
//! `.tmp-PID-NAME` where the extension must stay last), and renames it over the target when
//! complete. A writer killed half-way leaves its temporary behind; the next write to the same
//! target removes the temporaries of processes that no longer run ([`remove_stale_temporaries`]).
//!
//! (`sgplvm-core` keeps an identical copy for model files: it does not depend on this crate.)

use std::path::{Path, PathBuf};

/// The temporary path `.NAME.tmpPID` of a write of `target` by this process.
pub fn temporary_path(target: &Path) -> PathBuf {
    let name = target
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    target.with_file_name(format!(".{name}.tmp{}", std::process::id()))
}

/// The process id in `file`, if it is the name of a temporary of `target_name` (either form).
fn writer_pid(file: &str, target_name: &str) -> Option<u32> {
    let digits = file
        .strip_prefix('.')
        .and_then(|f| f.strip_prefix(target_name))
        .and_then(|f| f.strip_prefix(".tmp"))
        .or_else(|| {
            file.strip_prefix(".tmp-")
                .and_then(|f| f.strip_suffix(target_name))
                .and_then(|f| f.strip_suffix('-'))
        })?;
    if digits.is_empty() || !digits.bytes().all(|b| b.is_ascii_digit()) {
        return None;
    }
    digits.parse().ok()
}

/// Whether process `pid` runs; `None` when this cannot be told (no `/proc`).
fn process_runs(pid: u32) -> Option<bool> {
    if !Path::new("/proc/self").exists() {
        return None;
    }
    Some(Path::new(&format!("/proc/{pid}")).exists())
}

/// Temporaries of `target` beside it whose writing process no longer runs (none where that
/// cannot be told).
pub fn stale_temporaries(target: &Path) -> Vec<PathBuf> {
    let Some(name) = target.file_name().map(|n| n.to_string_lossy().into_owned()) else {
        return Vec::new();
    };
    let dir = match target.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    let Ok(entries) = std::fs::read_dir(dir) else {
        return Vec::new();
    };
    let me = std::process::id();
    entries
        .filter_map(|e| e.ok())
        .filter(|e| {
            let file = e.file_name().to_string_lossy().into_owned();
            writer_pid(&file, &name)
                .is_some_and(|pid| pid != me && process_runs(pid) == Some(false))
        })
        .map(|e| e.path())
        .collect()
}

/// Removes the temporaries of `target` left by writers that were killed (see the module
/// docs). Best effort: a temporary that cannot be removed stays.
pub fn remove_stale_temporaries(target: &Path) {
    for stale in stale_temporaries(target) {
        let _ = std::fs::remove_file(stale);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn temporaries_are_recognised_in_both_forms_and_only_for_their_target() {
        assert_eq!(writer_pid(".out.mcap.tmp123", "out.mcap"), Some(123));
        assert_eq!(writer_pid(".tmp-123-out.png", "out.png"), Some(123));
        assert_eq!(writer_pid(".out.mcap.tmp", "out.mcap"), None);
        assert_eq!(writer_pid(".out.mcap.tmp12x", "out.mcap"), None);
        assert_eq!(writer_pid(".other.mcap.tmp123", "out.mcap"), None);
        assert_eq!(writer_pid("out.mcap", "out.mcap"), None);
        assert_eq!(writer_pid(".tmp-123-xout.png", "out.png"), None);
        assert!(temporary_path(Path::new("/a/b.mcap"))
            .to_string_lossy()
            .starts_with("/a/.b.mcap.tmp"));
    }
}
