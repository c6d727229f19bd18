//! Output files written whole or not at all: everything goes to a temporary file beside the
//! target (`.tmp-PID-NAME`, the extension last), which is renamed over it only when complete.
//! The temporaries a killed writer left beside the target are removed by the next write to it
//! ([`sgplvm_robots::files::remove_stale_temporaries`]); errors name the target, never the
//! temporary file.

use std::path::{Path, PathBuf};

/// A file that could not be written.
#[derive(Debug, thiserror::Error)]
#[error("cannot write {path}: {source}")]
pub struct FileError {
    /// The file that was to be written.
    pub path: PathBuf,
    /// Why it failed.
    #[source]
    pub source: std::io::Error,
}

/// The temporary path used while `path` is being written.
fn temporary_path(path: &Path) -> PathBuf {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    // The extension stays last: some writers choose the format by it.
    path.with_file_name(format!(".tmp-{}-{name}", std::process::id()))
}

/// Calls `write` with a temporary path beside `path` and renames the result over `path` when
/// `write` succeeds; on failure the temporary file is removed and `path` is left untouched.
pub fn atomic_write_with(
    path: &Path,
    write: impl FnOnce(&Path) -> std::io::Result<()>,
) -> Result<(), FileError> {
    let fail = |source| FileError {
        path: path.to_path_buf(),
        source,
    };
    if let Some(parent) = path.parent().filter(|p| !p.as_os_str().is_empty()) {
        std::fs::create_dir_all(parent).map_err(fail)?;
    }
    sgplvm_robots::files::remove_stale_temporaries(path);
    let tmp = temporary_path(path);
    let result = write(&tmp).and_then(|()| std::fs::rename(&tmp, path));
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result.map_err(fail)
}

/// Writes `bytes` to `path` atomically.
pub fn atomic_write(path: &Path, bytes: &[u8]) -> Result<(), FileError> {
    atomic_write_with(path, |tmp| std::fs::write(tmp, bytes))
}

#[cfg(test)]
mod tests {
    /// The core keeps a copy of the robots crate's temporary-file rules for model files (neither
    /// crate depends on the other); the two must not drift apart.
    #[test]
    fn the_two_copies_of_the_temporary_file_rules_agree() {
        let body = |source: &str| -> String {
            let start = source.find("use std::path").expect("imports");
            let end = source.find("#[cfg(test)]").unwrap_or(source.len());
            source[start..end].replace("pub(crate) fn", "pub fn")
        };
        assert_eq!(
            body(include_str!("../crates/sgplvm-core/src/tempfiles.rs")),
            body(include_str!("../crates/sgplvm-robots/src/files.rs"))
        );
    }

    use super::*;

    #[test]
    fn failed_write_leaves_nothing_behind() {
        let dir = std::env::temp_dir().join(format!("sgplvm-files-{}", std::process::id()));
        let target = dir.join("out.txt");
        atomic_write(&target, b"first").unwrap();
        let err = atomic_write_with(&target, |tmp| {
            std::fs::write(tmp, b"half")?;
            Err(std::io::Error::other("interrupted"))
        })
        .unwrap_err();
        assert!(err.to_string().contains("out.txt"));
        assert_eq!(std::fs::read(&target).unwrap(), b"first");
        assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 1);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn the_next_write_removes_a_killed_writers_temporary() {
        let dir = std::env::temp_dir().join(format!("sgplvm-files-stale-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        let target = dir.join("figure.png");
        let mut child = std::process::Command::new("true").spawn().unwrap();
        let dead = child.id();
        child.wait().unwrap();
        let stale = dir.join(format!(".tmp-{dead}-figure.png"));
        std::fs::write(&stale, b"half").unwrap();
        atomic_write(&target, b"whole").unwrap();
        assert!(!stale.exists());
        assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 1);
        // A parent that is a file: the error names the target, not the temporary file.
        let err = atomic_write(&target.join("x.svg"), b"no")
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("figure.png/x.svg") && !err.contains(".tmp"),
            "{err}"
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
