//! `--calibration`, `--calibrate` and `--calibration-seconds`: how the person of a stream
//! (`teleop --input mvn|tf`, `import --mvn`) is calibrated, and `import`'s `--calibration` for
//! files. A calibration is read from a JSON file (`teleop --calibration-out`), an imported
//! demonstration file (MCAP, one per capture) or a model (`.sgp`, its training data's).

use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use clap::Args;
use sgplvm::capture::stream_calibration::DEFAULT_WATCH_SECONDS;
use sgplvm::capture::{calibrations_in, Calibration, StreamCalibrationOptions, CAPTURE_METADATA};
use sgplvm::{AnyModel, Predictor};

use super::args::load_any_model;

#[derive(Args, Clone)]
pub struct CalibrationArgs {
    /// The person's calibration to fit the stream through: a JSON file (as --calibration-out
    /// writes), an imported demonstration file (MCAP: the calibration of the capture whose rest
    /// pose is the stream's) or a model (.sgp: its training data's). A stream whose rest pose is
    /// none of its is refused [default: the models' training data's where the stream's rest
    /// pose is its, else the stream's own].
    #[arg(long, value_name = "FILE")]
    calibration: Option<PathBuf>,
    /// Calibrate the person on the stream itself, even where the models' training data was
    /// imported from the same skeleton.
    #[arg(long, conflicts_with = "calibration")]
    calibrate: bool,
    /// Seconds of the stream's motion to watch where its rest pose leaves an upper arm's
    /// twist untold (a T-pose with flat clavicles, a line of bones): the elbows' hinge tells it,
    /// as `import` reads it over a file; no commands until then (0: palms down assumed).
    #[arg(long, value_name = "SECONDS", default_value_t = DEFAULT_WATCH_SECONDS)]
    calibration_seconds: f64,
    /// Write the calibration the stream was fitted through to FILE (JSON) at the end, to give
    /// to --calibration next time.
    #[arg(long, value_name = "FILE")]
    calibration_out: Option<PathBuf>,
}

impl CalibrationArgs {
    /// The stream calibration's options, offered the calibrations of `models`' training data
    /// unless the user named one or asked for the stream's own.
    pub fn options(&self, models: &[&AnyModel]) -> Result<StreamCalibrationOptions> {
        if !(self.calibration_seconds.is_finite() && self.calibration_seconds >= 0.0) {
            bail!(
                "--calibration-seconds {}: expected seconds ≥ 0",
                self.calibration_seconds
            );
        }
        let (offered, required) = match (&self.calibration, self.calibrate) {
            (Some(path), _) => (read_calibrations(path)?, true),
            (None, true) => (Vec::new(), false),
            (None, false) => {
                let mut all = Vec::new();
                for m in models {
                    for c in model_calibrations(m)? {
                        if !all.contains(&c) {
                            all.push(c);
                        }
                    }
                }
                (all, false)
            }
        };
        Ok(StreamCalibrationOptions {
            offered,
            required,
            watch_seconds: self.calibration_seconds,
        })
    }

    /// Where to write the calibration used, if asked.
    pub fn out(&self) -> Option<&Path> {
        self.calibration_out.as_deref()
    }

    /// Writes the calibration a stream was fitted through to `--calibration-out`, if asked (a
    /// stream never calibrated is said, not an error: the run itself went as it went).
    pub fn write_used(&self, person: Option<&Calibration>) -> Result<()> {
        let Some(out) = self.out() else {
            return Ok(());
        };
        match person {
            Some(c) => {
                c.write(out)?;
                eprintln!("wrote the person's calibration to {}", out.display());
            }
            None => eprintln!(
                "--calibration-out {}: not written, the stream's person was never calibrated",
                out.display()
            ),
        }
        Ok(())
    }
}

/// The calibrations a model carries (its training data's).
pub fn model_calibrations(model: &AnyModel) -> Result<Vec<Calibration>> {
    match model.annotations().get(CAPTURE_METADATA) {
        None => Ok(Vec::new()),
        Some(sources) => calibrations_in(sources)
            .map_err(|e| anyhow::anyhow!("the model's `{CAPTURE_METADATA}` annotation: {e}")),
    }
}

/// The calibrations in `path`: a model file, an imported demonstration file or a JSON
/// calibration.
pub fn read_calibrations(path: &Path) -> Result<Vec<Calibration>> {
    let head = std::fs::read(path)
        .map(|b| b.get(..8).map(<[u8]>::to_vec).unwrap_or(b))
        .with_context(|| format!("--calibration {}", path.display()))?;
    if head.as_slice() == sgplvm::core::MAGIC {
        let model = load_any_model(path)?;
        let found = model_calibrations(&model)?;
        if found.is_empty() {
            bail!(
                "--calibration {}: the model carries no person's calibration (it was trained on data not imported from a capture, or before calibrations were stored)",
                path.display()
            );
        }
        return Ok(found);
    }
    Ok(Calibration::read(path)?)
}
