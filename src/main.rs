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

/// The chain of causes on one line, outermost first, leaving out causes that the message before
/// them already quotes.
fn one_line(e: &anyhow::Error) -> String {
    let mut message = String::new();
    for cause in e.chain().map(|c| c.to_string()) {
        if !message.contains(&cause) {
            message = if message.is_empty() {
                cause
            } else {
                format!("{message}: {cause}")
            };
        }
    }
    message
}
