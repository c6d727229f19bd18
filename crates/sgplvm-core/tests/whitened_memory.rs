//! Whitened back-constraint weights hold five more N×N matrices than a plain fit: the memory
//! check counts them, so a fit that fits in memory plainly is refused, before the
//! eigendecomposition allocates, when whitened. Its own process: it sets the memory limit.

use sgplvm_core::{
    BackConstraint, Error, Mat, ModelConfig, SharedGplvm, TrainOptions, MEMORY_LIMIT_ENV,
};

#[test]
fn the_memory_check_counts_the_whitening_matrices() {
    let n = 2000;
    // One N×N matrix is 32 MB; a fit of two spaces is counted as 15 of them, whitened 20.
    std::env::set_var(MEMORY_LIMIT_ENV, format!("{}", 17 * n * n * 8));
    let phase = |i: usize| i as f64 / n as f64 * 6.0;
    let human = Mat::from_fn(n, 6, |i, j| (phase(i) * (j + 1) as f64).sin());
    let robot = Mat::from_fn(n, 4, |i, j| (phase(i) * (j + 2) as f64).cos());
    let spaces = [("human", human.as_ref()), ("robot", robot.as_ref())];
    let config = ModelConfig::default()
        .with_latent_dim(2)
        .with_back_constraint(BackConstraint::Input);
    let options = TrainOptions::default().with_max_iters(1);

    SharedGplvm::fit(&config, &spaces, "human", &options, None).expect("plain fit fits");
    let err = SharedGplvm::fit(
        &config,
        &spaces,
        "human",
        &options.with_whiten_back_constraint(true),
        None,
    )
    .expect_err("whitened fit refused");
    match err {
        Error::TooLarge { what, matrices, .. } => {
            assert!(what.contains("whitened"), "{what}");
            assert_eq!(matrices, 20);
        }
        other => panic!("expected TooLarge, got {other}"),
    }
}
