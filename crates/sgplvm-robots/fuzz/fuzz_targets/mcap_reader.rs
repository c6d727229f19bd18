//! The MCAP JointState readers on arbitrary bytes: `read_topics` (every topic a seed has, by
//! joint name too), `load_demonstrations` (metadata path, or alignment of foreign topics) and
//! `list_channels`. Each input is read twice: as given, and with every chunk CRC zeroed (a
//! zero CRC is "not recorded" in MCAP), so that mutations inside chunks reach the record
//! parsers instead of stopping at the checksum. Any result is fine; a panic, abort, timeout or
//! out-of-memory is a finding.
#![no_main]

use libfuzzer_sys::fuzz_target;
use sgplvm_robots_fuzz::{read_everything, without_chunk_crcs};

fuzz_target!(
    // libfuzzer-sys's hook aborts on any panic, even one the reader catches and turns into an
    // error (it does so for panics inside the mcap crate): ours is quiet for those and still
    // aborts on any other.
    init: {
        sgplvm_robots_fuzz::install_panic_hook();
    },
    |data: &[u8]| {
        read_everything(data);
        let zeroed = without_chunk_crcs(data);
        if zeroed != data {
            read_everything(&zeroed);
        }
    }
);
