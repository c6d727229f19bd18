//! Tests of the model as a whole: every entry point answers bad input with a typed error, and
//! the public types can cross threads.

use crate::test_support::*;

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
fn public_types_are_send_and_sync() {
    fn check<T: Send + Sync>() {}
    check::<SharedGplvm>();
    check::<ModelConfig>();
    check::<TrainOptions>();
    check::<Params>();
    check::<Prediction>();
    check::<Error>();
}
