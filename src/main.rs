//! `sgplvm`: train a shared GP-LVM on human demonstrations, transfer it to other robots, predict
//! joint commands from human frames, and run the paper's experiments.
//!
//! Exit codes: 0 success, 2 bad usage, 1 any other error (one line naming the file and what was
//! wrong). Output files are written whole or not at all. Each command lives in its own module
//! under `cli/`; this file only parses the arguments and prints the error.

#![deny(clippy::unwrap_used)]

mod cli;

use clap::Parser;

#[derive(Parser)]
#[command(
    name = "sgplvm",
    version,
    about = "Teach a family of robots the same motions from one set of human demonstrations",
    long_about = "Teach a family of robots the same motions from one set of human demonstrations.\n\n\
A shared GP-LVM learns one latent space behind a human's joint angles and a robot's joint \
commands; trained fully on one robot, it is transferred to others by training only their \
latent-to-joint mapping. Start with `sgplvm demo`."
)]
struct Cli {
    #[command(subcommand)]
    command: cli::Command,
}

fn main() {
    quiet_panics();
    let cli = Cli::parse();
    if let Err(e) = cli.command.run() {
        if is_broken_pipe(&e) {
            // `sgplvm … | head`: the reader has all it wanted.
            std::process::exit(0);
        }
        eprintln!("error: {}", one_line(&e));
        std::process::exit(1);
    }
}

/// Panics that a reader catches and turns into an error (inside mcap's reader or rapier) print
/// nothing — the error that follows says what happened, on one line. `println!` panics when the
/// reader of stdout went away (`sgplvm simulate … | head`): that ends quietly with exit code 0, as
/// a Unix filter does. Any other panic is reported once, on one line, instead of Rust's several
/// lines of panic text.
fn quiet_panics() {
    use std::sync::atomic::{AtomicBool, Ordering};
    static REPORTED: AtomicBool = AtomicBool::new(false);
    sgplvm_robots::panics::install_hook(Box::new(|info| {
        let message = sgplvm_robots::panics::describe(info);
        if message.contains("failed printing to stdout") && message.contains("Broken pipe") {
            std::process::exit(0);
        }
        if !REPORTED.swap(true, Ordering::SeqCst) {
            eprintln!("error: internal error in sgplvm (please report it): {message}");
        }
    }));
}

/// Whether `e` comes from writing to a closed pipe (a stream to stdout whose reader is gone).
fn is_broken_pipe(e: &anyhow::Error) -> bool {
    e.chain().any(|c| {
        c.downcast_ref::<std::io::Error>()
            .is_some_and(|io| io.kind() == std::io::ErrorKind::BrokenPipe)
    })
}

/// The chain of causes on one line, outermost first, each fact once (issue 38): a cause that
/// the line already holds is left out; a cause's leading `subject: ` (one word: a file name,
/// say) that the line already names is dropped from it; and a part of the line that a later cause repeats
/// whole (a context naming a file, then an error naming the same file) gives way to that cause.
fn one_line(e: &anyhow::Error) -> String {
    join_causes(e.chain().map(|c| c.to_string()))
}

/// [`one_line`] of the causes' texts, outermost first.
fn join_causes(causes: impl Iterator<Item = String>) -> String {
    let mut parts: Vec<String> = Vec::new();
    let said = |parts: &[String], text: &str| parts.iter().any(|p| p.contains(text));
    for cause in causes {
        let mut cause = cause.trim().to_string();
        if cause.is_empty() || said(&parts, &cause) {
            continue;
        }
        // A subject is one word (a file name, a topic): a phrase that merely recurs stays.
        if let Some((subject, rest)) = cause.split_once(": ") {
            let one_word = !subject.is_empty() && !subject.contains(char::is_whitespace);
            if one_word && !rest.is_empty() && said(&parts, subject) {
                cause = rest.to_string();
                if said(&parts, &cause) {
                    continue;
                }
            }
        }
        parts.retain(|p| !cause.contains(p.as_str()));
        parts.push(cause);
    }
    parts.join(": ")
}

#[cfg(test)]
mod tests {
    use super::join_causes;

    fn line(causes: &[&str]) -> String {
        join_causes(causes.iter().map(|c| c.to_string()))
    }

    #[test]
    fn each_fact_appears_once() {
        // A context naming the file, an error naming it again.
        assert_eq!(
            line(&[
                "nosuch.sgp",
                "model file nosuch.sgp: No such file or directory (os error 2)",
                "No such file or directory (os error 2)",
            ]),
            "model file nosuch.sgp: No such file or directory (os error 2)"
        );
        // The same file leading the context and the cause.
        assert_eq!(
            line(&[
                "/x/y.mcap: cannot write the replay",
                "/x/y.mcap: cannot create: No such file or directory (os error 2)",
            ]),
            "/x/y.mcap: cannot write the replay: cannot create: No such file or directory (os \
             error 2)"
        );
        // Causes that add a fact are all kept, in order.
        assert_eq!(
            line(&["in.csv", "line 3: column 2 is \"x\", expected a number"]),
            "in.csv: line 3: column 2 is \"x\", expected a number"
        );
        // A cause the line already quotes is left out.
        assert_eq!(
            line(&["a.mcap: invalid MCAP: bad magic", "bad magic"]),
            "a.mcap: invalid MCAP: bad magic"
        );
    }
}
