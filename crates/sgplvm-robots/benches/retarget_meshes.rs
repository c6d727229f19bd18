//! Whole-arm retargeting with the robots' full collision meshes (issue 51's target: ≥ 500
//! frames/s per robot on one core, so that a suit streaming at 60–240 Hz can be followed live):
//! the captured human of `data/demos/captured.mcap` onto published robots as their makers
//! publish them, every collision mesh a convex hull (read once; the frames are what is timed),
//! self-collision and velocity limits on — `sgplvm retarget`'s defaults. Beside it, COMAN (the
//! robot of the mink comparison, `benches/retarget_vs_mink.py`; primitives only).
//!
//! The published robots come from PyPI's `example-robot-data` (6.0.0, the wheel carries the
//! URDFs and their meshes), which `.ci/run` installs into `target/ci-venv`:
//! `SGPLVM_ROBOTS_DIR=…/cmeel.prefix/share/example-robot-data/robots` points elsewhere. A robot
//! not found is skipped with a line saying so. `SGPLVM_BENCH_URDFS=name=path,...` adds robots
//! from elsewhere (their meshes found as `robot --urdf` finds them: the makers' own iCub,
//! `robotology/icub-models`' `iCub/robots/iCubGenova04/model.urdf`, say);
//! `SGPLVM_BENCH_ROBOTS=icub,coman` reads only the robots whose names hold one of these.
//!
//! Run: `cargo bench -p sgplvm-robots --bench retarget_meshes` (one thread: the retargeting of
//! one robot is serial).

use std::path::{Path, PathBuf};
use std::time::Duration;

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use sgplvm_robots::dataset::{BodyData, Dataset};
use sgplvm_robots::joint_state::read_joint_states;
use sgplvm_robots::retarget::{retarget, RetargetOptions};
use sgplvm_robots::{Anatomy, AnatomySpec};
use std::hint::black_box;

/// Frames retargeted per iteration: the first 400 of the capture (10 s at 40 Hz).
const FRAMES: usize = 400;

/// The published robots: name and URDF path below the robots folder.
const ROBOTS: &[(&str, &str)] = &[
    ("g1", "g1_description/urdf/g1_29dof_rev_1_0.urdf"),
    ("tiago_dual", "tiago_description/robots/tiago_dual.urdf"),
    ("tiago_pro", "tiago_pro_description/robots/tiago_pro.urdf"),
    ("pr2", "pr2_description/urdf/pr2.urdf"),
    ("romeo", "romeo_description/urdf/romeo.urdf"),
    ("alex", "alex_description/urdf/alex_psyonic_hands.urdf"),
    ("icub", "icub_description/robots/icub.urdf"),
];

/// example-robot-data's robots folder: `SGPLVM_ROBOTS_DIR`, else the CI venv's copy.
fn robots_dir() -> Option<PathBuf> {
    if let Some(dir) = std::env::var_os("SGPLVM_ROBOTS_DIR") {
        return Some(PathBuf::from(dir));
    }
    let lib = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../target/ci-venv/lib");
    std::fs::read_dir(lib).ok()?.flatten().find_map(|python| {
        let dir = python
            .path()
            .join("site-packages/cmeel.prefix/share/example-robot-data/robots");
        dir.is_dir().then_some(dir)
    })
}

/// Further robots from `SGPLVM_BENCH_URDFS` (`name=path,...`).
fn extra_urdfs() -> Vec<(String, PathBuf)> {
    let list = std::env::var("SGPLVM_BENCH_URDFS").unwrap_or_default();
    list.split(',')
        .filter_map(|item| item.split_once('='))
        .map(|(name, path)| (name.trim().to_string(), PathBuf::from(path.trim())))
        .collect()
}

/// The capture's first `FRAMES` frames of the human.
fn human() -> Dataset {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/demos/captured.mcap");
    let states = read_joint_states(&path, "/human/joint_states").expect("captured.mcap");
    let d = states.names.len();
    let n = FRAMES.min(states.times_ns.len());
    let positions = nalgebra::DMatrix::from_fn(n, d, |r, c| states.positions[r * d + c]);
    let human = BodyData {
        name: "human".into(),
        topic: "/human/joint_states".into(),
        joint_names: states.names,
        positions,
    };
    Dataset::unlabelled(states.times_ns[..n].to_vec(), human, Vec::new())
}

fn bench(c: &mut Criterion) {
    let dataset = human();
    let options = RetargetOptions::default();
    let mut group = c.benchmark_group("retarget_meshes");
    group
        .sample_size(10)
        .warm_up_time(Duration::from_secs(2))
        .measurement_time(Duration::from_secs(10))
        .throughput(Throughput::Elements(dataset.len() as u64));
    let mut robots = vec![(
        "coman".to_string(),
        Anatomy::builtin("coman").expect("COMAN"),
    )];
    match robots_dir() {
        Some(dir) => {
            for (name, urdf) in ROBOTS {
                let path = dir.join(urdf);
                match Anatomy::load(&path, &AnatomySpec::default()) {
                    Ok(a) => robots.push(((*name).to_string(), a)),
                    Err(e) => eprintln!("retarget_meshes: {name} skipped: {e}"),
                }
            }
        }
        None => eprintln!(
            "retarget_meshes: example-robot-data not found (pip install example-robot-data==6.0.0 into target/ci-venv, or set SGPLVM_ROBOTS_DIR): the published robots are skipped"
        ),
    }
    for (name, path) in extra_urdfs() {
        match Anatomy::load(&path, &AnatomySpec::default()) {
            Ok(a) => robots.push((name, a)),
            Err(e) => eprintln!("retarget_meshes: {name} skipped: {e}"),
        }
    }
    // `SGPLVM_BENCH_ROBOTS=icub,coman`: only robots whose names hold one of these, left out
    // before their first, untimed retargeting (criterion's own filter comes after it).
    if let Ok(only) = std::env::var("SGPLVM_BENCH_ROBOTS") {
        robots.retain(|(name, _)| only.split(',').any(|o| name.contains(o.trim())));
    }
    for (name, anatomy) in robots {
        let one = vec![(name.clone(), anatomy)];
        // Read the meshes once (the hulls are kept by the anatomy), and say what was checked.
        let first = retarget(&dataset, &one, &options).expect("retargets");
        if let Some(p) = first[0].report.posture.as_ref() {
            eprintln!(
                "retarget_meshes: {name}: {} pairs of shapes that can meet, {} collision element(s) unchecked",
                p.pairs,
                p.unchecked.len()
            );
        }
        group.bench_function(&name, |b| {
            b.iter(|| retarget(black_box(&dataset), &one, &options).expect("retargets"))
        });
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
