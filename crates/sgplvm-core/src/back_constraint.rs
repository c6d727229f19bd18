//! Back constraints: latent points as a kernel mapping of the data, `X = K_bc W` with
//! `K_bc[i, j] = exp(−|d_i − d_j|² / (2 bw²))` over the constrained data D (the human's for
//! input back constraints, the paper's choice; the robots' for output ones). The bandwidth is
//! the median pairwise distance of D (not trained); W starts at `(K_bc + λI)⁻¹ X_init` and
//! is trained through `∂L/∂W = K_bcᵀ ∂L/∂X`.

use std::sync::{Arc, OnceLock};

use faer::dyn_stack::MemStack;
use faer::linalg::cholesky::llt;
use faer::{Accum, Mat, MatMut, MatRef, Par};

use crate::config::BackConstraint;
use crate::error::Result;
use crate::kernel::{map_sqdist_lower, rbf_lower, row_major, KernelParams};
use crate::likelihood::cholesky_with_jitter;
use crate::model::{Latent, Space};
use crate::pool::par_for;

/// The back-constrained latent representation at the start of training: the constrained data
/// D (the input space for [`BackConstraint::Input`], the output spaces side by side for
/// [`BackConstraint::Output`]), its median-distance bandwidth and `W = (K_bc + λI)⁻¹ X_init`.
/// `spaces` are preprocessed, input first.
pub(crate) fn initial_latent(
    bc: BackConstraint,
    spaces: &[Space],
    x_init: MatRef<'_, f64>,
    ridge: f64,
) -> Result<Latent> {
    let data = match bc {
        BackConstraint::None => {
            return Ok(Latent::Free {
                x: x_init.to_owned(),
            })
        }
        BackConstraint::Input => spaces[0].data.clone(),
        BackConstraint::Output => side_by_side(&spaces[1..]),
    };
    let bandwidth = median_distance(data.as_ref());
    let kbc = bc_kernel(data.as_ref(), bandwidth);
    let weights = ridge_solve(kbc.as_ref(), x_init, ridge)?;
    Ok(Latent::Back {
        weights,
        bandwidth,
        data,
    })
}

/// The data of `spaces` as one matrix, their columns side by side.
fn side_by_side(spaces: &[Space]) -> Mat<f64> {
    let n = spaces[0].data.nrows();
    let cols: usize = spaces.iter().map(|s| s.data.ncols()).sum();
    let mut d = Mat::zeros(n, cols);
    let mut c0 = 0;
    for s in spaces {
        for j in 0..s.data.ncols() {
            for i in 0..n {
                d[(i, c0 + j)] = s.data[(i, j)];
            }
        }
        c0 += s.data.ncols();
    }
    d
}

/// The latent points `X = K_bc W`.
pub(crate) fn latent_points(kbc: MatRef<'_, f64>, weights: MatRef<'_, f64>, par: Par) -> Mat<f64> {
    let mut x = Mat::zeros(weights.nrows(), weights.ncols());
    faer::linalg::matmul::matmul(x.as_mut(), Accum::Replace, kbc, weights, 1.0, par);
    x
}

/// The chain rule to the weights: `∂L/∂W = K_bcᵀ ∂L/∂X`, written to `out` (N×Q).
pub(crate) fn weights_gradient(
    kbc: MatRef<'_, f64>,
    latent_grad: MatRef<'_, f64>,
    out: MatMut<'_, f64>,
    par: Par,
) {
    faer::linalg::matmul::matmul(out, Accum::Replace, kbc.transpose(), latent_grad, 1.0, par);
}

/// `∂L/∂bw = Σ_ij (∂L/∂X Wᵀ)_ij K_ij d²_ij / bw³ = Σ_it (∂L/∂X)_it ((K∘D²) W)_it / bw³`,
/// with `K_ij = exp(−d²_ij / 2bw²)` the back-constraint kernel, `d_ij` the distance between
/// rows i and j of the constrained data and `K∘D²` (symmetric, `kd2`) from [`BcCache`].
/// Reported with the gradient; the bandwidth itself is not trained.
pub(crate) fn bandwidth_gradient(
    latent_grad: MatRef<'_, f64>,
    weights: MatRef<'_, f64>,
    kd2: MatRef<'_, f64>,
    bandwidth: f64,
) -> f64 {
    let n = weights.nrows();
    let kw = latent_points(kd2, weights, par_for(n));
    let mut db = 0.0;
    for t in 0..weights.ncols() {
        for i in 0..n {
            db += latent_grad[(i, t)] * kw[(i, t)];
        }
    }
    db / bandwidth.powi(3)
}

/// The back-constraint matrices of a model, built on first use and kept (they depend only on
/// the constrained data and the bandwidth): `K_bc` for the latent points and their gradient,
/// `K_bc ∘ D²` for the bandwidth's gradient. A model's clone shares them. Each is kept with
/// the bandwidth it was built for: asked for another one (a bandwidth changed without
/// resetting the cache), it is computed afresh and not kept. The data must not change.
#[derive(Clone, Debug, Default)]
pub(crate) struct BcCache {
    kbc: OnceLock<(u64, Arc<Mat<f64>>)>,
    kd2: OnceLock<(u64, Arc<Mat<f64>>)>,
}

/// The kept matrix if it was built for `bandwidth`, else `build()` (kept if nothing was).
fn cached(
    cell: &OnceLock<(u64, Arc<Mat<f64>>)>,
    bandwidth: f64,
    build: impl FnOnce() -> Mat<f64>,
) -> Arc<Mat<f64>> {
    let bits = bandwidth.to_bits();
    match cell.get() {
        Some((b, m)) if *b == bits => Arc::clone(m),
        Some(_) => Arc::new(build()),
        None => Arc::clone(&cell.get_or_init(|| (bits, Arc::new(build()))).1),
    }
}

impl BcCache {
    /// `K_bc` of `data` at `bandwidth`.
    pub(crate) fn kbc(&self, data: MatRef<'_, f64>, bandwidth: f64) -> Arc<Mat<f64>> {
        cached(&self.kbc, bandwidth, || bc_kernel(data, bandwidth))
    }

    /// `K_bc ∘ D²` (full, symmetric), see [`bandwidth_gradient`].
    pub(crate) fn kd2(&self, data: MatRef<'_, f64>, bandwidth: f64) -> Arc<Mat<f64>> {
        let kbc = self.kbc(data, bandwidth);
        cached(&self.kd2, bandwidth, || {
            let (n, c) = (data.nrows(), data.ncols());
            let mut d2 = Mat::zeros(n, n);
            map_sqdist_lower(
                &row_major(data),
                c,
                &vec![1.0; c],
                &mut d2,
                #[inline(always)]
                |v| v,
            );
            for j in 0..n {
                for i in j..n {
                    d2[(i, j)] *= kbc[(i, j)];
                }
                for i in 0..j {
                    d2[(i, j)] = d2[(j, i)];
                }
            }
            d2
        })
    }
}

/// Median of the pairwise Euclidean distances between the rows of `m` (zero distances
/// excluded; 1 when every row is the same). The back-constraint bandwidth rule.
pub(crate) fn median_distance(m: MatRef<'_, f64>) -> f64 {
    let n = m.nrows();
    let rows = row_major(m);
    let c = m.ncols();
    let mut d = Vec::with_capacity(n * n.saturating_sub(1) / 2);
    for i in 0..n {
        for j in 0..i {
            let mut s = 0.0;
            for t in 0..c {
                let v = rows[i * c + t] - rows[j * c + t];
                s += v * v;
            }
            if s > 0.0 {
                d.push(s.sqrt());
            }
        }
    }
    if d.is_empty() {
        return 1.0;
    }
    let mid = d.len() / 2;
    let (_, m, _) = d.select_nth_unstable_by(mid, |a, b| a.total_cmp(b));
    *m
}

/// Back-constraint kernel matrix exp(-|a_i - a_j|² / (2 bw²)) (full, symmetric).
pub(crate) fn bc_kernel(data: MatRef<'_, f64>, bandwidth: f64) -> Mat<f64> {
    let n = data.nrows();
    let k = KernelParams {
        variance: 1.0,
        lengthscale: vec![bandwidth; data.ncols()],
        noise: 0.0,
    };
    let mut m = Mat::zeros(n, n);
    rbf_lower(&row_major(data), data.ncols(), &k, &mut m, Par::Seq);
    for j in 0..n {
        for i in 0..j {
            m[(i, j)] = m[(j, i)];
        }
    }
    m
}

/// Solves (A + ridge I) X = B for symmetric positive semi-definite A.
pub(crate) fn ridge_solve(a: MatRef<'_, f64>, b: MatRef<'_, f64>, ridge: f64) -> Result<Mat<f64>> {
    let n = a.nrows();
    let par = par_for(n);
    let mut l = Mat::zeros(n, n);
    cholesky_with_jitter(a, ridge, l.as_mut(), par).map_err(|e| e.in_space("back constraint"))?;
    let mut x = b.to_owned();
    llt::solve::solve_in_place(l.as_ref(), x.as_mut(), par, MemStack::new(&mut []));
    Ok(x)
}

#[cfg(test)]
mod tests {
    use crate::preprocess::preprocess;
    use crate::test_support::*;

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
        let centred = preprocess("human", h.as_ref(), m.config())
            .expect("in range")
            .0;
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
}
