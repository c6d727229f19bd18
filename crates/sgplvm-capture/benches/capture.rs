//! Motion capture in: BVH parsing plus the fit of the human model's angles (target: at least
//! 20,000 frames/s on one core) and retargeting to one robot (target: at least 2,000 frames/s).
//!
//! The import runs on the shipped human motion written as BVH (7,080 frames), and on
//! `SGPLVM_BENCH_BVH` if that names a real capture (e.g. a CMU trial: `bash
//! data/demos/make_captured.sh` leaves them in `target/cmu-bvh`). Retargeting runs on the human
//! of `data/demos/captured.mcap` (4,243 frames of real motion) for COMAN, each `--match` mode.
//!
//! Run: `cargo bench --release -p sgplvm-robots --bench capture` (criterion reports the
//! throughput in frames per second).

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use sgplvm_capture::{import_parsed, write_bvh, Bvh, ImportOptions};
use sgplvm_robots::dataset::load_demonstrations;
use sgplvm_robots::retarget::{retarget, Match, Redundancy, RetargetOptions};
use sgplvm_robots::Anatomy;
use std::hint::black_box;
use std::path::Path;

fn data(name: &str) -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../data/demos")
        .join(name)
}

fn import(c: &mut Criterion) {
    let demos = load_demonstrations(data("bimanual.mcap")).expect("the shipped demonstrations");
    let rows: Vec<[f64; 18]> = (0..demos.len())
        .map(|f| std::array::from_fn(|j| demos.human.positions[(f, j)]))
        .collect();
    let dir = std::env::temp_dir().join(format!("sgplvm-bench-capture-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("scratch");
    let path = dir.join("human.bvh");
    write_bvh(&path, 1.0 / 40.0, &rows).expect("write the BVH");
    let mut files = vec![("shipped_human_as_bvh".to_string(), path)];
    if let Ok(real) = std::env::var("SGPLVM_BENCH_BVH") {
        let name = Path::new(&real)
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        files.push((format!("capture_{name}"), real.into()));
    }
    let mut group = c.benchmark_group("import");
    group.sample_size(20);
    for (name, path) in files {
        let text = std::fs::read_to_string(&path).expect("read the BVH");
        let frames = Bvh::parse(&text, "bench.bvh").expect("parses").frames();
        group.throughput(Throughput::Elements(frames as u64));
        group.bench_function(format!("parse_and_fit_{name}"), |b| {
            b.iter(|| {
                let bvh = Bvh::parse(black_box(&text), "bench.bvh").expect("parses");
                import_parsed(&bvh, "bench.bvh", &ImportOptions::default()).expect("imports")
            })
        });
    }
    group.finish();
    std::fs::remove_dir_all(&dir).ok();
}

fn retargeting(c: &mut Criterion) {
    let demos =
        load_demonstrations(data("captured.mcap")).expect("the shipped captured demonstrations");
    let coman = vec![(
        "coman".to_string(),
        Anatomy::builtin("coman").expect("COMAN"),
    )];
    let mut group = c.benchmark_group("retarget");
    group.sample_size(10);
    group.throughput(Throughput::Elements(demos.len() as u64));
    for (mode, redundancy) in [
        (Match::Hands, Redundancy::Continuous),
        (Match::HandsAndElbows, Redundancy::Continuous),
        (Match::Poses, Redundancy::Continuous),
        (Match::Hands, Redundancy::Canonical),
    ] {
        let options = RetargetOptions {
            mode,
            redundancy,
            ..RetargetOptions::default()
        };
        group.bench_function(format!("coman_{}_{redundancy:?}", mode.name()), |b| {
            b.iter(|| retarget(black_box(&demos), &coman, &options).expect("retargets"))
        });
    }
    group.finish();
}

criterion_group!(benches, import, retargeting);
criterion_main!(benches);
