//! `sgplvm generate`: demonstrations following the paper's protocol.

use std::path::PathBuf;

use anyhow::Result;
use clap::builder::PossibleValuesParser;
use clap::Args;
use sgplvm::robots::generator::{
    all_test_pairs, generate_to_file, random_test_pairs, GeneratorConfig, DEMO_FILE_NAME, KEY_POSES,
};
use sgplvm::robots::Robot;

#[derive(Args)]
pub struct GenerateArgs {
    /// Output folder (the file is written into it).
    #[arg(long, default_value = "data/demos")]
    out: PathBuf,
    /// Name of the file written in the output folder.
    #[arg(long, default_value = DEMO_FILE_NAME)]
    file: PathBuf,
    /// Robots to record, comma-separated, in column order [default: walkman,coman,centauro].
    /// Motions keep the paper's timing whichever robots are recorded, so adding one changes
    /// nothing in the human's or the other robots' data.
    #[arg(long, value_delimiter = ',', value_parser = robot_names())]
    robots: Option<Vec<String>>,
    /// Seed of every random draw.
    #[arg(long)]
    seed: Option<u64>,
    /// Keep every k-th frame of the training trajectories.
    #[arg(long, value_parser = clap::value_parser!(u64).range(1..))]
    subsample: Option<u64>,
    /// How many times the human goes back and forth between the two poses of every pair
    /// [default: 3]: longer sessions of the same protocol (with `--subsample 1`, about 1,000
    /// training frames per repetition; 20 give the 20,000 frames of the sparse model's
    /// benchmarks).
    #[arg(long, value_parser = clap::value_parser!(u64).range(1..=1000))]
    repetitions: Option<u64>,
    /// The test set's pose pairs: `paper` (the paper's two pairs), `all` (every ordered pair
    /// of two non-neutral key poses, 210: a test set whose errors do not hang on two draws of
    /// the human's motion) or a number N (N of those, drawn from --seed).
    #[arg(long, default_value = "paper", value_parser = parse_test_pairs)]
    test_pairs: TestPairs,
}

/// `--test-pairs`.
#[derive(Clone, Debug)]
enum TestPairs {
    Paper,
    All,
    Random(usize),
}

fn parse_test_pairs(s: &str) -> Result<TestPairs, String> {
    let most = all_test_pairs().len();
    match s {
        "paper" => Ok(TestPairs::Paper),
        "all" => Ok(TestPairs::All),
        _ => match s.parse::<usize>() {
            Ok(n) if (1..=most).contains(&n) => Ok(TestPairs::Random(n)),
            _ => Err(format!("expected paper, all or a number from 1 to {most}")),
        },
    }
}

/// The built-in robot models (every built-in body but the demonstrator).
fn robot_names() -> PossibleValuesParser {
    let human = GeneratorConfig::default().human;
    PossibleValuesParser::new(
        Robot::builtin_names()
            .iter()
            .copied()
            .filter(move |&n| n != human),
    )
}

pub fn run(args: GenerateArgs) -> Result<()> {
    let mut config = GeneratorConfig::default();
    if let Some(seed) = args.seed {
        config.seed = seed;
    }
    if let Some(k) = args.subsample {
        config.train_subsample = k as usize;
    }
    if let Some(r) = args.repetitions {
        config.repetitions = r as usize;
    }
    if let Some(robots) = args.robots {
        config.robots = robots;
    }
    config.test_pairs = match args.test_pairs {
        TestPairs::Paper => config.test_pairs,
        TestPairs::All => all_test_pairs(),
        // The parser allowed only counts that exist.
        TestPairs::Random(n) => random_test_pairs(n, config.seed).unwrap_or_default(),
    };
    let path = args.out.join(&args.file);
    let generated = generate_to_file(&config, &path)?;
    let ds = &generated.dataset;
    println!(
        "wrote {}: {} frames ({} training, {} test), robots {}",
        path.display(),
        ds.len(),
        ds.train.len(),
        ds.test.len(),
        ds.robot_names().join(", ")
    );
    for body in &generated.bodies {
        let unreached: Vec<String> = body
            .unreached()
            .map(|r| {
                format!(
                    "{} {} hand {:.1} mm off",
                    KEY_POSES[r.pose].name,
                    r.side.as_str(),
                    r.residual * 1e3
                )
            })
            .collect();
        if !unreached.is_empty() {
            println!(
                "{}: closest reachable posture used for {}",
                body.name,
                unreached.join(", ")
            );
        }
    }
    Ok(())
}
