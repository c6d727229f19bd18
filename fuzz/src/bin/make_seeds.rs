//! Writes the seed corpora: a small trained model (whole file and payload alone) and CSV
//! frames with and without a time column.
use std::fs;
use std::path::Path;

use sgplvm::core::Mat;
use sgplvm::{ModelConfig, SharedGplvm, TrainOptions};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let dir = Path::new("corpus");
    fs::create_dir_all(dir.join("model_file"))?;
    fs::create_dir_all(dir.join("csv_input"))?;
    let n = 12;
    let h = Mat::from_fn(n, 3, |i, j| ((i as f64) * 0.4 + j as f64).sin());
    let r = Mat::from_fn(n, 2, |i, j| ((i as f64) * 0.4 + 0.5 * j as f64).cos());
    let model = SharedGplvm::fit(
        &ModelConfig::default().with_latent_dim(2),
        &[("human", h.as_ref()), ("robot", r.as_ref())],
        "human",
        &TrainOptions::default().with_max_iters(5),
        None,
    )?;
    let bytes = model.to_bytes();
    fs::write(dir.join("model_file/model.sgp"), &bytes)?;
    fs::write(dir.join("model_file/payload.json"), &bytes[28..])?;
    fs::write(
        dir.join("csv_input/timed.csv"),
        "time,a,b,c\n0.0,0.1,0.2,0.3\n0.025,0.11,0.21,0.31\n\n0.05,1e-3,-2.5,3\n",
    )?;
    fs::write(dir.join("csv_input/plain.csv"), "a,b\n1,2\n3,4\n")?;
    println!("wrote corpus/model_file and corpus/csv_input");
    Ok(())
}
