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

/// Centres (and optionally scales) a data matrix, returning (data, offset, scale).
pub(crate) fn preprocess(
    m: MatRef<'_, f64>,
    config: &ModelConfig,
) -> (Mat<f64>, Vec<f64>, Vec<f64>) {
    let (n, d) = (m.nrows(), m.ncols());
    let offset: Vec<f64> = (0..d)
        .map(|j| (0..n).map(|i| m[(i, j)]).sum::<f64>() / n as f64)
        .collect();
    let var: Vec<f64> = (0..d)
        .map(|j| (0..n).map(|i| (m[(i, j)] - offset[j]).powi(2)).sum::<f64>() / n as f64)
        .collect();
    let scale: Vec<f64> = if !config.scale {
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
    let data = Mat::from_fn(n, d, |i, j| (m[(i, j)] - offset[j]) / scale[j]);
    (data, offset, scale)
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
