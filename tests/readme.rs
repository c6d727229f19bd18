//! Every shell command of README.md and of the guides under docs/ runs as written: the test
//! parses each document's ```bash blocks and runs each command line, top to bottom, in a scratch
//! folder of the document's own holding a copy of the shipped data (as a fresh clone would:
//! the demonstrations, the capture, the published robots), with the `sgplvm` this build made
//! first on the PATH (`cargo run --release --` stands for it too). A command is skipped only
//! when an HTML comment `<!-- readme-test: skip `PREFIX` (reason) -->` just above its block
//! names the start of the line and says why; a marker that matches no command is an error. A
//! block under `<!-- readme-test: loopback (reason) -->` (a live ROS 2 session: DDS finds its
//! peers by multicast) runs as one script, background jobs and all, in a network namespace
//! holding only the loopback device (`unshare -n`; where that is not permitted the block is
//! skipped, and with `CI=true` that is a failure). The files the commands write must be ignored
//! by `.gitignore`.

use std::path::{Path, PathBuf};
use std::process::Command;

mod common;
use common::{s, scratch};

/// One ```bash block of a document: its command lines and the skip markers above it.
struct Block {
    /// The line number (1-based) of the opening fence.
    line: usize,
    commands: Vec<String>,
    /// `(prefix, reason)` of each `readme-test: skip` marker just above the block.
    skips: Vec<(String, String)>,
    /// Whether a `readme-test: loopback` marker is above it.
    loopback: bool,
}

/// A document's bash blocks. A marker line is `<!-- readme-test: skip `PREFIX` (reason) -->`.
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
                "line {}: a loopback marker must say why: {line}",
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
                .unwrap_or_else(|| panic!("line {}: unclosed ` in {line}", i + 1));
            let reason = rest.trim().trim_start_matches('(').trim_end_matches(')');
            assert!(
                !reason.trim().is_empty(),
                "line {}: a skip marker must say why: {line}",
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

/// A scratch folder laid out like a fresh clone for one document's commands: `data/demos` with
/// the shipped demonstration files, the published robots, the captures (the BVH, and the
/// capture crate's ASF/AMC fixtures) and the Foxglove layout.
fn fresh_clone_folder(name: &str) -> PathBuf {
    let dir = scratch(&format!("readme-{name}"));
    let demos = dir.join("data").join("demos");
    std::fs::create_dir_all(&demos).unwrap();
    for file in ["bimanual.mcap", "fleet.mcap", "captured.mcap"] {
        std::fs::copy(root().join("data/demos").join(file), demos.join(file)).unwrap();
    }
    for folder in [
        "data/urdf/published",
        "data/capture",
        "data/foxglove",
        "crates/sgplvm-capture/tests/fixtures",
    ] {
        let copy = dir.join(folder);
        std::fs::create_dir_all(&copy).unwrap();
        for entry in std::fs::read_dir(root().join(folder)).unwrap() {
            let path = entry.unwrap().path();
            std::fs::copy(&path, copy.join(path.file_name().unwrap())).unwrap();
        }
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

/// Panics with the output of a document's command (or block), `at` naming the document and the
/// block's line, unless it succeeded without a panic.
fn check(out: std::process::Output, what: &str, at: &str) {
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        out.status.success() && !stderr.contains("panicked"),
        "{at}: `{what}` failed ({}):\n{stderr}",
        out.status
    );
}

/// Runs one command line with bash in `dir`, `sgplvm` first on the PATH; panics with its
/// output unless it succeeds without a panic.
fn run(command: &str, dir: &Path, at: &str) {
    let out = Command::new("bash")
        .args(["-o", "pipefail", "-c", &as_run(command)])
        .current_dir(dir)
        .env("PATH", path_with_sgplvm())
        .output()
        .expect("bash runs");
    check(out, command, at);
}

/// Runs a block's command lines as one bash script (background jobs and `wait` included) in a
/// network namespace of its own holding only the loopback device, with multicast on it, for at
/// most 5 minutes. Returns false when no such namespace can be made here.
fn run_on_loopback(commands: &[&String], dir: &Path, at: &str) -> bool {
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
            "{at}: neither `unshare -n` nor `unshare -rn` is permitted, and with CI=true the live block must run"
        );
        eprintln!("{at}: skipped (no network namespace can be made here)");
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
    check(out, &script, at);
    true
}

/// Every file under `dir` (relative paths), leaving out the folders `skip`.
fn files_under(dir: &Path, skip: &[PathBuf]) -> Vec<PathBuf> {
    let mut found = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for entry in std::fs::read_dir(&d).unwrap() {
            let path = entry.unwrap().path();
            if skip.iter().any(|s| path.starts_with(s)) {
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

/// The documents whose commands run, with the fewest commands each must run (the rest skipped
/// by their markers): the README and every guide under docs/.
const DOCUMENTS: [(&str, usize); 9] = [
    ("README.md", 6),
    ("docs/ten-minutes.md", 7),
    ("docs/capture.md", 6),
    ("docs/robots.md", 8),
    ("docs/training.md", 19),
    ("docs/experiments.md", 0),
    ("docs/live.md", 7),
    ("docs/python.md", 0),
    ("docs/clusters.md", 0),
];

/// Runs every command of `document` (relative to the repository's root) in a scratch folder
/// of its own laid out like a clone, as the module's docs say, and checks that what they wrote
/// is ignored by `.gitignore`.
fn run_document(document: &str) {
    let (_, fewest) = DOCUMENTS
        .iter()
        .find(|(d, _)| *d == document)
        .unwrap_or_else(|| panic!("{document} is not in DOCUMENTS"));
    let text = std::fs::read_to_string(root().join(document)).unwrap();
    let blocks = bash_blocks(&text);
    let dir = fresh_clone_folder(&document.replace(['/', '.'], "-"));
    let mut ran = 0;
    let mut generated = false;
    for block in &blocks {
        let at = format!("{document}, block at line {}", block.line);
        let mut used = vec![false; block.skips.len()];
        let mut to_run = Vec::new();
        for command in &block.commands {
            let skip = block.skips.iter().position(|(p, _)| command.starts_with(p));
            match skip {
                Some(k) => used[k] = true,
                None => to_run.push(command),
            }
        }
        generated |= to_run
            .iter()
            .any(|c| c.starts_with("sgplvm generate --out data/demos"));
        if block.loopback {
            if run_on_loopback(&to_run, &dir, &at) {
                ran += to_run.len();
            }
        } else {
            for command in to_run {
                run(command, &dir, &at);
                ran += 1;
            }
        }
        for ((prefix, _), used) in block.skips.iter().zip(used) {
            assert!(used, "{at}: the skip marker `{prefix}` matches no command");
        }
    }
    assert!(ran >= *fewest, "{document}: only {ran} commands ran");
    // `generate` rewrote the shipped demonstrations byte for byte, as the guide says.
    if generated {
        for file in ["bimanual.mcap", "fleet.mcap", "captured.mcap"] {
            let shipped = std::fs::read(root().join("data/demos").join(file)).unwrap();
            let made = std::fs::read(dir.join("data/demos").join(file)).unwrap();
            assert!(shipped == made, "generate did not reproduce {file}");
        }
    }
    // What the commands wrote stays out of `git status` in a clone.
    // The copied inputs aside.
    let written = files_under(&dir, &[dir.join("data"), dir.join("crates")]);
    if written.is_empty() {
        return;
    }
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
        "{document}: outputs not in .gitignore: {not_ignored:?}"
    );
}

#[test]
fn every_readme_command_runs_as_written() {
    run_document("README.md");
}

#[test]
fn the_ten_minute_path_runs_as_written() {
    run_document("docs/ten-minutes.md");
}

#[test]
fn the_capture_guide_runs_as_written() {
    run_document("docs/capture.md");
}

#[test]
fn the_robots_guide_runs_as_written() {
    run_document("docs/robots.md");
}

#[test]
fn the_training_guide_runs_as_written() {
    run_document("docs/training.md");
}

#[test]
fn the_live_guide_runs_as_written() {
    run_document("docs/live.md");
}

#[test]
fn the_other_guides_run_as_written() {
    for document in ["docs/experiments.md", "docs/python.md", "docs/clusters.md"] {
        run_document(document);
    }
}

/// A guide added under docs/ with commands in it is run too: it must be in [`DOCUMENTS`].
#[test]
fn every_document_with_commands_is_run() {
    for entry in std::fs::read_dir(root().join("docs")).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().and_then(|e| e.to_str()) != Some("md") {
            continue;
        }
        let text = std::fs::read_to_string(&path).unwrap();
        let name = format!("docs/{}", path.file_name().unwrap().to_str().unwrap());
        assert!(
            bash_blocks(&text).is_empty() || DOCUMENTS.iter().any(|(d, _)| *d == name),
            "{name} has shell blocks but is not in DOCUMENTS (tests/readme.rs)"
        );
    }
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

/// Every document's text, joined.
fn all_documents() -> String {
    DOCUMENTS
        .iter()
        .map(|(d, _)| std::fs::read_to_string(root().join(d)).unwrap())
        .collect::<Vec<_>>()
        .join("\n")
}

/// A reader who runs the guides' command-line blocks and then the Python examples in the same
/// folder keeps what both wrote (issue 38: the Python example saved over the CLI's `coman.sgp`).
#[test]
fn the_python_examples_write_no_file_the_commands_write() {
    let readme = all_documents();
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
            "the guides' Python writes {name}, which a command of their shell blocks writes too"
        );
    }
}
