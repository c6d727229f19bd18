//! The core computes on its own fork-safe pool (`pool.rs`) and never starts rayon's global pool:
//! a forked child (Python's `multiprocessing`) would inherit that pool's bookkeeping but none of
//! its threads, and every process would carry its idle threads. Whether the global pool has been
//! started is visible from outside: building it fails once it exists. This binary holds one
//! test, so that nothing else starts the pool first.

use sgplvm_core::{Mat, ModelConfig, SharedGplvm, TrainOptions};

#[test]
fn training_transfer_and_prediction_leave_rayons_global_pool_unstarted() {
    // 40 frames: every evaluation on the calling thread. 300: the model's spaces side by side
    // on the pool, the transfer's whole evaluation on its threads.
    for n in [40, 300] {
        let wave =
            |c: usize, f: f64| Mat::from_fn(n, c, move |i, j| (i as f64 * f + j as f64).sin());
        let (human, robot, other) = (wave(4, 0.05), wave(3, 0.07), wave(2, 0.03));
        let config = ModelConfig::default().with_latent_dim(2);
        let options = TrainOptions::default().with_max_iters(3);
        let spaces = [("human", human.as_ref()), ("robot", robot.as_ref())];
        let model = SharedGplvm::fit(&config, &spaces, "human", &options, None).expect("fit");
        let moved = model
            .transfer("other", other.as_ref(), &options, None)
            .expect("transfer");
        moved
            .predict(human.as_ref(), "other", true)
            .expect("predict");
    }
    assert!(
        rayon::ThreadPoolBuilder::new().build_global().is_ok(),
        "the core started rayon's global pool"
    );
}
