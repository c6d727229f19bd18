//! Checks and preprocessing of observation spaces: every value finite, no empty space, and
//! every space centred (optionally scaled) before the model sees it: `Y ← (Y − mean) / scale`,
//! with the offsets and scales kept to undo it in prediction.

use faer::{Mat, MatRef};

use crate::config::{ModelConfig, ScaleMode};
use crate::error::{Error, Result};

pub(crate) fn check_finite(name: &str, m: MatRef<'_, f64>) -> Result<()> {
    for j in 0..m.ncols() {
        for i in 0..m.nrows() {
            let v = m[(i, j)];
            if !v.is_finite() {
                return Err(Error::NonFinite {
                    space: name.into(),
                    row: i,
                    col: j,
                    value: v,
                });
            }
        }
    }
    Ok(())
}

pub(crate) fn check_nonempty(name: &str, m: MatRef<'_, f64>) -> Result<()> {
    if m.nrows() == 0 || m.ncols() == 0 {
        return Err(Error::EmptySpace {
            space: name.into(),
            rows: m.nrows(),
            cols: m.ncols(),
        });
    }
    Ok(())
}

/// Spaces whose scale — the root mean square of their values after centring — lies outside
/// `[STANDARD_SCALES.0, STANDARD_SCALES.1]` are divided by the power of two nearest that scale
/// (exact in floating point), so that training sees values of order 1; the factor is kept in
/// the space's scales and undone in prediction. Spaces inside the range are left exactly as
/// they are.
pub const STANDARD_SCALES: (f64, f64) = (1e-6, 1e6);

/// The scales a space may have (see [`STANDARD_SCALES`]): beyond them squared errors in the
/// user's units (the validation error, for one) leave floating point, and such data is refused
/// with [`Error::DataScale`].
pub const ACCEPTED_SCALES: (f64, f64) = (1e-153, 1e153);

/// `2^k` for `|k| ≤ 1022`.
fn pow2(k: i32) -> f64 {
    f64::from_bits(((k + 1023) as u64) << 52)
}

/// The exponent `e` of a positive normal `x = f · 2^e`, `f ∈ [0.5, 1)`.
fn exponent(x: f64) -> i32 {
    ((x.to_bits() >> 52) & 0x7ff) as i32 - 1022
}

/// The power of two to divide the centred data `c` of space `name` by: 1 when its scale (root
/// mean square) is inside [`STANDARD_SCALES`] or it is constant, the power of two nearest the
/// scale when outside; an error beyond [`ACCEPTED_SCALES`] or when centring overflowed. The
/// scale is computed without overflow or underflow (on `c` divided by a power of two near its
/// largest value).
fn standardising_unit(name: &str, c: &Mat<f64>) -> Result<f64> {
    let refuse = |scale: f64| Error::DataScale {
        space: name.into(),
        scale,
        min: ACCEPTED_SCALES.0,
        max: ACCEPTED_SCALES.1,
    };
    let mut largest = 0.0f64;
    for j in 0..c.ncols() {
        for &v in c.col_as_slice(j) {
            if !v.is_finite() {
                return Err(refuse(f64::INFINITY));
            }
            largest = largest.max(v.abs());
        }
    }
    if largest == 0.0 {
        return Ok(1.0);
    }
    if largest < f64::MIN_POSITIVE {
        return Err(refuse(largest));
    }
    let e = exponent(largest);
    let pre = pow2(-e);
    let mut sum = 0.0;
    for j in 0..c.ncols() {
        for &v in c.col_as_slice(j) {
            sum += (v * pre) * (v * pre);
        }
    }
    // In (0, 1]: the mean of squares of values at most 1 in size, the largest at least ½.
    let rms_scaled = (sum / (c.nrows() * c.ncols()) as f64).sqrt();
    let log2_rms = rms_scaled.log2() + e as f64;
    if log2_rms < ACCEPTED_SCALES.0.log2() || log2_rms > ACCEPTED_SCALES.1.log2() {
        return Err(refuse(2f64.powf(log2_rms)));
    }
    if log2_rms >= STANDARD_SCALES.0.log2() && log2_rms <= STANDARD_SCALES.1.log2() {
        return Ok(1.0);
    }
    Ok(pow2(log2_rms.round() as i32))
}

/// `m` divided by the power of two that brings its centred values to unit scale (see
/// [`STANDARD_SCALES`]; 1, and `m` unchanged, inside them), and that power; refused like
/// [`preprocess`] beyond [`ACCEPTED_SCALES`]. `m` itself is not centred (for data whose
/// offset matters, such as a regression's inputs).
pub(crate) fn unit_scaled(name: &str, m: MatRef<'_, f64>) -> Result<(Mat<f64>, f64)> {
    let (n, d) = (m.nrows(), m.ncols());
    let mean: Vec<f64> = (0..d)
        .map(|j| (0..n).map(|i| m[(i, j)]).sum::<f64>() / n as f64)
        .collect();
    let centred = Mat::from_fn(n, d, |i, j| m[(i, j)] - mean[j]);
    let unit = standardising_unit(name, &centred)?;
    let scaled = Mat::from_fn(n, d, |i, j| m[(i, j)] / unit);
    check_finite(name, scaled.as_ref())?;
    Ok((scaled, unit))
}

/// Centres (and optionally scales) the data matrix of space `name`, returning (data, offset,
/// scale): `data = (m − offset) / scale`. A space far from unit scale is also divided by a
/// power of two (see [`STANDARD_SCALES`]; folded into `scale`); one beyond
/// [`ACCEPTED_SCALES`] is refused.
pub(crate) fn preprocess(
    name: &str,
    m: MatRef<'_, f64>,
    config: &ModelConfig,
) -> Result<(Mat<f64>, Vec<f64>, Vec<f64>)> {
    let (n, d) = (m.nrows(), m.ncols());
    let offset: Vec<f64> = (0..d)
        .map(|j| (0..n).map(|i| m[(i, j)]).sum::<f64>() / n as f64)
        .collect();
    let mut centred = Mat::from_fn(n, d, |i, j| m[(i, j)] - offset[j]);
    let unit = standardising_unit(name, &centred)?;
    if unit != 1.0 {
        for j in 0..d {
            centred
                .col_as_slice_mut(j)
                .iter_mut()
                .for_each(|v| *v /= unit);
        }
    }
    let var: Vec<f64> = (0..d)
        .map(|j| (0..n).map(|i| centred[(i, j)].powi(2)).sum::<f64>() / n as f64)
        .collect();
    let mut scale: Vec<f64> = if !config.scale {
        vec![1.0; d]
    } else {
        match config.scale_mode {
            ScaleMode::PerColumn => var
                .iter()
                .map(|&v| if v > 0.0 { v.sqrt() } else { 1.0 })
                .collect(),
            ScaleMode::PerSpace => {
                let mv = var.iter().sum::<f64>() / d as f64;
                vec![if mv > 0.0 { mv.sqrt() } else { 1.0 }; d]
            }
        }
    };
    let data = Mat::from_fn(n, d, |i, j| centred[(i, j)] / scale[j]);
    scale.iter_mut().for_each(|s| *s *= unit);
    Ok((data, offset, scale))
}

pub(crate) fn mean_col_var(m: MatRef<'_, f64>) -> f64 {
    let (n, d) = (m.nrows(), m.ncols());
    let mut s = 0.0;
    for j in 0..d {
        let mu = (0..n).map(|i| m[(i, j)]).sum::<f64>() / n as f64;
        s += (0..n).map(|i| (m[(i, j)] - mu).powi(2)).sum::<f64>() / n as f64;
    }
    let v = s / d.max(1) as f64;
    if v > 1e-12 && v.is_finite() {
        v
    } else {
        1.0
    }
}

pub(crate) fn check_shape(what: &str, m: MatRef<'_, f64>, n: usize, q: usize) -> Result<()> {
    if m.nrows() != n {
        return Err(Error::DimensionMismatch {
            what: format!("{what} rows"),
            expected: n,
            found: m.nrows(),
        });
    }
    if m.ncols() != q {
        return Err(Error::DimensionMismatch {
            what: format!("{what} columns"),
            expected: q,
            found: m.ncols(),
        });
    }
    check_finite(what, m)
}

/// Checks the spaces given to a fit — unique names, `input` among them, at least one output,
/// every matrix non-empty, finite and of the same number of rows, `1 ≤ latent_dim < N` — and
/// returns their order in the model: the input first, then the outputs as given.
pub(crate) fn checked_order(
    spaces: &[(&str, MatRef<'_, f64>)],
    input: &str,
    latent_dim: usize,
) -> Result<Vec<usize>> {
    let names: Vec<String> = spaces.iter().map(|(n, _)| n.to_string()).collect();
    for (i, n) in names.iter().enumerate() {
        if names[..i].contains(n) {
            return Err(Error::DuplicateSpace { name: n.clone() });
        }
    }
    let Some(ii) = names.iter().position(|n| n == input) else {
        return Err(Error::UnknownSpace {
            name: input.into(),
            known: names,
        });
    };
    if spaces.len() < 2 {
        return Err(Error::NoOutputSpace);
    }
    let n = spaces[ii].1.nrows();
    for (name, m) in spaces {
        check_nonempty(name, *m)?;
        if m.nrows() != n {
            return Err(Error::RowCountMismatch {
                space: name.to_string(),
                expected: n,
                found: m.nrows(),
            });
        }
        check_finite(name, *m)?;
    }
    if latent_dim == 0 || latent_dim >= n {
        return Err(Error::InvalidLatentDim { latent_dim, n });
    }
    let mut order = vec![ii];
    order.extend((0..spaces.len()).filter(|&i| i != ii));
    Ok(order)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_support::*;
    use crate::validation::Validation;

    /// Data ×2^±500 (≈ 3·10^∓151) trains exactly like the same data at unit scale: the same
    /// parameters bit for bit and predictions in the user's units, exactly 2^±500 times
    /// those at unit scale — through `fit`, `fit_validated` and `transfer`.
    #[test]
    fn data_far_from_unit_scale_is_standardised_exactly() {
        let (h, r1, r2, _) = demo(36, 11);
        let (h, r1, r2) = (unit_scale(&h), unit_scale(&r1), unit_scale(&r2));
        let config = ModelConfig::default().with_latent_dim(2);
        let validation = Validation::new((0..36).filter(|i| i % 4 == 1).collect());
        let train = |f: f64| {
            let (hf, rf, r2f) = (times(&h, f), times(&r1, f), times(&r2, f));
            let spaces = [("human", hf.as_ref()), ("walkman", rf.as_ref())];
            let plain = SharedGplvm::fit(&config, &spaces, "human", &quick(40), None).expect("fit");
            let chosen = SharedGplvm::fit_validated(
                &config,
                &spaces,
                "human",
                &quick(40),
                &validation,
                None,
            )
            .expect("fit_validated");
            let moved = plain
                .transfer("coman", r2f.as_ref(), &quick(20), None)
                .expect("transfer");
            (plain, chosen, moved, hf)
        };
        let (unit, unit_chosen, unit_moved, h1) = train(1.0);
        assert_eq!(unit.normalisation("human").expect("space").1, &[1.0; 6]);
        for f in [pow2(-500), pow2(500)] {
            let (m, chosen, moved, hf) = train(f);
            assert_eq!(m.params(), unit.params(), "×{f:e}");
            assert_eq!(moved.params(), unit_moved.params(), "×{f:e}");
            let s = chosen.selection().expect("selection");
            let s1 = unit_chosen.selection().expect("selection");
            assert_eq!(s.best_iteration, s1.best_iteration, "×{f:e}");
            assert_eq!(m.normalisation("walkman").expect("space").1, &[f; 4]);
            for (model, reference, robot) in [
                (&m, &unit, "walkman"),
                (&chosen, &unit_chosen, "walkman"),
                (&moved, &unit_moved, "coman"),
            ] {
                let p = model.predict(hf.as_ref(), robot, true).expect("predict");
                let q = reference
                    .predict(h1.as_ref(), robot, true)
                    .expect("predict");
                assert_eq!(p.mean, times(&q.mean, f), "{robot} ×{f:e}");
                let (v, w) = (p.variance.expect("v"), q.variance.expect("v"));
                assert_eq!(v, times(&w, f * f), "{robot} ×{f:e}");
            }
            // A model file keeps the scale: the loaded model predicts the same.
            let back = SharedGplvm::from_bytes(&m.to_bytes()).expect("load");
            assert_eq!(
                back.predict(hf.as_ref(), "walkman", false).expect("p"),
                m.predict(hf.as_ref(), "walkman", false).expect("p")
            );
        }
    }

    #[test]
    fn data_beyond_the_accepted_scales_is_refused_naming_the_space() {
        let (h, r1, _, _) = demo(20, 3);
        let config = ModelConfig::default().with_latent_dim(2);
        let mut huge = r1.clone();
        huge[(0, 0)] = 1e308;
        huge[(1, 0)] = -1e308;
        for (robot, expected) in [
            (times(&r1, 1e-160), "e-161 (root mean square"),
            (times(&r1, 1e160), "e159 (root mean square"),
            (huge, "scale of inf"),
        ] {
            let e = SharedGplvm::fit(
                &config,
                &[("human", h.as_ref()), ("walkman", robot.as_ref())],
                "human",
                &quick(5),
                None,
            )
            .expect_err("refused");
            let text = e.to_string();
            assert!(matches!(e, Error::DataScale { .. }), "{e:?}");
            assert!(
                text.starts_with("space 'walkman': its values vary on a scale of")
                    && text.contains(expected)
                    && text.contains("expected a scale between 1e-153 and 1e153"),
                "{text}"
            );
            assert!(!text.contains('\n'));
        }
        // The same check guards a transfer's new robot.
        let m = fit(BackConstraint::Input, 20, 3, 0);
        let e = m
            .transfer("coman", times(&r1, 1e200).as_ref(), &quick(3), None)
            .expect_err("refused")
            .to_string();
        assert!(e.starts_with("space 'coman': its values vary"), "{e}");
        // A constant space is not a scale problem.
        let flat = Mat::from_fn(20, 2, |_, _| 1e-200);
        assert_eq!(
            standardising_unit("flat", &times(&flat, 0.0)).expect("constant"),
            1.0
        );
    }
}
