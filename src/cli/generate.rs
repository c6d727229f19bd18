//! `sgplvm generate`: demonstrations following the paper's protocol.

use std::path::PathBuf;

use anyhow::Result;
use clap::Args;
use sgplvm::robots::generator::{generate_to_dir, GeneratorConfig};

#[derive(Args)]
pub struct GenerateArgs {
    /// Output folder (bimanual.mcap is written into it).
    #[arg(long, default_value = "data/demos")]
    out: PathBuf,
    /// Seed of every random draw.
    #[arg(long)]
    seed: Option<u64>,
    /// Keep every k-th frame of the training trajectories.
    #[arg(long, value_parser = clap::value_parser!(u64).range(1..))]
    subsample: Option<u64>,
}

pub fn run(args: GenerateArgs) -> Result<()> {
    let mut config = GeneratorConfig::default();
    if let Some(seed) = args.seed {
        config.seed = seed;
    }
    if let Some(k) = args.subsample {
        config.train_subsample = k as usize;
    }
    let (path, generated) = generate_to_dir(&config, &args.out)?;
    let ds = &generated.dataset;
    println!(
        "wrote {}: {} frames ({} training, {} test), robots {}",
        path.display(),
        ds.len(),
        ds.train.len(),
        ds.test.len(),
        ds.robot_names().join(", ")
    );
    Ok(())
}
