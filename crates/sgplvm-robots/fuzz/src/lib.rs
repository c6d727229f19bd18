//! Shared code of the robots crate's fuzz targets: the readers run on each input
//! ([`read_everything`]) and the structure-aware MCAP mutator ([`structured`]).

pub mod structured;

use std::io::Write;
use std::path::PathBuf;

use sgplvm_robots::dataset::load_demonstrations;
use sgplvm_robots::joint_state::{list_channels, read_aligned, read_topics, TopicRequest};

/// One scratch file per fuzzing process (in memory when /dev/shm exists).
fn scratch() -> PathBuf {
    let dir = if std::path::Path::new("/dev/shm").is_dir() {
        PathBuf::from("/dev/shm")
    } else {
        std::env::temp_dir()
    };
    dir.join(format!("sgplvm-fuzz-mcap-{}.mcap", std::process::id()))
}

/// `data` with the uncompressed CRC of every top-level chunk record set to 0.
pub fn without_chunk_crcs(data: &[u8]) -> Vec<u8> {
    let mut out = data.to_vec();
    let mut i = 8usize;
    while i + 9 <= out.len() {
        let op = out[i];
        let len = u64::from_le_bytes(out[i + 1..i + 9].try_into().unwrap_or([0xff; 8]));
        if op == 0x06 && i + 9 + 28 <= out.len() {
            out[i + 9 + 24..i + 9 + 28].fill(0);
        }
        match usize::try_from(len)
            .ok()
            .and_then(|l| (i + 9).checked_add(l))
        {
            Some(next) if next > i => i = next,
            _ => break,
        }
    }
    out
}

/// The fuzz targets' panic hook: quiet for the panics the readers catch (inside mcap's reader,
/// rapier) — Rust's default hook would print them, with a backtrace under `cargo fuzz`'s
/// `RUST_BACKTRACE=1` whose first symbolisation alone takes over a second (run 1 of
/// `mcap_structured` reported that as a timeout) — and an abort, which libFuzzer records as a
/// crash, for any other panic.
pub fn install_panic_hook() {
    sgplvm_robots::panics::install_hook(Box::new(|info| {
        eprintln!("{}", sgplvm_robots::panics::describe(info));
        std::process::abort();
    }));
}

/// Writes `bytes` to the scratch file and runs every MCAP reader on it: `list_channels`,
/// `read_topics` (all joints, and by joint name), `read_aligned` at 40 Hz and
/// `load_demonstrations`. Results are ignored; only panics, aborts, time and memory matter.
pub fn read_everything(bytes: &[u8]) {
    let path = scratch();
    {
        let Ok(mut f) = std::fs::File::create(&path) else {
            return;
        };
        if f.write_all(bytes).is_err() {
            return;
        }
    }
    let topics = ["/human/joint_states", "/walkman/joint_command"];
    let _ = list_channels(&path);
    let _ = read_topics(&path, &topics.map(TopicRequest::all));
    let _ = read_topics(
        &path,
        &[TopicRequest::joints(
            topics[0],
            &["a".to_string(), "c".to_string()],
        )],
    );
    let _ = read_aligned(&path, &topics.map(TopicRequest::all), 40.0);
    let _ = load_demonstrations(&path);
}
