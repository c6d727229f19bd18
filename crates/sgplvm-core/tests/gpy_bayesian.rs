//! The Bayesian GP-LVM's bound and every gradient against GPy's `BayesianGPLVM` (one space) and
//! `MRD` (two), at the same q(X), inducing inputs and kernels (fixture written by
//! `tests/fixtures/make_gpy_mrd_fixture.py`; `crates/sgplvm-py/tests/test_bayesian.py` compares
//! with a live GPy).

use sgplvm_core::{bayesian_bound, Jitter, KernelParams, Mat, MatRef};

fn mat(v: &serde_json::Value) -> Mat<f64> {
    let rows = v.as_array().expect("rows");
    let c = rows[0].as_array().expect("row").len();
    Mat::from_fn(rows.len(), c, |i, j| rows[i][j].as_f64().expect("number"))
}

fn numbers(v: &serde_json::Value) -> Vec<f64> {
    v.as_array()
        .expect("array")
        .iter()
        .map(|x| x.as_f64().expect("number"))
        .collect()
}

/// Largest |a − b| relative to the largest |b| of the set (a gradient's small entries are
/// judged on the scale of its large ones).
fn worst(a: &[f64], b: &[f64]) -> f64 {
    let scale = b.iter().fold(0.0f64, |m, v| m.max(v.abs())).max(1e-300);
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs() / scale)
        .fold(0.0, f64::max)
}

fn flat(m: &Mat<f64>) -> Vec<f64> {
    (0..m.nrows())
        .flat_map(|i| (0..m.ncols()).map(move |j| (i, j)))
        .map(|(i, j)| m[(i, j)])
        .collect()
}

#[test]
fn bound_and_gradients_match_gpy_bayesian_gplvm_and_mrd() {
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/fixtures/gpy_mrd_fixture.json"
    ))
    .expect("fixture present");
    let fx: serde_json::Value = serde_json::from_str(&text).expect("fixture is JSON");
    let jitter = Jitter::Absolute(fx["gpy_jitter"].as_f64().expect("jitter"));
    let mut models = Vec::new();
    for case in fx["cases"].as_array().expect("cases") {
        let ys: Vec<Mat<f64>> = case["ys"].as_array().expect("ys").iter().map(mat).collect();
        let kernels: Vec<KernelParams> = case["kernels"]
            .as_array()
            .expect("kernels")
            .iter()
            .map(|k| KernelParams {
                variance: k["variance"].as_f64().expect("variance"),
                lengthscale: numbers(&k["lengthscale"]),
                noise: k["noise"].as_f64().expect("noise"),
            })
            .collect();
        let refs: Vec<MatRef<'_, f64>> = ys.iter().map(|y| y.as_ref()).collect();
        let (mean, var, z) = (
            mat(&case["mean"]),
            mat(&case["variance"]),
            mat(&case["inducing"]),
        );
        let b = bayesian_bound(
            mean.as_ref(),
            var.as_ref(),
            z.as_ref(),
            &refs,
            &kernels,
            jitter,
        )
        .expect("bound");
        let gpy = case["objective"].as_f64().expect("objective");
        let model = case["model"].as_str().expect("model");
        let mut report = vec![("objective", (b.value - gpy).abs() / gpy.abs())];
        report.push((
            "d_mean",
            worst(&flat(&b.d_mean), &flat(&mat(&case["d_mean"]))),
        ));
        report.push((
            "d_variance",
            worst(&flat(&b.d_variance), &flat(&mat(&case["d_variance"]))),
        ));
        report.push((
            "d_inducing",
            worst(&flat(&b.d_inducing), &flat(&mat(&case["d_inducing"]))),
        ));
        for (ours, theirs) in b
            .spaces
            .iter()
            .zip(case["d_spaces"].as_array().expect("spaces"))
        {
            let mut a = vec![ours.variance, ours.noise];
            a.extend(&ours.lengthscale);
            let mut g = vec![
                theirs["variance"].as_f64().expect("v"),
                theirs["noise"].as_f64().expect("n"),
            ];
            g.extend(numbers(&theirs["lengthscale"]));
            report.push(("kernel", worst(&a, &g)));
        }
        for (what, err) in &report {
            assert!(
                *err <= 1e-8,
                "{model}: {what} differs from GPy by {err:e} (relative)"
            );
        }
        eprintln!("{model}: {report:?}");
        models.push(model.to_string());
        // Not an accident of the numbers: other inducing inputs give another bound.
        let moved = Mat::from_fn(z.nrows(), z.ncols(), |i, j| z[(i, j)] + 0.1);
        let other = bayesian_bound(
            mean.as_ref(),
            var.as_ref(),
            moved.as_ref(),
            &refs,
            &kernels,
            jitter,
        )
        .expect("bound");
        assert!((other.value - gpy).abs() > 1e-4 * gpy.abs());
    }
    assert!(models.iter().any(|m| m == "BayesianGPLVM") && models.iter().any(|m| m == "MRD"));
}
