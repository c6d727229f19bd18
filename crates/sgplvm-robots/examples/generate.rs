//! Generates the shipped demonstrations: `cargo run --release -p sgplvm-robots --example generate -- data/demos`
//!
//! Writes `<dir>/bimanual.mcap` with the default [`GeneratorConfig`] and prints a summary:
//! frames, training and test set sizes, and every key-pose hand target IK could not reach.

use sgplvm_robots::generator::{generate_to_dir, GeneratorConfig, KEY_POSES};

fn main() {
    let dir = std::env::args()
        .nth(1)
        .unwrap_or_else(|| "data/demos".to_string());
    let config = GeneratorConfig::default();
    match generate_to_dir(&config, &dir) {
        Ok((path, generated)) => {
            let ds = &generated.dataset;
            println!(
                "{}: {} frames at {} Hz, {} segments, train {} frames (every {}th), test {} frames",
                path.display(),
                ds.len(),
                config.rate_hz,
                ds.segments.len(),
                ds.train.len(),
                config.train_subsample,
                ds.test.len()
            );
            for body in &generated.bodies {
                // Posture continuity: how far each key posture is from the neutral one.
                let dists: Vec<f64> = body
                    .postures
                    .iter()
                    .map(|q| {
                        q.iter()
                            .zip(&body.postures[0])
                            .map(|(a, b)| (a - b).abs())
                            .fold(0.0, f64::max)
                    })
                    .collect();
                println!(
                    "  {}: largest joint move from neutral: mean {:.2} rad, max {:.2} rad",
                    body.name,
                    dists.iter().sum::<f64>() / (dists.len() - 1) as f64,
                    dists.iter().cloned().fold(0.0, f64::max)
                );
                let unreached: Vec<String> = body
                    .unreached()
                    .map(|r| {
                        format!(
                            "{}/{:?} ({:.1} mm)",
                            KEY_POSES[r.pose].name,
                            r.side,
                            r.residual * 1e3
                        )
                    })
                    .collect();
                if unreached.is_empty() {
                    println!("  {}: all 32 hand targets reached", body.name);
                } else {
                    println!(
                        "  {}: closest reachable used for {}",
                        body.name,
                        unreached.join(", ")
                    );
                }
            }
        }
        Err(e) => {
            eprintln!("error: {e}");
            std::process::exit(1);
        }
    }
}
