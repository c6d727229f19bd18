//! Tests of the model as a whole: every entry point answers bad input with a typed error, and
//! the public types can cross threads.

use crate::test_support::*;

#[test]
fn bad_training_input_is_a_typed_error() {
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
}

#[test]
fn misuse_of_a_trained_model_is_a_typed_error() {
    let (h, r1, _, _) = demo(20, 0);
    let cfg = ModelConfig::default().with_latent_dim(2);
    let o = quick(2);
    let mut nan = r1.clone();
    nan[(3, 2)] = f64::NAN;
    let mut inf = h.clone();
    inf[(0, 0)] = f64::INFINITY;
    let short = r1.subrows(0, 10).to_owned();
    let m = SharedGplvm::fit(
        &cfg,
        &[("human", h.as_ref()), ("r", r1.as_ref())],
        "human",
        &o,
        None,
    )
    .expect("fit");
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
fn public_types_are_send_and_sync() {
    fn check<T: Send + Sync>() {}
    check::<SharedGplvm>();
    check::<ModelConfig>();
    check::<TrainOptions>();
    check::<Params>();
    check::<Prediction>();
    check::<Error>();
}

/// Dense K(X, X) of `space` at the model's latent points (lower triangle is what is read).
fn dense_kernel(m: &SharedGplvm, space: usize) -> Mat<f64> {
    let k = &m.spaces[space].kernel;
    let x = m.latent_points();
    Mat::from_fn(x.nrows(), x.nrows(), |i, j| {
        let r2: f64 = (0..x.ncols())
            .map(|t| ((x[(i, t)] - x[(j, t)]) / k.lengthscale[t]).powi(2))
            .sum();
        k.variance * (-0.5 * r2).exp()
    })
}

#[test]
fn jitter_is_reported_when_the_factors_needed_it_and_only_then() {
    // Every frame twice: with input back constraints the latent points come in identical pairs,
    // so K is singular and a tiny noise cannot make it factorisable.
    let (h, r1, _, _) = demo(20, 3);
    let (hd, rd) = (
        Mat::from_fn(20, 6, |i, j| h[(i / 2 * 2, j)]),
        Mat::from_fn(20, 4, |i, j| r1[(i / 2 * 2, j)]),
    );
    let cfg = ModelConfig::default().with_latent_dim(2);
    let spaces = [("human", hd.as_ref()), ("walkman", rd.as_ref())];
    let plain = [("human", h.as_ref()), ("walkman", r1.as_ref())];
    let m = SharedGplvm::fit(&cfg, &plain, "human", &quick(5), None).expect("fit");
    assert_eq!(m.jitter(), 0.0, "distinct points need no jitter");
    let mut m = SharedGplvm::fit(&cfg, &spaces, "human", &quick(5), None).expect("fit");
    let mut p = m.params();
    for (_, k) in &mut p.spaces {
        k.noise = 1e-300;
    }
    m.set_params(&p).expect("jitter rescues it");
    let jitter = m.jitter();
    assert!(jitter > 0.0, "no jitter reported");
    // jitter() is the largest jitter of the caches, and each cache's factor is that of
    // K + (noise + its jitter) I (measured ≤ 2e-16 relative).
    let used: Vec<f64> = m
        .prepared()
        .expect("caches")
        .caches
        .iter()
        .map(|c| c.jitter)
        .collect();
    assert_eq!(jitter, used.iter().copied().fold(0.0, f64::max));
    for (s, c) in m.prepared().expect("caches").caches.iter().enumerate() {
        // The factorisation the caches are built from (`SpaceCache::new`), redone.
        let space = &m.spaces[s];
        let mut work = crate::likelihood::SpaceWork::new(m.n(), space.data.ncols());
        let e = space.factorise(&m.x_rows, m.q(), &mut work).expect("pd");
        assert_eq!(e.jitter, c.jitter);
        let k = dense_kernel(&m, s);
        let err = reconstruction_error(k.as_ref(), work.factor(), 1e-300 + c.jitter);
        assert!(err < 2e-15, "space {s}: L·Lᵀ off by {err:e}");
        let mean_diag = m.spaces[s].kernel.variance;
        // 0 when rounding left the pivots positive, else on the ladder 1e-10 … 1e-2 × mean K_ii.
        let rung = (c.jitter / mean_diag).log10();
        let ok = c.jitter == 0.0
            || ((-10.0..=-2.0).contains(&rung.round()) && (rung - rung.round()).abs() < 1e-9);
        assert!(ok, "space {s}: jitter {:e}", c.jitter);
    }
    // Loading rebuilds the same factors, hence the same jitter.
    let loaded = SharedGplvm::from_bytes(&m.to_bytes()).expect("load");
    assert_eq!(loaded.jitter(), jitter);
    // A noise of 10% of the variance: no jitter again (not the stale value).
    for (_, k) in &mut p.spaces {
        k.noise = 0.1 * k.variance;
    }
    m.set_params(&p).expect("set_params");
    assert_eq!(m.jitter(), 0.0, "stale jitter");
}

#[test]
fn a_kernel_that_cannot_be_factorised_is_a_typed_error_from_every_path() {
    let (h, r1, r2, _) = demo(20, 0);
    let cfg = ModelConfig::default().with_latent_dim(2);
    let spaces = [("human", h.as_ref()), ("walkman", r1.as_ref())];
    let m = SharedGplvm::fit(&cfg, &spaces, "human", &quick(3), None).expect("fit");
    let not_pd = |r: Result<SharedGplvm, Error>, space: &str| match r {
        Err(Error::NotPositiveDefinite { space: s, .. }) => assert_eq!(s, space),
        other => panic!("expected NotPositiveDefinite in '{space}', got {other:?}"),
    };
    // A finite, valid variance whose K cannot be factorised (the diagonal's sum overflows).
    let mut p = m.params();
    p.spaces[1].1.variance = 1e308;
    // set_params takes them (it factorises nothing); every use reports the failure.
    let mut broken = m.clone();
    broken.set_params(&p).expect("checked when used");
    not_pd(broken.evaluate().map(|_| m.clone()), "walkman");
    assert!(broken.objective().is_nan());
    not_pd(
        broken
            .predict(h.as_ref(), "walkman", false)
            .map(|_| m.clone()),
        "walkman",
    );
    let mut out = [0.0; 4];
    let row: Vec<f64> = (0..6).map(|j| h[(0, j)]).collect();
    not_pd(
        broken
            .predict_frame(&row, "walkman", &mut out)
            .map(|()| m.clone()),
        "walkman",
    );
    not_pd(broken.latent(h.as_ref()).map(|_| m.clone()), "walkman");
    assert!(broken.jitter().is_nan());
    // The same parameters in a model file: refused on load, before any factorisation, as a
    // kernel no training on standardised data produces.
    let mut raw = m.clone();
    raw.spaces[1].kernel.variance = 1e308;
    match SharedGplvm::from_bytes(&raw.to_bytes()) {
        Err(Error::Corrupt { reason }) => {
            assert!(reason.contains("'walkman': invalid kernel"), "{reason}")
        }
        other => panic!("expected an invalid kernel, got {other:?}"),
    }
    // Transfer: a source without caches (set_params drops them) has its frozen spaces
    // factorised for the objective's constant. (A source with caches lends them: its
    // factorisations succeeded.)
    let mut source = m.clone();
    let mut p0 = m.params();
    p0.spaces[0].1.variance = 1e308;
    source.set_params(&p0).expect("checked when used");
    not_pd(
        source.transfer("coman", r2.as_ref(), &quick(3), None),
        "human",
    );
    // Training (fit's last step) from a start that cannot be factorised.
    let mut start = m.clone();
    start.spaces[1].kernel.variance = 1e308;
    not_pd(
        start
            .train(
                crate::objective::Mode::Full,
                &quick(3),
                &crate::train::Limits::default(),
                None,
            )
            .map(|_| m.clone()),
        "walkman",
    );
}

/// Training and the GP regression at N = 100 000 frames (15 N×N matrices: 1.2 TB for training)
/// are refused before their matrices are allocated, with a one-line error naming the size.
#[test]
fn models_too_large_for_memory_are_refused_before_allocating() {
    let n = 100_000;
    let h = Mat::from_fn(n, 2, |i, j| (i as f64 * 1e-3 + j as f64).sin());
    let r = Mat::from_fn(n, 1, |i, _| (i as f64 * 2e-3).cos());
    let config = ModelConfig::default().with_latent_dim(1);
    let spaces = [("human", h.as_ref()), ("robot", r.as_ref())];
    let refused = |e: Error, what: &str| {
        let text = e.to_string();
        assert!(matches!(e, Error::TooLarge { n: 100_000, .. }), "{e:?}");
        assert!(
            text.starts_with(&format!("{what} with N = 100000 frames needs about")),
            "{text}"
        );
        assert!(
            text.contains("use fewer frames") && !text.contains('\n'),
            "{text}"
        );
    };
    refused(
        SharedGplvm::fit(&config, &spaces, "human", &quick(1), None).expect_err("refused"),
        "training",
    );
    let validation = crate::validation::Validation::blocks(n);
    refused(
        SharedGplvm::fit_validated(&config, &spaces, "human", &quick(1), &validation, None)
            .expect_err("refused"),
        "training",
    );
    refused(
        GpRegression::fit(h.as_ref(), r.as_ref(), &quick(1)).expect_err("refused"),
        "GP regression",
    );
}

#[test]
fn whitened_training_is_refused_where_it_cannot_apply() {
    let (h, r1, _, _) = demo(30, 0);
    let spaces = [("human", h.as_ref()), ("walkman", r1.as_ref())];
    let white = quick(3).with_whiten_back_constraint(true);
    let validation = crate::validation::Validation::blocks(30);
    for (config, word) in [
        (
            ModelConfig::default()
                .with_latent_dim(2)
                .with_back_constraint(BackConstraint::None),
            "free latent points",
        ),
        (
            ModelConfig::default()
                .with_latent_dim(2)
                .with_back_constraint(BackConstraint::Input)
                .with_inducing(Some(8)),
            "sparse",
        ),
    ] {
        for result in [
            SharedGplvm::fit(&config, &spaces, "human", &white, None),
            SharedGplvm::fit_validated(&config, &spaces, "human", &white, &validation, None),
        ] {
            match result {
                Err(e @ Error::InvalidValue { .. }) => {
                    let text = e.to_string();
                    assert!(text.contains("whiten_back_constraint"), "{text}");
                    assert!(text.contains(word), "{text}");
                }
                other => panic!("expected a refusal, got {:?}", other.map(|_| ())),
            }
        }
    }
}

#[test]
fn a_whitened_model_stores_its_weights_and_round_trips_like_any_other() {
    let (h, r1, _, _) = demo(40, 3);
    let spaces = [("human", h.as_ref()), ("walkman", r1.as_ref())];
    for bc in [BackConstraint::Input, BackConstraint::Output] {
        let config = ModelConfig::default()
            .with_latent_dim(2)
            .with_back_constraint(bc);
        let train = |whiten: bool| {
            SharedGplvm::fit(
                &config,
                &spaces,
                "human",
                &quick(15).with_whiten_back_constraint(whiten),
                None,
            )
            .expect("fit")
        };
        let (plain, white) = (train(false), train(true));
        // The flag changes the training path (the same start up to rounding — whitened X is
        // K_bc P V — then other iterates).
        let (f0, g0) = (plain.history()[0].objective, white.history()[0].objective);
        assert!((f0 - g0).abs() < 1e-12 * f0.abs(), "{bc:?}: {f0} vs {g0}");
        assert_ne!(
            plain.params(),
            white.params(),
            "{bc:?}: whitening changed nothing"
        );
        // The model holds W (not V): its objective, evaluated from the stored weights, is the
        // best the whitened training recorded, and its latent points are K_bc W.
        let best = white
            .history()
            .iter()
            .map(|r| r.objective)
            .fold(f64::INFINITY, f64::min);
        let f = white.objective();
        assert!(
            (f - best).abs() < 1e-9 * best.abs(),
            "{bc:?}: {f} vs {best}"
        );
        let mut recomputed = white.clone();
        recomputed.update_latent_points();
        let (a, b) = (recomputed.latent_points(), white.latent_points());
        for j in 0..a.ncols() {
            for i in 0..a.nrows() {
                assert_eq!(a[(i, j)], b[(i, j)], "{bc:?}: X[{i},{j}]");
            }
        }
        // Saved and loaded, it is the same model and predicts the same, bit for bit.
        let loaded = SharedGplvm::from_bytes(&white.to_bytes()).expect("load");
        assert_eq!(loaded.to_bytes(), white.to_bytes());
        let p = white.predict(h.as_ref(), "walkman", true).expect("predict");
        let q = loaded
            .predict(h.as_ref(), "walkman", true)
            .expect("predict");
        assert_eq!(p.mean, q.mean, "{bc:?}");
        assert_eq!(p.variance, q.variance, "{bc:?}");
    }
}

#[test]
fn input_means_are_the_training_frames_means_in_the_user_s_units() {
    let m = fit(BackConstraint::Input, 40, 2, 1);
    let (h, ..) = demo(40, 7);
    for (t, got) in m.input_means().into_iter().enumerate() {
        let want = (0..40).map(|i| h[(i, t)]).sum::<f64>() / 40.0;
        assert!((got - want).abs() < 1e-12, "column {t}: {got} vs {want}");
    }
}
