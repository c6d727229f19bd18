//! `sgplvm train`: the full model (one robot) or the multi-robot model (several); with
//! `--parts arms`, a latent space per arm joined by a parent latent space.

use std::collections::BTreeMap;
use std::path::PathBuf;

use anyhow::{anyhow, bail, Result};
use clap::Args;
use sgplvm::pipeline::Parts;
use sgplvm::PartsConfig;

use super::args::{DataArg, ModelConfigArgs, TrainOutputArgs};
use super::progress::{train_parts_with_progress, train_with_progress};
use super::report;

#[derive(Args)]
pub struct TrainArgs {
    #[command(flatten)]
    data: DataArg,
    /// Robot(s) to train on (repeat for the multi-robot model).
    #[arg(long = "robot", required = true)]
    robots: Vec<String>,
    #[command(flatten)]
    model: ModelConfigArgs,
    /// Choose the latent dimension Q among these (e.g. 5,8,12,16) on held-out training motions:
    /// one model per Q, each with its budget validated, and the one whose held-out error is
    /// lowest kept (the test frames are never looked at). The paper's Q = 5 suits its generated
    /// data; whole-arm retargeted captures carry more of the arm's posture (on captured.mcap
    /// the held-out error chose 16, 12 and 8 for WALK-MAN, COMAN and CENTAURO). Replaces
    /// --latent-dim; needs --validation auto.
    #[arg(long, value_name = "Q,Q,...", value_delimiter = ',', conflicts_with_all = ["parts", "latent_dim"])]
    choose_latent_dim: Vec<u64>,
    #[command(flatten)]
    parts: PartsArgs,
    #[command(flatten)]
    output: TrainOutputArgs,
}

// `--parts`, `--parent-latent-dim`, `--urdf`: a latent space per body part.
#[derive(Args)]
pub struct PartsArgs {
    /// A latent space per body part instead of one shared latent space: `arms` trains a shared
    /// GP-LVM per arm (the human's 9 left-arm joints with each robot's left-arm joints, likewise
    /// the right), each back-constrained on its own arm (the paper's future work, §V-B; a parent
    /// latent space joins them with --parent-latent-dim). A new pairing of arm motions is then predicted as
    /// each arm's own motion. Every setting (--latent-dim, --inducing, --bayesian, ...) applies
    /// to each arm's model. Robots' arms are the joints `retarget` took as each arm (the file
    /// records them), else come from their anatomy (built-in robots, --urdf) or their joint
    /// names (L…/R…, left_…/right_…).
    #[arg(long, value_name = "arms", value_parser = parse_parts)]
    pub parts: Option<Parts>,
    /// With --parts: also train a parent latent space of dimension Q above the parts' (the
    /// whole body's latent space, Lawrence & Moore's hierarchy), after them. No prediction goes
    /// through it, and it trains about as long as the parts together: without this flag (or
    /// with 0) there is none.
    #[arg(long, value_name = "Q", requires = "parts")]
    pub parent_latent_dim: Option<u64>,
    /// With --parts: a robot's URDF, ROBOT=FILE, whose anatomy (with the description file
    /// beside it) says which joints are its arms, before the file's record of them (a file
    /// `retarget` wrote before it recorded them).
    #[arg(long = "urdf", value_name = "ROBOT=FILE", requires = "parts")]
    pub urdf: Vec<String>,
}

/// `--parts`: a name of [`Parts`].
fn parse_parts(text: &str) -> Result<Parts, String> {
    text.parse()
}

impl PartsArgs {
    /// `--urdf ROBOT=FILE` by robot name.
    pub fn urdfs(&self) -> Result<BTreeMap<String, PathBuf>> {
        self.urdf
            .iter()
            .map(|s| {
                let (robot, file) = s
                    .split_once('=')
                    .filter(|(r, f)| !r.is_empty() && !f.is_empty())
                    .ok_or_else(|| anyhow!("--urdf {s}: expected ROBOT=FILE"))?;
                Ok((robot.to_string(), PathBuf::from(file)))
            })
            .collect()
    }

    /// The parent's latent dimension: `--parent-latent-dim` (absent or 0: no parent).
    pub fn parent_latent_dim(&self) -> Option<usize> {
        self.parent_latent_dim
            .filter(|&q| q > 0)
            .map(|q| q as usize)
    }
}

pub fn run(args: TrainArgs) -> Result<()> {
    let demos = args.data.load()?;
    let config = args.model.config();
    let options = args.model.options()?;
    let patience = args.model.budget.patience();
    let label = format!("training {}", args.robots.join(" + "));
    let n = demos.dataset.train.len();
    if n <= config.latent_dim && args.choose_latent_dim.is_empty() {
        bail!(
            "{}: {} to train on; latent dimension Q = {} needs more than Q of them (a longer capture, --train-subsample 1, or a smaller --latent-dim)",
            demos.source_name,
            sgplvm::robots::names::count(n, "training frame"),
            config.latent_dim
        );
    }
    if let Some(Parts::Arms) = args.parts.parts {
        let urdfs = args.parts.urdfs()?;
        if let Some(r) = urdfs.keys().find(|r| !args.robots.contains(r)) {
            bail!(
                "--urdf {r}=…: '{r}' is not one of the robots trained on ({:?})",
                args.robots
            );
        }
        let parts = demos.arm_parts(&args.robots, &urdfs)?;
        let config =
            PartsConfig::new(config, parts).with_parent_latent_dim(args.parts.parent_latent_dim());
        let mut model = train_parts_with_progress(&label, args.model.budget.max_iters, |cb| {
            demos.train_parts(&args.robots, &config, &options, patience, cb)
        })?;
        for (key, value) in args.data.annotations(&args.robots, model.annotations())? {
            model.annotate(key, value);
        }
        model.save(&args.output.out)?;
        report::parts_training(&model, &args.output.out, args.output.json.json);
        return Ok(());
    }
    let (mut model, seconds) = if args.choose_latent_dim.is_empty() {
        train_with_progress(&label, args.model.budget.max_iters, |cb| {
            demos.train(&args.robots, &config, &options, patience, cb)
        })?
    } else {
        let Some(patience) = patience else {
            bail!("--choose-latent-dim chooses on held-out training motions: it needs --validation auto");
        };
        choose_latent_dim(&args, &demos, &config, &options, patience, &label)?
    };
    for (key, value) in args.data.annotations(&args.robots, model.annotations())? {
        model.annotate(key, value);
    }
    model.save(&args.output.out)?;
    report::training(&model, seconds, &args.output.out, args.output.json.json);
    Ok(())
}

/// `--choose-latent-dim`: one model per Q, each validated on the held-out training motions;
/// the one with the lowest held-out error (at its chosen budget), and the seconds all took.
fn choose_latent_dim(
    args: &TrainArgs,
    demos: &sgplvm::pipeline::Demonstrations,
    config: &sgplvm::ModelConfig,
    options: &sgplvm::TrainOptions,
    patience: usize,
    label: &str,
) -> Result<(sgplvm::SharedGplvm, f64)> {
    let mut best: Option<(f64, sgplvm::SharedGplvm)> = None;
    let mut seconds = 0.0;
    for &q in &args.choose_latent_dim {
        if q == 0 {
            bail!("--choose-latent-dim: Q = 0; expected latent dimensions ≥ 1");
        }
        let config = config.clone().with_latent_dim(q as usize);
        let (model, s) = train_with_progress(
            &format!("{label}, Q = {q}"),
            args.model.budget.max_iters,
            |cb| demos.train(&args.robots, &config, options, Some(patience), cb),
        )?;
        seconds += s;
        let held_out = model
            .selection()
            .and_then(|sel| {
                sel.curve
                    .iter()
                    .find(|r| r.iteration == sel.best_iteration)
                    .map(|r| r.validation_mse)
            })
            .unwrap_or(f64::INFINITY);
        eprintln!("  Q = {q}: held-out MSE {held_out:.6}");
        if best.as_ref().is_none_or(|(e, _)| held_out < *e) {
            best = Some((held_out, model));
        }
    }
    let (held_out, model) =
        best.ok_or_else(|| anyhow::anyhow!("--choose-latent-dim: no Q given"))?;
    eprintln!(
        "chose Q = {} (held-out MSE {held_out:.6})",
        model.config().latent_dim
    );
    Ok((model, seconds))
}
