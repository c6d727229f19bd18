//! Objective and gradients against GPy's `GPLVM` (fixture written by
//! `tests/fixtures/make_gpy_fixtures.py`).

use sgplvm_core::{
    BackConstraint, KernelParams, LatentParams, Mat, ModelConfig, Params, SharedGplvm, TrainOptions,
};

fn mat(v: &serde_json::Value) -> Mat<f64> {
    let rows = v.as_array().expect("rows");
    let n = rows.len();
    let c = rows[0].as_array().expect("row").len();
    Mat::from_fn(n, c, |i, j| rows[i][j].as_f64().expect("number"))
}

fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs().max(1e-300)
}

#[test]
fn objective_and_gradients_match_gpy() {
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/fixtures/gpy_fixture.json"
    ))
    .expect("fixture present");
    let fx: serde_json::Value = serde_json::from_str(&text).expect("fixture is JSON");
    let jitter = fx["gpy_jitter"].as_f64().expect("jitter");
    for case in fx["cases"].as_array().expect("cases") {
        let q = case["q"].as_u64().expect("q") as usize;
        let x = mat(&case["x"]);
        let spaces: Vec<(String, Mat<f64>, KernelParams)> = case["spaces"]
            .as_array()
            .expect("spaces")
            .iter()
            .map(|s| {
                let k = KernelParams {
                    variance: s["variance"].as_f64().expect("v"),
                    lengthscale: s["lengthscale"]
                        .as_array()
                        .expect("l")
                        .iter()
                        .map(|v| v.as_f64().expect("l"))
                        .collect(),
                    // GPy factorises K + (noise + 1e-8) I.
                    noise: s["noise"].as_f64().expect("noise") + jitter,
                };
                (
                    s["name"].as_str().expect("name").to_string(),
                    mat(&s["y"]),
                    k,
                )
            })
            .collect();
        let refs: Vec<(&str, sgplvm_core::MatRef<'_, f64>)> = spaces
            .iter()
            .map(|(n, y, _)| (n.as_str(), y.as_ref()))
            .collect();
        let config = ModelConfig::default()
            .with_latent_dim(q)
            .with_back_constraint(BackConstraint::None);
        let options = TrainOptions {
            max_iters: 0,
            map_max_iters: 0,
            ..TrainOptions::default()
        };
        let mut model = SharedGplvm::fit(&config, &refs, "s0", &options, None).expect("fit");
        let params = Params {
            latent: LatentParams::Free { x: x.clone() },
            spaces: spaces
                .iter()
                .map(|(n, _, k)| (n.clone(), k.clone()))
                .collect(),
        };
        model.set_params(&params).expect("set params");
        let (f, g) = model.evaluate().expect("evaluate");
        let want = case["objective"].as_f64().expect("objective");
        assert!(rel(f, want) < 1e-8, "objective {f} vs GPy {want}");
        let LatentParams::Free { x: gx } = &g.latent else {
            panic!("free latent expected")
        };
        let want_x = mat(&case["d_x"]);
        let scale = (0..x.nrows())
            .flat_map(|i| (0..q).map(move |j| (i, j)))
            .fold(0.0f64, |m, (i, j)| m.max(want_x[(i, j)].abs()));
        for i in 0..x.nrows() {
            for j in 0..q {
                assert!(
                    (gx[(i, j)] - want_x[(i, j)]).abs() < 1e-8 * scale,
                    "dX[{i},{j}] {} vs {}",
                    gx[(i, j)],
                    want_x[(i, j)]
                );
            }
        }
        for (s, (name, k)) in case["spaces"]
            .as_array()
            .expect("spaces")
            .iter()
            .zip(&g.spaces)
        {
            assert_eq!(s["name"].as_str(), Some(name.as_str()));
            assert!(
                rel(k.variance, s["d_variance"].as_f64().expect("dv")) < 1e-8,
                "{name} d_variance"
            );
            assert!(
                rel(k.noise, s["d_noise"].as_f64().expect("dn")) < 1e-8,
                "{name} d_noise {} vs {}",
                k.noise,
                s["d_noise"]
            );
            for (a, b) in k
                .lengthscale
                .iter()
                .zip(s["d_lengthscale"].as_array().expect("dl"))
            {
                assert!(
                    rel(*a, b.as_f64().expect("dl")) < 1e-8,
                    "{name} d_lengthscale {a} vs {b}"
                );
            }
        }
    }
}

fn max_abs(m: sgplvm_core::MatRef<'_, f64>) -> f64 {
    (0..m.ncols())
        .flat_map(|j| (0..m.nrows()).map(move |i| m[(i, j)].abs()))
        .fold(0.0, f64::max)
}

fn numbers(v: &serde_json::Value) -> Vec<f64> {
    v.as_array()
        .expect("array")
        .iter()
        .map(|x| x.as_f64().expect("number"))
        .collect()
}

/// Back-constrained models (input and output) against GPy's kernel mapping
/// (`GPy.mappings.Kernel`, X = K_bc W) feeding GPy `GPLVM`s; fixture written by
/// `tests/fixtures/make_gpy_bc_fixtures.py`. Every weight's gradient is compared.
#[test]
fn back_constrained_objective_and_gradients_match_gpy() {
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/fixtures/gpy_bc_fixture.json"
    ))
    .expect("fixture present");
    let fx: serde_json::Value = serde_json::from_str(&text).expect("fixture is JSON");
    let jitter = fx["gpy_jitter"].as_f64().expect("jitter");
    let (mut worst_f, mut worst_x, mut worst_w, mut worst_b, mut worst_k) =
        (0.0f64, 0.0f64, 0.0f64, 0.0f64, 0.0f64);
    for case in fx["cases"].as_array().expect("cases") {
        let q = case["q"].as_u64().expect("q") as usize;
        let bc = match case["back_constraint"].as_str() {
            Some("input") => BackConstraint::Input,
            Some("output") => BackConstraint::Output,
            other => panic!("back constraint {other:?}"),
        };
        let spaces: Vec<(String, Mat<f64>, KernelParams)> = case["spaces"]
            .as_array()
            .expect("spaces")
            .iter()
            .map(|s| {
                let k = KernelParams {
                    variance: s["variance"].as_f64().expect("v"),
                    lengthscale: numbers(&s["lengthscale"]),
                    noise: s["noise"].as_f64().expect("noise") + jitter,
                };
                let name = s["name"].as_str().expect("name").to_string();
                (name, mat(&s["y"]), k)
            })
            .collect();
        let refs: Vec<(&str, sgplvm_core::MatRef<'_, f64>)> = spaces
            .iter()
            .map(|(n, y, _)| (n.as_str(), y.as_ref()))
            .collect();
        let config = ModelConfig::default()
            .with_latent_dim(q)
            .with_back_constraint(bc);
        let options = TrainOptions {
            max_iters: 0,
            map_max_iters: 0,
            ..TrainOptions::default()
        };
        let mut model = SharedGplvm::fit(&config, &refs, "human", &options, None).expect("fit");
        let weights = mat(&case["weights"]);
        let params = Params {
            latent: LatentParams::BackConstrained {
                weights: weights.clone(),
                bandwidth: case["bandwidth"].as_f64().expect("bandwidth"),
            },
            spaces: spaces
                .iter()
                .map(|(n, _, k)| (n.clone(), k.clone()))
                .collect(),
        };
        model.set_params(&params).expect("set params");
        // X = K_bc W as GPy's mapping computes it.
        let want_x = mat(&case["x"]);
        let x = model.latent_points();
        let x_scale = max_abs(want_x.as_ref());
        for i in 0..x.nrows() {
            for j in 0..q {
                worst_x = worst_x.max((x[(i, j)] - want_x[(i, j)]).abs() / x_scale);
            }
        }
        let (f, g) = model.evaluate().expect("evaluate");
        worst_f = worst_f.max(rel(f, case["objective"].as_f64().expect("objective")));
        let LatentParams::BackConstrained {
            weights: gw,
            bandwidth: gb,
        } = &g.latent
        else {
            panic!("back-constrained gradient expected")
        };
        let want_w = mat(&case["d_weights"]);
        let w_scale = max_abs(want_w.as_ref());
        for i in 0..gw.nrows() {
            for j in 0..q {
                worst_w = worst_w.max((gw[(i, j)] - want_w[(i, j)]).abs() / w_scale);
            }
        }
        worst_b = worst_b.max(rel(*gb, case["d_bandwidth"].as_f64().expect("d_bandwidth")));
        for (s, (name, k)) in case["spaces"]
            .as_array()
            .expect("spaces")
            .iter()
            .zip(&g.spaces)
        {
            assert_eq!(s["name"].as_str(), Some(name.as_str()));
            worst_k = worst_k.max(rel(k.variance, s["d_variance"].as_f64().expect("dv")));
            worst_k = worst_k.max(rel(k.noise, s["d_noise"].as_f64().expect("dn")));
            for (a, b) in k.lengthscale.iter().zip(numbers(&s["d_lengthscale"])) {
                worst_k = worst_k.max(rel(*a, b));
            }
        }
    }
    // Measured: objective 1.6e-15, X 6.0e-16, dW 2.3e-14 (relative to the largest), d bandwidth
    // 1.1e-13, kernel gradients 8.5e-14; tolerances about 10× these.
    assert!(worst_f < 2e-14, "objective off by {worst_f:e}");
    assert!(worst_x < 1e-14, "X off by {worst_x:e}");
    assert!(worst_w < 3e-13, "dW off by {worst_w:e}");
    assert!(worst_b < 1e-12, "d bandwidth off by {worst_b:e}");
    assert!(worst_k < 1e-12, "kernel gradients off by {worst_k:e}");
}
