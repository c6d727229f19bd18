//! Where training starts: the paper's initialisation of the latent points as the mean of the
//! spaces' PCA projections (each scaled to a unit first component and sign-aligned with the
//! input's), plus a seeded Gaussian perturbation.

use faer::dyn_stack::MemStack;
use faer::{Accum, Mat, MatRef, Par};

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

use crate::config::ModelConfig;
use crate::error::{Error, Result};
use crate::kernel::KernelParams;
use crate::model::Space;
use crate::preprocess::{mean_col_var, preprocess};
use crate::simd::clear_upper_simd_state;

/// PCA projection of centred `y` onto its top `q` principal directions (columns beyond the
/// rank of `y` are zero). Eigenvector signs are fixed so that their largest component is
/// positive. Returns the projection and the variance of its first column.
pub(crate) fn pca(y: MatRef<'_, f64>, q: usize) -> Result<(Mat<f64>, f64)> {
    let (n, d) = (y.nrows(), y.ncols());
    // Explicitly sequential: faer's operators and `self_adjoint_eigen` use its global
    // parallelism, i.e. rayon's global pool, which deadlocks in a forked child (see `pool`).
    let mut cov = Mat::zeros(d, d);
    faer::linalg::matmul::matmul(
        cov.as_mut(),
        Accum::Replace,
        y.transpose(),
        y,
        1.0 / n as f64,
        Par::Seq,
    );
    let mut eigenvalues = faer::diag::Diag::<f64>::zeros(d);
    let mut u = Mat::zeros(d, d);
    let params = Default::default();
    let scratch = faer::linalg::evd::self_adjoint_evd_scratch::<f64>(
        d,
        faer::linalg::evd::ComputeEigenvectors::Yes,
        Par::Seq,
        params,
    );
    faer::linalg::evd::self_adjoint_evd(
        cov.as_ref(),
        eigenvalues.as_mut(),
        Some(u.as_mut()),
        Par::Seq,
        MemStack::new(&mut faer::dyn_stack::MemBuffer::new(scratch)),
        params,
    )
    .map_err(|e| Error::InvalidValue {
        what: "PCA initialisation".into(),
        reason: format!("eigen-decomposition failed: {e:?}"),
    })?;
    clear_upper_simd_state();
    let s = eigenvalues.column_vector();
    let k = q.min(d);
    let mut z = Mat::zeros(n, q);
    let mut top = 0.0;
    for c in 0..k {
        let idx = d - 1 - c; // eigenvalues ascending
        if c == 0 {
            top = s[idx].max(0.0);
        }
        let mut big = 0usize;
        for r in 0..d {
            if u[(r, idx)].abs() > u[(big, idx)].abs() {
                big = r;
            }
        }
        let sign = if u[(big, idx)] < 0.0 { -1.0 } else { 1.0 };
        for i in 0..n {
            let mut acc = 0.0;
            for r in 0..d {
                acc += y[(i, r)] * u[(r, idx)];
            }
            z[(i, c)] = sign * acc;
        }
    }
    Ok((z, top))
}

/// The paper's initialisation: mean of the PCA projections of the spaces. Each projection is
/// divided by the standard deviation of its first component (so the spaces weigh equally and
/// X's first column has unit spread) and every column is sign-aligned with the first space's
/// (positive correlation) before averaging.
pub(crate) fn pca_init(spaces: &[Space], q: usize) -> Result<Mat<f64>> {
    let n = spaces[0].data.nrows();
    let mut acc: Mat<f64> = Mat::zeros(n, q);
    let mut count = vec![0usize; q];
    let mut reference: Option<Mat<f64>> = None;
    for s in spaces {
        let (mut z, top) = pca(s.data.as_ref(), q)?;
        if top <= 0.0 {
            continue;
        }
        let inv = 1.0 / top.sqrt();
        for j in 0..q {
            for i in 0..n {
                z[(i, j)] *= inv;
            }
        }
        if let Some(r) = &reference {
            for j in 0..q {
                let dot: f64 = (0..n).map(|i| z[(i, j)] * r[(i, j)]).sum();
                if dot < 0.0 {
                    for i in 0..n {
                        z[(i, j)] = -z[(i, j)];
                    }
                }
            }
        } else {
            reference = Some(z.clone());
        }
        let dk = s.data.ncols().min(q);
        for j in 0..dk {
            count[j] += 1;
            for i in 0..n {
                acc[(i, j)] += z[(i, j)];
            }
        }
    }
    for j in 0..q {
        if count[j] > 0 {
            for i in 0..n {
                acc[(i, j)] /= count[j] as f64;
            }
        }
    }
    Ok(acc)
}

/// The starting latent points: [`pca_init`] plus `init_perturbation` × N(0, 1), drawn column
/// by column from a ChaCha8 generator seeded with the configuration's seed.
pub(crate) fn initial_latent_points(spaces: &[Space], config: &ModelConfig) -> Result<Mat<f64>> {
    let q = config.latent_dim;
    let n = spaces[0].data.nrows();
    let mut x0 = pca_init(spaces, q)?;
    if config.init_perturbation > 0.0 {
        let mut rng = ChaCha8Rng::seed_from_u64(config.seed);
        for j in 0..q {
            for i in 0..n {
                let z: f64 = StandardNormal.sample(&mut rng);
                x0[(i, j)] += config.init_perturbation * z;
            }
        }
    }
    Ok(x0)
}

/// The kernel a space starts from: variance = its mean column variance `v`, every lengthscale
/// 1, noise = `init_noise_fraction` × v.
pub(crate) fn initial_kernel(v: f64, config: &ModelConfig) -> KernelParams {
    KernelParams {
        variance: v,
        lengthscale: vec![1.0; config.latent_dim],
        noise: config.init_noise_fraction * v,
    }
}

impl Space {
    /// A space of the model from raw data: centred (and scaled, see `preprocess`), with its
    /// [`initial_kernel`]; data too far from unit scale is an error.
    pub(crate) fn from_data(
        name: &str,
        raw: MatRef<'_, f64>,
        config: &ModelConfig,
    ) -> Result<Self> {
        let (data, offset, scale) = preprocess(name, raw, config)?;
        let kernel = initial_kernel(mean_col_var(data.as_ref()), config);
        Ok(Space {
            name: name.into(),
            data,
            offset,
            scale,
            kernel,
            columns: None,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
}
