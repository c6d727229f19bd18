//! Progress bars on a terminal (nothing when stderr is not one), and a training run under one.

use std::io::IsTerminal;
use std::time::Instant;

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use sgplvm::core::{Callback, Control, IterationRecord};
use sgplvm::pipeline::PipelineError;
use sgplvm::SharedGplvm;

/// A progress bar on a terminal, nothing otherwise.
pub fn progress_bar(length: u64, prefix: &str) -> ProgressBar {
    let bar = ProgressBar::with_draw_target(
        Some(length),
        if std::io::stderr().is_terminal() {
            ProgressDrawTarget::stderr()
        } else {
            ProgressDrawTarget::hidden()
        },
    );
    bar.set_style(
        ProgressStyle::with_template("{prefix:>20} [{bar:30}] {pos}/{len} {msg}")
            .expect("valid template")
            .progress_chars("=> "),
    );
    bar.set_prefix(prefix.to_string());
    bar
}

/// Runs a training with a progress bar; returns the model and its training seconds.
pub fn train_with_progress(
    label: &str,
    max_iters: u64,
    train: impl FnOnce(Option<Callback<'_>>) -> Result<SharedGplvm, PipelineError>,
) -> Result<(SharedGplvm, f64), PipelineError> {
    let bar = progress_bar(max_iters, label);
    let started = Instant::now();
    let mut on_iteration = |record: &IterationRecord, _: &SharedGplvm| {
        bar.set_position(record.iteration as u64);
        bar.set_message(format!("objective {:.2}", record.objective));
        Control::Continue
    };
    // The snapshot the core builds for a callback costs time: only ask for it on a terminal.
    let callback: Option<Callback<'_>> = if bar.is_hidden() {
        None
    } else {
        Some(&mut on_iteration)
    };
    let model = train(callback)?;
    bar.finish_and_clear();
    let seconds = model
        .history()
        .last()
        .map_or(started.elapsed().as_secs_f64(), |r| r.seconds);
    Ok((model, seconds))
}
