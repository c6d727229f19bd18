//! Decoding one MVN frame as MVN sends it by default: a type 02 (quaternion) datagram of the 23
//! body segments (760 bytes). Run with `cargo bench -p sgplvm-live --bench mvn_decode`.

use criterion::{criterion_group, criterion_main, Criterion};
use sgplvm_live::mvn::{decode, encode, MvnPose, PoseType, SegmentCounts, SegmentPose};

fn mvn_decode(c: &mut Criterion) {
    let segments = (1..=23u32)
        .map(|id| {
            let a = id as f32 * 0.1;
            let (s, co) = (0.5 * a).sin_cos();
            SegmentPose {
                id,
                position: [0.01 * id as f32, -0.02 * id as f32, 0.9 + 0.03 * id as f32],
                orientation: [co, 0.0, 0.0, s],
            }
        })
        .collect();
    let pose = MvnPose {
        kind: PoseType::Quaternion,
        sample_counter: 1234,
        time_code_ms: 56_789,
        character_id: 0,
        counts: Some(SegmentCounts {
            body: 23,
            props: 0,
            fingers: 0,
        }),
        segments,
    };
    let datagram = encode(&pose, PoseType::Quaternion).unwrap();
    assert_eq!(decode(&datagram).unwrap(), pose);
    c.bench_function("mvn decode (type 02, 23 segments, 760 bytes)", |b| {
        b.iter(|| decode(std::hint::black_box(&datagram)).unwrap())
    });
    let euler = encode(&pose, PoseType::Euler).unwrap();
    c.bench_function("mvn decode (type 01, 23 segments, 668 bytes)", |b| {
        b.iter(|| decode(std::hint::black_box(&euler)).unwrap())
    });
}

criterion_group!(benches, mvn_decode);
criterion_main!(benches);
