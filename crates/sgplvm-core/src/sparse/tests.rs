use super::objective::SparseObjective;
use super::*;
use crate::objective::Mode;
use crate::test_support::*;
use crate::train::Objective;

fn sparse_fit(bc: BackConstraint, n: usize, m: usize, iters: usize) -> SharedGplvm {
    let config = ModelConfig::default()
        .with_latent_dim(2)
        .with_back_constraint(bc)
        .with_inducing(Some(m));
    fit_on_demo(&config, n, iters)
}

/// A model of `config` trained on `n` frames of the demo data's human and first robot.
fn fit_on_demo(config: &ModelConfig, n: usize, iters: usize) -> SharedGplvm {
    let (h, r1, _, _) = demo(n, 7);
    SharedGplvm::fit(
        config,
        &[("human", h.as_ref()), ("walkman", r1.as_ref())],
        "human",
        &quick(iters),
        None,
    )
    .expect("fit")
}

#[test]
fn the_objective_gradient_matches_central_differences_on_theta() {
    // Every block of θ: latent (X or the centres' weights W), Z, every log kernel parameter;
    // measured below 1e-6, tolerance 1e-5.
    for bc in [BackConstraint::None, BackConstraint::Input] {
        let mut model = sparse_fit(bc, 40, 8, 5);
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        for s in &mut model.spaces {
            s.kernel.noise = rng.random_range(0.05..0.3);
            for l in &mut s.kernel.lengthscale {
                *l = rng.random_range(0.5..2.0);
            }
        }
        let obj = SparseObjective::new(&model, Mode::Full).expect("objective");
        let theta = obj.theta0();
        let latent = if bc == BackConstraint::None {
            40 * 2
        } else {
            8 * 2
        };
        assert_eq!(theta.len(), latent + 8 * 2 + 2 * 4, "θ layout");
        check_fd(&obj, &theta, &format!("{bc:?}"));
    }
}

#[test]
fn with_every_frame_as_inducing_input_it_predicts_like_the_exact_model() {
    // The exact model with input back constraints and its sparse twin with Z = X, M = N
    // (centres = every frame, same W): Q_nn = K_nn, so the predictions agree up to the
    // relative jitter 1e-6 on K_mm.
    let exact = fit(BackConstraint::Input, 30, 20, 0);
    let mut sparse = exact.clone();
    sparse.config.inducing = Some(30);
    sparse.sparse = Some(SparseState::new(exact.x.clone()));
    sparse.rebuild().expect("rebuild");
    let (h, _, _, _) = demo(45, 3);
    let a = exact.predict(h.as_ref(), "walkman", true).expect("exact");
    let b = sparse.predict(h.as_ref(), "walkman", true).expect("sparse");
    let (va, vb) = (a.variance.expect("v"), b.variance.expect("v"));
    let mut worst = 0.0f64;
    for i in 0..45 {
        for j in 0..4 {
            worst = worst.max((a.mean[(i, j)] - b.mean[(i, j)]).abs());
            worst = worst.max((va[(i, j)] - vb[(i, j)]).abs());
        }
    }
    // Measured 1.8e-4, all from the relative jitter 1e-6 on K_mm (ill-conditioned at M = N):
    // with 1e-13 it is below 1e-4. A wrong weight or variance matrix is off by O(1).
    assert!(
        worst < 1e-3,
        "sparse vs exact prediction differ by {worst:e}"
    );
    // One frame at a time gives the batch path's mean.
    let mut out = [0.0; 4];
    for i in [0, 17, 44] {
        let row: Vec<f64> = (0..6).map(|t| h[(i, t)]).collect();
        sparse
            .predict_frame(&row, "walkman", &mut out)
            .expect("frame");
        for j in 0..4 {
            assert!((out[j] - b.mean[(i, j)]).abs() < 1e-12, "frame {i}");
        }
    }
}

#[test]
fn sparse_training_fits_saves_and_transfers() {
    for bc in [BackConstraint::Input, BackConstraint::None] {
        let n = 150;
        let model = sparse_fit(bc, n, 15, 60);
        let hist = model.history();
        assert!(hist.len() > 3 && hist.last().expect("h").objective < hist[0].objective);
        let f = model.objective();
        assert!((f - hist.last().expect("h").objective).abs() < 1e-9 * f.abs());
        let z = model.inducing_inputs().expect("sparse").to_owned();
        assert_eq!((z.nrows(), z.ncols()), (15, 2));
        let (h, r1, r2, _) = demo(n, 7);
        let p = model.predict(h.as_ref(), "walkman", true).expect("predict");
        let mse: f64 = (0..n)
            .flat_map(|i| (0..4).map(move |j| (i, j)))
            .map(|(i, j)| (p.mean[(i, j)] - r1[(i, j)]).powi(2))
            .sum::<f64>()
            / (4 * n) as f64;
        assert!(mse < 0.05, "{bc:?} training mse {mse}");
        // Round trip: bit-identical predictions, Z kept.
        let back = SharedGplvm::from_bytes(&model.to_bytes()).expect("load");
        assert_eq!(back.predict(h.as_ref(), "walkman", true).expect("p"), p);
        assert_eq!(back.inducing_inputs().expect("z").to_owned(), z);
        // Transfer: X, Z, the latent block and the frozen kernels stay; the new kernel moves.
        let t = model
            .transfer("coman", r2.as_ref(), &quick(40), None)
            .expect("transfer");
        assert_eq!(t.inducing_inputs().expect("z").to_owned(), z);
        assert_eq!(t.latent_points(), model.latent_points());
        assert_eq!(t.params().latent, model.params().latent);
        assert_eq!(t.kernel("human"), model.kernel("human"));
        assert_eq!(t.kernel("walkman"), model.kernel("walkman"));
        assert!(t.history().last().expect("h").objective < t.history()[0].objective);
        let c = t.predict(h.as_ref(), "coman", false).expect("p");
        let mse: f64 = (0..n)
            .flat_map(|i| (0..4).map(move |j| (i, j)))
            .map(|(i, j)| (c.mean[(i, j)] - r2[(i, j)]).powi(2))
            .sum::<f64>()
            / (4 * n) as f64;
        assert!(mse < 0.05, "{bc:?} transfer training mse {mse}");
    }
}

#[test]
fn fixed_inducing_inputs_do_not_move_and_bad_counts_are_refused() {
    let (h, r1, r2, _) = demo(60, 7);
    let config = ModelConfig::default()
        .with_latent_dim(2)
        .with_inducing(Some(10))
        .with_fixed_inducing(true);
    let spaces = [
        ("human", h.as_ref()),
        ("walkman", r1.as_ref()),
        ("coman", r2.as_ref()),
    ];
    let start = SharedGplvm::initial(&config, &spaces, "human").expect("initial");
    let m = SharedGplvm::fit(&config, &spaces, "human", &quick(20), None).expect("multi-robot");
    assert_eq!(m.inducing_inputs(), start.inducing_inputs());
    assert_eq!(m.output_names(), vec!["walkman", "coman"]);
    // Z starts at the initial latent points of spread frames.
    let frames = spread(60, 10);
    for (i, &f) in frames.iter().enumerate() {
        for t in 0..2 {
            assert_eq!(start.inducing_inputs().expect("z")[(i, t)], start.x[(f, t)]);
        }
    }
    for (bad, what) in [
        (config.clone().with_inducing(Some(61)), "at most 60"),
        (config.clone().with_inducing(Some(0)), "at least 1"),
        (
            config.clone().with_back_constraint(BackConstraint::Output),
            "none and input",
        ),
    ] {
        let e = SharedGplvm::fit(&bad, &spaces, "human", &quick(2), None)
            .expect_err("refused")
            .to_string();
        assert!(e.contains(what), "{e}");
    }
}

#[test]
fn set_params_rebuilds_a_sparse_models_caches_or_changes_nothing() {
    for bc in [BackConstraint::Input, BackConstraint::None] {
        let model = sparse_fit(bc, 80, 10, 20);
        let (h, _, _, _) = demo(80, 7);
        let before = model.predict(h.as_ref(), "walkman", true).expect("p");
        // The same parameters: the same predictions, bit for bit (free latent points refit
        // their input map, warm-started, as the exact model does).
        let mut same = model.clone();
        same.set_params(&model.params()).expect("set_params");
        if bc == BackConstraint::Input {
            assert_eq!(
                same.predict(h.as_ref(), "walkman", true).expect("p"),
                before
            );
        }
        // New parameters: predictions follow them at once (no stale sparse cache), as a
        // model loaded with them does.
        let mut p = model.params();
        p.spaces[1].1.variance *= 2.0;
        let mut moved = model.clone();
        moved.set_params(&p).expect("set_params");
        let after = moved.predict(h.as_ref(), "walkman", true).expect("p");
        assert_ne!(after, before, "{bc:?}: stale caches");
        let loaded = SharedGplvm::from_bytes(&moved.to_bytes()).expect("load");
        assert_eq!(
            loaded.predict(h.as_ref(), "walkman", true).expect("p"),
            after
        );
        // A kernel that cannot be factorised: an error, and the model is unchanged.
        p.spaces[1].1.variance = 1e308;
        let mut broken = model.clone();
        assert!(broken.set_params(&p).is_err(), "{bc:?}");
        assert_eq!(broken.to_bytes(), model.to_bytes());
    }
}

#[test]
fn batches_on_threads_predict_what_one_thread_predicts() {
    // Over two chunks of frames `predict` runs on the pool; the blocks are the same, so the
    // results must be the same bits — for the sparse model and the exact one, with variance
    // and latent points.
    let (h, _, _, _) = demo(40, 3);
    let n = 2 * crate::predict::PARALLEL_CHUNK + 37;
    let hh = Mat::from_fn(n, h.ncols(), |i, j| h[(i % 40, j)] + 1e-3 * (i / 40) as f64);
    for model in [
        sparse_fit(BackConstraint::Input, 40, 8, 5),
        sparse_fit(BackConstraint::None, 40, 8, 5),
        fit(BackConstraint::Input, 40, 5, 0),
    ] {
        let si = model.output_index("walkman").expect("output");
        let par = model
            .predict(hh.as_ref(), "walkman", true)
            .expect("predicts");
        let seq = model.predict_rows(hh.as_ref(), si, true).expect("predicts");
        assert_eq!(par.mean, seq.mean);
        assert_eq!(par.variance, seq.variance);
        assert_eq!(par.mean.nrows(), n);
        // The latent points come with the prediction, those `latent` gives.
        assert_eq!(par.latent, seq.latent);
        assert_eq!(par.latent, model.latent(hh.as_ref()).expect("latent"));
    }
}

#[test]
fn evaluations_reuse_the_models_buffers_and_give_the_same_bits() {
    let model = sparse_fit(BackConstraint::Input, 40, 8, 5);
    let st = model.sparse.as_ref().expect("sparse");
    assert!(crate::pool::lock(&st.work.0).is_empty());
    let first = model.evaluate_sparse().expect("evaluates");
    // The objective handed its buffers (one per space, Φ filled) back to the model.
    let kept = crate::pool::lock(&st.work.0).len();
    assert_eq!(kept, model.spaces.len());
    let second = model.evaluate_sparse().expect("evaluates");
    assert_eq!(first.0, second.0);
    // (The gradient's bandwidth entry is NaN: not computed for centres.)
    match (&first.1.latent, &second.1.latent) {
        (
            LatentParams::BackConstrained { weights: a, .. },
            LatentParams::BackConstrained { weights: b, .. },
        ) => assert_eq!(a, b),
        other => panic!("{other:?}"),
    }
    assert_eq!(first.1.spaces, second.1.spaces);
    // A clone starts without buffers.
    let copy = model.clone();
    let cst = copy.sparse.as_ref().expect("sparse");
    assert!(crate::pool::lock(&cst.work.0).is_empty());
}

fn bayesian_fit(bc: BackConstraint, n: usize, m: usize, iters: usize) -> SharedGplvm {
    let config = ModelConfig::default()
        .with_latent_dim(3)
        .with_back_constraint(bc)
        .with_inducing(Some(m))
        .with_bayesian(true);
    fit_on_demo(&config, n, iters)
}

#[test]
fn the_bayesian_objective_gradient_matches_central_differences_on_theta() {
    // Every block of θ: the means (or the centres' weights), log S, Z, every log kernel
    // parameter; then, in transfer, the new robot's kernel alone.
    for bc in [BackConstraint::None, BackConstraint::Input] {
        let model = bayesian_fit(bc, 30, 6, 3);
        assert!(model.is_bayesian());
        let obj = SparseObjective::new(&model, Mode::Full).expect("objective");
        let theta = obj.theta0();
        let latent = if bc == BackConstraint::None {
            30 * 3
        } else {
            6 * 3
        };
        assert_eq!(theta.len(), latent + 30 * 3 + 6 * 3 + 2 * 5, "θ layout");
        check_fd(&obj, &theta, &format!("{bc:?}"));
        let (_, _, r2, _) = demo(30, 7);
        let mut t = model.clone();
        let space = t.transfer_space("coman", r2.as_ref(), None).expect("space");
        t.spaces.push(space);
        let obj = SparseObjective::new(&t, Mode::Kernels(vec![2])).expect("objective");
        let theta = obj.theta0();
        assert_eq!(theta.len(), 5);
        check_fd(&obj, &theta, &format!("{bc:?} transfer"));
    }
}

/// Every entry of the objective's gradient at `theta` against central differences, to 1e-5
/// relative to 1 + |difference quotient|.
fn check_fd(obj: &SparseObjective<'_>, theta: &[f64], what: &str) {
    let mut g = vec![0.0; theta.len()];
    obj.eval(theta, &mut g).expect("eval");
    let mut scratch = vec![0.0; theta.len()];
    for i in 0..theta.len() {
        let h = 1e-6 * theta[i].abs().max(1.0);
        let (mut p, mut m) = (theta.to_vec(), theta.to_vec());
        p[i] += h;
        m[i] -= h;
        let fd = (obj.eval(&p, &mut scratch).expect("eval")
            - obj.eval(&m, &mut scratch).expect("eval"))
            / (2.0 * h);
        let err = (g[i] - fd).abs() / (1.0 + fd.abs());
        assert!(err < 1e-5, "{what} θ[{i}]: analytic {} vs fd {fd}", g[i]);
    }
}

#[test]
fn bayesian_training_fits_saves_as_format_3_and_transfers() {
    for bc in [BackConstraint::Input, BackConstraint::None] {
        let n = 120;
        let model = bayesian_fit(bc, n, 12, 60);
        let hist = model.history();
        assert!(hist.len() > 3 && hist.last().expect("h").objective < hist[0].objective);
        let f = model.objective();
        assert!(
            (f - hist.last().expect("h").objective).abs() < 1e-9 * f.abs(),
            "{f} vs {:?}",
            hist.last()
        );
        let s = model.latent_variances().expect("q(X)");
        assert_eq!((s.nrows(), s.ncols()), (n, 3));
        assert!(s
            .col_iter()
            .all(|c| c.iter().all(|v| *v > 0.0 && v.is_finite())));
        let (h, r1, r2, _) = demo(n, 7);
        let p = model.predict(h.as_ref(), "walkman", true).expect("predict");
        let mse: f64 = (0..n)
            .flat_map(|i| (0..4).map(move |j| (i, j)))
            .map(|(i, j)| (p.mean[(i, j)] - r1[(i, j)]).powi(2))
            .sum::<f64>()
            / (4 * n) as f64;
        let var: f64 = (0..4)
            .map(|j| {
                let m = (0..n).map(|i| r1[(i, j)]).sum::<f64>() / n as f64;
                (0..n).map(|i| (r1[(i, j)] - m).powi(2)).sum::<f64>() / n as f64
            })
            .sum::<f64>()
            / 4.0;
        assert!(
            mse < 0.2 * var,
            "{bc:?}: training MSE {mse} against variance {var}"
        );
        // Saved as format 3, loaded with the same predictions bit for bit.
        let bytes = model.to_bytes();
        assert_eq!(u32::from_le_bytes(bytes[8..12].try_into().expect("4")), 3);
        let back = SharedGplvm::from_bytes(&bytes).expect("load");
        assert!(back.is_bayesian());
        let q = back.predict(h.as_ref(), "walkman", true).expect("predict");
        assert!(q.mean == p.mean && q.variance == p.variance);
        // Transfer: q(X), Z and the first spaces unchanged; the new robot learned.
        let t = model
            .transfer("coman", r2.as_ref(), &quick(40), None)
            .expect("transfer");
        assert!(t.is_bayesian());
        assert!(t.latent_variances() == model.latent_variances());
        assert!(t.inducing_inputs() == model.inducing_inputs());
        let pc = t.predict(h.as_ref(), "coman", false).expect("predict");
        let e: f64 = (0..n)
            .flat_map(|i| (0..4).map(move |j| (i, j)))
            .map(|(i, j)| (pc.mean[(i, j)] - r2[(i, j)]).powi(2))
            .sum::<f64>()
            / (4 * n) as f64;
        assert!(e.is_finite());
        let w = t.predict(h.as_ref(), "walkman", false).expect("predict");
        assert!(w.mean == p.mean);
    }
}

#[test]
fn a_bayesian_model_without_inducing_inputs_or_with_a_bad_file_is_refused() {
    let config = ModelConfig::default().with_bayesian(true);
    let e = config.check().expect_err("no inducing inputs");
    assert!(e.to_string().contains("inducing"), "{e}");
    // A point-latent model's file claiming version 3, and the other way round.
    let model = bayesian_fit(BackConstraint::Input, 40, 6, 3);
    let mut bytes = model.to_bytes();
    bytes[8..12].copy_from_slice(&2u32.to_le_bytes());
    let e = SharedGplvm::from_bytes(&bytes).expect_err("version 2 with bayesian");
    assert!(e.to_string().contains("format 2"), "{e}");
    let plain = sparse_fit(BackConstraint::Input, 40, 6, 3);
    let bytes = plain.to_bytes();
    assert_eq!(u32::from_le_bytes(bytes[8..12].try_into().expect("4")), 2);
}

#[test]
fn ard_weights_are_variance_over_squared_lengthscales() {
    let model = bayesian_fit(BackConstraint::Input, 40, 6, 3);
    let k = model.kernel("walkman").expect("kernel").clone();
    let w = model.ard_weights("walkman").expect("weights");
    for (w, l) in w.iter().zip(&k.lengthscale) {
        assert!((w - k.variance / (l * l)).abs() <= 1e-15 * w.abs());
    }
    assert!(model.ard_weights("nosuch").is_err());
}
