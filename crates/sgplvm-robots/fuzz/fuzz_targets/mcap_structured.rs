//! The MCAP readers (as `mcap_reader`) under a structure-aware mutator (issue 13): each
//! mutation parses the input into records and chunks, changes a message's CDR payload, a
//! record's fields, an opcode, a timestamp, a channel id, the record order, the chunking or
//! the compression, and writes the file back with correct lengths and chunk CRCs (zstd / lz4
//! recompressed), sometimes breaking one length, size or CRC field on purpose — so that
//! mutations reach the parsers behind the checksum. Inputs that do not parse as MCAP get
//! libFuzzer's byte mutation.
#![no_main]

use libfuzzer_sys::{fuzz_mutator, fuzz_target, fuzzer_mutate};
use sgplvm_robots_fuzz::{read_everything, structured};

fuzz_target!(
    // libfuzzer-sys's hook aborts on any panic, even one the reader catches and turns into an
    // error (it does so for panics inside the mcap crate): ours is quiet for those and still
    // aborts on any other.
    init: {
        sgplvm_robots_fuzz::install_panic_hook();
    },
    |data: &[u8]| {
        read_everything(data);
    }
);

fuzz_mutator!(|data: &mut [u8], size: usize, max_size: usize, seed: u32| {
    let mut bytes = |buf: &mut Vec<u8>, room: usize| {
        let len = buf.len();
        buf.resize(len + room, 0);
        let n = fuzzer_mutate(buf, len, len + room);
        buf.truncate(n);
    };
    // One mutation in eight stays byte-level, so that the corpus also keeps inputs the
    // structure cannot express.
    if seed % 8 != 0 {
        if let Some(out) = structured::mutate(&data[..size], max_size, seed / 8, &mut bytes) {
            data[..out.len()].copy_from_slice(&out);
            return out.len();
        }
    }
    fuzzer_mutate(data, size, max_size)
});
