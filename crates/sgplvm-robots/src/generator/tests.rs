use super::*;

fn fake_body(name: &str, dof: usize, seed: u64) -> BodyPoses {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let limits = vec![(-1.5, 1.2); dof];
    let postures = (0..KEY_POSES.len())
        .map(|_| (0..dof).map(|_| rng.random_range(-1.0..1.0)).collect())
        .collect();
    BodyPoses {
        name: name.into(),
        joint_names: (0..dof).map(|j| format!("{name}{j}")).collect(),
        limits,
        postures,
        reports: Vec::new(),
    }
}

fn bodies() -> (BodyPoses, Vec<BodyPoses>) {
    (
        fake_body("human", 18, 1),
        vec![fake_body("walkman", 14, 2), fake_body("coman", 14, 3)],
    )
}

#[test]
fn quintic_has_zero_velocity_and_acceleration_at_both_ends() {
    assert_eq!(quintic(0.0), 0.0);
    assert_eq!(quintic(1.0), 1.0);
    assert!((quintic(0.5) - 0.5).abs() < 1e-15);
    assert_eq!(quintic(-0.3), 0.0);
    assert_eq!(quintic(1.7), 1.0);
    for tau in [0.0, 1.0] {
        assert_eq!(quintic_derivatives(tau), (0.0, 0.0));
    }
    // Derivatives match central differences inside.
    let h = 1e-5;
    for tau in [0.1, 0.33, 0.5, 0.8] {
        let (d1, d2) = quintic_derivatives(tau);
        let fd1 = (quintic(tau + h) - quintic(tau - h)) / (2.0 * h);
        let fd2 = (quintic(tau + h) - 2.0 * quintic(tau) + quintic(tau - h)) / (h * h);
        assert!((d1 - fd1).abs() < 1e-8, "{tau}: {d1} vs {fd1}");
        assert!((d2 - fd2).abs() < 1e-4, "{tau}: {d2} vs {fd2}");
    }
    // Peak velocity 15/8 at the middle.
    assert!((quintic_derivatives(0.5).0 - 1.875).abs() < 1e-15);
}

#[test]
fn key_poses_are_sixteen_distinct_reachable_targets() {
    assert_eq!(KEY_POSES.len(), 16);
    assert_eq!(KEY_POSES[NEUTRAL].name, "neutral");
    for (i, p) in KEY_POSES.iter().enumerate() {
        for hand in [p.left, p.right] {
            let r = (hand[0] * hand[0] + hand[1] * hand[1] + hand[2] * hand[2]).sqrt();
            assert!((0.3..=0.9).contains(&r), "{}: reach {r}", p.name);
        }
        for q in &KEY_POSES[..i] {
            assert_ne!(q.name, p.name);
            assert!(
                q.left != p.left || q.right != p.right,
                "{} = {}",
                p.name,
                q.name
            );
        }
    }
}

#[test]
fn plan_records_every_pose_from_neutral_and_the_test_pairs() {
    let cfg = GeneratorConfig::default();
    let moves = plan(&cfg);
    // 15 poses × 3 × 2 from/to neutral, then per test pair an approach + 6 moves.
    assert_eq!(moves.len(), 15 * 6 + cfg.test_pairs.len() * 7);
    // Consecutive moves connect.
    assert_eq!(moves[0].from, NEUTRAL);
    for w in moves.windows(2) {
        assert_eq!(w[0].to, w[1].from);
    }
    let from_neutral = moves
        .iter()
        .filter(|m| m.from == NEUTRAL && m.repetition.is_some())
        .count();
    assert_eq!(from_neutral, 45);
    assert_eq!(moves.iter().filter(|m| m.repetition.is_none()).count(), 2);
}

#[test]
fn synthesis_is_deterministic_and_seed_dependent() {
    let (h, r) = bodies();
    let cfg = GeneratorConfig::default();
    let a = synthesize(&cfg, &h, &r).expect("a");
    let b = synthesize(&cfg, &h, &r).expect("b");
    assert_eq!(a, b);
    let c = synthesize(
        &GeneratorConfig {
            seed: 7,
            ..cfg.clone()
        },
        &h,
        &r,
    )
    .expect("c");
    assert_ne!(a.human.positions, c.human.positions);
    // The robots' commands do not depend on the seed.
    assert_eq!(a.robots, c.robots);
}

#[test]
fn robot_trajectories_are_quintic_between_exact_key_postures() {
    let (h, r) = bodies();
    let cfg = GeneratorConfig::default();
    let ds = synthesize(&cfg, &h, &r).expect("ds");
    let dt = 1.0 / cfg.rate_hz;
    for (b, body) in ds.robots.iter().zip(&r) {
        let q = &b.positions;
        for (i, (lo, hi)) in body.limits.iter().enumerate() {
            let col = q.column(i);
            assert!(col.min() >= *lo && col.max() <= *hi);
        }
        for s in &ds.segments {
            let (from, to) = (s.from_pose.expect("labelled"), s.to_pose.expect("labelled"));
            let qa = &body.postures[from];
            let qb = &body.postures[to];
            // Starts exactly at the key posture and ends (holding) exactly at the next one.
            for j in 0..qa.len() {
                assert_eq!(q[(s.start, j)], qa[j]);
                assert!((q[(s.end - 1, j)] - qb[j]).abs() < 1e-12);
                assert!((q[(s.end - 2, j)] - qb[j]).abs() < 1e-12, "hold");
            }
            // Zero velocity and acceleration at the start: the first step is O(τ³).
            let max_disp = (0..qa.len())
                .map(|j| (qb[j] - qa[j]).abs())
                .fold(0.0, f64::max);
            for j in 0..qa.len() {
                let step = (q[(s.start + 1, j)] - q[(s.start, j)]).abs();
                let tau = dt / cfg.duration_s.0;
                assert!(step <= 10.0 * tau.powi(3) * max_disp + 1e-12, "step {step}");
                // second difference at the start ≈ 0 as well (acceleration).
                let acc = q[(s.start + 2, j)] - 2.0 * q[(s.start + 1, j)] + q[(s.start, j)];
                assert!(
                    acc.abs() <= 80.0 * tau.powi(3) * max_disp + 1e-12,
                    "acc {acc}"
                );
            }
        }
    }
}

#[test]
fn human_mimics_with_delay_variation_and_noise_within_limits() {
    let (h, r) = bodies();
    let quiet = GeneratorConfig {
        mimic: HumanMimic {
            noise_std: 0.0,
            posture_std: 0.0,
            path_bend_std: 0.0,
            ..HumanMimic::default()
        },
        ..GeneratorConfig::default()
    };
    let ds = synthesize(&quiet, &h, &r).expect("quiet");
    // Without variation, the human reaches each key posture exactly before the segment ends,
    // and does not move during the minimal reaction delay.
    let still = (quiet.mimic.delay_s.0 * quiet.rate_hz).floor() as usize;
    for s in &ds.segments {
        let target = &h.postures[s.to_pose.expect("labelled")];
        let from = &h.postures[s.from_pose.expect("labelled")];
        for j in 0..18 {
            assert!((ds.human.positions[(s.end - 1, j)] - target[j]).abs() < 1e-12);
            for k in 0..=still {
                assert!((ds.human.positions[(s.start + k, j)] - from[j]).abs() < 1e-12);
            }
        }
    }
    // With the default mimic: noisy, varied, still within limits, never identical repetitions.
    let cfg = GeneratorConfig::default();
    let ds = synthesize(&cfg, &h, &r).expect("default");
    let hp = &ds.human.positions;
    assert!(hp.min() >= -1.5 && hp.max() <= 1.2);
    let reps: Vec<&Segment> = ds
        .segments
        .iter()
        .filter(|s| s.from_pose == Some(NEUTRAL) && s.to_pose == Some(1))
        .collect();
    assert_eq!(reps.len(), 3);
    let end0 = hp.row(reps[0].end - 1).into_owned();
    let end1 = hp.row(reps[1].end - 1).into_owned();
    let diff = (end0 - end1).norm();
    assert!(diff > 0.02, "repetitions differ in posture: {diff}");
    // Noise: a held posture jitters at the sensor-noise level.
    let s = reps[0];
    let jitter = (hp.row(s.end - 1) - hp.row(s.end - 2)).norm() / (2.0f64 * 18.0).sqrt();
    assert!(
        jitter > 0.3 * cfg.mimic.noise_std && jitter < 3.0 * cfg.mimic.noise_std,
        "{jitter}"
    );
}

#[test]
fn split_uses_neutral_starts_for_training_and_non_neutral_pairs_for_test() {
    let (h, r) = bodies();
    let cfg = GeneratorConfig::default();
    let ds = synthesize(&cfg, &h, &r).expect("ds");
    let pool: usize = ds
        .segments
        .iter()
        .filter(|s| s.from_pose == Some(NEUTRAL) && s.repetition.is_some())
        .map(Segment::len)
        .sum();
    assert_eq!(ds.train.len(), pool.div_ceil(cfg.train_subsample));
    for &f in &ds.train {
        assert_eq!(ds.segment_of(f).and_then(|s| s.from_pose), Some(NEUTRAL));
    }
    for &f in &ds.test {
        let s = ds.segment_of(f).expect("segment");
        assert!(s.repetition.is_some());
        assert!(s.from_pose != Some(NEUTRAL) && s.to_pose != Some(NEUTRAL));
    }
    assert!(ds.test.iter().all(|f| ds.train.binary_search(f).is_err()));
    let expected_test: usize = ds
        .segments
        .iter()
        .filter(|s| {
            s.repetition.is_some() && s.from_pose != Some(NEUTRAL) && s.to_pose != Some(NEUTRAL)
        })
        .map(Segment::len)
        .sum();
    assert_eq!(ds.test.len(), expected_test.div_ceil(cfg.test_subsample));
}

#[test]
fn bad_configurations_are_rejected() {
    let (h, r) = bodies();
    let base = GeneratorConfig::default();
    let cases = [
        GeneratorConfig {
            rate_hz: 0.0,
            ..base.clone()
        },
        GeneratorConfig {
            train_subsample: 0,
            ..base.clone()
        },
        GeneratorConfig {
            test_subsample: 0,
            ..base.clone()
        },
        GeneratorConfig {
            test_pairs: vec![(0, 3)],
            ..base.clone()
        },
        GeneratorConfig {
            test_pairs: vec![(3, 3)],
            ..base.clone()
        },
        GeneratorConfig {
            test_pairs: vec![(3, 16)],
            ..base.clone()
        },
        GeneratorConfig {
            duration_s: (2.0, 1.0),
            ..base.clone()
        },
        GeneratorConfig {
            mimic: HumanMimic {
                delay_s: (0.1, 5.0),
                ..HumanMimic::default()
            },
            ..base.clone()
        },
    ];
    for c in &cases {
        assert!(
            matches!(synthesize(c, &h, &r), Err(GenerateError::Config(_))),
            "{c:?}"
        );
    }
    let mut broken = h.clone();
    broken.postures.pop();
    assert!(synthesize(&base, &broken, &r).is_err());
}

#[test]
fn recording_another_robot_changes_nothing_else() {
    let (h, r) = bodies();
    // A robot whose key postures are far apart: were it pacing, the motions would be slower.
    let mut far = fake_body("ur", 12, 4);
    for (p, q) in far.postures.iter_mut().enumerate() {
        q.iter_mut()
            .for_each(|v| *v = if p % 2 == 0 { -1.5 } else { 1.2 });
    }
    let cfg = GeneratorConfig::default();
    let three = synthesize_paced(&cfg, &h, &r, &r).expect("without");
    let mut with = r.clone();
    with.push(far.clone());
    let four = synthesize_paced(&cfg, &h, &with, &r).expect("with");
    assert_eq!(four.robots.len(), 3);
    assert_eq!(four.robots[2].name, "ur");
    let bits = |m: &nalgebra::DMatrix<f64>| m.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
    assert_eq!(three.times_ns, four.times_ns);
    assert_eq!(bits(&three.human.positions), bits(&four.human.positions));
    for (a, b) in three.robots.iter().zip(&four.robots) {
        assert_eq!(a.name, b.name);
        assert_eq!(bits(&a.positions), bits(&b.positions));
    }
    assert_eq!(three.segments, four.segments);
    assert_eq!((&three.train, &three.test), (&four.train, &four.test));
    // The new robot still starts and ends every motion exactly at its key postures.
    for s in &four.segments {
        let q = &four.robots[2].positions;
        let (from, to) = (s.from_pose.expect("labelled"), s.to_pose.expect("labelled"));
        for j in 0..12 {
            assert_eq!(q[(s.start, j)], far.postures[from][j]);
            assert!((q[(s.end - 1, j)] - far.postures[to][j]).abs() < 1e-12);
        }
    }
    // Pacing by every recorded robot (`synthesize`) would have slowed the motions down.
    let paced_by_all = synthesize(&cfg, &h, &with).expect("paced by all");
    assert!(paced_by_all.len() > four.len());
}

#[test]
fn robot_lists_name_built_in_robots_once() {
    let with = |robots: &[&str], pace: &[&str]| GeneratorConfig {
        robots: robots.iter().map(|r| r.to_string()).collect(),
        pace_robots: pace.iter().map(|r| r.to_string()).collect(),
        ..GeneratorConfig::default()
    };
    let paper = &PAPER_ROBOTS[..];
    for (robots, pace, unknown) in [
        (&["walkman", "asimo"][..], paper, "asimo"),
        (&["human"][..], paper, "human"),
        (&["coman"][..], &["nao"][..], "nao"),
    ] {
        match generate(&with(robots, pace)) {
            Err(GenerateError::UnknownRobot { name, known }) => {
                assert_eq!(name, unknown);
                assert_eq!(known, ["walkman", "coman", "centauro", "ur5e"]);
            }
            other => panic!("{robots:?}: {other:?}"),
        }
    }
    let e = generate(&with(&["walkman", "asimo"], paper)).unwrap_err();
    assert_eq!(
        e.to_string(),
        "unknown robot `asimo`; the built-in robots are: walkman, coman, centauro, ur5e"
    );
    for robots in [&[][..], &["coman", "ur5e", "coman"][..]] {
        assert!(
            matches!(
                generate(&with(robots, paper)),
                Err(GenerateError::Config(_))
            ),
            "{robots:?}"
        );
    }
}

#[test]
fn the_richer_test_sets_are_every_pair_or_a_seeded_subset() {
    let all = all_test_pairs();
    assert_eq!(all.len(), 15 * 14);
    let distinct: std::collections::BTreeSet<_> = all.iter().collect();
    assert_eq!(distinct.len(), all.len());
    assert!(all
        .iter()
        .all(|&(a, b)| a != b && a != NEUTRAL && b != NEUTRAL));
    assert!(all.contains(&(2, 5)) && all.contains(&(5, 2)));
    let a = random_test_pairs(12, 1).expect("12 pairs");
    assert_eq!(a.len(), 12);
    assert_eq!(random_test_pairs(12, 1), Some(a.clone()), "seeded");
    assert_ne!(
        random_test_pairs(12, 2),
        Some(a.clone()),
        "another seed, other pairs"
    );
    assert!(a.iter().all(|p| all.contains(p)));
    assert_eq!(random_test_pairs(0, 1), None);
    assert_eq!(random_test_pairs(211, 1), None);
    assert_eq!(random_test_pairs(210, 1), Some(all));
    // The default is the paper's protocol.
    assert_eq!(
        GeneratorConfig::default().test_pairs,
        PAPER_TEST_PAIRS.to_vec()
    );
}
