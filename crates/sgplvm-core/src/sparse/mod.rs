//! The sparse shared GP-LVM: per space Titsias' collapsed variational bound with inducing
//! inputs Z (M×Q) shared by all spaces (see `likelihood`), latent points as point estimates,
//! for trainings on every frame of long demonstrations in O(N M²) time and O(N M) memory.
//!
//! Switched on by [`crate::ModelConfig::inducing`]; with [`crate::ModelConfig::bayesian`] the
//! latent points get a Gaussian posterior q(X) and the bound is MRD's (`bayesian`, `psi`). Where the exact model would form N×N
//! matrices the sparse one does not:
//! - **Inducing inputs** start at the initial latent points of M frames spread evenly over
//!   the training frames ([`spread`]) and are trained with everything else unless
//!   [`crate::ModelConfig::fixed_inducing`].
//! - **Input back constraints** use M_c = M centres, the human frames at the same spread
//!   indices: `X = K_bc(H, C) W`, W M×Q, the bandwidth the median distance between centres,
//!   `W = (K_bc(C, C) + λI)⁻¹ X_init[C]`. With C = every frame this is the exact model's
//!   parametrisation.
//! - **Free latent points**: the human → latent GP regression is fitted on at most
//!   [`MAP_FRAMES`] spread frames.
//! - **Transfer** freezes X, Z, W and the human kernel; only the new robot's kernel moves.
//! - **Prediction**: mean `k(x, Z) w` with `w = L_m⁻ᵀ β / σ` (M×D), O(M(Q + D)) per frame;
//!   variance `α² − k*ᵀ (K_mm⁻¹ − (K_mm + σ⁻² K_mn K_nm)⁻¹) k*` (M×M precomputed).

pub(crate) mod bayesian;
pub(crate) mod likelihood;
pub(crate) mod objective;
pub(crate) mod predict;
pub(crate) mod psi;

use faer::{Mat, MatRef};

use crate::back_constraint::{bc_kernel, median_distance, ridge_solve};
use crate::config::{BackConstraint, ModelConfig};
use crate::error::{Error, Result};
use crate::kernel::{row_major, KernelParams};
use crate::model::{Latent, SharedGplvm, Space};

/// Frames on which the input map of a sparse model with free latent points is fitted (a GP
/// regression, O(F³)).
pub(crate) const MAP_FRAMES: usize = 1000;

/// Where every variance of the Bayesian model's q(X) starts (GPy's `BayesianGPLVM` draws them
/// from U(0, 0.1), `MRD` from U(0.1, 0.2); a constant keeps the start free of the seed).
pub(crate) const INITIAL_LATENT_VARIANCE: f64 = 0.1;

/// State of the sparse model: the inducing inputs and the prediction caches.
#[derive(Clone, Debug)]
pub(crate) struct SparseState {
    /// Inducing inputs Z (M×Q).
    pub z: Mat<f64>,
    /// Z row-major (derived).
    pub z_rows: Vec<f64>,
    /// The variances S (N×Q) of q(X) of the Bayesian model (`bayesian`); `None`: point latent
    /// positions.
    pub latent_var: Option<Mat<f64>>,
    /// S row-major (derived; empty without S).
    pub var_rows: Vec<f64>,
    /// Per space, its prediction cache (derived by `rebuild`).
    pub caches: Vec<predict::SparseCache>,
    /// Evaluation buffers kept between objectives built on this model (`evaluate` after
    /// `set_params` builds a new one each time); a clone starts without.
    pub work: SparseWorkspace,
}

/// Evaluation buffers of a sparse model, one per space, kept between objectives.
#[derive(Default)]
pub(crate) struct SparseWorkspace(std::sync::Mutex<Vec<likelihood::SparseWork>>);

impl SparseWorkspace {
    /// `spaces` buffers: the kept ones when there are as many, else new (empty) ones.
    pub(crate) fn take(&self, spaces: usize) -> Vec<likelihood::SparseWork> {
        let kept = std::mem::take(&mut *crate::pool::lock(&self.0));
        if kept.len() == spaces {
            kept
        } else {
            (0..spaces)
                .map(|_| likelihood::SparseWork::default())
                .collect()
        }
    }

    /// Keeps `works` for the next objective.
    pub(crate) fn put(&self, works: Vec<likelihood::SparseWork>) {
        *crate::pool::lock(&self.0) = works;
    }
}

impl Clone for SparseWorkspace {
    fn clone(&self) -> Self {
        Self::default()
    }
}

impl std::fmt::Debug for SparseWorkspace {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("SparseWorkspace")
    }
}

impl SparseState {
    /// The state for inducing inputs `z`, caches empty.
    pub(crate) fn new(z: Mat<f64>) -> Self {
        let z_rows = row_major(z.as_ref());
        Self {
            z,
            z_rows,
            latent_var: None,
            var_rows: Vec::new(),
            caches: Vec::new(),
            work: SparseWorkspace::default(),
        }
    }

    /// The state with the variances `s` (N×Q) of q(X): the Bayesian model's.
    pub(crate) fn with_latent_var(mut self, s: Option<Mat<f64>>) -> Self {
        self.var_rows = s.as_ref().map_or_else(Vec::new, |s| row_major(s.as_ref()));
        self.latent_var = s;
        self
    }

    /// Number of inducing inputs M.
    pub(crate) fn m(&self) -> usize {
        self.z.nrows()
    }
}

/// `k` frame indices spread evenly over `0..n`: the middle of each of `k` equal segments.
pub(crate) fn spread(n: usize, k: usize) -> Vec<usize> {
    let k = k.min(n);
    (0..k).map(|i| ((2 * i + 1) * n) / (2 * k)).collect()
}

/// The rows `frames` of `m`.
pub(crate) fn rows(m: MatRef<'_, f64>, frames: &[usize]) -> Mat<f64> {
    Mat::from_fn(frames.len(), m.ncols(), |i, j| m[(frames[i], j)])
}

/// `K_bc(C, D)` (M_c×N): the back-constraint kernel between centres C and data rows D.
pub(crate) fn bc_cross(
    data: MatRef<'_, f64>,
    centres: MatRef<'_, f64>,
    bandwidth: f64,
) -> Mat<f64> {
    let k = KernelParams {
        variance: 1.0,
        lengthscale: vec![bandwidth; data.ncols()],
        noise: 0.0,
    };
    likelihood::cross_kernel(
        &row_major(centres),
        &row_major(data),
        data.ncols(),
        &k,
        centres.nrows(),
        data.nrows(),
    )
}

impl SharedGplvm {
    /// The sparse model [`SharedGplvm::fit`] starts from, for preprocessed spaces `sp` (input
    /// first), initial latent points `x0` and `m` inducing inputs.
    pub(crate) fn initial_sparse(
        config: &ModelConfig,
        sp: Vec<Space>,
        x0: Mat<f64>,
        m: usize,
    ) -> Result<Self> {
        let n = sp[0].data.nrows();
        if m > n {
            return Err(Error::InvalidValue {
                what: "inducing".into(),
                reason: format!(
                    "{m} inducing inputs for {n} training frames; expected at most {n}"
                ),
            });
        }
        let frames = spread(n, m);
        let latent = match config.back_constraint {
            BackConstraint::None => Latent::Free { x: x0.clone() },
            BackConstraint::Input => {
                let c = rows(sp[0].data.as_ref(), &frames);
                let bandwidth = median_distance(c.as_ref());
                let kcc = bc_kernel(c.as_ref(), bandwidth);
                let weights = ridge_solve(
                    kcc.as_ref(),
                    rows(x0.as_ref(), &frames).as_ref(),
                    config.bc_ridge,
                )?;
                Latent::Back {
                    weights,
                    bandwidth,
                    data: c,
                }
            }
            BackConstraint::Output => {
                return Err(Error::InvalidValue {
                    what: "ModelConfig::inducing".into(),
                    reason: "the sparse model supports back constraints none and input, not output"
                        .into(),
                })
            }
        };
        let mut model = SharedGplvm::new(config.clone(), sp, latent);
        model.sparse = Some(SparseState::new(Mat::zeros(0, config.latent_dim)));
        model.update_latent_points();
        let z = rows(model.x.as_ref(), &frames);
        let s = config
            .bayesian
            .then(|| Mat::from_fn(n, config.latent_dim, |_, _| INITIAL_LATENT_VARIANCE));
        model.sparse = Some(SparseState::new(z).with_latent_var(s));
        Ok(model)
    }

    /// Latent points of a sparse model with input back constraints: `K_bc(H, C) W`.
    pub(crate) fn sparse_latent_points(
        &self,
        weights: MatRef<'_, f64>,
        bandwidth: f64,
        centres: MatRef<'_, f64>,
    ) -> Mat<f64> {
        let kcn = bc_cross(self.spaces[0].data.as_ref(), centres, bandwidth);
        let mut x = Mat::zeros(kcn.ncols(), weights.ncols());
        faer::linalg::matmul::matmul(
            x.as_mut(),
            faer::Accum::Replace,
            kcn.transpose(),
            weights,
            1.0,
            faer::Par::Seq,
        );
        crate::simd::clear_upper_simd_state();
        x
    }

    /// True for the Bayesian model ([`ModelConfig::bayesian`]).
    pub fn is_bayesian(&self) -> bool {
        self.sparse.as_ref().is_some_and(|s| s.latent_var.is_some())
    }

    /// The variances S (N×Q) of the Bayesian model's q(X) (its means are
    /// [`SharedGplvm::latent_points`]); `None` for a model with point latent positions.
    pub fn latent_variances(&self) -> Option<MatRef<'_, f64>> {
        self.sparse
            .as_ref()
            .and_then(|s| s.latent_var.as_ref())
            .map(|s| s.as_ref())
    }

    /// The ARD weight of each latent dimension in `space`: `α² / ℓ_q²` (GPy's
    /// `input_sensitivity`), how strongly the space varies along it. A dimension whose weight
    /// is small against the space's largest is one the space does not use: in the Bayesian
    /// model, training switches such dimensions off, which is how it chooses the dimension and
    /// the split into shared and private dimensions.
    pub fn ard_weights(&self, space: &str) -> Result<Vec<f64>> {
        let k = self.kernel(space).ok_or_else(|| Error::UnknownSpace {
            name: space.into(),
            known: self.spaces.iter().map(|s| s.name.clone()).collect(),
        })?;
        Ok(k.lengthscale.iter().map(|l| k.variance / (l * l)).collect())
    }

    /// The (human, latent) pairs the input map is fitted on: every training frame, or for a
    /// sparse model at most [`MAP_FRAMES`] spread ones.
    pub(crate) fn map_pairs(&self) -> (Mat<f64>, Mat<f64>) {
        let n = self.n();
        let h = self.spaces[0].data.as_ref();
        match &self.sparse {
            Some(_) if n > MAP_FRAMES => {
                let f = spread(n, MAP_FRAMES);
                (rows(h, &f), rows(self.x.as_ref(), &f))
            }
            _ => (h.to_owned(), self.x.clone()),
        }
    }
}

#[cfg(test)]
mod tests;

/// One space's negative collapsed variational bound (Titsias 2009; GPy's `VarDTC`), the term
/// the sparse model sums over spaces: for latent points `x` (N×Q), inducing inputs `z` (M×Q),
/// data `y` (N×D, used as given: not centred here) and an RBF-ARD kernel with Gaussian noise,
/// `−log N(Y | 0, Q_nn + σ²I) + D/(2σ²) tr(K_nn − Q_nn)`, with `relative_jitter × α²` added
/// to K_mm's diagonal (the model uses 1e-6; GPy's `VarDTC` adds an absolute 1e-8, so pass
/// `1e-8 / α²` to compare). O(N M² + M³); for checks against other implementations.
pub fn sparse_bound(
    x: MatRef<'_, f64>,
    z: MatRef<'_, f64>,
    y: MatRef<'_, f64>,
    kernel: &KernelParams,
    relative_jitter: f64,
) -> Result<f64> {
    let q = x.ncols();
    let dims = [
        ("z columns", z.ncols(), q),
        ("kernel lengthscales", kernel.lengthscale.len(), q),
        ("y rows", y.nrows(), x.nrows()),
    ];
    for (what, found, expected) in dims {
        if found != expected {
            return Err(Error::DimensionMismatch {
                what: format!("sparse_bound: {what}"),
                expected,
                found,
            });
        }
    }
    if !(kernel.is_valid() && relative_jitter >= 0.0 && relative_jitter.is_finite()) {
        return Err(Error::InvalidValue {
            what: "sparse_bound".into(),
            reason: "expected a kernel of finite values > 0 and a finite jitter ≥ 0".into(),
        });
    }
    for (name, m) in [("x", x), ("z", z), ("y", y)] {
        crate::preprocess::check_finite(name, m)?;
    }
    likelihood::eval_sparse_space(
        &row_major(x),
        &row_major(z),
        q,
        y,
        kernel,
        relative_jitter,
        false,
        None,
        None,
    )
    .map(|e| e.nll)
    .map_err(|e| e.in_space("sparse_bound"))
}
