//! Progress bars on a terminal (nothing when stderr is not one), a training run under one, and
//! for long work in stages, one line per finished stage where no bar can be drawn (logs, CI);
//! work without stages ([`Activity`]) gets a spinner, or lines while it lasts.

use std::collections::BTreeMap;
use std::io::IsTerminal;
use std::sync::mpsc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use sgplvm::core::{Callback, Control, IterationRecord, PartStage, PartsCallback, PartsGplvm};
use sgplvm::experiment::{ModelKind, Progress, Stage};
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

/// Whether progress is drawn as bars (stderr is a terminal) rather than written as lines.
pub fn on_terminal() -> bool {
    std::io::stderr().is_terminal()
}

/// Work with no steps to count (a physics replay, a training without a terminal): on a
/// terminal a spinner with the time elapsed; without one, nothing if it ends within
/// [`Activity::QUIET`], else a line saying it is under way, another every
/// [`Activity::EVERY`], and one when it ends.
pub struct Activity {
    spinner: ProgressBar,
    lines: Option<(mpsc::Sender<()>, JoinHandle<bool>)>,
    label: String,
    started: Instant,
}

impl Activity {
    /// How long work may take before lines say it is under way.
    pub const QUIET: Duration = Duration::from_secs(5);
    /// Time between two lines while it lasts.
    pub const EVERY: Duration = Duration::from_secs(30);

    /// Starts showing `label` (what is being done); `detail` is added to the first line (e.g.
    /// how much work there is).
    pub fn start(label: &str, detail: &str) -> Activity {
        Self::start_with(label, detail, on_terminal(), Self::QUIET, Self::EVERY)
    }

    fn start_with(
        label: &str,
        detail: &str,
        terminal: bool,
        quiet: Duration,
        every: Duration,
    ) -> Activity {
        let started = Instant::now();
        let spinner = if terminal {
            let s = ProgressBar::new_spinner();
            s.set_style(
                ProgressStyle::with_template("{spinner} {prefix} {elapsed} {msg}")
                    .expect("valid template"),
            );
            s.set_prefix(label.to_string());
            s.enable_steady_tick(Duration::from_millis(120));
            s
        } else {
            ProgressBar::hidden()
        };
        let lines = (!terminal).then(|| {
            let (stop, stopped) = mpsc::channel::<()>();
            let (label, detail) = (label.to_string(), detail.to_string());
            let thread = std::thread::spawn(move || {
                if stopped.recv_timeout(quiet) != Err(mpsc::RecvTimeoutError::Timeout) {
                    return false;
                }
                eprintln!("{label}: under way{detail}");
                while stopped.recv_timeout(every) == Err(mpsc::RecvTimeoutError::Timeout) {
                    eprintln!(
                        "{label}: {} elapsed, still running",
                        short_duration(started.elapsed())
                    );
                }
                true
            });
            (stop, thread)
        });
        Activity {
            spinner,
            lines,
            label: label.to_string(),
            started,
        }
    }

    /// Ends it; without a terminal, says so if a line said it was under way.
    pub fn finish(self) {
        self.spinner.finish_and_clear();
        if let Some((stop, thread)) = self.lines {
            let _ = stop.send(());
            if thread.join().unwrap_or(false) {
                eprintln!(
                    "{}: done in {}",
                    self.label,
                    short_duration(self.started.elapsed())
                );
            }
        }
    }
}

/// Runs a training with a progress bar (on a terminal; else an [`Activity`]'s lines); returns
/// the model and its training seconds.
pub fn train_with_progress(
    label: &str,
    max_iters: u64,
    train: impl FnOnce(Option<Callback<'_>>) -> Result<SharedGplvm, PipelineError>,
) -> Result<(SharedGplvm, f64), PipelineError> {
    if !on_terminal() {
        // The snapshot the core builds for a callback costs time: lines need none.
        let activity = Activity::start(label, &format!(", at most {max_iters} iterations"));
        let started = Instant::now();
        let result = train(None);
        activity.finish();
        let model = result?;
        let seconds = model
            .history()
            .last()
            .map_or(started.elapsed().as_secs_f64(), |r| r.seconds);
        return Ok((model, seconds));
    }
    let bar = progress_bar(max_iters, label);
    let started = Instant::now();
    let mut on_iteration = |record: &IterationRecord, _: &SharedGplvm| {
        bar.set_position(record.iteration as u64);
        bar.set_message(format!("objective {:.2}", record.objective));
        Control::Continue
    };
    let model = train(Some(&mut on_iteration))?;
    bar.finish_and_clear();
    let seconds = model
        .history()
        .last()
        .map_or(started.elapsed().as_secs_f64(), |r| r.seconds);
    Ok((model, seconds))
}

/// Runs a per-part training with a progress bar (on a terminal; else an [`Activity`]'s lines):
/// the bar restarts for each model trained, each part then the parent, and names it.
pub fn train_parts_with_progress(
    label: &str,
    max_iters: u64,
    train: impl FnOnce(Option<PartsCallback<'_>>) -> Result<PartsGplvm, PipelineError>,
) -> Result<PartsGplvm, PipelineError> {
    if !on_terminal() {
        let activity = Activity::start(
            label,
            &format!(", each part and the parent at most {max_iters} iterations"),
        );
        let result = train(None);
        activity.finish();
        return result;
    }
    let bar = progress_bar(max_iters, label);
    let mut shown = None;
    let mut on_iteration = |stage: PartStage<'_>, record: &IterationRecord, _: &SharedGplvm| {
        let name = match stage {
            PartStage::Part { name, .. } => name.to_string(),
            PartStage::Parent => "parent".to_string(),
        };
        if shown.as_ref() != Some(&name) {
            bar.reset();
            bar.set_prefix(format!("{label}: {name}"));
            shown = Some(name);
        }
        bar.set_position(record.iteration as u64);
        bar.set_message(format!("objective {:.2}", record.objective));
        Control::Continue
    };
    let model = train(Some(&mut on_iteration))?;
    bar.finish_and_clear();
    Ok(model)
}

/// One line per finished stage of an experiment, with the time elapsed and an estimate of the
/// time left: for a log, where a progress bar cannot be drawn.
pub struct StageLines {
    plan: Vec<Stage>,
    /// Elapsed time when the current stage started.
    stage_started: Duration,
    /// Seconds and trainings of finished stages, by kind of model (`None`: direct regressions).
    timed: BTreeMap<Option<ModelKind>, (f64, usize)>,
    /// Work (in [`Stage::work`] units) and seconds of the finished stages that train shared
    /// GP-LVMs (the direct regressions cost far less per unit).
    work_done: f64,
    work_seconds: f64,
}

impl StageLines {
    /// Lines for the stages of `plan`.
    pub fn new(plan: Vec<Stage>) -> Self {
        StageLines {
            plan,
            stage_started: Duration::ZERO,
            timed: BTreeMap::new(),
            work_done: 0.0,
            work_seconds: 0.0,
        }
    }

    /// The line to print for `progress`, `elapsed` after the start: `Some` when it completes a
    /// stage.
    pub fn update(&mut self, progress: &Progress, elapsed: Duration) -> Option<String> {
        let stage = self.plan.get(progress.stage)?;
        if progress.stage_done < stage.trainings {
            return None;
        }
        let seconds = (elapsed - self.stage_started.min(elapsed)).as_secs_f64();
        let entry = self.timed.entry(stage.model).or_insert((0.0, 0));
        entry.0 += seconds;
        entry.1 += stage.trainings;
        if stage.model.is_some() {
            self.work_done += stage.work * stage.trainings as f64;
            self.work_seconds += seconds;
        }
        self.stage_started = elapsed;
        let eta = self
            .time_left(progress.stage)
            .map_or("unknown yet".to_string(), short_duration);
        Some(format!(
            "{}: {}/{} trainings, {} elapsed, ETA {} ({}/{} in all)",
            stage.name,
            progress.stage_done,
            stage.trainings,
            short_duration(elapsed),
            eta,
            progress.done,
            progress.total,
        ))
    }

    /// Estimated time for the stages after `finished`: each at the seconds per training of its
    /// kind of model once one stage of that kind was timed, else at the rate per unit of work of
    /// the shared GP-LVMs trained so far; `None` before any was.
    fn time_left(&self, finished: usize) -> Option<Duration> {
        let per_work = (self.work_done > 0.0).then(|| self.work_seconds / self.work_done);
        let mut seconds = 0.0;
        for s in &self.plan[finished + 1..] {
            let per_training = match self.timed.get(&s.model) {
                Some(&(secs, n)) if n > 0 => secs / n as f64,
                _ => per_work? * s.work,
            };
            seconds += per_training * s.trainings as f64;
        }
        Some(Duration::from_secs_f64(seconds.max(0.0)))
    }
}

/// One line per finished step of a fixed number of steps, with the time elapsed and an
/// estimate of the time left (at the mean time per step so far): the demo's progress in a log.
pub struct StepLines {
    total: usize,
    done: usize,
}

impl StepLines {
    /// Lines for `total` steps.
    pub fn new(total: usize) -> Self {
        StepLines { total, done: 0 }
    }

    /// The line for the step just finished (`what`), `elapsed` after the first one started.
    pub fn step(&mut self, what: &str, elapsed: Duration) -> String {
        self.done = (self.done + 1).min(self.total.max(1));
        let left = self.total.saturating_sub(self.done);
        let eta = elapsed.mul_f64(left as f64 / self.done as f64);
        format!(
            "{what} ({}/{} steps, {} elapsed, ETA {})",
            self.done,
            self.total,
            short_duration(elapsed),
            short_duration(eta)
        )
    }
}

/// A duration as `42s`, `3m07s` or `1h05m`.
pub fn short_duration(d: Duration) -> String {
    let s = d.as_secs_f64().round() as u64;
    match s {
        0..60 => format!("{s}s"),
        60..3600 => format!("{}m{:02}s", s / 60, s % 60),
        _ => format!("{}h{:02}m", s / 3600, s % 3600 / 60),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn stage(name: &str, model: Option<ModelKind>, trainings: usize, work: f64) -> Stage {
        Stage {
            name: name.into(),
            model,
            trainings,
            work,
        }
    }

    fn progress(stage: usize, stage_done: usize, done: usize) -> Progress {
        Progress {
            done,
            total: 17,
            message: String::new(),
            stage,
            stage_done,
        }
    }

    #[test]
    fn an_activity_is_quiet_when_short_and_says_when_long() {
        let (quiet, every) = (Duration::from_millis(50), Duration::from_millis(40));
        // Short: the thread stops without a line.
        let short = Activity::start_with("quick", "", false, Duration::from_secs(60), every);
        let (stop, thread) = short.lines.expect("lines without a terminal");
        stop.send(()).expect("thread alive");
        assert!(!thread.join().expect("no panic"));
        // Long: it said so.
        let long = Activity::start_with("slow", "", false, quiet, every);
        std::thread::sleep(Duration::from_millis(150));
        let (stop, thread) = long.lines.expect("lines without a terminal");
        stop.send(()).expect("thread alive");
        assert!(thread.join().expect("no panic"));
        // On a terminal: a spinner, no lines.
        let drawn = Activity::start_with("drawn", "", true, quiet, every);
        assert!(drawn.lines.is_none());
        drawn.finish();
    }

    #[test]
    fn step_lines_estimate_the_rest_at_the_mean_so_far() {
        let mut lines = StepLines::new(4);
        assert_eq!(
            lines.step("trained walkman", Duration::from_secs(10)),
            "trained walkman (1/4 steps, 10s elapsed, ETA 30s)"
        );
        lines.step("b", Duration::from_secs(12));
        lines.step("c", Duration::from_secs(15));
        assert_eq!(
            lines.step("figures", Duration::from_secs(20)),
            "figures (4/4 steps, 20s elapsed, ETA 0s)"
        );
        // More steps than announced: never a division by zero or a negative estimate.
        assert!(lines
            .step("extra", Duration::from_secs(21))
            .ends_with("ETA 0s)"));
    }

    #[test]
    fn short_durations() {
        assert_eq!(short_duration(Duration::from_secs_f64(41.6)), "42s");
        assert_eq!(short_duration(Duration::from_secs(187)), "3m07s");
        assert_eq!(short_duration(Duration::from_secs(3900)), "1h05m");
        assert_eq!(short_duration(Duration::ZERO), "0s");
    }

    #[test]
    fn one_line_per_finished_stage_with_an_eta_by_kind_of_model() {
        use ModelKind::*;
        let mut lines = StageLines::new(vec![
            stage("direct GP regression H → R", None, 2, 1000.0),
            stage("baselines, none BC", Some(Baseline), 4, 600.0),
            stage("transfers, none BC", Some(Transfer), 10, 300.0),
            stage("baselines, input BC", Some(Baseline), 2, 600.0),
            stage("multi-robot, input BC", Some(Multi), 1, 1200.0),
        ]);
        let at = |s| Duration::from_secs(s);
        // The direct regressions say nothing of how long a shared GP-LVM takes.
        assert_eq!(
            lines.update(&progress(0, 2, 2), at(2)).as_deref(),
            Some("direct GP regression H → R: 2/2 trainings, 2s elapsed, ETA unknown yet (2/17 in all)")
        );
        // Within a stage: no line.
        assert_eq!(lines.update(&progress(1, 3, 3), at(30)), None);
        // Baselines: 4 in 40 s (from 2 s to 42 s), 10 s each, 2400 work units → 1/60 s per unit. Left: 10
        // transfers (never timed: 300 units → 5 s each) 50 s, 2 baselines at 10 s = 20 s, the
        // multi-robot model (1200 units) 20 s: 90 s.
        assert_eq!(
            lines.update(&progress(1, 4, 4), at(42)).as_deref(),
            Some("baselines, none BC: 4/4 trainings, 42s elapsed, ETA 1m30s (4/17 in all)")
        );
        // Transfers took 20 s (2 s each, faster than the work estimate): left 2 baselines at
        // 10 s and the multi-robot model at (60 s / 5400 units) × 1200 = 13.3 s: 33 s.
        assert_eq!(
            lines.update(&progress(2, 10, 14), at(62)).as_deref(),
            Some("transfers, none BC: 10/10 trainings, 1m02s elapsed, ETA 33s (14/17 in all)")
        );
        // The last stage: nothing left.
        lines.update(&progress(3, 2, 16), at(82));
        assert_eq!(
            lines.update(&progress(4, 1, 17), at(95)).as_deref(),
            Some("multi-robot, input BC: 1/1 trainings, 1m35s elapsed, ETA 0s (17/17 in all)")
        );
        // A stage index outside the plan is ignored.
        assert_eq!(lines.update(&progress(9, 1, 17), at(99)), None);
    }
}
