//! Tests of the shared GP-LVM (gradients, training, transfer, prediction, files, bad input).

use super::*;
use rand::Rng;

/// Synthetic demonstration: a 2-D phase drives a human (6 columns) and robots (4 columns,
/// each robot a slightly different smooth function of the same phase).
fn demo(n: usize, seed: u64) -> (Mat<f64>, Mat<f64>, Mat<f64>, Mat<f64>) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let t: Vec<(f64, f64)> = (0..n)
        .map(|i| (i as f64 / n as f64 * 6.0, rng.random_range(-1.0..1.0)))
        .collect();
    let mut noise = |s: f64| s * rng.random_range(-1.0..1.0);
    let h = Mat::from_fn(n, 6, |i, j| {
        let (a, b) = t[i];
        (a * (1.0 + 0.2 * j as f64)).sin() + 0.3 * b * j as f64 + 2.0 + noise(0.02)
    });
    let robot = |scale: f64, shift: f64| {
        Mat::from_fn(n, 4, |i, j| {
            let (a, b) = t[i];
            scale * (a * (1.0 + 0.2 * j as f64) + shift).sin() + 0.2 * b - 1.0
                + 0.01 * ((i * 7 + j * 3) % 5) as f64
        })
    };
    (h, robot(1.0, 0.0), robot(0.8, 0.1), robot(1.2, -0.1))
}

fn quick(max_iters: usize) -> TrainOptions {
    TrainOptions {
        max_iters,
        map_max_iters: 50,
        ..TrainOptions::default()
    }
}

fn fit(bc: BackConstraint, n: usize, iters: usize, seed: u64) -> SharedGplvm {
    let (h, r1, _, _) = demo(n, 7);
    let config = ModelConfig::default()
        .with_latent_dim(2)
        .with_back_constraint(bc)
        .with_seed(seed);
    SharedGplvm::fit(
        &config,
        &[("human", h.as_ref()), ("walkman", r1.as_ref())],
        "human",
        &quick(iters),
        None,
    )
    .expect("fit")
}

/// Every scalar of `p`: latent entries (column-major), then (bandwidth,) then per space
/// variance, lengthscales, noise.
fn flatten(p: &Params) -> Vec<f64> {
    let mut v = Vec::new();
    let lat = match &p.latent {
        LatentParams::Free { x } => x,
        LatentParams::BackConstrained { weights, .. } => weights,
    };
    for j in 0..lat.ncols() {
        for i in 0..lat.nrows() {
            v.push(lat[(i, j)]);
        }
    }
    if let LatentParams::BackConstrained { bandwidth, .. } = &p.latent {
        v.push(*bandwidth);
    }
    for (_, k) in &p.spaces {
        v.push(k.variance);
        v.extend(&k.lengthscale);
        v.push(k.noise);
    }
    v
}

/// Inverse of [`flatten`] with the structure of `like`.
fn unflatten(like: &Params, v: &[f64]) -> Params {
    let mut p = like.clone();
    let mut it = v.iter().copied();
    let mut next = || it.next().expect("length");
    let lat = match &mut p.latent {
        LatentParams::Free { x } => x,
        LatentParams::BackConstrained { weights, .. } => weights,
    };
    for j in 0..lat.ncols() {
        for i in 0..lat.nrows() {
            lat[(i, j)] = next();
        }
    }
    if let LatentParams::BackConstrained { bandwidth, .. } = &mut p.latent {
        *bandwidth = next();
    }
    for (_, k) in &mut p.spaces {
        k.variance = next();
        for l in &mut k.lengthscale {
            *l = next();
        }
        k.noise = next();
    }
    p
}

fn bump(p: &Params, which: usize, h: f64) -> Params {
    let mut v = flatten(p);
    v[which] += h;
    unflatten(p, &v)
}

/// Objective at parameters `p` without refitting anything (crate-internal).
fn objective_at(model: &SharedGplvm, p: &Params) -> f64 {
    let mut m = model.clone();
    match (&mut m.latent, &p.latent) {
        (Latent::Free { x }, LatentParams::Free { x: nx }) => *x = nx.clone(),
        (
            Latent::Back {
                weights, bandwidth, ..
            },
            LatentParams::BackConstrained {
                weights: w,
                bandwidth: b,
            },
        ) => {
            *weights = w.clone();
            *bandwidth = *b;
        }
        _ => panic!("kind"),
    }
    for (s, (_, k)) in m.spaces.iter_mut().zip(&p.spaces) {
        s.kernel = k.clone();
    }
    m.update_latent_points();
    m.objective()
}

#[test]
fn gradients_match_finite_differences_for_every_block_and_parametrisation() {
    for bc in [
        BackConstraint::None,
        BackConstraint::Input,
        BackConstraint::Output,
    ] {
        // 24 points evaluates the spaces one after the other, 80 on separate threads.
        for (seed, n) in [(0, 24), (1, 24), (2, 80)] {
            let mut model = fit(bc, n, 3, seed);
            // Move to a random point so that no gradient is accidentally ~0.
            let mut rng = ChaCha8Rng::seed_from_u64(100 + seed);
            for s in &mut model.spaces {
                s.kernel.variance *= rng.random_range(0.7..1.5);
                s.kernel.noise = rng.random_range(0.05..0.3);
                for l in &mut s.kernel.lengthscale {
                    *l = rng.random_range(0.5..2.0);
                }
            }
            model.update_latent_points();
            let (_, g) = model.evaluate().expect("evaluate");
            let p = model.params();
            let values = flatten(&p);
            let grads = flatten(&g);
            let total = values.len();
            assert_eq!(grads.len(), total);
            let ll = n * 2;
            // A few latent entries, the bandwidth, and every kernel scalar.
            let mut idx: Vec<usize> = vec![0, 5, ll / 2 + 3, ll - 1];
            idx.extend(ll..total);
            for which in idx {
                let scale = values[which].abs().max(1.0);
                let h = 1e-6 * scale;
                let fd = (objective_at(&model, &bump(&p, which, h))
                    - objective_at(&model, &bump(&p, which, -h)))
                    / (2.0 * h);
                let an = grads[which];
                assert!(
                    (an - fd).abs() <= 2e-5 * (1.0 + fd.abs()),
                    "{bc:?} seed {seed} n {n} param {which}: analytic {an} vs fd {fd}"
                );
            }
        }
    }
}

#[test]
fn training_decreases_objective_monotonically_and_is_deterministic() {
    for bc in [
        BackConstraint::None,
        BackConstraint::Input,
        BackConstraint::Output,
    ] {
        let a = fit(bc, 40, 25, 3);
        let h = a.history();
        assert!(h.len() > 3, "{bc:?}: only {} records", h.len());
        assert!(
            h.last().expect("records").objective < h[0].objective - 1.0,
            "{bc:?} did not improve"
        );
        for w in h.windows(2) {
            assert!(
                w[1].objective <= w[0].objective,
                "{bc:?} history not monotone"
            );
            assert!(w[1].seconds >= w[0].seconds);
        }
        // The reported objective is the model's objective at its final parameters.
        let f = a.objective();
        assert!((f - h.last().expect("records").objective).abs() < 1e-9 * f.abs());
        let b = fit(bc, 40, 25, 3);
        assert_eq!(a.params(), b.params(), "{bc:?} not deterministic");
        let c = fit(bc, 40, 25, 4);
        assert_ne!(a.params(), c.params(), "{bc:?}: seed ignored");
    }
}

#[test]
fn callback_sees_snapshots_and_can_stop() {
    let (h, r1, _, _) = demo(30, 1);
    let config = ModelConfig::default().with_latent_dim(2);
    let mut seen = Vec::new();
    let mut cb = |rec: &IterationRecord, m: &SharedGplvm| {
        let p = m
            .predict(h.as_ref(), "walkman", false)
            .expect("snapshot predicts");
        seen.push((rec.iteration, p.mean[(0, 0)]));
        if rec.iteration == 4 {
            Control::Stop
        } else {
            Control::Continue
        }
    };
    let m = SharedGplvm::fit(
        &config,
        &[("human", h.as_ref()), ("walkman", r1.as_ref())],
        "human",
        &quick(100),
        Some(&mut cb),
    )
    .expect("fit");
    assert_eq!(
        seen.iter().map(|s| s.0).collect::<Vec<_>>(),
        vec![1, 2, 3, 4]
    );
    assert_eq!(m.stop_reason(), Some(&StopReason::Callback));
    assert_eq!(m.history().len(), 5);
    // The last snapshot predicts exactly what the returned model predicts.
    let p = m.predict(h.as_ref(), "walkman", false).expect("predict");
    assert_eq!(p.mean[(0, 0)], seen[3].1);
}

#[test]
fn transfer_freezes_everything_but_the_new_robot() {
    for bc in [BackConstraint::Input, BackConstraint::None] {
        let (h, _, r2, _) = demo(40, 7);
        let source = fit(bc, 40, 20, 0);
        let before = source.to_bytes();
        let t = source
            .transfer("coman", r2.as_ref(), &quick(50), None)
            .expect("transfer");
        assert_eq!(source.to_bytes(), before, "source modified");
        let (ps, pt) = (source.params(), t.params());
        assert_eq!(ps.latent, pt.latent, "latent moved");
        assert_eq!(ps.spaces[..], pt.spaces[..2], "frozen kernels moved");
        assert_eq!(t.latent_points(), source.latent_points());
        assert_eq!(t.output_names(), vec!["walkman", "coman"]);
        let (_, k) = &pt.spaces[2];
        let v0 = mean_col_var(preprocess(r2.as_ref(), source.config()).0.as_ref());
        assert!(
            k.variance != v0 || k.noise != 0.1 * v0,
            "new kernel did not move"
        );
        assert!(t.history().len() > 2);
        assert!(t.history().last().expect("h").objective < t.history()[0].objective);
        // Both robots predict from one model; the source robot's prediction is unchanged.
        let a = source.predict(h.as_ref(), "walkman", true).expect("p");
        let b = t.predict(h.as_ref(), "walkman", true).expect("p");
        assert_eq!(a, b);
        let c = t.predict(h.as_ref(), "coman", false).expect("p");
        let mse: f64 = (0..40)
            .flat_map(|i| (0..4).map(move |j| (i, j)))
            .map(|(i, j)| (c.mean[(i, j)] - r2[(i, j)]).powi(2))
            .sum::<f64>()
            / 160.0;
        assert!(mse < 0.05, "{bc:?} transfer training mse {mse}");
        // Transferring to an existing name fails.
        assert!(matches!(
            t.transfer("coman", r2.as_ref(), &quick(5), None),
            Err(Error::DuplicateSpace { .. })
        ));
    }
}

#[test]
fn multi_robot_fit_predicts_every_robot() {
    let (h, r1, r2, r3) = demo(40, 2);
    let config = ModelConfig::default().with_latent_dim(2);
    let m = SharedGplvm::fit(
        &config,
        &[
            ("walkman", r1.as_ref()),
            ("human", h.as_ref()),
            ("coman", r2.as_ref()),
            ("centauro", r3.as_ref()),
        ],
        "human",
        &quick(60),
        None,
    )
    .expect("fit");
    assert_eq!(m.input_name(), "human");
    assert_eq!(m.output_names(), vec!["walkman", "coman", "centauro"]);
    for (name, r) in [("walkman", &r1), ("coman", &r2), ("centauro", &r3)] {
        let p = m.predict(h.as_ref(), name, false).expect("predict");
        let mse: f64 = (0..40)
            .flat_map(|i| (0..4).map(move |j| (i, j)))
            .map(|(i, j)| (p.mean[(i, j)] - r[(i, j)]).powi(2))
            .sum::<f64>()
            / 160.0;
        assert!(mse < 0.05, "{name} training mse {mse}");
    }
}

#[test]
fn prediction_paths_agree_and_variance_matches_dense_formula() {
    for bc in [BackConstraint::Input, BackConstraint::Output] {
        let m = fit(bc, 30, 15, 0);
        let (h, _, _, _) = demo(30, 9);
        let p = m.predict(h.as_ref(), "walkman", true).expect("predict");
        let mut out = vec![0.0; 4];
        let mut row = vec![0.0; 6];
        let lat = m.latent(h.as_ref()).expect("latent");
        for r in [0, 11, 29] {
            for c in 0..6 {
                row[c] = h[(r, c)];
            }
            m.predict_frame(&row, "walkman", &mut out).expect("frame");
            // The batch path sums in another order (blocked matrix products).
            for c in 0..4 {
                let diff = (out[c] - p.mean[(r, c)]).abs();
                assert!(diff <= 1e-12 * out[c].abs().max(1.0), "{diff:e}");
            }
            // Dense reference: mean = k*ᵀ K⁻¹ Y + offset, var = k** − k*ᵀ K⁻¹ k*.
            let s = &m.spaces[1];
            let n = m.n();
            let kx = |a: &[f64], b: &[f64]| {
                let r2: f64 = (0..2)
                    .map(|t| (a[t] - b[t]).powi(2) / s.kernel.lengthscale[t].powi(2))
                    .sum();
                s.kernel.variance * (-0.5 * r2).exp()
            };
            let xs = [lat[(r, 0)], lat[(r, 1)]];
            let kmat = Mat::from_fn(n, n, |i, j| {
                kx(&m.x_rows[i * 2..i * 2 + 2], &m.x_rows[j * 2..j * 2 + 2])
                    + if i == j { s.kernel.noise } else { 0.0 }
            });
            let kinv = {
                use faer::linalg::solvers::DenseSolveCore;
                kmat.llt(faer::Side::Lower).expect("pd").inverse()
            };
            let kstar = Mat::from_fn(n, 1, |i, _| kx(&xs, &m.x_rows[i * 2..i * 2 + 2]));
            let mean = kstar.transpose() * &kinv * &s.data;
            let var = s.kernel.variance - (kstar.transpose() * &kinv * &kstar)[(0, 0)];
            for c in 0..4 {
                assert!((mean[(0, c)] + s.offset[c] - out[c]).abs() < 1e-8, "mean");
                let pv = p.variance.as_ref().expect("variance")[(r, c)];
                assert!((pv - var).abs() < 1e-8, "variance {pv} vs {var}");
            }
        }
        // Training frames are reproduced well.
        let (h0, r1, _, _) = demo(30, 7);
        let p = m.predict(h0.as_ref(), "walkman", true).expect("predict");
        let mse: f64 = (0..30)
            .flat_map(|i| (0..4).map(move |j| (i, j)))
            .map(|(i, j)| (p.mean[(i, j)] - r1[(i, j)]).powi(2))
            .sum::<f64>()
            / 120.0;
        assert!(mse < 0.05, "{bc:?} mse {mse}");
    }
}

#[test]
fn input_back_constraint_latent_is_the_kernel_mapping() {
    let m = fit(BackConstraint::Input, 30, 10, 0);
    let (h, _, _, _) = demo(30, 7);
    // x* = k_bc(h*, H) W on training frames equals X = K_bc W.
    let lat = m.latent(h.as_ref()).expect("latent");
    for i in 0..30 {
        for t in 0..2 {
            assert!((lat[(i, t)] - m.latent_points()[(i, t)]).abs() < 1e-9);
        }
    }
    // The bandwidth is the median pairwise distance of the centred human data.
    let LatentParams::BackConstrained { bandwidth, .. } = m.params().latent else {
        panic!("bc")
    };
    let centred = preprocess(h.as_ref(), m.config()).0;
    let mut d = Vec::new();
    for i in 0..30 {
        for j in 0..i {
            d.push(
                (0..6)
                    .map(|c| (centred[(i, c)] - centred[(j, c)]).powi(2))
                    .sum::<f64>()
                    .sqrt(),
            );
        }
    }
    d.sort_by(f64::total_cmp);
    assert_eq!(bandwidth, d[d.len() / 2]);
}

#[test]
fn pca_init_recovers_the_principal_direction() {
    // Data on a line along (1, 2, 2)/3 in 3-D: the first PCA component is the line coordinate.
    let n = 20;
    let y = Mat::from_fn(n, 3, |i, j| (i as f64 - 9.5) * [1.0, 2.0, 2.0][j] / 3.0);
    let (z, top) = pca(y.as_ref(), 2).expect("pca");
    let var = (0..n).map(|i| (i as f64 - 9.5).powi(2)).sum::<f64>() / n as f64;
    assert!((top - var).abs() < 1e-9 * var);
    for i in 0..n {
        assert!((z[(i, 0)] - (i as f64 - 9.5)).abs() < 1e-9, "{}", z[(i, 0)]);
        assert!(z[(i, 1)].abs() < 1e-9);
    }
}

#[test]
fn save_load_round_trip_is_bit_identical_and_bad_files_fail() {
    let mut m = fit(BackConstraint::Input, 30, 10, 0);
    m.set_column_names("walkman", (0..4).map(|i| format!("j{i}")).collect())
        .expect("names");
    let dir = std::env::temp_dir().join(format!("sgplvm-core-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("tmp dir");
    let path = dir.join("model.sgp");
    m.save(&path).expect("save");
    let l = SharedGplvm::load(&path).expect("load");
    let (h, _, _, _) = demo(30, 5);
    let a = m.predict(h.as_ref(), "walkman", true).expect("p");
    let b = l.predict(h.as_ref(), "walkman", true).expect("p");
    assert_eq!(a, b);
    assert_eq!(l.column_names("walkman").map(|c| c.len()), Some(4));
    assert_eq!(l.history(), m.history());
    assert_eq!(l.to_bytes(), m.to_bytes());
    // No temporary file left behind.
    assert_eq!(std::fs::read_dir(&dir).expect("dir").count(), 1);
    let bytes = m.to_bytes();
    assert!(matches!(
        SharedGplvm::from_bytes(b"PK\x03\x04 a zip file"),
        Err(Error::BadMagic)
    ));
    assert!(matches!(
        SharedGplvm::from_bytes(&bytes[..bytes.len() - 10]),
        Err(Error::Truncated { .. })
    ));
    assert!(matches!(
        SharedGplvm::from_bytes(&bytes[..12]),
        Err(Error::Truncated { .. })
    ));
    let mut old = bytes.clone();
    old[8..12].copy_from_slice(&0u32.to_le_bytes());
    assert!(matches!(
        SharedGplvm::from_bytes(&old),
        Err(Error::UnsupportedVersion {
            found: 0,
            supported: 1
        })
    ));
    let mut bad = bytes.clone();
    let k = bytes.len() / 2;
    bad[k] = if bad[k] == b'1' { b'2' } else { b'1' };
    assert!(matches!(
        SharedGplvm::from_bytes(&bad),
        Err(Error::Corrupt { .. })
    ));
    assert!(matches!(
        SharedGplvm::load(&dir.join("missing.sgp")),
        Err(Error::Io { .. })
    ));
    std::fs::remove_dir_all(&dir).expect("cleanup");
}

#[test]
fn bad_input_is_a_typed_error() {
    let (h, r1, _, _) = demo(20, 0);
    let cfg = ModelConfig::default().with_latent_dim(2);
    let o = quick(2);
    let fit = |spaces: &[(&str, MatRef<'_, f64>)], input: &str, cfg: &ModelConfig| {
        SharedGplvm::fit(cfg, spaces, input, &o, None)
    };
    let mut nan = r1.clone();
    nan[(3, 2)] = f64::NAN;
    assert!(matches!(
        fit(&[("human", h.as_ref()), ("r", nan.as_ref())], "human", &cfg),
        Err(Error::NonFinite { row: 3, col: 2, .. })
    ));
    let mut inf = h.clone();
    inf[(0, 0)] = f64::INFINITY;
    assert!(matches!(
        fit(
            &[("human", inf.as_ref()), ("r", r1.as_ref())],
            "human",
            &cfg
        ),
        Err(Error::NonFinite { .. })
    ));
    let short = r1.subrows(0, 10).to_owned();
    assert!(matches!(
        fit(
            &[("human", h.as_ref()), ("r", short.as_ref())],
            "human",
            &cfg
        ),
        Err(Error::RowCountMismatch {
            expected: 20,
            found: 10,
            ..
        })
    ));
    assert!(matches!(
        fit(
            &[("human", h.as_ref()), ("r", r1.as_ref())],
            "human",
            &cfg.clone().with_latent_dim(20)
        ),
        Err(Error::InvalidLatentDim {
            latent_dim: 20,
            n: 20
        })
    ));
    assert!(matches!(
        fit(
            &[("human", h.as_ref()), ("r", r1.as_ref())],
            "human",
            &cfg.clone().with_latent_dim(0)
        ),
        Err(Error::InvalidLatentDim { .. })
    ));
    let empty = Mat::<f64>::zeros(20, 0);
    assert!(matches!(
        fit(
            &[("human", h.as_ref()), ("r", empty.as_ref())],
            "human",
            &cfg
        ),
        Err(Error::EmptySpace { .. })
    ));
    assert!(matches!(
        fit(&[("human", h.as_ref()), ("r", r1.as_ref())], "humn", &cfg),
        Err(Error::UnknownSpace { .. })
    ));
    assert!(matches!(
        fit(&[("human", h.as_ref())], "human", &cfg),
        Err(Error::NoOutputSpace)
    ));
    assert!(matches!(
        fit(
            &[("human", h.as_ref()), ("human", r1.as_ref())],
            "human",
            &cfg
        ),
        Err(Error::DuplicateSpace { .. })
    ));
    let bad_opts = TrainOptions {
        memory: 0,
        ..quick(2)
    };
    assert!(matches!(
        SharedGplvm::fit(
            &cfg,
            &[("human", h.as_ref()), ("r", r1.as_ref())],
            "human",
            &bad_opts,
            None
        ),
        Err(Error::InvalidValue { .. })
    ));

    let m = fit(&[("human", h.as_ref()), ("r", r1.as_ref())], "human", &cfg).expect("fit");
    assert!(matches!(
        m.predict(h.as_ref(), "coman", false),
        Err(Error::NotAnOutput { .. })
    ));
    assert!(matches!(
        m.predict(h.as_ref(), "human", false),
        Err(Error::NotAnOutput { .. })
    ));
    assert!(matches!(
        m.predict(r1.as_ref(), "r", false),
        Err(Error::DimensionMismatch {
            expected: 6,
            found: 4,
            ..
        })
    ));
    let mut out = vec![0.0; 4];
    assert!(matches!(
        m.predict_frame(&[0.0; 5], "r", &mut out),
        Err(Error::DimensionMismatch { .. })
    ));
    assert!(matches!(
        m.predict_frame(&[f64::NAN; 6], "r", &mut out),
        Err(Error::NonFinite { .. })
    ));
    assert!(matches!(
        m.predict_frame(&[0.0; 6], "r", &mut [0.0; 3]),
        Err(Error::DimensionMismatch { .. })
    ));
    assert!(matches!(
        m.latent(inf.as_ref()),
        Err(Error::NonFinite { .. })
    ));
    assert!(matches!(
        m.transfer("c", short.as_ref(), &o, None),
        Err(Error::RowCountMismatch { .. })
    ));
    assert!(matches!(
        m.transfer("c", nan.as_ref(), &o, None),
        Err(Error::NonFinite { .. })
    ));
    let mut mm = m.clone();
    assert!(matches!(
        mm.set_column_names("r", vec!["a".into()]),
        Err(Error::DimensionMismatch { .. })
    ));
    assert!(matches!(
        mm.set_column_names("x", vec![]),
        Err(Error::UnknownSpace { .. })
    ));
    let mut p = m.params();
    p.spaces[1].1.noise = -1.0;
    assert!(matches!(mm.set_params(&p), Err(Error::InvalidValue { .. })));
    let mut p = m.params();
    p.spaces[1].1.lengthscale.push(1.0);
    assert!(matches!(
        mm.set_params(&p),
        Err(Error::DimensionMismatch { .. })
    ));
    let mut p = m.params();
    p.latent = LatentParams::Free {
        x: Mat::zeros(20, 2),
    };
    assert!(matches!(mm.set_params(&p), Err(Error::InvalidValue { .. })));
    assert_eq!(
        mm.params(),
        m.params(),
        "failed set_params must not change the model"
    );
}

#[test]
fn set_params_round_trip_and_scaling_undone() {
    let (h, r1, _, _) = demo(25, 3);
    let mut big = r1.clone();
    for j in 0..4 {
        for i in 0..25 {
            big[(i, j)] = 100.0 * r1[(i, j)] + 50.0 * j as f64;
        }
    }
    for mode in [ScaleMode::PerColumn, ScaleMode::PerSpace] {
        let cfg = ModelConfig::default()
            .with_latent_dim(2)
            .with_scale_mode(mode);
        let m = SharedGplvm::fit(
            &cfg,
            &[("human", h.as_ref()), ("r", big.as_ref())],
            "human",
            &quick(30),
            None,
        )
        .expect("fit");
        let (_, scale) = m.normalisation("r").expect("space");
        assert!(scale.iter().all(|&s| s > 10.0), "{scale:?}");
        let p = m.predict(h.as_ref(), "r", false).expect("predict");
        let rms: f64 = ((0..25)
            .map(|i| (p.mean[(i, 1)] - big[(i, 1)]).powi(2))
            .sum::<f64>()
            / 25.0)
            .sqrt();
        assert!(
            rms < 10.0,
            "{mode:?}: predictions not in original units (rms {rms})"
        );
        let mut m2 = m.clone();
        m2.set_params(&m.params()).expect("set");
        assert_eq!(m2.predict(h.as_ref(), "r", false).expect("p"), p);
    }
}

#[test]
fn public_types_are_send_and_sync() {
    fn check<T: Send + Sync>() {}
    check::<SharedGplvm>();
    check::<ModelConfig>();
    check::<TrainOptions>();
    check::<Params>();
    check::<Prediction>();
    check::<Error>();
}

#[test]
fn seeded_transfer_varies_with_the_seed_only() {
    let (_, _, r2, _) = demo(40, 7);
    let source = fit(BackConstraint::Input, 40, 20, 0);
    let before = source.to_bytes();
    let run = |seed: u64| {
        source
            .transfer_seeded("coman", r2.as_ref(), seed, &quick(10), None)
            .expect("transfer_seeded")
    };
    let (a, a2, b) = (run(1), run(1), run(2));
    let plain = source
        .transfer("coman", r2.as_ref(), &quick(10), None)
        .expect("transfer");
    assert!(source.to_bytes() == before, "source modified");
    // Bit-identical except the wall-clock seconds in the history.
    let objs = |m: &SharedGplvm| -> Vec<u64> {
        m.history().iter().map(|r| r.objective.to_bits()).collect()
    };
    assert!(a.params() == a2.params(), "same seed, different parameters");
    assert!(objs(&a) == objs(&a2), "same seed, different history");
    // Different starting kernels ⇒ different initial objectives and trained kernels.
    let h0 = |m: &SharedGplvm| m.history()[0].objective;
    assert_ne!(h0(&a), h0(&b));
    assert_ne!(h0(&a), h0(&plain));
    assert_ne!(a.kernel("coman"), b.kernel("coman"));
    // The unseeded transfer is deterministic.
    let plain2 = source
        .transfer("coman", r2.as_ref(), &quick(10), None)
        .expect("transfer");
    assert!(plain.params() == plain2.params() && objs(&plain) == objs(&plain2));
    // Frozen parts are shared by all runs.
    assert_eq!(a.latent_points(), source.latent_points());
    assert_eq!(a.kernel("walkman"), source.kernel("walkman"));
}

#[test]
fn batch_prediction_matches_the_per_frame_path() {
    use rand::{Rng, SeedableRng};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
    for bc in [BackConstraint::Input, BackConstraint::None] {
        let m = fit(bc, 40, 20, 0);
        // 300 random frames (more than one block of 256), around and beyond the data.
        let (h, _, _, _) = demo(40, 7);
        let hn = Mat::from_fn(300, h.ncols(), |r, c| {
            h[(r % 40, c)] + rng.random_range(-0.5..0.5)
        });
        // Norm-wise relative: differences over the largest magnitude of the quantity (the
        // summation order differs, and the sums over weights of both signs cancel).
        let rel = |a: f64, b: f64, scale: f64| (a - b).abs() / scale;
        let lat = m.latent(hn.as_ref()).expect("latent");
        let amax = |a: &Mat<f64>| {
            (0..a.nrows())
                .flat_map(|r| (0..a.ncols()).map(move |c| (r, c)))
                .map(|(r, c)| a[(r, c)].abs())
                .fold(0.0f64, f64::max)
        };
        let lscale = amax(&lat);
        for with_var in [false, true] {
            let p = m
                .predict(hn.as_ref(), "walkman", with_var)
                .expect("predict");
            let mut out = vec![0.0; p.mean.ncols()];
            let mut row = vec![0.0; hn.ncols()];
            let mut worst: f64 = 0.0;
            let mscale = amax(&p.mean);
            for r in 0..300 {
                for (c, v) in row.iter_mut().enumerate() {
                    *v = hn[(r, c)];
                }
                m.predict_frame(&row, "walkman", &mut out).expect("frame");
                for (t, &o) in out.iter().enumerate() {
                    worst = worst.max(rel(p.mean[(r, t)], o, mscale));
                }
                let mut x = vec![0.0; m.latent_points().ncols()];
                m.latent_into(&row, &mut x).expect("latent_into");
                for (t, &xv) in x.iter().enumerate() {
                    worst = worst.max(rel(lat[(r, t)], xv, lscale));
                }
            }
            assert!(
                worst < 1e-12,
                "{bc:?} var={with_var}: worst rel diff {worst:e}"
            );
            assert_eq!(p.variance.is_some(), with_var);
        }
        // Variances of the blocked path are finite and non-negative everywhere.
        let p = m.predict(hn.as_ref(), "walkman", true).expect("predict");
        let v = p.variance.expect("variance");
        assert!((0..300).all(|r| v[(r, 0)] >= 0.0 && v[(r, 0)].is_finite()));
    }
}
