//! The training objective: the negative log marginal likelihood summed over spaces,
//! `L(θ) = Σ_s L_s(X, α_s, ℓ_s, σ_s)` (see `likelihood`), on the unconstrained vector θ the
//! optimiser moves: the latent block (X, or W for back constraints) column-major, then per
//! space log α², log ℓ_q, log σ². In transfer (`Mode::Kernels`) only the new robot's kernel
//! moves and the frozen spaces add a constant.

use std::sync::{Arc, Mutex};

use faer::{Accum, Mat, MatRef};
use rayon::prelude::*;

use crate::back_constraint::{bandwidth_gradient, latent_points, weights_gradient};
use crate::error::{Error, Result};
use crate::kernel::{row_major, KernelParams};
use crate::likelihood::{eval_space, SpaceEval, SpaceWork, Wanted};
use crate::model::{Latent, SharedGplvm};
use crate::params::{LatentParams, Params};
use crate::pool::{in_pool, lock, on_pool_thread, par_for, ALONE_PARALLEL_FROM};
use crate::simd::clear_upper_simd_state;
use crate::train::Objective;

/// Points from which the spaces of one evaluation run on separate threads (below it the
/// thread hand-off costs more than it saves).
pub(crate) const SPACES_IN_PARALLEL_FROM: usize = 64;

/// Which parameters an optimisation moves.
#[derive(Clone, Debug)]
pub(crate) enum Mode {
    /// The latent block and every space's kernel.
    Full,
    /// Only the kernels of these spaces (latent frozen); other spaces add a constant.
    Kernels(Vec<usize>),
}

pub(crate) fn encode_kernel(k: &KernelParams, out: &mut Vec<f64>) {
    out.push(k.variance.ln());
    out.extend(k.lengthscale.iter().map(|l| l.ln()));
    out.push(k.noise.ln());
}

pub(crate) fn decode_kernel(t: &[f64], q: usize) -> KernelParams {
    KernelParams {
        variance: t[0].exp(),
        lengthscale: t[1..=q].iter().map(|v| v.exp()).collect(),
        noise: t[q + 1].exp(),
    }
}

/// Writes ∂L/∂(log p) = p ∂L/∂p for one space.
pub(crate) fn kernel_grad_log(k: &KernelParams, e: &SpaceEval, out: &mut [f64]) {
    out[0] = e.d_variance * k.variance;
    for (t, l) in k.lengthscale.iter().enumerate() {
        out[1 + t] = e.d_lengthscale[t] * l;
    }
    out[k.lengthscale.len() + 1] = e.d_noise * k.noise;
}

pub(crate) struct ModelObjective<'a> {
    model: &'a SharedGplvm,
    mode: Mode,
    /// The matrix that maps the latent block to X for back-constrained models in full mode:
    /// K_bc (block W), or `K_bc P` when whitened (block V, see [`Whitening`]).
    kbc: Option<Arc<Mat<f64>>>,
    /// The whitened parametrisation of the weights, when [`ModelObjective::whitened`] set it.
    whitening: Option<Whitening>,
    /// Sum of the frozen spaces' objective (Kernels mode).
    constant: f64,
    /// Latent points row-major (Kernels mode).
    x_rows: Vec<f64>,
    works: Mutex<Vec<SpaceWork>>,
    /// ∂L/∂X of the last evaluation, for back-constrained models (before the chain rule to W).
    latent_grad: Mutex<Option<Mat<f64>>>,
}

impl<'a> ModelObjective<'a> {
    pub(crate) fn new(model: &'a SharedGplvm, mode: Mode) -> Result<Self> {
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
            ) => Some(model.bc.kbc(data.as_ref(), *bandwidth)),
            _ => None,
        };
        let mut constant = 0.0;
        if let Mode::Kernels(v) = &mode {
            // A frozen space's likelihood is in the model's prediction caches when it has
            // them (a transfer's source model): the same factorisation, not made again.
            let cached = model.prepared.get().map(|p| &p.caches);
            let mut w = SpaceWork::new(n, 1);
            for (s, space) in model.spaces.iter().enumerate() {
                if v.contains(&s) {
                    continue;
                }
                if let Some(c) = cached.and_then(|c| c.get(s)) {
                    constant += c.nll;
                    continue;
                }
                if w.alpha().ncols() != space.data.ncols() {
                    w = SpaceWork::new(n, space.data.ncols());
                }
                constant += space.factorise(&model.x_rows, model.q(), &mut w)?.nll;
            }
        }
        Ok(Self {
            model,
            mode,
            kbc,
            whitening: None,
            constant,
            x_rows: model.x_rows.clone(),
            works: Mutex::new(works),
            latent_grad: Mutex::new(None),
        })
    }

    pub(crate) fn evaluated(&self) -> Vec<usize> {
        match &self.mode {
            Mode::Full => (0..self.model.spaces.len()).collect(),
            Mode::Kernels(v) => v.clone(),
        }
    }

    pub(crate) fn theta0(&self) -> Vec<f64> {
        let m = self.model;
        let mut t = Vec::new();
        if let Mode::Full = self.mode {
            let whitened;
            let lat = match (&m.latent, &self.whitening) {
                (Latent::Free { x }, _) => x,
                (Latent::Back { weights, .. }, None) => weights,
                (Latent::Back { weights, .. }, Some(w)) => {
                    whitened = w.to_block(weights.as_ref());
                    &whitened
                }
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

    pub(crate) fn latent_len(&self) -> usize {
        match self.mode {
            Mode::Full => self.model.n() * self.model.q(),
            Mode::Kernels(_) => 0,
        }
    }

    /// This objective in the whitened parametrisation of the back-constraint weights (see
    /// [`Whitening`]); unchanged for free latent points and in `Mode::Kernels`.
    pub(crate) fn whitened(mut self) -> Result<Self> {
        if let (Some(kbc), Latent::Back { .. }) = (&self.kbc, &self.model.latent) {
            crate::memory::check(
                "training with whitened back-constraint weights",
                kbc.nrows(),
                crate::memory::fit_matrices(self.model.spaces.len())
                    + crate::memory::WHITENING_MATRICES,
            )?;
            let w = Whitening::new(kbc.as_ref().as_ref())?;
            self.kbc = Some(Arc::new(w.map.clone()));
            self.whitening = Some(w);
        }
        Ok(self)
    }

    /// Writes `theta` into a copy of the model (no caches rebuilt).
    pub(crate) fn apply(&self, theta: &[f64], target: &mut SharedGplvm) {
        let (n, q) = (target.n(), target.q());
        let ll = self.latent_len();
        if ll > 0 {
            let lat = Mat::from_fn(n, q, |i, j| theta[j * n + i]);
            match &mut target.latent {
                Latent::Free { x } => *x = lat,
                Latent::Back { weights, .. } => {
                    *weights = match &self.whitening {
                        Some(w) => w.to_weights(lat.as_ref()),
                        None => lat,
                    }
                }
            }
        }
        let mut off = ll;
        for s in self.evaluated() {
            target.spaces[s].kernel = decode_kernel(&theta[off..off + q + 2], q);
            off += q + 2;
        }
    }
}

/// Relative floor of the eigenvalues of K_bc in [`Whitening`]: directions below
/// `WHITEN_FLOOR · λ_max` (duplicate frames make K_bc singular) are scaled as if their
/// eigenvalue were the floor.
const WHITEN_FLOOR: f64 = 1e-10;

/// The whitened parametrisation of back-constraint weights: `W = P V` with
/// `P = U Λ^(−1/2) Uᵀ` from the eigendecomposition `K_bc = U Λ Uᵀ` (eigenvalues floored at
/// [`WHITEN_FLOOR`] λ_max), so that `X = K_bc P V ≈ K_bc^(1/2) V` and the optimiser moves V.
/// P is invertible, so the latent points reachable are the same as with W; what changes is
/// the conditioning: the Hessian in W is `K_bc H_X K_bc` (condition number up to cond(K_bc)²
/// times that of the free-latent Hessian H_X), in V it is `K_bc^(1/2) H_X K_bc^(1/2)`.
/// (V's squared norm is the RKHS norm WᵀK_bcW of the mapping: the "whitening" of GP
/// literature.)
pub(crate) struct Whitening {
    /// `P = K_bc^(−1/2)`: V → W.
    p: Mat<f64>,
    /// `P⁻¹ = K_bc^(1/2)`: W → V.
    p_inv: Mat<f64>,
    /// `K_bc P`: V → X, computed as this product so that X is the model's `K_bc W` up to
    /// rounding.
    map: Mat<f64>,
}

impl Whitening {
    /// The whitening of `kbc` (symmetric positive semi-definite).
    pub(crate) fn new(kbc: MatRef<'_, f64>) -> Result<Self> {
        use faer::dyn_stack::{MemBuffer, MemStack};
        use faer::linalg::evd;
        let n = kbc.nrows();
        let par = par_for(n);
        let mut u = Mat::zeros(n, n);
        let mut s = faer::diag::Diag::zeros(n);
        evd::self_adjoint_evd(
            kbc,
            s.as_mut(),
            Some(u.as_mut()),
            par,
            MemStack::new(&mut MemBuffer::new(evd::self_adjoint_evd_scratch::<f64>(
                n,
                evd::ComputeEigenvectors::Yes,
                par,
                Default::default(),
            ))),
            Default::default(),
        )
        .map_err(|e| Error::InvalidValue {
            what: "back-constraint kernel matrix".into(),
            reason: format!("eigendecomposition failed ({e:?})"),
        })?;
        let s = s.column_vector();
        let top = (0..n).fold(0.0f64, |m, i| m.max(s[i]));
        let floor = (WHITEN_FLOOR * top).max(f64::MIN_POSITIVE);
        let root: Vec<f64> = (0..n).map(|i| s[i].max(floor).sqrt()).collect();
        let scaled = |f: &dyn Fn(f64) -> f64| {
            let us = Mat::from_fn(n, n, |i, j| u[(i, j)] * f(root[j]));
            let mut out = Mat::zeros(n, n);
            faer::linalg::matmul::matmul(
                out.as_mut(),
                Accum::Replace,
                us.as_ref(),
                u.transpose(),
                1.0,
                par,
            );
            out
        };
        let p = scaled(&|r| 1.0 / r);
        let p_inv = scaled(&|r| r);
        let mut map = Mat::zeros(n, n);
        faer::linalg::matmul::matmul(map.as_mut(), Accum::Replace, kbc, p.as_ref(), 1.0, par);
        Ok(Self { p, p_inv, map })
    }

    /// The weights `W = P V` of the block V.
    pub(crate) fn to_weights(&self, v: MatRef<'_, f64>) -> Mat<f64> {
        latent_points(self.p.as_ref(), v, par_for(v.nrows()))
    }

    /// The block `V = P⁻¹ W` of the weights W.
    pub(crate) fn to_block(&self, w: MatRef<'_, f64>) -> Mat<f64> {
        latent_points(self.p_inv.as_ref(), w, par_for(w.nrows()))
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
        // enough for faer's threads (a small transfer evaluates one space and would only pay
        // the hand-off to a pool thread).
        let n = self.model.n();
        let spaces = match &self.mode {
            Mode::Full => self.model.spaces.len(),
            Mode::Kernels(v) => v.len(),
        };
        if (spaces > 1 && n >= SPACES_IN_PARALLEL_FROM) || n >= ALONE_PARALLEL_FROM {
            in_pool(|| self.eval_here(theta, grad))
        } else {
            self.eval_here(theta, grad)
        }
    }
}

impl ModelObjective<'_> {
    /// [`Objective::eval`] on the calling thread (spaces in parallel if it is a pool thread).
    fn eval_here(&self, theta: &[f64], grad: &mut [f64]) -> Result<f64> {
        let (n, q) = (self.model.n(), self.model.q());
        let ll = self.latent_len();
        let owned_rows = (ll > 0).then(|| self.latent_rows(&theta[..ll]));
        let xr = owned_rows.as_deref().unwrap_or(&self.x_rows);
        let kernels = self.kernels(&theta[ll..])?;
        let results = self.eval_spaces(xr, &kernels);
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
            self.latent_gradient(&dx, &mut grad[..ll]);
        }
        Ok(total)
    }

    /// The latent points, row-major, from the latent block of θ (X itself, or `K_bc W`).
    fn latent_rows(&self, block: &[f64]) -> Vec<f64> {
        let (n, q) = (self.model.n(), self.model.q());
        let lat = MatRef::from_column_major_slice(block, n, q);
        let x = match &self.kbc {
            Some(k) => latent_points(k.as_ref().as_ref(), lat, par_for(n)),
            None => lat.to_owned(),
        };
        clear_upper_simd_state();
        row_major(x.as_ref())
    }

    /// The kernels of the evaluated spaces from the kernel part of θ (log parameters).
    fn kernels(&self, theta: &[f64]) -> Result<Vec<KernelParams>> {
        let q = self.model.q();
        let evaluated = self.evaluated();
        let mut kernels = Vec::with_capacity(evaluated.len());
        for (i, &s) in evaluated.iter().enumerate() {
            let k = decode_kernel(&theta[i * (q + 2)..(i + 1) * (q + 2)], q);
            if !k.is_valid() {
                return Err(Error::InvalidValue {
                    what: format!("kernel of '{}'", self.model.spaces[s].name),
                    reason: "overflow".into(),
                });
            }
            kernels.push(k);
        }
        Ok(kernels)
    }

    /// Evaluates every space at latent points `xr`, each on its own thread when worth it, into
    /// its own latent gradient (empty when the latent block is frozen). The spaces share only
    /// X, and their results are summed by the caller in a fixed order (deterministic).
    fn eval_spaces(
        &self,
        xr: &[f64],
        kernels: &[KernelParams],
    ) -> Vec<Result<(SpaceEval, Vec<f64>)>> {
        let m = self.model;
        let (n, q) = (m.n(), m.q());
        let with_latent = self.latent_len() > 0;
        let evaluated = self.evaluated();
        let mut works = lock(&self.works);
        let side_by_side = evaluated.len() > 1 && n >= SPACES_IN_PARALLEL_FROM && on_pool_thread();
        let alongside = if side_by_side { evaluated.len() } else { 1 };
        let one_space = |(w, (&s, k)): (&mut SpaceWork, (&usize, &KernelParams))| {
            let mut dx = vec![0.0; if with_latent { n * q } else { 0 }];
            let space = &m.spaces[s];
            let wanted = if with_latent {
                Wanted::AllGradients(&mut dx[..])
            } else {
                Wanted::KernelGradient
            };
            eval_space(xr, q, space.data.as_ref(), k, w, alongside, wanted)
                .map(|e| (e, dx))
                .map_err(|e| e.in_space(&space.name))
        };
        if side_by_side {
            works
                .par_iter_mut()
                .zip(evaluated.par_iter().zip(kernels.par_iter()))
                .map(one_space)
                .collect()
        } else {
            works
                .iter_mut()
                .zip(evaluated.iter().zip(kernels))
                .map(one_space)
                .collect()
        }
    }

    /// Writes the latent block's gradient from `dx` = ∂L/∂X (row-major): ∂L/∂X itself, or
    /// `K_bcᵀ ∂L/∂X` for back constraints (∂L/∂X is then kept for the bandwidth gradient).
    fn latent_gradient(&self, dx: &[f64], out: &mut [f64]) {
        let (n, q) = (self.model.n(), self.model.q());
        let dxm = Mat::from_fn(n, q, |i, j| dx[i * q + j]);
        match &self.kbc {
            Some(k) => {
                let gm = faer::MatMut::from_column_major_slice_mut(out, n, q);
                weights_gradient(k.as_ref().as_ref(), dxm.as_ref(), gm, par_for(n));
                *lock(&self.latent_grad) = Some(dxm);
            }
            None => {
                for j in 0..q {
                    for i in 0..n {
                        out[j * n + i] = dxm[(i, j)];
                    }
                }
            }
        }
    }
}

impl SharedGplvm {
    /// Objective and gradient (natural units, same structure as [`SharedGplvm::params`]; the
    /// bandwidth entry holds ∂L/∂bandwidth).
    pub fn evaluate(&self) -> Result<(f64, Params)> {
        if self.sparse.is_some() {
            return self.evaluate_sparse();
        }
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
                let Some(dx) = lock(&obj.latent_grad).take() else {
                    unreachable!("a full evaluation of a back-constrained model sets it");
                };
                let kd2 = self.bc.kd2(data.as_ref(), *bandwidth);
                let db = bandwidth_gradient(
                    dx.as_ref(),
                    weights.as_ref(),
                    kd2.as_ref().as_ref(),
                    *bandwidth,
                );
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
        if self.sparse.is_some() {
            return Err(Error::InvalidValue {
                what: "evaluator".into(),
                reason: "a sparse model; use sparse_evaluator".into(),
            });
        }
        let obj = ModelObjective::new(self, Mode::Full)?;
        let theta = obj.theta0();
        let grad = vec![0.0; theta.len()];
        Ok(Evaluator { obj, theta, grad })
    }
}

#[cfg(test)]
mod tests {
    use crate::test_support::*;

    #[test]
    fn gradients_match_finite_differences_for_every_block_and_parametrisation() {
        let mut worst = 0.0f64;
        for bc in [
            BackConstraint::None,
            BackConstraint::Input,
            BackConstraint::Output,
        ] {
            // 24 points evaluates the spaces one after the other, 80 on separate threads.
            for (seed, n) in [(0, 24), (1, 24), (2, 80)] {
                let mut model = fit(bc, n, 3, seed);
                // Move to a random point so that no gradient is accidentally ~0.
                let mut rng = ChaCha8Rng::seed_from_u64(100 + seed);
                for s in &mut model.spaces {
                    s.kernel.variance *= rng.random_range(0.7..1.5);
                    s.kernel.noise = rng.random_range(0.05..0.3);
                    for l in &mut s.kernel.lengthscale {
                        *l = rng.random_range(0.5..2.0);
                    }
                }
                model.update_latent_points();
                let (_, g) = model.evaluate().expect("evaluate");
                let p = model.params();
                let values = flatten(&p);
                let grads = flatten(&g);
                let total = values.len();
                assert_eq!(grads.len(), total);
                let ll = n * 2;
                // Every latent entry (X, or all N·Q back-constraint weights) of the small
                // models, a few of the large one; the bandwidth and every kernel scalar.
                let mut idx: Vec<usize> = if n <= 24 {
                    (0..ll).collect()
                } else {
                    vec![0, 5, ll / 2 + 3, ll - 1]
                };
                idx.extend(ll..total);
                for which in idx {
                    let scale = values[which].abs().max(1.0);
                    let h = 1e-6 * scale;
                    let fd = (objective_at(&model, &bump(&p, which, h))
                        - objective_at(&model, &bump(&p, which, -h)))
                        / (2.0 * h);
                    let an = grads[which];
                    worst = worst.max((an - fd).abs() / (1.0 + fd.abs()));
                    assert!(
                        (an - fd).abs() <= 1e-6 * (1.0 + fd.abs()),
                        "{bc:?} seed {seed} n {n} param {which}: analytic {an} vs fd {fd}"
                    );
                }
            }
        }
        // Measured 8.2e-8 (central differences, h = 1e-6 relative); tolerance 1e-6 above.
        assert!(worst < 1e-6, "{worst:e}");
    }

    #[test]
    fn whitened_weights_have_finite_difference_gradients_and_reach_the_same_points() {
        use crate::objective::{Mode, ModelObjective};
        use crate::train::Objective;
        for bc in [BackConstraint::Input, BackConstraint::Output] {
            let model = fit(bc, 24, 3, 5);
            let plain = ModelObjective::new(&model, Mode::Full).expect("objective");
            let white = ModelObjective::new(&model, Mode::Full)
                .expect("objective")
                .whitened()
                .expect("whitened");
            let (t_plain, t_white) = (plain.theta0(), white.theta0());
            assert_ne!(t_plain, t_white, "{bc:?}: the block did not change");
            // The same model, so the same objective and the same kernel gradients.
            let mut g_plain = vec![0.0; t_plain.len()];
            let mut g = vec![0.0; t_white.len()];
            let f_plain = plain.eval(&t_plain, &mut g_plain).expect("eval");
            let f = white.eval(&t_white, &mut g).expect("eval");
            assert!(
                (f - f_plain).abs() < 1e-9 * f.abs(),
                "{bc:?}: {f} vs {f_plain}"
            );
            let ll = 24 * 2;
            for k in ll..g.len() {
                assert!(
                    (g[k] - g_plain[k]).abs() < 1e-7 * (1.0 + g[k].abs()),
                    "{bc:?} {k}"
                );
            }
            // V → W → V round trip, and the model written from V has the evaluated X.
            let mut m = model.clone();
            white.apply(&t_white, &mut m);
            m.update_latent_points();
            for (a, b) in
                m.x.col_iter()
                    .flat_map(|c| c.iter().copied().collect::<Vec<_>>())
                    .zip(
                        model
                            .x
                            .col_iter()
                            .flat_map(|c| c.iter().copied().collect::<Vec<_>>()),
                    )
            {
                assert!(
                    (a - b).abs() < 1e-8 * (1.0 + b.abs()),
                    "{bc:?}: X {a} vs {b}"
                );
            }
            // Central differences on every entry of V.
            let mut worst = 0.0f64;
            for k in 0..ll {
                let h = 1e-6 * t_white[k].abs().max(1.0);
                let at = |d: f64| {
                    let mut t = t_white.clone();
                    t[k] += d;
                    let mut gg = vec![0.0; t.len()];
                    white.eval(&t, &mut gg).expect("eval")
                };
                let fd = (at(h) - at(-h)) / (2.0 * h);
                let err = (g[k] - fd).abs() / (1.0 + fd.abs());
                worst = worst.max(err);
                assert!(err < 1e-6, "{bc:?} V[{k}]: analytic {} vs fd {fd}", g[k]);
            }
            assert!(worst < 1e-6, "{worst:e}");
        }
    }

    /// Time to solution of back-constrained training on the bench's data, plain and whitened
    /// weights, or of free latent points (issue 18). `BC_DATA` names a file of little-endian
    /// f64: n, d_human, d_robot, then the human rows and the robot rows (benches' smooth_data,
    /// written by Python);
    /// `BC_LEVEL` the objective level to reach; `BC_MEMORY` the L-BFGS memory sizes to try
    /// (`TrainOptions::back_constraint_memory`; default its default); `BC_MAX_ITERS` the
    /// iteration budget (default 100,000). `BC_CONSTRAINT=none` trains free latent points
    /// instead (`BC_MEMORY` is then `TrainOptions::memory`, and there are no weights to
    /// whiten); `BC_HISTORY=PREFIX` writes each run's history (iteration, evaluations,
    /// objective) to `PREFIX-m{memory}-w{0|1}.csv`; `BC_NUDGE=k` multiplies the first human
    /// value by 1 + k·10⁻¹⁵, a last-bits change of the problem, to see how far the late
    /// phase's path depends on rounding (BENCHMARKS.md, issue 18's twelfth pass).
    /// `BC_DATA=/tmp/bc.bin cargo test --release -p sgplvm-core --lib whitened_time -- --ignored --nocapture`
    #[test]
    #[ignore = "measurement, not a check: needs BC_DATA and trains for minutes (BENCHMARKS.md, issue 18)"]
    fn whitened_time_to_solution() {
        let Some((mut h, r)) = bench_data_from_env() else {
            return;
        };
        if let Ok(k) = std::env::var("BC_NUDGE") {
            h[(0, 0)] *= 1.0 + k.parse::<f64>().expect("BC_NUDGE is a number") * 1e-15;
        }
        let level: f64 = std::env::var("BC_LEVEL").map_or(f64::NEG_INFINITY, |s| {
            s.parse().expect("BC_LEVEL is a number")
        });
        let max_iters: usize = std::env::var("BC_MAX_ITERS").map_or(100_000, |s| {
            s.parse().expect("BC_MAX_ITERS is a number of iterations")
        });
        let free = std::env::var("BC_CONSTRAINT").is_ok_and(|s| s == "none");
        let defaults = TrainOptions::default();
        let default_memory = if free {
            defaults.memory
        } else {
            defaults.back_constraint_memory
        };
        let memories: Vec<usize> = std::env::var("BC_MEMORY").map_or(vec![default_memory], |s| {
            s.split(',').map(|m| m.parse().expect("memory")).collect()
        });
        let whitens: Vec<bool> = if free {
            vec![false]
        } else {
            std::env::var("BC_WHITEN").map_or(vec![false, true], |s| {
                s.split(',').map(|m| m == "1").collect()
            })
        };
        let history_prefix = std::env::var("BC_HISTORY").ok();
        let config = ModelConfig::default()
            .with_latent_dim(5)
            .with_back_constraint(if free {
                BackConstraint::None
            } else {
                BackConstraint::Input
            });
        for &memory in &memories {
            for &whiten in &whitens {
                let options = TrainOptions::default()
                    .with_max_iters(max_iters)
                    .with_whiten_back_constraint(whiten);
                let options = if free {
                    options.with_memory(memory)
                } else {
                    options.with_back_constraint_memory(memory)
                };
                let t = std::time::Instant::now();
                let m = SharedGplvm::fit(
                    &config,
                    &[("human", h.as_ref()), ("robot", r.as_ref())],
                    "human",
                    &options,
                    None,
                )
                .expect("fit");
                let hist = m.history();
                if let Some(prefix) = &history_prefix {
                    let rows: String = hist
                        .iter()
                        .map(|r| format!("{},{},{:.6}\n", r.iteration, r.evaluations, r.objective))
                        .collect();
                    let path = format!("{prefix}-m{memory}-w{}.csv", u8::from(whiten));
                    std::fs::write(&path, format!("iteration,evaluations,objective\n{rows}"))
                        .expect("BC_HISTORY writes");
                }
                let last = hist.last().expect("history");
                let target = level + 1e-4 * level.abs();
                let reached = hist.iter().find(|r| r.objective <= target);
                println!(
                    "memory {memory} whiten {whiten}: {} iterations, {} evaluations, final {:.4}, \
                     {:?}, fit {:.2} s; level {level} reached at {}",
                    last.iteration,
                    last.evaluations,
                    last.objective,
                    m.stop_reason(),
                    t.elapsed().as_secs_f64(),
                    reached.map_or("never".into(), |r| format!(
                        "iteration {} ({} evaluations, {:.2} s)",
                        r.iteration, r.evaluations, r.seconds
                    )),
                );
                for k in [0usize, 10, 100, 1000, 3000, 10000, 30000] {
                    if let Some(r) = hist.get(k) {
                        println!(
                            "    iteration {k}: {:.4} (|g| {:.3e})",
                            r.objective, r.gradient_norm
                        );
                    }
                }
            }
        }
    }

    /// Diagonal entries of the free-latent training objective's Hessian, by central
    /// differences of the gradient (step 1e-4 in θ), at iterations 1, 10, 100, 1,000 and 3,000
    /// of training on `BC_DATA` (as [`whitened_time_to_solution`]): twelve latent coordinates
    /// drawn at random, every kernel log-parameter, and the latent block's mean diagonal
    /// (Rayleigh quotient of a random ±1 vector). Shows which block is stiff and how far the
    /// curvature spreads within it (BENCHMARKS.md, issue 18's thirteenth pass).
    /// `BC_DATA=/tmp/bc.bin cargo test --release -p sgplvm-core --lib hessian_diagonal -- --ignored --nocapture`
    #[test]
    #[ignore = "measurement, not a check: needs BC_DATA and prints curvatures (BENCHMARKS.md, issue 18)"]
    fn hessian_diagonal_by_blocks() {
        use super::{Mode, ModelObjective};
        use crate::train::{Control, IterationRecord, Objective};
        let Some((h, r)) = bench_data_from_env() else {
            return;
        };
        let config = ModelConfig::default()
            .with_latent_dim(5)
            .with_back_constraint(BackConstraint::None);
        let at = [1usize, 10, 100, 1000, 3000];
        let mut report = |rec: &IterationRecord, m: &SharedGplvm| {
            if !at.contains(&rec.iteration) {
                return Control::Continue;
            }
            let obj = ModelObjective::new(m, Mode::Full).expect("objective");
            let theta = obj.theta0();
            let (len, latent) = (theta.len(), obj.latent_len());
            // H v by central differences of the gradient.
            let hessian_times = |v: &[f64]| -> Vec<f64> {
                let eps = 1e-4;
                let [plus, minus] = [eps, -eps].map(|e| {
                    let t: Vec<f64> = theta.iter().zip(v).map(|(a, b)| a + e * b).collect();
                    let mut g = vec![0.0; len];
                    obj.eval(&t, &mut g).expect("evaluation");
                    g
                });
                plus.iter()
                    .zip(&minus)
                    .map(|(p, m)| (p - m) / (2.0 * eps))
                    .collect()
            };
            // One generator per report: the same signs and coordinates at every iteration.
            let mut rng = ChaCha8Rng::seed_from_u64(7);
            let signs: Vec<f64> = (0..len)
                .map(|k| {
                    if k >= latent {
                        0.0
                    } else if rng.random_bool(0.5) {
                        1.0
                    } else {
                        -1.0
                    }
                })
                .collect();
            let mean_latent = signs
                .iter()
                .zip(hessian_times(&signs))
                .map(|(a, b)| a * b)
                .sum::<f64>()
                / latent as f64;
            println!(
                "iteration {} (objective {:.4}): latent block's mean diagonal {mean_latent:.3e}",
                rec.iteration, rec.objective
            );
            let sampled: Vec<usize> = (0..12).map(|_| rng.random_range(0..latent)).collect();
            for i in sampled.into_iter().chain(latent..len) {
                let mut e = vec![0.0; len];
                e[i] = 1.0;
                let name = if i < latent {
                    format!("X[{}, {}]", i % m.n(), i / m.n())
                } else {
                    format!("kernel log-parameter {}", i - latent)
                };
                println!(
                    "    {name}: {:.3e} (θ = {:.3})",
                    hessian_times(&e)[i],
                    theta[i]
                );
            }
            Control::Continue
        };
        SharedGplvm::fit(
            &config,
            &[("human", h.as_ref()), ("robot", r.as_ref())],
            "human",
            &TrainOptions::default().with_max_iters(at[at.len() - 1]),
            Some(&mut report),
        )
        .expect("fit");
    }
}
