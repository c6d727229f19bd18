//! CSV input: a whole file (`read_frames`, the `--input x.csv` path) and the same bytes as the
//! teleoperation stream (`--input -`: the header, then one frame per line). Any result is
//! fine; a panic, abort, timeout or out-of-memory is a finding.
#![no_main]

use libfuzzer_sys::fuzz_target;
use sgplvm::csv::{read_frames, CsvHeader};

fuzz_target!(|data: &[u8]| {
    let _ = read_frames(data, "fuzz.csv");
    let text = String::from_utf8_lossy(data);
    let mut lines = text.lines();
    if let Some(first) = lines.next() {
        let header = CsvHeader::parse(first);
        for (i, line) in lines.enumerate() {
            let _ = header.parse_line(line, i + 2, "-");
        }
    }
});
