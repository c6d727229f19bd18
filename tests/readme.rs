//! Every shell command of README.md runs as written: the test parses the README's ```bash
//! blocks and runs each command line, top to bottom, in one scratch folder holding a copy of the
//! shipped demonstrations (as a fresh clone would), with the `sgplvm` this build made first on
//! the PATH (`cargo run --release --` stands for it too). A command is skipped only when an
//! HTML comment `<!-- readme-test: skip `PREFIX` (reason) -->` just above its block names the
//! start of the line and says why; a marker that matches no command is an error. A block under
//! `<!-- readme-test: loopback (reason) -->` (a live ROS 2 session: DDS finds its peers by
//! multicast) runs as one script, background jobs and all, in a network namespace holding only
//! the loopback device (`unshare -n`; where that is not permitted the block is skipped, and with
//! `CI=true` that is a failure). The files the commands write must be ignored by `.gitignore`.

use std::path::{Path, PathBuf};
use std::process::Command;

mod common;
use common::{s, scratch};

/// One ```bash block of the README: its command lines and the skip markers above it.
struct Block {
    /// The line number (1-based) of the opening fence.
    line: usize,
    commands: Vec<String>,
    /// `(prefix, reason)` of each `readme-test: skip` marker just above the block.
    skips: Vec<(String, String)>,
    /// Whether a `readme-test: loopback` marker is above it.
    loopback: bool,
}

/// The README's bash blocks. A marker line is `<!-- readme-test: skip `PREFIX` (reason) -->`.
fn bash_blocks(readme: &str) -> Vec<Block> {
    let mut blocks = Vec::new();
    let mut pending: Vec<(String, String)> = Vec::new();
    let mut loopback = false;
    let mut lines = readme.lines().enumerate();
    while let Some((i, line)) = lines.next() {
        let line = line.trim();
        if let Some(reason) = line
            .strip_prefix("<!-- readme-test: loopback")
            .and_then(|m| m.strip_suffix("-->"))
        {
            let reason = reason.trim().trim_start_matches('(').trim_end_matches(')');
            assert!(
                !reason.trim().is_empty(),
                "README.md:{}: a loopback marker must say why: {line}",
                i + 1
            );
            loopback = true;
            continue;
        }
        if let Some(marker) = line
            .strip_prefix("<!-- readme-test: skip `")
            .and_then(|m| m.strip_suffix("-->"))
        {
            let (prefix, rest) = marker
                .split_once('`')
                .unwrap_or_else(|| panic!("README.md:{}: unclosed ` in {line}", i + 1));
            let reason = rest.trim().trim_start_matches('(').trim_end_matches(')');
            assert!(
                !reason.trim().is_empty(),
                "README.md:{}: a skip marker must say why: {line}",
                i + 1
            );
            pending.push((prefix.to_string(), reason.to_string()));
            continue;
        }
        if line == "```bash" || line == "```sh" {
            let mut commands = Vec::new();
            let mut continued = String::new();
            for (_, body) in lines.by_ref() {
                if body.trim() == "```" {
                    break;
                }
                // A trailing backslash continues the command on the next line.
                if let Some(head) = body.strip_suffix('\\') {
                    continued.push_str(head);
                    continue;
                }
                let command = format!("{continued}{body}");
                continued.clear();
                let command = command.trim();
                if !command.is_empty() && !command.starts_with('#') {
                    commands.push(command.to_string());
                }
            }
            blocks.push(Block {
                line: i + 1,
                commands,
                skips: std::mem::take(&mut pending),
                loopback: std::mem::take(&mut loopback),
            });
        } else if !line.is_empty() {
            // A marker belongs to the block right below it (blank lines and markers between).
            pending.clear();
            loopback = false;
        }
    }
    blocks
}

/// The repository's root (where README.md is).
fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// A scratch folder laid out like a fresh clone for the commands: `data/demos` with the shipped
/// demonstration files, `data/urdf/published` with the published robots.
fn fresh_clone_folder() -> PathBuf {
    let dir = scratch("readme");
    let demos = dir.join("data").join("demos");
    std::fs::create_dir_all(&demos).unwrap();
    for file in ["bimanual.mcap", "fleet.mcap", "captured.mcap"] {
        std::fs::copy(root().join("data/demos").join(file), demos.join(file)).unwrap();
    }
    let published = dir.join("data").join("urdf").join("published");
    std::fs::create_dir_all(&published).unwrap();
    for entry in std::fs::read_dir(root().join("data/urdf/published")).unwrap() {
        let path = entry.unwrap().path();
        std::fs::copy(&path, published.join(path.file_name().unwrap())).unwrap();
    }
    dir
}

/// `PATH` with the `sgplvm` this build made first.
fn path_with_sgplvm() -> std::ffi::OsString {
    let binary = PathBuf::from(env!("CARGO_BIN_EXE_sgplvm"));
    let bin_dir = binary.parent().unwrap();
    std::env::join_paths(
        std::iter::once(bin_dir.to_path_buf()).chain(std::env::split_paths(
            &std::env::var_os("PATH").unwrap_or_default(),
        )),
    )
    .unwrap()
}

/// A README command line as it runs (`cargo run --release --` is the built `sgplvm`).
fn as_run(command: &str) -> String {
    match command.strip_prefix("cargo run --release --") {
        Some(rest) => format!("sgplvm{rest}"),
        None => command.to_string(),
    }
}

/// Panics with the output of a README command (or block) unless it succeeded without a panic.
fn check(out: std::process::Output, what: &str, block: usize) {
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        out.status.success() && !stderr.contains("panicked"),
        "README.md block at line {block}: `{what}` failed ({}):\n{stderr}",
        out.status
    );
}

/// Runs one README command line with bash in `dir`, `sgplvm` first on the PATH; panics with its
/// output unless it succeeds without a panic.
fn run(command: &str, dir: &Path, block: usize) {
    let out = Command::new("bash")
        .args(["-o", "pipefail", "-c", &as_run(command)])
        .current_dir(dir)
        .env("PATH", path_with_sgplvm())
        .output()
        .expect("bash runs");
    check(out, command, block);
}

/// Runs a block's command lines as one bash script (background jobs and `wait` included) in a
/// network namespace of its own holding only the loopback device, with multicast on it, for at
/// most 5 minutes. Returns false when no such namespace can be made here.
fn run_on_loopback(commands: &[&String], dir: &Path, block: usize) -> bool {
    // Root: `unshare -n`; else unprivileged user namespaces: `unshare -rn`.
    let flag = ["-n", "-rn"].into_iter().find(|flag| {
        Command::new("unshare")
            .args([flag, "true"])
            .output()
            .is_ok_and(|o| o.status.success())
    });
    let Some(flag) = flag else {
        let ci = std::env::var("CI").is_ok_and(|v| v.eq_ignore_ascii_case("true"));
        assert!(
            !ci,
            "README.md block at line {block}: neither `unshare -n` nor `unshare -rn` is permitted, and with CI=true the live block must run"
        );
        eprintln!(
            "README.md block at line {block}: skipped (no network namespace can be made here)"
        );
        return false;
    };
    let script: Vec<String> = commands.iter().map(|c| as_run(c)).collect();
    let script = format!("set -eo pipefail\n{}\n", script.join("\n"));
    let out = Command::new("unshare")
        .args([
            flag,
            "sh",
            "-c",
            "ip link set lo up && ip link set lo multicast on && exec timeout 300 bash -c \"$0\"",
            &script,
        ])
        .current_dir(dir)
        .env("PATH", path_with_sgplvm())
        .output()
        .expect("unshare runs");
    check(out, &script, block);
    true
}

/// Every file under `dir` (relative paths), leaving out `skip`.
fn files_under(dir: &Path, skip: &Path) -> Vec<PathBuf> {
    let mut found = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for entry in std::fs::read_dir(&d).unwrap() {
            let path = entry.unwrap().path();
            if path.starts_with(skip) {
                continue;
            }
            if path.is_dir() {
                stack.push(path);
            } else {
                found.push(path.strip_prefix(dir).unwrap().to_path_buf());
            }
        }
    }
    found
}

#[test]
fn every_readme_command_runs_as_written() {
    let readme = std::fs::read_to_string(root().join("README.md")).unwrap();
    let blocks = bash_blocks(&readme);
    let dir = fresh_clone_folder();
    let mut ran = 0;
    for block in &blocks {
        let mut used = vec![false; block.skips.len()];
        let mut to_run = Vec::new();
        for command in &block.commands {
            let skip = block.skips.iter().position(|(p, _)| command.starts_with(p));
            match skip {
                Some(k) => used[k] = true,
                None => to_run.push(command),
            }
        }
        if block.loopback {
            if run_on_loopback(&to_run, &dir, block.line) {
                ran += to_run.len();
            }
        } else {
            for command in to_run {
                run(command, &dir, block.line);
                ran += 1;
            }
        }
        for ((prefix, _), used) in block.skips.iter().zip(used) {
            assert!(
                used,
                "README.md block at line {}: the skip marker `{prefix}` matches no command",
                block.line
            );
        }
    }
    // The demo, the command-line tour: far more than a handful.
    assert!(ran >= 15, "only {ran} README commands ran");
    // `generate` rewrote the shipped demonstrations byte for byte, as the README says.
    for file in ["bimanual.mcap", "fleet.mcap", "captured.mcap"] {
        let shipped = std::fs::read(root().join("data/demos").join(file)).unwrap();
        let made = std::fs::read(dir.join("data/demos").join(file)).unwrap();
        assert!(shipped == made, "generate did not reproduce {file}");
    }
    // What the commands wrote stays out of `git status` in a clone.
    let written = files_under(&dir, &dir.join("data"));
    assert!(written.len() >= 10, "{written:?}");
    let check = Command::new("git")
        .args(["check-ignore", "--no-index", "--verbose", "--non-matching"])
        .args(written.iter().map(|p| s(p)))
        .current_dir(root())
        .output();
    let Ok(check) = check else {
        eprintln!("git is not installed: .gitignore not checked");
        return;
    };
    let listing = String::from_utf8_lossy(&check.stdout);
    // `--non-matching` prints `::\tPATH` for a path no pattern ignores.
    let not_ignored: Vec<&str> = listing
        .lines()
        .filter_map(|l| l.strip_prefix("::\t"))
        .collect();
    assert!(
        not_ignored.is_empty(),
        "README outputs not in .gitignore: {not_ignored:?}"
    );
}

#[test]
fn skip_markers_attach_to_the_block_below_them() {
    let text = "<!-- readme-test: skip `slow` (takes long) -->\n\n```bash\nslow --x\nfast \\\n  --y\n# note\n```\n\ntext\n<!-- readme-test: skip `other` (why) -->\nmore text\n```bash\nother\n```\n";
    let blocks = bash_blocks(text);
    assert_eq!(blocks.len(), 2);
    assert_eq!(blocks[0].commands, vec!["slow --x", "fast   --y"]);
    assert_eq!(
        blocks[0].skips,
        vec![("slow".to_string(), "takes long".to_string())]
    );
    // Text between a marker and a block detaches it.
    assert!(blocks[1].skips.is_empty());
    assert!(!blocks[0].loopback && !blocks[1].loopback);
    let live = bash_blocks("<!-- readme-test: loopback (DDS) -->\n```bash\na &\nb\nwait\n```\n");
    assert!(live[0].loopback);
    assert_eq!(live[0].commands, vec!["a &", "b", "wait"]);
}

/// The text of every ```python block of `readme`.
fn python_blocks(readme: &str) -> Vec<String> {
    let mut blocks = Vec::new();
    let mut lines = readme.lines();
    while let Some(line) = lines.next() {
        if line.trim() == "```python" {
            let body: Vec<&str> = lines.by_ref().take_while(|l| l.trim() != "```").collect();
            blocks.push(body.join("\n"));
        }
    }
    blocks
}

/// The quoted strings that follow `before` in `text` (`save("a.sgp")` → `a.sgp`).
fn quoted_after(text: &str, before: &str) -> Vec<String> {
    text.match_indices(before)
        .filter_map(|(i, _)| {
            let rest = text[i + before.len()..].strip_prefix('"')?;
            rest.split_once('"').map(|(name, _)| name.to_string())
        })
        .collect()
}

/// A reader who runs the command-line block and then the Python examples in the same folder
/// keeps what both wrote (issue 38: the Python example saved over the CLI's `coman.sgp`).
#[test]
fn the_python_examples_write_no_file_the_commands_write() {
    let readme = std::fs::read_to_string(root().join("README.md")).unwrap();
    let python = python_blocks(&readme).join("\n");
    let mut written: Vec<String> = quoted_after(&python, "save(");
    written.extend(quoted_after(&python, "out="));
    assert!(written.len() >= 2, "{written:?}");
    let commands: Vec<String> = bash_blocks(&readme)
        .into_iter()
        .flat_map(|b| b.commands)
        .collect();
    let outputs: Vec<&str> = commands
        .iter()
        .flat_map(|c| {
            let words: Vec<&str> = c.split_whitespace().collect();
            words
                .windows(2)
                .filter(|w| w[0] == "--out")
                .map(|w| w[1])
                .collect::<Vec<_>>()
        })
        .collect();
    assert!(outputs.contains(&"coman.sgp"), "{outputs:?}");
    for name in &written {
        assert!(
            !outputs.contains(&name.as_str()),
            "the README's Python writes {name}, which a command of its shell blocks writes too"
        );
    }
}
