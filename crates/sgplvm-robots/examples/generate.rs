//! Generates the shipped demonstrations:
//! `cargo run --release -p sgplvm-robots --example generate -- data/demos` writes
//! `data/demos/bimanual.mcap` (the paper's three robots), and
//! `cargo run --release -p sgplvm-robots --example generate -- data/demos walkman,coman,centauro,ur5e fleet.mcap`
//! writes `data/demos/fleet.mcap` (the same with the 6-joint `ur5e`).
//!
//! Arguments: the folder, then optionally the robots (comma-separated) and the file name.
//! Prints a summary: frames, training and test set sizes, how far each body's key postures are
//! from its neutral one, every key-pose hand target IK could not reach, and each robot's
//! fastest joint against its URDF velocity limit.

use sgplvm_robots::generator::{generate_to_file, GeneratorConfig, DEMO_FILE_NAME, KEY_POSES};
use sgplvm_robots::Robot;

fn main() {
    let mut args = std::env::args().skip(1);
    let dir = args.next().unwrap_or_else(|| "data/demos".to_string());
    let mut config = GeneratorConfig::default();
    if let Some(robots) = args.next() {
        config.robots = robots.split(',').map(str::to_string).collect();
    }
    let file = args.next().unwrap_or_else(|| DEMO_FILE_NAME.to_string());
    let path = std::path::Path::new(&dir).join(file);
    match generate_to_file(&config, &path) {
        Ok(generated) => {
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
                let largest = body.reports.iter().map(|r| r.residual).fold(0.0, f64::max);
                if unreached.is_empty() {
                    println!(
                        "  {}: all 32 hand targets reached (largest IK residual {largest:.1e} m)",
                        body.name
                    );
                } else {
                    println!(
                        "  {}: closest reachable used for {}",
                        body.name,
                        unreached.join(", ")
                    );
                }
            }
            for robot in &ds.robots {
                let limits = Robot::builtin(&robot.name)
                    .map(|r| r.velocity_limits())
                    .unwrap_or_default();
                let q = &robot.positions;
                // (speed / limit, speed, limit) of the fastest joint relative to its limit.
                let mut worst = (0.0_f64, 0.0_f64, f64::INFINITY);
                for j in 0..q.ncols() {
                    let limit = limits.get(j).copied().unwrap_or(f64::INFINITY);
                    for k in 1..q.nrows() {
                        let speed = (q[(k, j)] - q[(k - 1, j)]).abs() * config.rate_hz;
                        if speed / limit > worst.0 {
                            worst = (speed / limit, speed, limit);
                        }
                    }
                }
                println!(
                    "  {}: fastest joint {:.2} rad/s (limit {:.2} rad/s)",
                    robot.name, worst.1, worst.2
                );
            }
        }
        Err(e) => {
            eprintln!("error: {e}");
            std::process::exit(1);
        }
    }
}
