//! The sparse training objective: the negative bound summed over spaces on the optimiser's
//! vector θ — the latent block (X, or the centres' weights W) column-major, for the Bayesian
//! model then log S (q(X)'s variances, N×Q) column-major, then Z column-major (unless fixed),
//! then per space log α², log ℓ_q, log σ². The Bayesian model's objective adds
//! KL(q(X) ‖ N(0, I)) and takes its latent block as q(X)'s means. In transfer (`Mode::Kernels`)
//! only the listed spaces' kernels move; X (and S), Z and the other spaces are frozen and add a
//! constant.

use std::sync::Mutex;

use faer::{Accum, Mat, MatRef, Par};
use rayon::prelude::*;

use super::bayesian::{eval_bayes_space, kl_divergence, Jitter};
use super::likelihood::{eval_sparse_space, eval_sparse_space_in, SparseWork, RELATIVE_JITTER};
use super::{bc_cross, SparseState};
use crate::error::{Error, Result};
use crate::kernel::{row_major, KernelParams};
use crate::model::{Latent, SharedGplvm};
use crate::objective::{decode_kernel, encode_kernel, Mode};
use crate::params::{LatentParams, Params};
use crate::pool::{in_pool, lock};
use crate::simd::clear_upper_simd_state;
use crate::train::Objective;

/// Frames from which one evaluation runs on the pool's threads (its spaces, and the blocks of
/// frames within each space, in parallel).
const PARALLEL_FROM: usize = 2000;

/// The sparse model's objective in `mode`.
pub(crate) struct SparseObjective<'a> {
    model: &'a SharedGplvm,
    mode: Mode,
    /// `K_bc(C, H)` (M_c×N) for input back constraints in full mode.
    kcn: Option<Mat<f64>>,
    /// Sum of the frozen spaces' objective (Kernels mode).
    constant: f64,
    /// Whether Z is part of θ.
    train_z: bool,
    /// Whether q(X)'s variances S are part of θ (the Bayesian model in full mode).
    train_var: bool,
    /// Per evaluated space, the buffers its evaluations reuse.
    works: Mutex<Vec<SparseWork>>,
}

fn state(model: &SharedGplvm) -> Result<&SparseState> {
    model.sparse.as_ref().ok_or_else(|| Error::Corrupt {
        reason: "the sparse objective of a model without inducing inputs".into(),
    })
}

impl<'a> SparseObjective<'a> {
    pub(crate) fn new(model: &'a SharedGplvm, mode: Mode) -> Result<Self> {
        let st = state(model)?;
        let kcn = match (&mode, &model.latent) {
            (
                Mode::Full,
                Latent::Back {
                    bandwidth, data, ..
                },
            ) => Some(bc_cross(
                model.spaces[0].data.as_ref(),
                data.as_ref(),
                *bandwidth,
            )),
            _ => None,
        };
        let mut constant = 0.0;
        if let Mode::Kernels(v) = &mode {
            for s in (0..model.spaces.len()).filter(|s| !v.contains(s)) {
                constant += frozen_space_term(model, st, s)?;
            }
            if st.latent_var.is_some() {
                constant += kl_divergence(&model.x_rows, &st.var_rows, None);
            }
        }
        let train_z = matches!(mode, Mode::Full) && !model.config.fixed_inducing;
        let train_var = matches!(mode, Mode::Full) && st.latent_var.is_some();
        let spaces = match &mode {
            Mode::Full => model.spaces.len(),
            Mode::Kernels(v) => v.len(),
        };
        Ok(Self {
            model,
            mode,
            kcn,
            constant,
            train_z,
            train_var,
            works: Mutex::new(st.work.take(spaces)),
        })
    }

    pub(crate) fn evaluated(&self) -> Vec<usize> {
        match &self.mode {
            Mode::Full => (0..self.model.spaces.len()).collect(),
            Mode::Kernels(v) => v.clone(),
        }
    }

    fn latent_rows_count(&self) -> usize {
        match &self.model.latent {
            Latent::Free { x } => x.nrows(),
            Latent::Back { weights, .. } => weights.nrows(),
        }
    }

    fn latent_len(&self) -> usize {
        match self.mode {
            Mode::Full => self.latent_rows_count() * self.model.q(),
            Mode::Kernels(_) => 0,
        }
    }

    fn var_len(&self) -> usize {
        if self.train_var {
            self.model.n() * self.model.q()
        } else {
            0
        }
    }

    fn z_len(&self) -> usize {
        if self.train_z {
            self.model.sparse.as_ref().map_or(0, |s| s.m()) * self.model.q()
        } else {
            0
        }
    }

    pub(crate) fn theta0(&self) -> Vec<f64> {
        let m = self.model;
        let mut t = Vec::new();
        if let Mode::Full = self.mode {
            let lat = match &m.latent {
                Latent::Free { x } => x,
                Latent::Back { weights, .. } => weights,
            };
            push_col_major(lat.as_ref(), &mut t);
            if let (true, Some(s)) = (self.train_var, m.sparse.as_ref()) {
                if let Some(var) = &s.latent_var {
                    let start = t.len();
                    push_col_major(var.as_ref(), &mut t);
                    t[start..].iter_mut().for_each(|v| *v = v.ln());
                }
            }
            if self.train_z {
                if let Some(st) = &m.sparse {
                    push_col_major(st.z.as_ref(), &mut t);
                }
            }
        }
        for s in self.evaluated() {
            encode_kernel(&m.spaces[s].kernel, &mut t);
        }
        t
    }

    /// Writes `theta` into a copy of the model (no caches rebuilt).
    pub(crate) fn apply(&self, theta: &[f64], target: &mut SharedGplvm) {
        let q = target.q();
        let (ll, vl, zl) = (self.latent_len(), self.var_len(), self.z_len());
        if ll > 0 {
            let r = ll / q;
            let lat = Mat::from_fn(r, q, |i, j| theta[j * r + i]);
            match &mut target.latent {
                Latent::Free { x } => *x = lat,
                Latent::Back { weights, .. } => *weights = lat,
            }
        }
        if vl > 0 || zl > 0 {
            let old = target.sparse.as_ref();
            let var = match vl {
                0 => old.and_then(|s| s.latent_var.clone()),
                _ => {
                    let n = vl / q;
                    Some(Mat::from_fn(n, q, |i, j| theta[ll + j * n + i].exp()))
                }
            };
            let z = match zl {
                0 => old.map_or_else(|| Mat::zeros(0, q), |s| s.z.clone()),
                _ => {
                    let m = zl / q;
                    Mat::from_fn(m, q, |i, j| theta[ll + vl + j * m + i])
                }
            };
            target.sparse = Some(SparseState::new(z).with_latent_var(var));
        }
        let mut off = ll + vl + zl;
        for s in self.evaluated() {
            target.spaces[s].kernel = decode_kernel(&theta[off..off + q + 2], q);
            off += q + 2;
        }
    }

    /// Objective and gradient; also returns ∂L/∂X (row-major, empty when frozen).
    fn eval_full(&self, theta: &[f64], grad: &mut [f64]) -> Result<(f64, Vec<f64>)> {
        let m = self.model;
        let (n, q) = (m.n(), m.q());
        let st = state(m)?;
        let (ll, vl, zl) = (self.latent_len(), self.var_len(), self.z_len());
        let owned_x = (ll > 0).then(|| self.latent_rows(&theta[..ll]));
        let xr = owned_x.as_deref().unwrap_or(&m.x_rows);
        let owned_var = (vl > 0).then(|| {
            let mut r = rows_of_col_major(&theta[ll..ll + vl], q);
            r.iter_mut().for_each(|v| *v = v.exp());
            r
        });
        let sr = owned_var.as_deref().unwrap_or(&st.var_rows);
        let bayes = st.latent_var.is_some();
        if bayes && sr.iter().any(|&v| !(v > 0.0 && v.is_finite())) {
            return Err(Error::InvalidValue {
                what: "variances of q(X)".into(),
                reason: "overflow or underflow (expected finite values > 0)".into(),
            });
        }
        let owned_z = (zl > 0).then(|| rows_of_col_major(&theta[ll + vl..ll + vl + zl], q));
        let zr = owned_z.as_deref().unwrap_or(&st.z_rows);
        let kernels = self.decode_kernels(&theta[ll + vl + zl..])?;
        let inputs = Inputs { xr, sr, zr, bayes };
        let results = self.evaluate_spaces(&inputs, &kernels);
        let mut total = self.constant;
        let mut dx = vec![0.0; if ll > 0 { n * q } else { 0 }];
        let mut ds = vec![0.0; vl];
        let mut dz = vec![0.0; zl];
        for (i, (r, k)) in results.into_iter().zip(&kernels).enumerate() {
            let e = r?;
            total += e.nll;
            let off = ll + vl + zl + i * (q + 2);
            let g = &mut grad[off..off + q + 2];
            g[0] = e.d_variance * k.variance;
            for (t, l) in k.lengthscale.iter().enumerate() {
                g[1 + t] = e.d_lengthscale[t] * l;
            }
            g[q + 1] = e.d_noise * k.noise;
            dx.iter_mut().zip(&e.dx).for_each(|(a, b)| *a += b);
            ds.iter_mut().zip(&e.ds).for_each(|(a, b)| *a += b);
            dz.iter_mut().zip(&e.dz).for_each(|(a, b)| *a += b);
        }
        if bayes && matches!(self.mode, Mode::Full) {
            // Full mode trains the means and the variances: both gradients are there.
            total += kl_divergence(xr, sr, Some((&mut dx, &mut ds)));
        }
        self.write_latent_gradient(&dx, &ds, sr, &dz, grad);
        Ok((total, dx))
    }

    /// The evaluated spaces' kernels from their block of θ (`block` starts at the first).
    fn decode_kernels(&self, block: &[f64]) -> Result<Vec<KernelParams>> {
        let q = self.model.q();
        self.evaluated()
            .iter()
            .enumerate()
            .map(|(i, &s)| {
                let k = decode_kernel(&block[i * (q + 2)..(i + 1) * (q + 2)], q);
                match k.is_valid() {
                    true => Ok(k),
                    false => Err(Error::InvalidValue {
                        what: format!("kernel of '{}'", self.model.spaces[s].name),
                        reason: "overflow".into(),
                    }),
                }
            })
            .collect()
    }

    /// Every evaluated space's bound and gradients, on the pool's threads from
    /// [`PARALLEL_FROM`] frames.
    fn evaluate_spaces(
        &self,
        inputs: &Inputs<'_>,
        kernels: &[KernelParams],
    ) -> Vec<Result<SpaceTerms>> {
        let evaluated = self.evaluated();
        let one = |((&s, k), work): ((&usize, &KernelParams), &mut SparseWork)| {
            self.space_terms(s, k, inputs, work)
        };
        let mut guard = lock(&self.works);
        let works: &mut Vec<SparseWork> = &mut guard;
        if self.model.n() >= PARALLEL_FROM {
            in_pool(|| {
                evaluated
                    .par_iter()
                    .zip(kernels.par_iter())
                    .zip(works.par_iter_mut())
                    .map(one)
                    .collect()
            })
        } else {
            evaluated
                .iter()
                .zip(kernels.iter())
                .zip(works.iter_mut())
                .map(one)
                .collect()
        }
    }

    /// Space `s`'s share: the Bayesian bound or the point model's sparse bound, with the
    /// gradients θ holds (latent, variances, Z).
    fn space_terms(
        &self,
        s: usize,
        k: &KernelParams,
        inputs: &Inputs<'_>,
        work: &mut SparseWork,
    ) -> Result<SpaceTerms> {
        let space = &self.model.spaces[s];
        let q = self.model.q();
        let named = |e: crate::likelihood::NotPd| e.in_space(&space.name);
        let (with_x, with_var, with_z) =
            (self.latent_len() > 0, self.var_len() > 0, self.z_len() > 0);
        if inputs.bayes {
            let e = eval_bayes_space(
                inputs.xr,
                inputs.sr,
                inputs.zr,
                q,
                space.data.as_ref(),
                k,
                Jitter::Relative(RELATIVE_JITTER),
                true,
            )
            .map_err(named)?;
            return Ok(SpaceTerms {
                nll: e.nll,
                d_variance: e.d_variance,
                d_lengthscale: e.d_lengthscale,
                d_noise: e.d_noise,
                dx: if with_x { e.d_mean } else { Vec::new() },
                ds: if with_var { e.d_var } else { Vec::new() },
                dz: if with_z { e.d_z } else { Vec::new() },
            });
        }
        let mut dx = vec![0.0; if with_x { self.model.n() * q } else { 0 }];
        let mut dz = vec![0.0; self.z_len()];
        let e = eval_sparse_space_in(
            inputs.xr,
            inputs.zr,
            q,
            space.data.as_ref(),
            k,
            RELATIVE_JITTER,
            true,
            with_x.then_some(&mut dx[..]),
            with_z.then_some(&mut dz[..]),
            work,
        )
        .map_err(named)?;
        Ok(SpaceTerms {
            nll: e.nll,
            d_variance: e.d_variance,
            d_lengthscale: e.d_lengthscale,
            d_noise: e.d_noise,
            dx,
            ds: Vec::new(),
            dz,
        })
    }

    /// Writes the row-major gradients of the latent points `dx`, of q(X)'s variances `ds`
    /// (as ∂/∂log S, `sr` the variances) and of Z `dz` into θ's column-major blocks; the
    /// latent block through the back constraint when there is one.
    fn write_latent_gradient(
        &self,
        dx: &[f64],
        ds: &[f64],
        sr: &[f64],
        dz: &[f64],
        grad: &mut [f64],
    ) {
        let (n, q) = (self.model.n(), self.model.q());
        let (ll, vl, zl) = (self.latent_len(), self.var_len(), self.z_len());
        if vl > 0 {
            // ∂/∂log S = S ∂/∂S.
            let nr = vl / q;
            for j in 0..q {
                for i in 0..nr {
                    grad[ll + j * nr + i] = ds[i * q + j] * sr[i * q + j];
                }
            }
        }
        if zl > 0 {
            let mz = zl / q;
            for j in 0..q {
                for i in 0..mz {
                    grad[ll + vl + j * mz + i] = dz[i * q + j];
                }
            }
        }
        if ll == 0 {
            return;
        }
        let dxm = Mat::from_fn(n, q, |i, j| dx[i * q + j]);
        match &self.kcn {
            Some(kcn) => {
                let r = kcn.nrows();
                let out = faer::MatMut::from_column_major_slice_mut(&mut grad[..ll], r, q);
                let (a, b) = (kcn.as_ref(), dxm.as_ref());
                faer::linalg::matmul::matmul(out, Accum::Replace, a, b, 1.0, Par::Seq);
                clear_upper_simd_state();
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

    /// Latent points row-major from the latent block of θ.
    fn latent_rows(&self, block: &[f64]) -> Vec<f64> {
        let q = self.model.q();
        let r = block.len() / q;
        let lat = MatRef::from_column_major_slice(block, r, q);
        match &self.kcn {
            Some(kcn) => {
                let mut x = Mat::zeros(kcn.ncols(), q);
                faer::linalg::matmul::matmul(
                    x.as_mut(),
                    Accum::Replace,
                    kcn.transpose(),
                    lat,
                    1.0,
                    Par::Seq,
                );
                clear_upper_simd_state();
                row_major(x.as_ref())
            }
            None => row_major(lat),
        }
    }
}

/// What every space's evaluation reads, row-major: the latent points (or q(X)'s means), q(X)'s
/// variances (empty for the point model) and Z.
struct Inputs<'x> {
    xr: &'x [f64],
    sr: &'x [f64],
    zr: &'x [f64],
    /// Whether the model is Bayesian.
    bayes: bool,
}

/// One space's share of an evaluation: its term, its kernel's derivatives and its derivatives
/// with respect to the latent points (or means), q(X)'s variances and Z, row-major (empty when
/// not wanted).
struct SpaceTerms {
    nll: f64,
    d_variance: f64,
    d_lengthscale: Vec<f64>,
    d_noise: f64,
    dx: Vec<f64>,
    ds: Vec<f64>,
    dz: Vec<f64>,
}

/// The term of a space that does not move (transfer), at the model's parameters.
fn frozen_space_term(model: &SharedGplvm, st: &SparseState, s: usize) -> Result<f64> {
    let space = &model.spaces[s];
    let term = match &st.latent_var {
        Some(_) => eval_bayes_space(
            &model.x_rows,
            &st.var_rows,
            &st.z_rows,
            model.q(),
            space.data.as_ref(),
            &space.kernel,
            Jitter::Relative(RELATIVE_JITTER),
            false,
        )
        .map(|e| e.nll),
        None => eval_sparse_space(
            &model.x_rows,
            &st.z_rows,
            model.q(),
            space.data.as_ref(),
            &space.kernel,
            RELATIVE_JITTER,
            false,
            None,
            None,
        )
        .map(|e| e.nll),
    };
    term.map_err(|e| e.in_space(&space.name))
}

/// A column-major block of `q` columns, row-major.
fn rows_of_col_major(block: &[f64], q: usize) -> Vec<f64> {
    let r = block.len() / q;
    let mut out = vec![0.0; block.len()];
    for j in 0..q {
        for i in 0..r {
            out[i * q + j] = block[j * r + i];
        }
    }
    out
}

fn push_col_major(m: MatRef<'_, f64>, out: &mut Vec<f64>) {
    for j in 0..m.ncols() {
        for i in 0..m.nrows() {
            out.push(m[(i, j)]);
        }
    }
}

impl Drop for SparseObjective<'_> {
    fn drop(&mut self) {
        if let Some(st) = &self.model.sparse {
            st.work.put(std::mem::take(&mut *lock(&self.works)));
        }
    }
}

impl Objective for SparseObjective<'_> {
    fn eval(&self, theta: &[f64], grad: &mut [f64]) -> Result<f64> {
        self.eval_full(theta, grad).map(|(f, _)| f)
    }
}

/// Repeated objective + gradient evaluation of a sparse model at its parameters (all spaces,
/// latent block and inducing inputs): the work of one optimiser evaluation in a sparse fit.
/// Meant for benchmarks and profiling.
pub struct SparseEvaluator<'a> {
    obj: SparseObjective<'a>,
    theta: Vec<f64>,
    grad: Vec<f64>,
}

impl SparseEvaluator<'_> {
    /// Evaluates the objective and the gradient.
    pub fn evaluate(&mut self) -> Result<f64> {
        self.obj.eval(&self.theta, &mut self.grad)
    }

    /// Gradient of the last [`SparseEvaluator::evaluate`] (θ order: latent block, Z, kernels).
    pub fn gradient(&self) -> &[f64] {
        &self.grad
    }
}

impl SharedGplvm {
    /// A [`SparseEvaluator`] at the current parameters of a sparse model (error for an exact
    /// one: use [`SharedGplvm::evaluator`]).
    pub fn sparse_evaluator(&self) -> Result<SparseEvaluator<'_>> {
        let obj = SparseObjective::new(self, Mode::Full)?;
        let theta = obj.theta0();
        let grad = vec![0.0; theta.len()];
        Ok(SparseEvaluator { obj, theta, grad })
    }

    /// Inducing inputs Z (M×Q) of a sparse model; `None` for the exact model.
    pub fn inducing_inputs(&self) -> Option<MatRef<'_, f64>> {
        self.sparse.as_ref().map(|s| s.z.as_ref())
    }

    /// [`SharedGplvm::evaluate`] of a sparse model: the negative bound and its gradient in
    /// natural units (the bandwidth entry is NaN: not computed for centres).
    pub(crate) fn evaluate_sparse(&self) -> Result<(f64, Params)> {
        let obj = SparseObjective::new(self, Mode::Full)?;
        let theta = obj.theta0();
        let mut g = vec![0.0; theta.len()];
        let (f, _) = obj.eval_full(&theta, &mut g)?;
        let q = self.q();
        // The kernels' block follows the latent one, q(X)'s variances (Bayesian) and Z, whose
        // gradients `Params` has no place for.
        let (ll, skipped) = (obj.latent_len(), obj.var_len() + obj.z_len());
        let r = ll / q;
        let lat_g = Mat::from_fn(r, q, |i, j| g[j * r + i]);
        let latent = match &self.latent {
            Latent::Free { .. } => LatentParams::Free { x: lat_g },
            Latent::Back { .. } => LatentParams::BackConstrained {
                weights: lat_g,
                bandwidth: f64::NAN,
            },
        };
        let mut spaces = Vec::new();
        let mut off = ll + skipped;
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
}
