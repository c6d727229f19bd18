//! The shared GP-LVM: configuration, fitting (full and multi-robot), transfer, prediction.

use std::sync::Mutex;

use faer::dyn_stack::MemStack;
use faer::linalg::cholesky::llt;
use faer::reborrow::ReborrowMut;
use faer::{Accum, Mat, MatRef, Par};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

use rayon::prelude::*;

use crate::config::{BackConstraint, ModelConfig, ScaleMode};
use crate::error::{Error, Result};
use crate::kernel::{
    cholesky_with_jitter, clear_upper_simd_state, eval_space, exp_neg, exp_neg_slice,
    map_sqdist_lower, par_for, rbf_lower, row_major, weighted_sqdist, KernelParams, SpaceEval,
    SpaceWork, PARALLEL_FROM,
};
use crate::pool::{in_pool, lock, on_pool_thread};
use crate::train::{minimise, Control, IterationRecord, Objective, StopReason, TrainOptions};

/// Training points per block in the prediction loops (stack buffer size).
const BLOCK: usize = 64;
/// Points from which the spaces of one evaluation run on separate threads (below it the
/// thread hand-off costs more than it saves).
const SPACES_IN_PARALLEL_FROM: usize = 64;
/// Frames per block in the batch paths ([`SharedGplvm::latent`], [`SharedGplvm::predict`]).
const BATCH: usize = 256;

/// `out[(r, i)] = exp(−|a_r − b_i|²)` for pre-scaled rows (columns already multiplied by
/// `1/(√2 ℓ)`), via `|a|² + |b|² − 2 A Bᵀ` (one matrix product), clamped to ≤ 0, then the
/// vectorised exp column by column.
fn rbf_block(a: MatRef<'_, f64>, b: MatRef<'_, f64>, mut out: faer::MatMut<'_, f64>) {
    let na: Vec<f64> = (0..a.nrows())
        .map(|r| (0..a.ncols()).map(|t| a[(r, t)] * a[(r, t)]).sum())
        .collect();
    faer::linalg::matmul::matmul(
        out.rb_mut(),
        Accum::Replace,
        a,
        b.transpose(),
        2.0,
        Par::Seq,
    );
    clear_upper_simd_state();
    for i in 0..b.nrows() {
        let nb: f64 = (0..b.ncols()).map(|t| b[(i, t)] * b[(i, t)]).sum();
        let mut col = out.rb_mut().col_mut(i);
        if let Some(col) = col.rb_mut().try_as_col_major_mut() {
            let col = col.as_slice_mut();
            for (v, &na) in col.iter_mut().zip(&na) {
                *v = (*v - na - nb).min(0.0);
            }
            exp_neg_slice(col);
        } else {
            for (r, &na) in na.iter().enumerate() {
                col[r] = exp_neg((col[r] - na - nb).min(0.0));
            }
        }
    }
}

/// Latent block of [`Params`].
#[derive(Clone, Debug, PartialEq)]
pub enum LatentParams {
    /// Free latent points X (N×Q).
    Free {
        /// Latent matrix.
        x: Mat<f64>,
    },
    /// Back-constrained latent points X = K_bc W.
    BackConstrained {
        /// Weights W (N×Q).
        weights: Mat<f64>,
        /// Bandwidth of the back-constraint RBF, `k(a,b) = exp(-|a-b|²/(2 bw²))` (not trained;
        /// its gradient is reported for completeness).
        bandwidth: f64,
    },
}

/// All model parameters in natural units (also used for gradients, same structure).
#[derive(Clone, Debug, PartialEq)]
pub struct Params {
    /// Latent points or back-constraint weights.
    pub latent: LatentParams,
    /// Per space (input first), its kernel hyperparameters.
    pub spaces: Vec<(String, KernelParams)>,
}

/// Result of [`SharedGplvm::predict`].
#[derive(Clone, Debug, PartialEq)]
pub struct Prediction {
    /// Posterior mean in the space's original units (offsets and scales undone), n×D.
    pub mean: Mat<f64>,
    /// Posterior variance of the latent function `k** − kᵀK⁻¹k` in original units (×scale²),
    /// n×D, identical across the columns of a space; add the space's `noise` (× scale²) for
    /// GPy's `include_likelihood=True` semantics. Uncertainty of the latent point is not
    /// propagated.
    pub variance: Option<Mat<f64>>,
}

/// One observation space.
#[derive(Clone, Debug)]
pub(crate) struct Space {
    pub name: String,
    /// Centred (and scaled) data, N×D.
    pub data: Mat<f64>,
    pub offset: Vec<f64>,
    pub scale: Vec<f64>,
    pub kernel: KernelParams,
    pub columns: Option<Vec<String>>,
}

/// Latent representation.
#[derive(Clone, Debug)]
pub(crate) enum Latent {
    Free {
        x: Mat<f64>,
    },
    Back {
        weights: Mat<f64>,
        bandwidth: f64,
        data: Mat<f64>,
    },
}

/// GP regression human → latent (for `None` and `Output` back constraints).
#[derive(Clone, Debug)]
pub(crate) struct InputMap {
    pub kernel: KernelParams,
    pub x_mean: Vec<f64>,
}

/// Prediction caches of one space.
#[derive(Clone, Debug)]
pub(crate) struct SpaceCache {
    /// K⁻¹Y row-major N×D.
    alpha_rows: Vec<f64>,
    /// Cholesky factor of K (lower).
    factor: Mat<f64>,
    /// −1/(2 l²) per latent dimension.
    half_inv_l2: Vec<f64>,
    pub(crate) jitter: f64,
}

/// Caches of the human → latent step.
#[derive(Clone, Debug)]
pub(crate) struct LatentCache {
    /// Training inputs of the mapping (centred/scaled H) row-major N×D_H.
    h_rows: Vec<f64>,
    /// Weights row-major N×Q (W, or K⁻¹(X − mean) for the regression).
    weights: Vec<f64>,
    /// −1/(2 l²) per input dimension.
    half_inv_l2: Vec<f64>,
    /// Kernel amplitude (1 for back constraints).
    amplitude: f64,
    /// Added to every latent point.
    offset: Vec<f64>,
}

/// A trained shared GP-LVM over named observation spaces (input first, then robots).
///
/// Build with [`SharedGplvm::fit`]; extend to a new robot with [`SharedGplvm::transfer`];
/// predict with [`SharedGplvm::predict`] / [`SharedGplvm::predict_frame`]; store with
/// [`SharedGplvm::save`] / [`SharedGplvm::to_bytes`].
#[derive(Clone, Debug)]
pub struct SharedGplvm {
    pub(crate) config: ModelConfig,
    pub(crate) spaces: Vec<Space>,
    pub(crate) latent: Latent,
    pub(crate) map: Option<InputMap>,
    pub(crate) history: Vec<IterationRecord>,
    pub(crate) stop_reason: Option<StopReason>,
    pub(crate) training_jitter: f64,
    // ----- derived, recomputed by `rebuild` -----
    pub(crate) x: Mat<f64>,
    pub(crate) x_rows: Vec<f64>,
    pub(crate) caches: Vec<SpaceCache>,
    pub(crate) latent_cache: Option<LatentCache>,
    /// Evaluation buffers kept between calls of [`SharedGplvm::evaluate`] (fresh N×N buffers
    /// cost more than the evaluation itself: page faults on every call).
    pub(crate) workspace: Workspace,
}

/// Reusable per-space evaluation buffers; a clone starts empty.
#[derive(Default)]
pub(crate) struct Workspace(Mutex<Vec<SpaceWork>>);

impl Workspace {
    /// Buffers for spaces of `dims` output columns at `n` points: the kept ones if they fit.
    fn take(&self, n: usize, dims: &[usize]) -> Vec<SpaceWork> {
        let kept = std::mem::take(&mut *lock(&self.0));
        if kept.len() == dims.len() && kept.iter().zip(dims).all(|(w, &d)| w.fits(n, d)) {
            kept
        } else {
            dims.iter().map(|&d| SpaceWork::new(n, d)).collect()
        }
    }

    /// Keeps `works` for the next evaluation.
    fn put(&self, works: Vec<SpaceWork>) {
        *lock(&self.0) = works;
    }
}

impl Clone for Workspace {
    fn clone(&self) -> Self {
        Self::default()
    }
}

impl std::fmt::Debug for Workspace {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("Workspace")
    }
}

// ---------------------------------------------------------------------------------------------
// validation and preprocessing

fn check_finite(name: &str, m: MatRef<'_, f64>) -> Result<()> {
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

fn check_nonempty(name: &str, m: MatRef<'_, f64>) -> Result<()> {
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
fn preprocess(m: MatRef<'_, f64>, config: &ModelConfig) -> (Mat<f64>, Vec<f64>, Vec<f64>) {
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

fn mean_col_var(m: MatRef<'_, f64>) -> f64 {
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

/// PCA projection of centred `y` onto its top `q` principal directions (columns beyond the
/// rank of `y` are zero). Eigenvector signs are fixed so that their largest component is
/// positive. Returns the projection and the variance of its first column.
fn pca(y: MatRef<'_, f64>, q: usize) -> Result<(Mat<f64>, f64)> {
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
fn pca_init(spaces: &[Space], q: usize) -> Result<Mat<f64>> {
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
    rbf_lower(&row_major(data), data.ncols(), &k, &mut m);
    for j in 0..n {
        for i in 0..j {
            m[(i, j)] = m[(j, i)];
        }
    }
    m
}

/// Solves (A + ridge I) X = B for symmetric positive semi-definite A.
fn ridge_solve(a: MatRef<'_, f64>, b: MatRef<'_, f64>, ridge: f64) -> Result<Mat<f64>> {
    let n = a.nrows();
    let par = par_for(n);
    let mut l = Mat::zeros(n, n);
    cholesky_with_jitter(a, ridge, l.as_mut(), par).map_err(|e| Error::NotPositiveDefinite {
        space: "back constraint".into(),
        jitter: e.jitter,
    })?;
    let mut x = b.to_owned();
    llt::solve::solve_in_place(l.as_ref(), x.as_mut(), par, MemStack::new(&mut []));
    Ok(x)
}

// ---------------------------------------------------------------------------------------------
// objectives

/// Which parameters an optimisation moves.
#[derive(Clone, Debug)]
pub(crate) enum Mode {
    /// The latent block and every space's kernel.
    Full,
    /// Only the kernels of these spaces (latent frozen); other spaces add a constant.
    Kernels(Vec<usize>),
}

fn encode_kernel(k: &KernelParams, out: &mut Vec<f64>) {
    out.push(k.variance.ln());
    out.extend(k.lengthscale.iter().map(|l| l.ln()));
    out.push(k.noise.ln());
}

fn decode_kernel(t: &[f64], q: usize) -> KernelParams {
    KernelParams {
        variance: t[0].exp(),
        lengthscale: t[1..=q].iter().map(|v| v.exp()).collect(),
        noise: t[q + 1].exp(),
    }
}

/// Writes ∂L/∂(log p) = p ∂L/∂p for one space.
fn kernel_grad_log(k: &KernelParams, e: &crate::kernel::SpaceEval, out: &mut [f64]) {
    out[0] = e.d_variance * k.variance;
    for (t, l) in k.lengthscale.iter().enumerate() {
        out[1 + t] = e.d_lengthscale[t] * l;
    }
    out[k.lengthscale.len() + 1] = e.d_noise * k.noise;
}

struct ModelObjective<'a> {
    model: &'a SharedGplvm,
    mode: Mode,
    /// K_bc for back-constrained models in full mode.
    kbc: Option<Mat<f64>>,
    /// Sum of the frozen spaces' objective (Kernels mode).
    constant: f64,
    /// Latent points row-major (Kernels mode).
    x_rows: Vec<f64>,
    works: Mutex<Vec<SpaceWork>>,
    /// ∂L/∂X of the last evaluation, for back-constrained models (before the chain rule to W).
    latent_grad: Mutex<Option<Mat<f64>>>,
}

impl<'a> ModelObjective<'a> {
    fn new(model: &'a SharedGplvm, mode: Mode) -> Result<Self> {
        let n = model.n();
        let evaluated: Vec<usize> = match &mode {
            Mode::Full => (0..model.spaces.len()).collect(),
            Mode::Kernels(v) => v.clone(),
        };
        let dims: Vec<usize> = evaluated
            .iter()
            .map(|&s| model.spaces[s].data.ncols())
            .collect();
        let works = model.workspace.take(n, &dims);
        let kbc = match (&mode, &model.latent) {
            (
                Mode::Full,
                Latent::Back {
                    data, bandwidth, ..
                },
            ) => Some(bc_kernel(data.as_ref(), *bandwidth)),
            _ => None,
        };
        let mut constant = 0.0;
        if let Mode::Kernels(v) = &mode {
            let mut w = SpaceWork::new(n, 1);
            for (s, space) in model.spaces.iter().enumerate() {
                if v.contains(&s) {
                    continue;
                }
                if w.alpha().ncols() != space.data.ncols() {
                    w = SpaceWork::new(n, space.data.ncols());
                }
                let e = eval_space(
                    &model.x_rows,
                    model.q(),
                    space.data.as_ref(),
                    &space.kernel,
                    &mut w,
                    false,
                    None,
                )
                .map_err(|e| Error::NotPositiveDefinite {
                    space: space.name.clone(),
                    jitter: e.jitter,
                })?;
                constant += e.nll;
            }
        }
        Ok(Self {
            model,
            mode,
            kbc,
            constant,
            x_rows: model.x_rows.clone(),
            works: Mutex::new(works),
            latent_grad: Mutex::new(None),
        })
    }

    fn evaluated(&self) -> Vec<usize> {
        match &self.mode {
            Mode::Full => (0..self.model.spaces.len()).collect(),
            Mode::Kernels(v) => v.clone(),
        }
    }

    fn theta0(&self) -> Vec<f64> {
        let m = self.model;
        let mut t = Vec::new();
        if let Mode::Full = self.mode {
            let lat = match &m.latent {
                Latent::Free { x } => x,
                Latent::Back { weights, .. } => weights,
            };
            for j in 0..lat.ncols() {
                for i in 0..lat.nrows() {
                    t.push(lat[(i, j)]);
                }
            }
        }
        for s in self.evaluated() {
            encode_kernel(&m.spaces[s].kernel, &mut t);
        }
        t
    }

    fn latent_len(&self) -> usize {
        match self.mode {
            Mode::Full => self.model.n() * self.model.q(),
            Mode::Kernels(_) => 0,
        }
    }

    /// Writes `theta` into a copy of the model (no caches rebuilt).
    fn apply(&self, theta: &[f64], target: &mut SharedGplvm) {
        let (n, q) = (target.n(), target.q());
        let ll = self.latent_len();
        if ll > 0 {
            let lat = Mat::from_fn(n, q, |i, j| theta[j * n + i]);
            match &mut target.latent {
                Latent::Free { x } => *x = lat,
                Latent::Back { weights, .. } => *weights = lat,
            }
        }
        let mut off = ll;
        for s in self.evaluated() {
            target.spaces[s].kernel = decode_kernel(&theta[off..off + q + 2], q);
            off += q + 2;
        }
    }
}

impl Drop for ModelObjective<'_> {
    fn drop(&mut self) {
        self.model
            .workspace
            .put(std::mem::take(&mut *lock(&self.works)));
    }
}

impl Objective for ModelObjective<'_> {
    fn eval(&self, theta: &[f64], grad: &mut [f64]) -> Result<f64> {
        // On the pool only when there is parallel work: several spaces, or one space large
        // enough for faer's threads (transfer evaluates one space and would only pay the
        // hand-off to a pool thread).
        let n = self.model.n();
        let spaces = match &self.mode {
            Mode::Full => self.model.spaces.len(),
            Mode::Kernels(v) => v.len(),
        };
        if (spaces > 1 && n >= SPACES_IN_PARALLEL_FROM) || n >= PARALLEL_FROM {
            in_pool(|| self.eval_here(theta, grad))
        } else {
            self.eval_here(theta, grad)
        }
    }
}

impl ModelObjective<'_> {
    /// [`Objective::eval`] on the calling thread (spaces in parallel if it is a pool thread).
    fn eval_here(&self, theta: &[f64], grad: &mut [f64]) -> Result<f64> {
        let m = self.model;
        let (n, q) = (m.n(), m.q());
        let ll = self.latent_len();
        let par = par_for(n);
        // Latent points.
        let owned_rows;
        let xr: &[f64] = if ll > 0 {
            let lat = MatRef::from_column_major_slice(&theta[..ll], n, q);
            let x = match &self.kbc {
                Some(k) => {
                    let mut x = Mat::zeros(n, q);
                    faer::linalg::matmul::matmul(
                        x.as_mut(),
                        Accum::Replace,
                        k.as_ref(),
                        lat,
                        1.0,
                        par,
                    );
                    x
                }
                None => lat.to_owned(),
            };
            clear_upper_simd_state();
            owned_rows = row_major(x.as_ref());
            &owned_rows
        } else {
            &self.x_rows
        };
        let evaluated = self.evaluated();
        let mut kernels = Vec::with_capacity(evaluated.len());
        for (i, &s) in evaluated.iter().enumerate() {
            let off = ll + i * (q + 2);
            let k = decode_kernel(&theta[off..off + q + 2], q);
            if !k.is_valid() {
                return Err(Error::InvalidValue {
                    what: format!("kernel of '{}'", m.spaces[s].name),
                    reason: "overflow".into(),
                });
            }
            kernels.push(k);
        }
        let mut works = lock(&self.works);
        // The spaces share only X: each is evaluated on its own thread, into its own latent
        // gradient, and the results are summed in a fixed order (deterministic).
        let one_space = |(w, (&s, k)): (&mut SpaceWork, (&usize, &KernelParams))| {
            let mut dx = vec![0.0; if ll > 0 { n * q } else { 0 }];
            let space = &m.spaces[s];
            let dx_out = if ll > 0 { Some(&mut dx[..]) } else { None };
            eval_space(xr, q, space.data.as_ref(), k, w, true, dx_out)
                .map(|e| (e, dx))
                .map_err(|e| Error::NotPositiveDefinite {
                    space: space.name.clone(),
                    jitter: e.jitter,
                })
        };
        let pairs = evaluated.iter().zip(&kernels);
        let results: Vec<Result<(SpaceEval, Vec<f64>)>> =
            if evaluated.len() > 1 && n >= SPACES_IN_PARALLEL_FROM && on_pool_thread() {
                works
                    .par_iter_mut()
                    .zip(evaluated.par_iter().zip(kernels.par_iter()))
                    .map(one_space)
                    .collect()
            } else {
                works.iter_mut().zip(pairs).map(one_space).collect()
            };
        drop(works);
        let mut total = self.constant;
        let mut dx = vec![0.0; if ll > 0 { n * q } else { 0 }];
        for (i, (result, k)) in results.into_iter().zip(&kernels).enumerate() {
            let (e, dxs) = result?;
            total += e.nll;
            let off = ll + i * (q + 2);
            kernel_grad_log(k, &e, &mut grad[off..off + q + 2]);
            dx.iter_mut().zip(&dxs).for_each(|(a, b)| *a += b);
        }
        if ll > 0 {
            let dxm = Mat::from_fn(n, q, |i, j| dx[i * q + j]);
            match &self.kbc {
                Some(k) => {
                    let gm = faer::MatMut::from_column_major_slice_mut(&mut grad[..ll], n, q);
                    faer::linalg::matmul::matmul(
                        gm,
                        Accum::Replace,
                        k.transpose(),
                        dxm.as_ref(),
                        1.0,
                        par,
                    );
                    *lock(&self.latent_grad) = Some(dxm);
                }
                None => {
                    for j in 0..q {
                        for i in 0..n {
                            grad[j * n + i] = dxm[(i, j)];
                        }
                    }
                }
            }
        }
        Ok(total)
    }
}

/// GP regression objective (inputs fixed, one output block), θ = log kernel params.
struct MapObjective {
    h_rows: Vec<f64>,
    dh: usize,
    y: Mat<f64>,
    work: Mutex<SpaceWork>,
}

impl Objective for MapObjective {
    fn eval(&self, theta: &[f64], grad: &mut [f64]) -> Result<f64> {
        if self.y.nrows() >= PARALLEL_FROM {
            in_pool(|| self.eval_here(theta, grad))
        } else {
            self.eval_here(theta, grad)
        }
    }
}

impl MapObjective {
    /// [`Objective::eval`] on the calling thread.
    fn eval_here(&self, theta: &[f64], grad: &mut [f64]) -> Result<f64> {
        let k = decode_kernel(theta, self.dh);
        if !k.is_valid() {
            return Err(Error::InvalidValue {
                what: "input map kernel".into(),
                reason: "overflow".into(),
            });
        }
        let mut w = lock(&self.work);
        let e = eval_space(
            &self.h_rows,
            self.dh,
            self.y.as_ref(),
            &k,
            &mut w,
            true,
            None,
        )
        .map_err(|e| Error::NotPositiveDefinite {
            space: "input map".into(),
            jitter: e.jitter,
        })?;
        kernel_grad_log(&k, &e, grad);
        Ok(e.nll)
    }
}

// ---------------------------------------------------------------------------------------------
// the model

/// Callback type of training: sees each accepted iteration and a snapshot of the model.
pub type Callback<'c> = &'c mut dyn FnMut(&IterationRecord, &SharedGplvm) -> Control;

impl SharedGplvm {
    pub(crate) fn n(&self) -> usize {
        self.spaces[0].data.nrows()
    }

    pub(crate) fn q(&self) -> usize {
        self.config.latent_dim
    }

    /// Fits a shared GP-LVM. `spaces` are named data matrices with the same number of rows;
    /// `input` names the human space; with one other space this is the paper's *full* model,
    /// with several the *multi-robot* model. `callback` sees every iteration with a model
    /// snapshot (built only when a callback is given) and may stop training.
    pub fn fit(
        config: &ModelConfig,
        spaces: &[(&str, MatRef<'_, f64>)],
        input: &str,
        options: &TrainOptions,
        callback: Option<Callback<'_>>,
    ) -> Result<Self> {
        config.check()?;
        options.check()?;
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
        let q = config.latent_dim;
        if q == 0 || q >= n {
            return Err(Error::InvalidLatentDim { latent_dim: q, n });
        }
        // Input first, then the robots in the given order.
        let mut order = vec![ii];
        order.extend((0..spaces.len()).filter(|&i| i != ii));
        let mut sp = Vec::new();
        for &i in &order {
            let (data, offset, scale) = preprocess(spaces[i].1, config);
            let v = mean_col_var(data.as_ref());
            sp.push(Space {
                name: names[i].clone(),
                data,
                offset,
                scale,
                kernel: KernelParams {
                    variance: v,
                    lengthscale: vec![1.0; q],
                    noise: config.init_noise_fraction * v,
                },
                columns: None,
            });
        }
        let mut x0 = pca_init(&sp, q)?;
        if config.init_perturbation > 0.0 {
            let mut rng = ChaCha8Rng::seed_from_u64(config.seed);
            for j in 0..q {
                for i in 0..n {
                    let z: f64 = StandardNormal.sample(&mut rng);
                    x0[(i, j)] += config.init_perturbation * z;
                }
            }
        }
        let latent = match config.back_constraint {
            BackConstraint::None => Latent::Free { x: x0.clone() },
            bc => {
                let data = if bc == BackConstraint::Input {
                    sp[0].data.clone()
                } else {
                    let cols: usize = sp[1..].iter().map(|s| s.data.ncols()).sum();
                    let mut d = Mat::zeros(n, cols);
                    let mut c0 = 0;
                    for s in &sp[1..] {
                        for j in 0..s.data.ncols() {
                            for i in 0..n {
                                d[(i, c0 + j)] = s.data[(i, j)];
                            }
                        }
                        c0 += s.data.ncols();
                    }
                    d
                };
                let bandwidth = median_distance(data.as_ref());
                let kbc = bc_kernel(data.as_ref(), bandwidth);
                let weights = ridge_solve(kbc.as_ref(), x0.as_ref(), config.bc_ridge)?;
                Latent::Back {
                    weights,
                    bandwidth,
                    data,
                }
            }
        };
        let mut model = SharedGplvm {
            config: config.clone(),
            spaces: sp,
            latent,
            map: None,
            history: Vec::new(),
            stop_reason: None,
            training_jitter: 0.0,
            x: Mat::zeros(0, 0),
            x_rows: Vec::new(),
            caches: Vec::new(),
            latent_cache: None,
            workspace: Workspace::default(),
        };
        model.update_latent_points();
        model.train(Mode::Full, options, callback)?;
        Ok(model)
    }

    /// Recomputes X (and its row-major copy) from the latent representation.
    fn update_latent_points(&mut self) {
        self.x = match &self.latent {
            Latent::Free { x } => x.clone(),
            Latent::Back {
                weights,
                bandwidth,
                data,
            } => {
                let k = bc_kernel(data.as_ref(), *bandwidth);
                let mut x = Mat::zeros(weights.nrows(), weights.ncols());
                faer::linalg::matmul::matmul(
                    x.as_mut(),
                    Accum::Replace,
                    k.as_ref(),
                    weights.as_ref(),
                    1.0,
                    par_for(weights.nrows()),
                );
                x
            }
        };
        self.x_rows = row_major(self.x.as_ref());
    }

    fn needs_map(&self) -> bool {
        self.config.back_constraint != BackConstraint::Input
    }

    /// Runs the optimiser in `mode`, then fits the input map (full mode) and rebuilds caches.
    fn train(
        &mut self,
        mode: Mode,
        options: &TrainOptions,
        mut callback: Option<Callback<'_>>,
    ) -> Result<()> {
        let (outcome, jitter) = {
            let obj = ModelObjective::new(self, mode.clone())?;
            let theta0 = obj.theta0();
            let d_total: usize = obj
                .evaluated()
                .iter()
                .map(|&s| self.spaces[s].data.ncols())
                .sum();
            let scale = 1.0 / (self.n() * d_total.max(1)) as f64;
            let mut prev_map = self.map.as_ref().map(|m| m.kernel.clone());
            let outcome = minimise(&obj, theta0, scale, options, |rec, theta| {
                let Some(cb) = callback.as_mut() else {
                    return Control::Continue;
                };
                let mut snap = self.clone();
                obj.apply(theta, &mut snap);
                snap.update_latent_points();
                if matches!(mode, Mode::Full) && snap.needs_map() {
                    if let Err(_e) = snap.fit_map(options, prev_map.clone()) {
                        return Control::Continue;
                    }
                    prev_map = snap.map.as_ref().map(|m| m.kernel.clone());
                }
                if snap.rebuild().is_err() {
                    return Control::Continue;
                }
                snap.history = Vec::new();
                cb(rec, &snap)
            })?;
            let mut applied = self.clone();
            obj.apply(&outcome.theta, &mut applied);
            (outcome, applied)
        };
        let mut applied = jitter;
        applied.update_latent_points();
        if matches!(mode, Mode::Full) && applied.needs_map() {
            let warm = None;
            applied.fit_map(options, warm)?;
        }
        applied.rebuild()?;
        applied.history = outcome.history;
        applied.stop_reason = Some(outcome.reason);
        applied.training_jitter = applied.caches.iter().fold(0.0, |m, c| m.max(c.jitter));
        *self = applied;
        Ok(())
    }

    /// Fits the GP regression human → latent (targets: X minus its mean).
    fn fit_map(&mut self, options: &TrainOptions, warm: Option<KernelParams>) -> Result<()> {
        let h = self.spaces[0].data.as_ref();
        let (n, dh, q) = (self.n(), h.ncols(), self.q());
        let x_mean: Vec<f64> = (0..q)
            .map(|j| (0..n).map(|i| self.x[(i, j)]).sum::<f64>() / n as f64)
            .collect();
        let y = Mat::from_fn(n, q, |i, j| self.x[(i, j)] - x_mean[j]);
        let kernel0 = match warm {
            Some(k) if k.lengthscale.len() == dh && k.is_valid() => k,
            _ => {
                let v = mean_col_var(y.as_ref());
                KernelParams {
                    variance: v,
                    lengthscale: vec![median_distance(h); dh],
                    noise: 0.01 * v,
                }
            }
        };
        let obj = MapObjective {
            h_rows: row_major(h),
            dh,
            y: y.clone(),
            work: Mutex::new(SpaceWork::new(n, q)),
        };
        let mut theta0 = Vec::new();
        encode_kernel(&kernel0, &mut theta0);
        let opts = TrainOptions {
            max_iters: options.map_max_iters,
            ..options.clone()
        };
        let out = minimise(&obj, theta0, 1.0 / (n * q) as f64, &opts, |_, _| {
            Control::Continue
        })?;
        self.map = Some(InputMap {
            kernel: decode_kernel(&out.theta, dh),
            x_mean,
        });
        Ok(())
    }

    /// Recomputes every prediction cache from the stored parameters (used after training, on
    /// load and by `set_params`, so that a loaded model predicts bit-identically).
    pub(crate) fn rebuild(&mut self) -> Result<()> {
        self.update_latent_points();
        let (n, q) = (self.n(), self.q());
        let mut caches = Vec::with_capacity(self.spaces.len());
        for s in &self.spaces {
            let mut w = SpaceWork::new(n, s.data.ncols());
            let e = eval_space(
                &self.x_rows,
                q,
                s.data.as_ref(),
                &s.kernel,
                &mut w,
                false,
                None,
            )
            .map_err(|e| Error::NotPositiveDefinite {
                space: s.name.clone(),
                jitter: e.jitter,
            })?;
            caches.push(SpaceCache {
                alpha_rows: row_major(w.alpha()),
                factor: w.factor().to_owned(),
                half_inv_l2: s
                    .kernel
                    .lengthscale
                    .iter()
                    .map(|l| -0.5 / (l * l))
                    .collect(),
                jitter: e.jitter,
            });
        }
        self.caches = caches;
        self.latent_cache = Some(match (&self.latent, &self.map) {
            (
                Latent::Back {
                    weights, bandwidth, ..
                },
                _,
            ) if self.config.back_constraint == BackConstraint::Input => LatentCache {
                h_rows: row_major(self.spaces[0].data.as_ref()),
                weights: row_major(weights.as_ref()),
                half_inv_l2: vec![-0.5 / (bandwidth * bandwidth); self.spaces[0].data.ncols()],
                amplitude: 1.0,
                offset: vec![0.0; q],
            },
            (_, Some(map)) => {
                let h = self.spaces[0].data.as_ref();
                let y = Mat::from_fn(n, q, |i, j| self.x[(i, j)] - map.x_mean[j]);
                let mut w = SpaceWork::new(n, q);
                let hr = row_major(h);
                eval_space(&hr, h.ncols(), y.as_ref(), &map.kernel, &mut w, false, None).map_err(
                    |e| Error::NotPositiveDefinite {
                        space: "input map".into(),
                        jitter: e.jitter,
                    },
                )?;
                LatentCache {
                    h_rows: hr,
                    weights: row_major(w.alpha()),
                    half_inv_l2: map
                        .kernel
                        .lengthscale
                        .iter()
                        .map(|l| -0.5 / (l * l))
                        .collect(),
                    amplitude: map.kernel.variance,
                    offset: map.x_mean.clone(),
                }
            }
            _ => {
                return Err(Error::Corrupt {
                    reason: "model without input back constraint has no input map".into(),
                })
            }
        });
        Ok(())
    }

    /// Transfers the model to a new robot (the paper's eq. 8): a new model with the same latent
    /// points, back-constraint weights, human kernel and input map (all frozen), the existing
    /// robots kept with their kernels frozen (so one model predicts for all), and the new robot
    /// `name` whose kernel (variance, lengthscales, noise) alone is trained. Only the new
    /// space's Cholesky factor is computed per evaluation. `self` is not modified.
    ///
    /// The new kernel starts from the data's mean column variance, the first robot's
    /// lengthscales and `init_noise_fraction` of the variance, so repeated calls give identical
    /// models; see [`SharedGplvm::transfer_seeded`] for randomised restarts.
    pub fn transfer(
        &self,
        name: &str,
        data: MatRef<'_, f64>,
        options: &TrainOptions,
        callback: Option<Callback<'_>>,
    ) -> Result<Self> {
        self.transfer_impl(name, data, None, options, callback)
    }

    /// [`SharedGplvm::transfer`] from a randomly perturbed starting kernel, for repeated
    /// transfer runs per source model (the paper runs 10). The initial variance and each
    /// initial lengthscale are multiplied by `exp(0.3 z)`, `z ~ N(0, 1)` drawn in that order
    /// (variance first) from a ChaCha8 generator seeded with `seed`; the initial noise stays
    /// `init_noise_fraction` of the unperturbed variance. Same seed ⇒ bit-identical model.
    /// `self` is not modified.
    pub fn transfer_seeded(
        &self,
        name: &str,
        data: MatRef<'_, f64>,
        seed: u64,
        options: &TrainOptions,
        callback: Option<Callback<'_>>,
    ) -> Result<Self> {
        self.transfer_impl(name, data, Some(seed), options, callback)
    }

    /// Shared body of [`SharedGplvm::transfer`] (`seed = None`: no perturbation) and
    /// [`SharedGplvm::transfer_seeded`].
    fn transfer_impl(
        &self,
        name: &str,
        data: MatRef<'_, f64>,
        seed: Option<u64>,
        options: &TrainOptions,
        callback: Option<Callback<'_>>,
    ) -> Result<Self> {
        options.check()?;
        if self.spaces.iter().any(|s| s.name == name) {
            return Err(Error::DuplicateSpace { name: name.into() });
        }
        check_nonempty(name, data)?;
        if data.nrows() != self.n() {
            return Err(Error::RowCountMismatch {
                space: name.into(),
                expected: self.n(),
                found: data.nrows(),
            });
        }
        check_finite(name, data)?;
        let (d, offset, scale) = preprocess(data, &self.config);
        let v = mean_col_var(d.as_ref());
        let lengthscale = self
            .spaces
            .get(1)
            .map(|s| s.kernel.lengthscale.clone())
            .unwrap_or(vec![1.0; self.q()]);
        let mut lengthscale = lengthscale;
        let mut variance = v;
        if let Some(seed) = seed {
            const SPREAD: f64 = 0.3;
            let mut rng = ChaCha8Rng::seed_from_u64(seed);
            let z: f64 = StandardNormal.sample(&mut rng);
            variance *= (SPREAD * z).exp();
            for l in lengthscale.iter_mut() {
                let z: f64 = StandardNormal.sample(&mut rng);
                *l *= (SPREAD * z).exp();
            }
        }
        let mut model = self.clone();
        model.history = Vec::new();
        model.spaces.push(Space {
            name: name.into(),
            data: d,
            offset,
            scale,
            kernel: KernelParams {
                variance,
                lengthscale,
                noise: self.config.init_noise_fraction * v,
            },
            columns: None,
        });
        let idx = model.spaces.len() - 1;
        model.train(Mode::Kernels(vec![idx]), options, callback)?;
        Ok(model)
    }

    // -----------------------------------------------------------------------------------------
    // prediction

    fn output_index(&self, space: &str) -> Result<usize> {
        match self.spaces.iter().position(|s| s.name == space) {
            Some(i) if i > 0 => Ok(i),
            _ => Err(Error::NotAnOutput {
                name: space.into(),
                known: self.output_names().iter().map(|s| s.to_string()).collect(),
            }),
        }
    }

    fn check_input_row(&self, h: &[f64]) -> Result<()> {
        let dh = self.spaces[0].data.ncols();
        if h.len() != dh {
            return Err(Error::DimensionMismatch {
                what: format!("input frame for '{}'", self.spaces[0].name),
                expected: dh,
                found: h.len(),
            });
        }
        for (c, &v) in h.iter().enumerate() {
            if !v.is_finite() {
                return Err(Error::NonFinite {
                    space: self.spaces[0].name.clone(),
                    row: 0,
                    col: c,
                    value: v,
                });
            }
        }
        Ok(())
    }

    /// Latent point of one raw input frame into `x` (length Q). Allocation-free for
    /// D_H ≤ 64: training points are processed in blocks of [`BLOCK`] (distances, then a
    /// vectorised exp, then the weighted sum).
    fn latent_into(&self, h: &[f64], x: &mut [f64]) -> Result<()> {
        clear_upper_simd_state();
        let Some(lc) = &self.latent_cache else {
            return Err(Error::Corrupt {
                reason: "prediction caches missing".into(),
            });
        };
        let s0 = &self.spaces[0];
        let dh = h.len();
        let mut hs_stack = [0.0f64; 64];
        let mut hs_heap;
        let hs: &mut [f64] = if dh <= 64 {
            &mut hs_stack[..dh]
        } else {
            hs_heap = vec![0.0; dh];
            &mut hs_heap
        };
        for t in 0..dh {
            hs[t] = (h[t] - s0.offset[t]) / s0.scale[t];
        }
        x.copy_from_slice(&lc.offset);
        add_kernel_weighted(
            hs,
            &lc.h_rows,
            &lc.half_inv_l2,
            &lc.weights,
            lc.amplitude,
            self.n(),
            x,
        );
        Ok(())
    }

    /// Mean (original units) of space `si` at latent point `x` into `out`. Allocation-free.
    fn mean_into(&self, si: usize, x: &[f64], out: &mut [f64]) {
        let s = &self.spaces[si];
        let c = &self.caches[si];
        let d = out.len();
        out.iter_mut().for_each(|v| *v = 0.0);
        add_kernel_weighted(
            x,
            &self.x_rows,
            &c.half_inv_l2,
            &c.alpha_rows,
            s.kernel.variance,
            self.n(),
            out,
        );
        for t in 0..d {
            out[t] = out[t] * s.scale[t] + s.offset[t];
        }
    }

    /// Posterior mean of robot `space` for one raw human frame `h`, written to `out` (length
    /// D of the space). Costs O(N(D_H + Q + D)); allocates nothing for Q ≤ 32 and D_H ≤ 64.
    pub fn predict_frame(&self, h: &[f64], space: &str, out: &mut [f64]) -> Result<()> {
        self.check_input_row(h)?;
        let si = self.output_index(space)?;
        let d = self.spaces[si].data.ncols();
        if out.len() != d {
            return Err(Error::DimensionMismatch {
                what: format!("output buffer for '{space}'"),
                expected: d,
                found: out.len(),
            });
        }
        let q = self.q();
        let mut stack = [0.0f64; 32];
        let mut heap;
        let x: &mut [f64] = if q <= 32 {
            &mut stack[..q]
        } else {
            heap = vec![0.0; q];
            &mut heap
        };
        self.latent_into(h, x)?;
        self.mean_into(si, x, out);
        Ok(())
    }

    fn check_input_matrix(&self, h: MatRef<'_, f64>) -> Result<()> {
        let dh = self.spaces[0].data.ncols();
        if h.ncols() != dh {
            return Err(Error::DimensionMismatch {
                what: format!("input columns for '{}'", self.spaces[0].name),
                expected: dh,
                found: h.ncols(),
            });
        }
        check_finite(&self.spaces[0].name, h)
    }

    /// Latent points of raw human frames (rows of `h`), n×Q. Frames are processed in blocks
    /// of [`BATCH`] with matrix products (see [`rbf_block`]).
    pub fn latent(&self, h: MatRef<'_, f64>) -> Result<Mat<f64>> {
        self.check_input_matrix(h)?;
        self.latent_batch(h)
    }

    fn latent_batch(&self, h: MatRef<'_, f64>) -> Result<Mat<f64>> {
        let Some(lc) = &self.latent_cache else {
            return Err(Error::Corrupt {
                reason: "prediction caches missing".into(),
            });
        };
        let s0 = &self.spaces[0];
        let (n, dh, q, m_all) = (self.n(), h.ncols(), self.q(), h.nrows());
        let sc: Vec<f64> = lc.half_inv_l2.iter().map(|v| (-v).sqrt()).collect();
        // Both sides centred on the training mean: smaller norms, less cancellation in
        // |a|² + |b|² − 2 a·b.
        let mu: Vec<f64> = (0..dh)
            .map(|t| (0..n).map(|i| lc.h_rows[i * dh + t]).sum::<f64>() / n.max(1) as f64)
            .collect();
        let train = Mat::from_fn(n, dh, |i, t| (lc.h_rows[i * dh + t] - mu[t]) * sc[t]);
        let w = Mat::from_fn(n, q, |i, t| lc.weights[i * q + t]);
        let hs = Mat::from_fn(m_all, dh, |r, t| {
            ((h[(r, t)] - s0.offset[t]) / s0.scale[t] - mu[t]) * sc[t]
        });
        let mut out = Mat::from_fn(m_all, q, |_, t| lc.offset[t]);
        let mut k = Mat::zeros(BATCH.min(m_all), n);
        let mut r0 = 0;
        while r0 < m_all {
            let m = BATCH.min(m_all - r0);
            let mut kb = k.as_mut().subrows_mut(0, m);
            rbf_block(hs.as_ref().subrows(r0, m), train.as_ref(), kb.rb_mut());
            faer::linalg::matmul::matmul(
                out.as_mut().subrows_mut(r0, m),
                Accum::Add,
                kb.as_ref(),
                w.as_ref(),
                lc.amplitude,
                Par::Seq,
            );
            r0 += m;
        }
        Ok(out)
    }

    /// Posterior mean (and optionally variance, see [`Prediction`]) of robot `space` for the
    /// raw human frames in the rows of `h`. Frames go in blocks of [`BATCH`]: kernel blocks
    /// from matrix products ([`rbf_block`]), the mean as `K* (K⁻¹Y)`, the variance as
    /// `k** − |L⁻¹k*|²` with one multi-right-hand-side triangular solve per block.
    pub fn predict(
        &self,
        h: MatRef<'_, f64>,
        space: &str,
        with_variance: bool,
    ) -> Result<Prediction> {
        self.check_input_matrix(h)?;
        let si = self.output_index(space)?;
        let xs = self.latent_batch(h)?;
        let (n_new, q, n) = (h.nrows(), self.q(), self.n());
        let s = &self.spaces[si];
        let c = &self.caches[si];
        let d = s.data.ncols();
        let sc: Vec<f64> = c.half_inv_l2.iter().map(|v| (-v).sqrt()).collect();
        let mu: Vec<f64> = (0..q)
            .map(|t| (0..n).map(|i| self.x_rows[i * q + t]).sum::<f64>() / n.max(1) as f64)
            .collect();
        let train = Mat::from_fn(n, q, |i, t| (self.x_rows[i * q + t] - mu[t]) * sc[t]);
        let alpha = Mat::from_fn(n, d, |i, t| c.alpha_rows[i * d + t]);
        let xsc = Mat::from_fn(n_new, q, |r, t| (xs[(r, t)] - mu[t]) * sc[t]);
        let mut mean = Mat::zeros(n_new, d);
        let mut variance = if with_variance {
            Some(Mat::zeros(n_new, d))
        } else {
            None
        };
        let bm = BATCH.min(n_new);
        let mut k = Mat::zeros(bm, n);
        let mut kt = Mat::zeros(if with_variance { n } else { 0 }, bm);
        let mut r0 = 0;
        while r0 < n_new {
            let m = BATCH.min(n_new - r0);
            let mut kb = k.as_mut().subrows_mut(0, m);
            rbf_block(xsc.as_ref().subrows(r0, m), train.as_ref(), kb.rb_mut());
            faer::linalg::matmul::matmul(
                mean.as_mut().subrows_mut(r0, m),
                Accum::Replace,
                kb.as_ref(),
                alpha.as_ref(),
                s.kernel.variance,
                Par::Seq,
            );
            if let Some(var) = variance.as_mut() {
                let mut ks = kt.as_mut().subcols_mut(0, m);
                ks.copy_from(kb.as_ref().transpose());
                faer::linalg::triangular_solve::solve_lower_triangular_in_place(
                    c.factor.as_ref(),
                    ks.rb_mut(),
                    par_for(n),
                );
                clear_upper_simd_state();
                for f in 0..m {
                    let explained: f64 = (0..n).map(|i| ks[(i, f)] * ks[(i, f)]).sum::<f64>()
                        * s.kernel.variance
                        * s.kernel.variance;
                    let v = (s.kernel.variance - explained).max(0.0);
                    for t in 0..d {
                        var[(r0 + f, t)] = v * s.scale[t] * s.scale[t];
                    }
                }
            }
            r0 += m;
        }
        for t in 0..d {
            for r in 0..n_new {
                mean[(r, t)] = mean[(r, t)] * s.scale[t] + s.offset[t];
            }
        }
        Ok(Prediction { mean, variance })
    }

    // -----------------------------------------------------------------------------------------
    // accessors

    /// Name of the input (human) space.
    pub fn input_name(&self) -> &str {
        &self.spaces[0].name
    }

    /// Names of the output (robot) spaces, in model order.
    pub fn output_names(&self) -> Vec<&str> {
        self.spaces[1..].iter().map(|s| s.name.as_str()).collect()
    }

    /// Number of columns of a space, if the model has it.
    pub fn space_dim(&self, name: &str) -> Option<usize> {
        self.spaces
            .iter()
            .find(|s| s.name == name)
            .map(|s| s.data.ncols())
    }

    /// Training latent points X (N×Q).
    pub fn latent_points(&self) -> MatRef<'_, f64> {
        self.x.as_ref()
    }

    /// Objective and time per iteration of the last training run (iteration 0 = start).
    pub fn history(&self) -> &[IterationRecord] {
        &self.history
    }

    /// Why the last training run stopped.
    pub fn stop_reason(&self) -> Option<&StopReason> {
        self.stop_reason.as_ref()
    }

    /// Largest diagonal jitter the final kernel matrices needed (0 when none).
    pub fn jitter(&self) -> f64 {
        self.training_jitter
    }

    /// The configuration the model was built with.
    pub fn config(&self) -> &ModelConfig {
        &self.config
    }

    /// Number of training frames N.
    pub fn num_points(&self) -> usize {
        self.n()
    }

    /// Kernel hyperparameters of a space.
    pub fn kernel(&self, space: &str) -> Option<&KernelParams> {
        self.spaces
            .iter()
            .find(|s| s.name == space)
            .map(|s| &s.kernel)
    }

    /// Hyperparameters of the human → latent GP regression (models without input back
    /// constraints), with the latent mean it adds back.
    pub fn input_map(&self) -> Option<(&KernelParams, &[f64])> {
        self.map.as_ref().map(|m| (&m.kernel, m.x_mean.as_slice()))
    }

    /// Column (joint) names of a space, if set.
    pub fn column_names(&self, space: &str) -> Option<&[String]> {
        self.spaces
            .iter()
            .find(|s| s.name == space)
            .and_then(|s| s.columns.as_deref())
    }

    /// Stores column (joint) names for a space (saved with the model).
    pub fn set_column_names(&mut self, space: &str, names: Vec<String>) -> Result<()> {
        let known: Vec<String> = self.spaces.iter().map(|s| s.name.clone()).collect();
        let Some(s) = self.spaces.iter_mut().find(|s| s.name == space) else {
            return Err(Error::UnknownSpace {
                name: space.into(),
                known,
            });
        };
        if names.len() != s.data.ncols() {
            return Err(Error::DimensionMismatch {
                what: format!("column names of '{space}'"),
                expected: s.data.ncols(),
                found: names.len(),
            });
        }
        s.columns = Some(names);
        Ok(())
    }

    /// Per-column offset (mean) and scale of a space's preprocessing.
    pub fn normalisation(&self, space: &str) -> Option<(&[f64], &[f64])> {
        self.spaces
            .iter()
            .find(|s| s.name == space)
            .map(|s| (s.offset.as_slice(), s.scale.as_slice()))
    }

    // -----------------------------------------------------------------------------------------
    // parameters, objective, gradient

    /// All parameters in natural units.
    pub fn params(&self) -> Params {
        Params {
            latent: match &self.latent {
                Latent::Free { x } => LatentParams::Free { x: x.clone() },
                Latent::Back {
                    weights, bandwidth, ..
                } => LatentParams::BackConstrained {
                    weights: weights.clone(),
                    bandwidth: *bandwidth,
                },
            },
            spaces: self
                .spaces
                .iter()
                .map(|s| (s.name.clone(), s.kernel.clone()))
                .collect(),
        }
    }

    /// Replaces the parameters (same structure as [`SharedGplvm::params`]; spaces are matched by
    /// name and must all be given) and recomputes the caches. For models with a GP regression
    /// human → latent the regression is refitted (warm-started, default options).
    pub fn set_params(&mut self, p: &Params) -> Result<()> {
        let (n, q) = (self.n(), self.q());
        let mut next = self.clone();
        match (&mut next.latent, &p.latent) {
            (Latent::Free { x }, LatentParams::Free { x: nx }) => {
                check_shape("latent x", nx.as_ref(), n, q)?;
                *x = nx.clone();
            }
            (Latent::Back { weights, bandwidth, .. }, LatentParams::BackConstrained { weights: nw, bandwidth: nb }) => {
                check_shape("latent weights", nw.as_ref(), n, q)?;
                if !(nb.is_finite() && *nb > 0.0) {
                    return Err(Error::InvalidValue { what: "bandwidth".into(), reason: format!("{nb}; expected a finite number > 0") });
                }
                *weights = nw.clone();
                *bandwidth = *nb;
            }
            _ => {
                return Err(Error::InvalidValue {
                    what: "params.latent".into(),
                    reason: "kind does not match the model's back constraint (Free for None, BackConstrained otherwise)".into(),
                })
            }
        }
        if p.spaces.len() != next.spaces.len() {
            return Err(Error::DimensionMismatch {
                what: "params.spaces".into(),
                expected: next.spaces.len(),
                found: p.spaces.len(),
            });
        }
        let known: Vec<String> = next.spaces.iter().map(|s| s.name.clone()).collect();
        for (name, k) in &p.spaces {
            let Some(s) = next.spaces.iter_mut().find(|s| &s.name == name) else {
                return Err(Error::UnknownSpace {
                    name: name.clone(),
                    known,
                });
            };
            if k.lengthscale.len() != q {
                return Err(Error::DimensionMismatch {
                    what: format!("lengthscale of '{name}'"),
                    expected: q,
                    found: k.lengthscale.len(),
                });
            }
            if !k.is_valid() {
                return Err(Error::InvalidValue {
                    what: format!("kernel of '{name}'"),
                    reason: "expected finite values > 0".into(),
                });
            }
            s.kernel = k.clone();
        }
        next.update_latent_points();
        if next.needs_map() {
            let warm = next.map.as_ref().map(|m| m.kernel.clone());
            next.fit_map(&TrainOptions::default(), warm)?;
        }
        next.rebuild()?;
        *self = next;
        Ok(())
    }

    /// Objective and gradient (natural units, same structure as [`SharedGplvm::params`]; the
    /// bandwidth entry holds ∂L/∂bandwidth).
    pub fn evaluate(&self) -> Result<(f64, Params)> {
        let obj = ModelObjective::new(self, Mode::Full)?;
        let theta = obj.theta0();
        let mut g = vec![0.0; theta.len()];
        let f = obj.eval(&theta, &mut g)?;
        let (n, q) = (self.n(), self.q());
        let ll = n * q;
        let lat_g = Mat::from_fn(n, q, |i, j| g[j * n + i]);
        let latent = match &self.latent {
            Latent::Free { .. } => LatentParams::Free { x: lat_g },
            Latent::Back {
                weights,
                bandwidth,
                data,
            } => {
                // ∂L/∂bw = Σ_ij (∂L/∂X Wᵀ)_ij K_ij d²_ij / bw³, with K_ij = exp(−d²_ij / 2bw²).
                let (dx, k) = match (lock(&obj.latent_grad).take(), &obj.kbc) {
                    (Some(dx), Some(k)) => (dx, k),
                    _ => unreachable!("a full evaluation of a back-constrained model sets both"),
                };
                let mut a = Mat::zeros(n, n);
                faer::linalg::matmul::matmul(
                    a.as_mut(),
                    Accum::Replace,
                    dx.as_ref(),
                    weights.transpose(),
                    1.0,
                    par_for(n),
                );
                let c = data.ncols();
                let mut d2 = Mat::zeros(n, n);
                map_sqdist_lower(
                    &row_major(data.as_ref()),
                    c,
                    &vec![1.0; c],
                    &mut d2,
                    #[inline(always)]
                    |v| v,
                );
                let mut db = 0.0;
                for j in 0..n {
                    for i in j + 1..n {
                        db += (a[(i, j)] + a[(j, i)]) * k[(i, j)] * d2[(i, j)];
                    }
                }
                db /= bandwidth.powi(3);
                LatentParams::BackConstrained {
                    weights: lat_g,
                    bandwidth: db,
                }
            }
        };
        let mut spaces = Vec::new();
        let mut off = ll;
        for s in &self.spaces {
            let t = &g[off..off + q + 2];
            spaces.push((
                s.name.clone(),
                KernelParams {
                    variance: t[0] / s.kernel.variance,
                    lengthscale: (0..q).map(|i| t[1 + i] / s.kernel.lengthscale[i]).collect(),
                    noise: t[q + 1] / s.kernel.noise,
                },
            ));
            off += q + 2;
        }
        Ok((f, Params { latent, spaces }))
    }

    /// Negative log marginal likelihood at the current parameters (NaN if a kernel matrix
    /// cannot be factorised; see [`SharedGplvm::evaluate`] for the error).
    pub fn objective(&self) -> f64 {
        self.evaluate().map(|(f, _)| f).unwrap_or(f64::NAN)
    }

    /// Gradient of the objective in natural units (NaN-filled if it cannot be evaluated; see
    /// [`SharedGplvm::evaluate`] for the error).
    pub fn gradient(&self) -> Params {
        match self.evaluate() {
            Ok((_, g)) => g,
            Err(_) => {
                let mut p = self.params();
                match &mut p.latent {
                    LatentParams::Free { x } => x.fill(f64::NAN),
                    LatentParams::BackConstrained { weights, bandwidth } => {
                        weights.fill(f64::NAN);
                        *bandwidth = f64::NAN;
                    }
                }
                for (_, k) in &mut p.spaces {
                    k.variance = f64::NAN;
                    k.noise = f64::NAN;
                    k.lengthscale.iter_mut().for_each(|l| *l = f64::NAN);
                }
                p
            }
        }
    }
}

/// Repeated objective + gradient evaluation at a model's parameters with every buffer reused:
/// exactly the work of one optimiser evaluation in a full fit (all spaces, latent block).
/// Meant for benchmarks and profiling.
pub struct Evaluator<'a> {
    obj: ModelObjective<'a>,
    theta: Vec<f64>,
    grad: Vec<f64>,
}

impl Evaluator<'_> {
    /// Evaluates the objective and the gradient (unconstrained parametrisation: latent block
    /// column-major, then per space log variance, log lengthscales, log noise).
    pub fn evaluate(&mut self) -> Result<f64> {
        self.obj.eval(&self.theta, &mut self.grad)
    }

    /// Gradient of the last [`Evaluator::evaluate`].
    pub fn gradient(&self) -> &[f64] {
        &self.grad
    }
}

impl SharedGplvm {
    /// An [`Evaluator`] at the current parameters.
    pub fn evaluator(&self) -> Result<Evaluator<'_>> {
        let obj = ModelObjective::new(self, Mode::Full)?;
        let theta = obj.theta0();
        let grad = vec![0.0; theta.len()];
        Ok(Evaluator { obj, theta, grad })
    }
}

fn check_shape(what: &str, m: MatRef<'_, f64>, n: usize, q: usize) -> Result<()> {
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

#[cfg(test)]
#[path = "model_tests.rs"]
mod tests;

/// Adds `scale · Σ_i exp(−Σ_t (p_t − r_it)² · w_t) · weights_i` to `out` over the `n` rows `r_i`
/// of `rows` (row-major, `p.len()` columns; `weights` row-major, `out.len()` columns). Rows are
/// taken in blocks of [`BLOCK`] so that the exponentials vectorise; allocation-free. The
/// per-frame kernel-row product shared by the human → latent step and the latent → robot mean.
fn add_kernel_weighted(
    p: &[f64],
    rows: &[f64],
    half_inv_l2: &[f64],
    weights: &[f64],
    scale: f64,
    n: usize,
    out: &mut [f64],
) {
    let (dim, wdim) = (p.len(), out.len());
    let mut kb = [0.0f64; BLOCK];
    let mut start = 0;
    while start < n {
        let end = (start + BLOCK).min(n);
        let k = &mut kb[..end - start];
        for (o, v) in k.iter_mut().enumerate() {
            let i = start + o;
            *v = weighted_sqdist(p, &rows[i * dim..(i + 1) * dim], half_inv_l2);
        }
        exp_neg_slice(k);
        for (o, &kv) in k.iter().enumerate() {
            let i = start + o;
            let wi = &weights[i * wdim..(i + 1) * wdim];
            let kv = scale * kv;
            for t in 0..wdim {
                out[t] += kv * wi[t];
            }
        }
        start = end;
    }
}
