//! Onboarding a robot: parse its URDF, find its arms, body frame, reach and neutral posture
//! (issue 42's target: ≤ 50 ms for a 300-link URDF). Measured on the published Unitree G1
//! (39 links) and on the G1 with 270 more links hung on it — fixed sensor frames on every
//! link and a five-finger hand of 3-joint fingers at each wrist — so that the search has a
//! large tree to walk.
//!
//! Run: `cargo bench -p sgplvm-robots --bench anatomy`.

use criterion::{criterion_group, criterion_main, Criterion};
use sgplvm_robots::{Anatomy, Robot};
use std::hint::black_box;

const G1: &str = include_str!("../../../data/urdf/published/g1_29dof.urdf");

/// The G1 with fixed frames on its links and a hand of five 3-joint fingers on each wrist:
/// `extra` more links in all.
fn g1_with(extra: usize) -> String {
    let mut more = String::new();
    let hosts = [
        "torso_link",
        "pelvis",
        "left_wrist_yaw_link",
        "right_wrist_yaw_link",
        "left_knee_link",
    ];
    let mut n = 0;
    for side in ["left", "right"] {
        for f in 0..5 {
            let mut parent = format!("{side}_wrist_yaw_link");
            for k in 0..3 {
                let link = format!("{side}_hand_finger{f}_{k}_link");
                more += &format!(
                    r#"<link name="{link}"/><joint name="{side}_hand_finger{f}_{k}_joint" type="revolute"><parent link="{parent}"/><child link="{link}"/><origin xyz="0.03 {y} 0"/><axis xyz="0 1 0"/><limit lower="0" upper="1.5" effort="1" velocity="1"/></joint>"#,
                    y = 0.01 * f as f64
                );
                parent = link;
                n += 1;
            }
        }
    }
    while n < extra {
        let host = hosts[n % hosts.len()];
        more += &format!(
            r#"<link name="sensor_{n}"/><joint name="sensor_{n}_joint" type="fixed"><parent link="{host}"/><child link="sensor_{n}"/><origin xyz="0 0 0.01"/></joint>"#
        );
        n += 1;
    }
    G1.replacen("</robot>", &format!("{more}</robot>"), 1)
}

fn bench(c: &mut Criterion) {
    let big = g1_with(270);
    let links = Robot::from_urdf_str(&big, "g1-300.urdf")
        .expect("the grown G1 loads")
        .link_names()
        .len();
    assert!(links >= 300, "{links} links");
    for (name, text) in [("g1", G1.to_string()), ("g1_300_links", big)] {
        c.bench_function(&format!("onboard_{name}"), |b| {
            b.iter(|| {
                let robot = Robot::from_urdf_str(black_box(&text), "bench.urdf").expect("loads");
                Anatomy::of(robot).expect("arms found")
            })
        });
    }
    let robot = Robot::from_urdf_str(G1, "g1.urdf").expect("loads");
    c.bench_function("parse_g1", |b| {
        b.iter(|| Robot::from_urdf_str(black_box(G1), "g1.urdf").expect("loads"))
    });
    c.bench_function("anatomy_g1_parsed", |b| {
        b.iter(|| Anatomy::of(black_box(robot.clone())).expect("arms found"))
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
