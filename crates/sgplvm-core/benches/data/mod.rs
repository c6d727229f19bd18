//! The benches' synthetic demonstration (shared with the profiling examples by `#[path]`).

use sgplvm_core::Mat;

/// Smooth synthetic demonstration of `n` frames: a phase running over `span` radians drives
/// an 18-D human and a 14-D robot.
pub fn smooth(n: usize, span: f64) -> (Mat<f64>, Mat<f64>) {
    let h = Mat::from_fn(n, 18, |i, j| {
        let t = i as f64 / n as f64 * span;
        (t * (1.0 + 0.05 * j as f64)).sin() + 0.3 * (0.37 * t + j as f64).cos()
    });
    let r = Mat::from_fn(n, 14, |i, j| {
        let t = i as f64 / n as f64 * span;
        0.8 * (t * (1.0 + 0.07 * j as f64) + 0.1).sin() + 0.2 * (0.41 * t + j as f64).cos()
    });
    (h, r)
}
