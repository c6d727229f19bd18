//! Argument groups that several commands share (`#[command(flatten)]`): the demonstrations, the
//! model file, the training budget and configuration, and where a trained model goes.
//!
//! A group's flag keeps its name, default and help wherever it is flattened; a command whose help
//! for the same flag says more overrides only the help text (`mut_arg`).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use clap::builder::PossibleValue;
use clap::{Args, ValueEnum};
use sgplvm::capture::girdle::GirdleAlignment;
use sgplvm::pipeline::{self, Demonstrations};
use sgplvm::provenance::demonstration_annotations;
use sgplvm::{AnyModel, BackConstraint, ModelConfig, TrainOptions, Validation};

// The groups' own doc comments are `//` comments: clap would take a `///` comment on a flattened
// struct for the about text of the command it is flattened into.

// `--data`: the demonstrations.
#[derive(Args)]
pub struct DataArg {
    /// Demonstrations (MCAP); default: the shipped data.
    #[arg(long)]
    pub data: Option<PathBuf>,
}

impl DataArg {
    /// The demonstrations named by `--data`, or the shipped ones.
    pub fn load(&self) -> Result<Demonstrations> {
        Ok(pipeline::load(self.data.as_deref())?)
    }

    /// What a model trained on `--data`'s robots `robots` carries of them, as annotations to
    /// add to one whose annotations are `existing` (none for the shipped data):
    /// [`demonstration_annotations`].
    pub fn annotations(
        &self,
        robots: &[String],
        existing: &BTreeMap<String, serde_json::Value>,
    ) -> Result<Vec<(&'static str, serde_json::Value)>> {
        let Some(path) = &self.data else {
            return Ok(Vec::new());
        };
        demonstration_annotations(path, robots, existing)
            .with_context(|| path.display().to_string())
    }
}

// `--model`: a trained model to read.
#[derive(Args)]
pub struct ModelFileArg {
    /// The model.
    #[arg(long)]
    pub model: PathBuf,
}

impl ModelFileArg {
    /// The model named by `--model`, of either kind (a latent space per body part too).
    pub fn load_any(&self) -> Result<AnyModel> {
        load_any_model(&self.model)
    }
}

/// Reads a model file of either kind; errors name the file.
pub fn load_any_model(path: &Path) -> Result<AnyModel> {
    AnyModel::load(path).with_context(|| path.display().to_string())
}

/// Creates the output folder `dir` (and its parents) before any work, so that a path that cannot
/// be a folder fails at once rather than after the trainings.
pub fn output_folder(dir: &Path) -> Result<()> {
    std::fs::create_dir_all(dir)
        .with_context(|| format!("{}: cannot create the output folder", dir.display()))
}

// `--json`: machine-readable output.
#[derive(Args)]
pub struct JsonArg {
    /// Print machine-readable results.
    #[arg(long)]
    pub json: bool,
}

// `--girdle`: how a person's clavicles reach the model.
#[derive(Args)]
pub struct GirdleArg {
    /// How a person's clavicle angles reach the model: `aligned` moves each person's mean
    /// clavicle elevation and protraction (over their frames so far) to the model's people's
    /// and turns the shoulder so that the arm keeps its pose — rigs put the collarbone in
    /// different places (docs/capture.md); `as-captured` gives them as imported.
    #[arg(long, value_enum, default_value_t = Girdle::Aligned)]
    pub girdle: Girdle,
}

/// `--girdle`'s values.
#[derive(Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum Girdle {
    /// Aligned to the model's people.
    Aligned,
    /// As the capture gives them.
    AsCaptured,
}

impl GirdleArg {
    /// The alignment for `model`'s human frames, where asked for and the model has one.
    pub fn alignment(&self, model: &AnyModel) -> Option<GirdleAlignment> {
        match self.girdle {
            Girdle::Aligned => sgplvm::girdle::for_model(model),
            Girdle::AsCaptured => None,
        }
    }

    /// One person's frames `h` (rows, in order) aligned for `model` as asked; `None` where they
    /// go to it as they are.
    pub fn aligned_rows(&self, model: &AnyModel, h: &sgplvm::Mat<f64>) -> Option<sgplvm::Mat<f64>> {
        let mut alignment = self.alignment(model)?;
        let mut aligned = h.clone();
        sgplvm::girdle::align_rows(&mut alignment, &mut aligned);
        Some(aligned)
    }
}

// `--max-iters`, `--validation`, `--patience`: the iteration budget of a training and how it is
// chosen.
#[derive(Args)]
pub struct BudgetArg {
    /// Iteration budget (an upper bound when the budget is chosen on validation frames).
    #[arg(long, default_value_t = 1000)]
    pub max_iters: u64,
    /// How many iterations to train: `auto` holds out the last repetition of every training
    /// motion (or every third trajectory), trains until the error on them stops falling, then
    /// trains on all training frames for the best iteration count; `none` trains on all
    /// frames until convergence or `--max-iters`.
    #[arg(long, value_enum, default_value = "auto")]
    pub validation: ValidationArg,
    /// With `--validation auto`: iterations without a lower validation error before the
    /// selection run stops.
    #[arg(long, default_value_t = Validation::DEFAULT_PATIENCE as u64)]
    pub patience: u64,
    /// Wall-clock budget of each training in seconds (with `--validation auto`, half of it for
    /// choosing the iteration count): when it runs out, training stops and keeps the best
    /// parameters so far (stop reason `time_limit`). Default: no limit.
    #[arg(long, value_parser = parse_seconds)]
    pub max_seconds: Option<f64>,
}

/// A `--max-seconds` value: a number of seconds ≥ 0.
pub fn parse_seconds(text: &str) -> Result<f64, String> {
    match text.parse::<f64>() {
        Ok(s) if s >= 0.0 => Ok(s),
        _ => Err(format!("expected a number of seconds ≥ 0, got '{text}'")),
    }
}

/// `--validation`: whether the iteration budget is chosen on held-out training frames.
#[derive(Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum ValidationArg {
    /// Early stopping on held-out training frames, then retraining on all of them.
    Auto,
    /// Train on all frames until convergence or the budget.
    None,
}

impl BudgetArg {
    /// Training options with this budget.
    pub fn options(&self) -> TrainOptions {
        TrainOptions::default()
            .with_max_iters(self.max_iters as usize)
            .with_max_seconds(self.max_seconds)
    }

    /// The patience of `--validation auto` (the frames held out depend on the frames a model
    /// trains on: [`Demonstrations::train`]); `None` for `none`.
    pub fn patience(&self) -> Option<usize> {
        (self.validation == ValidationArg::Auto).then_some(self.patience as usize)
    }
}

/// Inducing inputs of `--bayesian` without `--inducing`.
pub const BAYESIAN_INDUCING: usize = 50;

// The model configuration of a full training.
#[derive(Args)]
pub struct ModelConfigArgs {
    /// Latent parametrisation.
    #[arg(long, value_enum, default_value = "input")]
    pub back_constraint: BackConstraintArg,
    /// Latent dimension Q.
    #[arg(long, default_value_t = 5, value_parser = clap::value_parser!(u64).range(1..))]
    pub latent_dim: u64,
    #[command(flatten)]
    pub budget: BudgetArg,
    /// Seed of the initialisation.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Train the sparse model with M inducing inputs on every frame of the training motions,
    /// not only the subsampled training set the exact model takes (O(N M²) time, O(N M)
    /// memory; back constraints none or input); without it the exact model (O(N³), O(N²)).
    /// Models transferred from a sparse model are sparse too, on the same frames.
    #[arg(long, value_name = "M", value_parser = clap::value_parser!(u64).range(1..))]
    pub inducing: Option<u64>,
    /// Keep the inducing inputs where they start (with --inducing) instead of training them.
    #[arg(long, requires = "inducing")]
    pub fixed_inducing: bool,
    /// The Bayesian shared GP-LVM (MRD): a Gaussian posterior over each frame's latent point
    /// and a KL term to the prior instead of point positions that overfit, each space's ARD
    /// lengthscales switching off the latent dimensions it does not need (--latent-dim is then
    /// an upper bound). Sparse, on every frame: --inducing defaults to 50 for it. Meant to be trained to
    /// convergence (--validation none); its transfers need --validation none.
    #[arg(long)]
    pub bayesian: bool,
    /// Train the back-constraint weights whitened (W = K_bc^(-1/2) V): the same model, far better
    /// conditioned, so training reaches a low objective in far fewer iterations (on the benchmark
    /// data GPy's final level at iteration 56; the plain weights at iteration 17,055).
    /// For when you want the optimum fast (time to solution, training to convergence); off by
    /// default because the slow plain route regularises: held-out error was worse with it on the
    /// shipped data (BENCHMARKS.md, issue 18). Needs --back-constraint input or output and the
    /// exact model (not --inducing).
    #[arg(long, conflicts_with_all = ["inducing", "bayesian"])]
    pub whiten_back_constraint: bool,
}

impl ModelConfigArgs {
    /// The model configuration these flags describe.
    pub fn config(&self) -> ModelConfig {
        ModelConfig::default()
            .with_latent_dim(self.latent_dim as usize)
            .with_back_constraint(self.back_constraint.0)
            .with_seed(self.seed)
            .with_inducing(
                self.inducing
                    .map(|m| m as usize)
                    .or(self.bayesian.then_some(BAYESIAN_INDUCING)),
            )
            .with_fixed_inducing(self.fixed_inducing)
            .with_bayesian(self.bayesian)
    }

    /// The training options these flags describe: the budget's, and whether back-constraint
    /// weights are trained whitened (refused for free latent points).
    pub fn options(&self) -> Result<TrainOptions> {
        if self.whiten_back_constraint && self.back_constraint.0 == BackConstraint::None {
            anyhow::bail!(
                "--whiten-back-constraint needs back constraints (--back-constraint input or \
                 output); --back-constraint none has free latent points"
            );
        }
        Ok(self
            .budget
            .options()
            .with_whiten_back_constraint(self.whiten_back_constraint))
    }
}

// `--out` and `--json` of a training: where the model goes and how the result is reported.
#[derive(Args)]
pub struct TrainOutputArgs {
    /// Where to write the model.
    #[arg(long)]
    pub out: PathBuf,
    #[command(flatten)]
    pub json: JsonArg,
}

/// `--back-constraint`: the core's [`BackConstraint`] by its name ([`BackConstraint::name`], the
/// one its `Display` and `FromStr` use), with a line of help for each value.
#[derive(Clone, Copy)]
pub struct BackConstraintArg(pub BackConstraint);

impl BackConstraintArg {
    const ALL: [BackConstraintArg; 3] = [
        BackConstraintArg(BackConstraint::ALL[0]),
        BackConstraintArg(BackConstraint::ALL[1]),
        BackConstraintArg(BackConstraint::ALL[2]),
    ];
}

impl ValueEnum for BackConstraintArg {
    fn value_variants<'a>() -> &'a [Self] {
        &Self::ALL
    }

    fn to_possible_value(&self) -> Option<PossibleValue> {
        let help = match self.0 {
            BackConstraint::None => {
                "Free latent points (human → latent by GP regression after training)"
            }
            BackConstraint::Input => {
                "Latent points as a kernel mapping of the human input (the paper's choice)"
            }
            BackConstraint::Output => "Latent points as a kernel mapping of the robot output",
        };
        Some(PossibleValue::new(self.0.name()).help(help))
    }
}
