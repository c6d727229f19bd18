//! The BVH reader on arbitrary text, and, for files it accepts that have arms, the whole import
//! (arm identification, the fit of every frame, resampling) — the path of `sgplvm import`. Any
//! result is fine; a panic, abort, stack overflow, timeout or out-of-memory is a finding.
#![no_main]

use libfuzzer_sys::fuzz_target;
use sgplvm_robots::capture::{import_parsed, Bvh, ImportOptions};

fuzz_target!(|data: &[u8]| {
    let text = String::from_utf8_lossy(data);
    let Ok(bvh) = Bvh::parse(&text, "fuzz.bvh") else {
        return;
    };
    if bvh.frames() > 2_000 {
        return;
    }
    let _ = import_parsed(&bvh, "fuzz.bvh", &ImportOptions::default());
});
