//! Running the `sgplvm` program in the integration tests: shared by every test file that drives
//! it (each uses only some of these).
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};

/// Runs `sgplvm args…` with no stdin.
pub fn sgplvm(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_sgplvm"))
        .args(args)
        .stdin(Stdio::null())
        .output()
        .expect("the sgplvm binary runs")
}

/// Runs a command that must succeed; returns its stdout.
pub fn ok(args: &[&str]) -> String {
    let out = sgplvm(args);
    assert!(
        out.status.success(),
        "sgplvm {args:?} failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).expect("utf-8 output")
}

/// Runs a command that must fail with exit code `code` and no panic; returns its stderr.
pub fn fails(args: &[&str], code: i32) -> String {
    let out = sgplvm(args);
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert_eq!(out.status.code(), Some(code), "sgplvm {args:?}: {stderr}");
    assert!(
        !stderr.contains("panicked"),
        "sgplvm {args:?} panicked: {stderr}"
    );
    stderr
}

/// Runs a command that must fail with exit code 1 and one plain line; returns it.
pub fn fails_on_one_line(args: &[&str]) -> String {
    let stderr = fails(args, 1);
    assert_eq!(stderr.trim_end().lines().count(), 1, "{stderr}");
    stderr
}

/// A fresh scratch folder for one test of this process.
pub fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("sgplvm-cli-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("scratch folder");
    dir
}

/// A path as the `&str` a command line takes.
pub fn s(p: &Path) -> &str {
    p.to_str().expect("UTF-8 path")
}
