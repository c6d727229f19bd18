//! The URDF parser on arbitrary text, and, for small robots it accepts, a short physics
//! replay (the path of `simulate --urdf`). Any result is fine; a panic, abort, stack overflow,
//! timeout or out-of-memory is a finding.
#![no_main]

use libfuzzer_sys::fuzz_target;
use sgplvm_robots::physics::{replay_urdf, ReplayOptions, Trajectory};
use sgplvm_robots::Robot;

fuzz_target!(|data: &[u8]| {
    let text = String::from_utf8_lossy(data);
    let Ok(robot) = Robot::from_urdf_str(&text, "fuzz.urdf") else {
        return;
    };
    let names = robot.joint_names();
    if names.len() > 12 || text.len() > 20_000 {
        return;
    }
    let dof = names.len();
    let times = vec![0.0, 0.02, 0.04];
    let positions: Vec<f64> = (0..3 * dof).map(|i| 0.01 * (i % 7) as f64).collect();
    let Ok(trajectory) = Trajectory::new(names, times, positions) else {
        return;
    };
    let options = ReplayOptions {
        physics_rate_hz: 200.0,
        settle_seconds: 0.02,
        max_steps: 1_000,
        ..ReplayOptions::default()
    };
    let _ = replay_urdf(robot.urdf(), "fuzz.urdf", &trajectory, &options);
});
