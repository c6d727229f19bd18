//! Reading speed of JointState MCAP files: one million 14-joint CDR messages (zstd chunks),
//! the size of a long teleoperation recording. Target: under 2 s.
//!
//! `cargo bench -p sgplvm-robots --bench mcap`

use std::hint::black_box;
use std::time::Instant;

use criterion::{criterion_group, criterion_main, Criterion};
use sgplvm_robots::joint_state::{
    read_joint_states, read_topics, write_joint_states, Compression, JointStates, TopicRequest,
};

const MESSAGES: usize = 1_000_000;
const JOINTS: usize = 14;

fn one_million(compression: Compression, dir: &std::path::Path) -> std::path::PathBuf {
    let names: Vec<String> = (0..JOINTS).map(|j| format!("arm_joint_{j}")).collect();
    let times: Vec<i64> = (0..MESSAGES as i64).map(|k| k * 25_000_000).collect();
    let positions: Vec<f64> = (0..MESSAGES * JOINTS)
        .map(|i| ((i % 9973) as f64 * 1e-3).sin())
        .collect();
    let states = JointStates::new(times, names, positions).expect("valid series");
    let path = dir.join(format!("one_million_{compression:?}.mcap"));
    let t = Instant::now();
    write_joint_states(&path, "/robot/joint_command", &states, compression).expect("write");
    let size = std::fs::metadata(&path).map(|m| m.len()).unwrap_or(0);
    eprintln!(
        "wrote {MESSAGES} messages ({compression:?}, {:.1} MB) in {:.2} s",
        size as f64 / 1e6,
        t.elapsed().as_secs_f64()
    );
    path
}

fn bench_read(c: &mut Criterion) {
    let dir = std::env::temp_dir().join(format!("sgplvm-bench-mcap-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let mut group = c.benchmark_group("mcap_read_1M_joint_states");
    group.sample_size(10);
    for compression in [Compression::Zstd, Compression::Lz4, Compression::None] {
        let path = one_million(compression, &dir);
        group.bench_function(format!("{compression:?}/all_joints"), |b| {
            b.iter(|| {
                let s = read_joint_states(black_box(&path), "/robot/joint_command").expect("read");
                assert_eq!(s.len(), MESSAGES);
                s
            })
        });
        if compression == Compression::Zstd {
            // Model-ordered subset (the common case: a body model's joints in its order).
            let want: Vec<String> = (0..7).rev().map(|j| format!("arm_joint_{j}")).collect();
            group.bench_function("Zstd/seven_reordered_joints", |b| {
                b.iter(|| {
                    read_topics(
                        black_box(&path),
                        &[TopicRequest::joints("/robot/joint_command", &want)],
                    )
                    .expect("read")
                })
            });
        }
        let _ = std::fs::remove_file(&path);
    }
    group.finish();
    let _ = std::fs::remove_dir_all(&dir);
}

criterion_group!(benches, bench_read);
criterion_main!(benches);
