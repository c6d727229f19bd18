//! Model files: `SharedGplvm::from_bytes`, then one prediction per robot of a model it accepts.
//! Structure-aware: an input that does not start with the magic bytes is taken as the JSON
//! payload and wrapped in a valid header and hash, so that mutations reach the JSON parser and
//! the model's validation instead of stopping at the checksum. Any result is fine; a panic,
//! abort, timeout or out-of-memory is a finding.
#![no_main]

use libfuzzer_sys::fuzz_target;
use sgplvm::core::{FORMAT_VERSION, MAGIC};
use sgplvm::SharedGplvm;

/// FNV-1a 64, the model file's payload hash.
fn fnv1a(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |h, &b| {
        (h ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01b3)
    })
}

/// A model file around `payload`.
fn wrap(payload: &[u8]) -> Vec<u8> {
    let mut out = MAGIC.to_vec();
    out.extend_from_slice(&FORMAT_VERSION.to_le_bytes());
    out.extend_from_slice(&(payload.len() as u64).to_le_bytes());
    out.extend_from_slice(&fnv1a(payload).to_le_bytes());
    out.extend_from_slice(payload);
    out
}

fuzz_target!(|data: &[u8]| {
    let bytes = if data.starts_with(MAGIC) {
        data.to_vec()
    } else {
        wrap(data)
    };
    let Ok(model) = SharedGplvm::from_bytes(&bytes) else {
        return;
    };
    let Some(dh) = model.space_dim(model.input_name()) else {
        return;
    };
    let h = vec![0.1; dh];
    for robot in model.output_names() {
        let mut out = vec![0.0; model.space_dim(robot).unwrap_or(0)];
        let _ = model.predict_frame(&h, robot, &mut out);
    }
});
