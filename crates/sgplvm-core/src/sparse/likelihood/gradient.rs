//! The analytic gradient of one space's bound (the formulas are in the [parent
//! module](super)'s documentation): ∂L/∂σ² with G_w, ∂L/∂K_mm, the two factors of ∂L/∂Φ, the
//! second pass over the blocks that forms W2 = ∂L/∂Φ ∘ Φ and reduces it at once, and the chain
//! rule through the RBF kernel to ∂L/∂α², ∂L/∂ℓ, ∂L/∂X and ∂L/∂Z.

use faer::linalg::matmul::matmul;
use faer::linalg::triangular_solve::{
    solve_lower_triangular_in_place, solve_upper_triangular_in_place,
};
use faer::{Accum, Mat, MatRef, Par};

use super::{map_blocks, BoundSums, Space, SparseEval, SparseFactors, BLOCK};
use crate::kernel::KernelParams;
use crate::simd::clear_upper_simd_state;

/// The gradient into `out`: ∂L/∂σ², ∂L/∂α², ∂L/∂ℓ, and ∂L/∂X, ∂L/∂Z added to `dx`, `dz`
/// (row-major) when given. `phi` holds Φ from the first pass.
pub(super) fn gradient(
    space: &Space<'_>,
    out: &mut SparseEval,
    kmm: &Mat<f64>,
    sums: &BoundSums,
    phi: &[f64],
    dx: Option<&mut [f64]>,
    dz: Option<&mut [f64]>,
) {
    let Space {
        zr, q, m, y, kern, ..
    } = *space;
    let (n, d) = (y.nrows(), y.ncols());
    let (df, nf) = (d as f64, n as f64);
    let var = kern.variance;
    let s2 = kern.noise;
    let SparseFactors { lm, lb, beta } = &out.factors;
    let (gw, d_noise) = noise_gradient(space, lb, beta, sums);
    out.d_noise = d_noise;
    let gmm = kmm_gradient(&gw, &sums.aat, lm, df);
    let (c2, lbeta) = phi_gradient_factors(&gw, lm, beta, s2, df);
    // W1 = ∂L/∂K_mm ∘ K_mm; W2 = ∂L/∂Φ ∘ Φ block by block (second pass).
    let w1 = Mat::from_fn(m, m, |i, j| gmm[(i, j)] * kmm[(i, j)]);
    let mean: Vec<f64> = (0..q)
        .map(|t| (0..m).map(|i| zr[i * q + t]).sum::<f64>() / m.max(1) as f64)
        .collect();
    let zc = Mat::from_fn(m, q, |i, t| zr[i * q + t] - mean[t]);
    let total = second_pass(space, &c2, &lbeta, &mean, zc.as_ref(), phi, dx);
    let (sum_w, d_l) = chain(w1.as_ref(), &total, zc.as_ref(), kern, dz);
    out.d_variance = sum_w / var + 0.5 * df * nf / s2;
    out.d_lengthscale = d_l;
}

/// G_w = D/2 B⁻¹ + ββᵀ/(2σ²), and ∂L/∂σ².
fn noise_gradient(
    space: &Space<'_>,
    lb: &Mat<f64>,
    beta: &Mat<f64>,
    sums: &BoundSums,
) -> (Mat<f64>, f64) {
    let Space { m, y, kern, .. } = *space;
    let (n, d) = (y.nrows(), y.ncols());
    let (df, nf) = (d as f64, n as f64);
    let var = kern.variance;
    let s2 = kern.noise;
    let par = Par::Seq;
    let (aat, yy, cc, tr_aat) = (&sums.aat, sums.yy, sums.cc, sums.tr_aat);
    // B⁻¹ = L_B⁻ᵀ L_B⁻¹.
    let mut binv = Mat::<f64>::identity(m, m);
    solve_lower_triangular_in_place(lb.as_ref(), binv.as_mut(), par);
    solve_upper_triangular_in_place(lb.transpose(), binv.as_mut(), par);
    clear_upper_simd_state();
    // G_w = D/2 B⁻¹ + ββᵀ/(2σ²).
    let mut gw = Mat::from_fn(m, m, |i, j| 0.5 * df * 0.5 * (binv[(i, j)] + binv[(j, i)]));
    matmul(
        gw.as_mut(),
        Accum::Add,
        beta.as_ref(),
        beta.transpose(),
        0.5 / s2,
        par,
    );
    clear_upper_simd_state();
    let tr_gw_aat: f64 = (0..m)
        .map(|j| (0..m).map(|i| gw[(i, j)] * aat[(i, j)]).sum::<f64>())
        .sum();
    let d_noise = 0.5 * nf * df / s2 - 0.5 * yy / (s2 * s2) + cc / (s2 * s2)
        - 0.5 * df * nf * var / (s2 * s2)
        + 0.5 * df * tr_aat / s2
        - tr_gw_aat / s2;
    (gw, d_noise)
}

/// ∂L/∂K_mm = L_m⁻ᵀ S L_m⁻¹ with S = G_w − D/2 I + D/2 AAᵀ, symmetrised.
fn kmm_gradient(gw: &Mat<f64>, aat: &Mat<f64>, lm: &Mat<f64>, df: f64) -> Mat<f64> {
    let (m, par) = (lm.nrows(), Par::Seq);
    let mut gmm = Mat::from_fn(m, m, |i, j| {
        gw[(i, j)] + 0.5 * df * aat[(i, j)] - if i == j { 0.5 * df } else { 0.0 }
    });
    solve_upper_triangular_in_place(lm.transpose(), gmm.as_mut(), par);
    let mut gmm_t = gmm.transpose().to_owned();
    solve_upper_triangular_in_place(lm.transpose(), gmm_t.as_mut(), par);
    clear_upper_simd_state();
    // gmm_t = L_m⁻ᵀ (L_m⁻ᵀ S)ᵀ = L_m⁻ᵀ S L_m⁻¹ (S symmetric): symmetrise the rounding.
    Mat::from_fn(m, m, |i, j| 0.5 * (gmm_t[(i, j)] + gmm_t[(j, i)]))
}

/// The two factors of ∂L/∂Φ = σ⁻² [L_m⁻ᵀ (2G_w − D I) L_m⁻¹] Φ − σ⁻³ (L_m⁻ᵀ β) Yᵀ: the M×M
/// matrix in brackets over σ² (symmetrised) and −L_m⁻ᵀ β / σ³.
fn phi_gradient_factors(
    gw: &Mat<f64>,
    lm: &Mat<f64>,
    beta: &Mat<f64>,
    s2: f64,
    df: f64,
) -> (Mat<f64>, Mat<f64>) {
    let (m, par) = (lm.nrows(), Par::Seq);
    let sigma = s2.sqrt();
    // ∂L/∂Φ = σ⁻¹ L_m⁻ᵀ ((2G_w − D I) A − βYᵀ/σ²)
    //       = σ⁻² [L_m⁻ᵀ (2G_w − D I) L_m⁻¹] Φ − σ⁻³ (L_m⁻ᵀ β) Yᵀ: M×M work, then two products.
    let mut c2 = Mat::from_fn(m, m, |i, j| {
        2.0 * gw[(i, j)] - if i == j { df } else { 0.0 }
    });
    solve_upper_triangular_in_place(lm.transpose(), c2.as_mut(), par);
    let mut c2t = c2.transpose().to_owned();
    solve_upper_triangular_in_place(lm.transpose(), c2t.as_mut(), par);
    let c2 = Mat::from_fn(m, m, |i, j| 0.5 * (c2t[(i, j)] + c2t[(j, i)]) / s2);
    let mut lbeta = beta.clone();
    solve_upper_triangular_in_place(lm.transpose(), lbeta.as_mut(), par);
    clear_upper_simd_state();
    lbeta
        .col_iter_mut()
        .for_each(|c| c.iter_mut().for_each(|v| *v *= -1.0 / (s2 * sigma)));
    (c2, lbeta)
}

/// Second pass: W2 = ∂L/∂Φ ∘ Φ block by block, from the factors of ∂L/∂Φ (`c2`, `lbeta`) and
/// Φ (`phi`), reduced at once to its sums (coordinates centred on Z's `mean`; `zc` is Z
/// centred); ∂L/∂X added to `dx` when given.
fn second_pass(
    space: &Space<'_>,
    c2: &Mat<f64>,
    lbeta: &Mat<f64>,
    mean: &[f64],
    zc: MatRef<'_, f64>,
    phi: &[f64],
    dx: Option<&mut [f64]>,
) -> W2Sums {
    let Space {
        xr, q, m, y, kern, ..
    } = *space;
    let n = y.nrows();
    let dx_chunks: Vec<Option<&mut [f64]>> = match dx {
        Some(dx) => dx.chunks_mut(BLOCK * q).map(Some).collect(),
        None => (0..space.blocks).map(|_| None).collect(),
    };
    let second = |b: usize, dx_b: Option<&mut [f64]>| {
        let (j0, nb) = (b * BLOCK, BLOCK.min(n - b * BLOCK));
        let phi_b = MatRef::from_column_major_slice(&phi[j0 * m..(j0 + nb) * m], m, nb);
        let mut w2 = Mat::zeros(m, nb);
        matmul(
            w2.as_mut(),
            Accum::Replace,
            c2.as_ref(),
            phi_b,
            1.0,
            Par::Seq,
        );
        matmul(
            w2.as_mut(),
            Accum::Add,
            lbeta.as_ref(),
            y.subrows(j0, nb).transpose(),
            1.0,
            Par::Seq,
        );
        clear_upper_simd_state();
        for j in 0..nb {
            for (g, p) in w2.col_as_slice_mut(j).iter_mut().zip(phi_b.col(j).iter()) {
                *g *= p;
            }
        }
        let xc = Mat::from_fn(nb, q, |j, t| xr[(j0 + j) * q + t] - mean[t]);
        w2_block(w2.as_ref(), xc.as_ref(), zc.as_ref(), kern, dx_b)
    };
    let parts = map_blocks(dx_chunks, space.parallel, second);
    let mut total = W2Sums::zeros(m, q);
    for p in &parts {
        total.add(p);
    }
    total
}

/// What one block of W2 = ∂L/∂Φ ∘ Φ contributes to the gradients (coordinates centred on Z's
/// mean): its row sums, W2 X_c (M×Q) and per dimension Σ_j x_j (c_j x_j − (W2ᵀ Z_c)_j).
struct W2Sums {
    rows: Vec<f64>,
    w2x: Mat<f64>,
    from_x: Vec<f64>,
}

impl W2Sums {
    fn zeros(m: usize, q: usize) -> Self {
        Self {
            rows: vec![0.0; m],
            w2x: Mat::zeros(m, q),
            from_x: vec![0.0; q],
        }
    }

    fn add(&mut self, o: &W2Sums) {
        self.rows.iter_mut().zip(&o.rows).for_each(|(a, b)| *a += b);
        self.w2x += &o.w2x;
        self.from_x
            .iter_mut()
            .zip(&o.from_x)
            .for_each(|(a, b)| *a += b);
    }
}

/// The sums of one block of W2 (M×b) at centred latent points `xc` (b×Q); ∂L/∂X of the block
/// added to `dx` (row-major b×Q) when given.
fn w2_block(
    w2: MatRef<'_, f64>,
    xc: MatRef<'_, f64>,
    zc: MatRef<'_, f64>,
    kern: &KernelParams,
    dx: Option<&mut [f64]>,
) -> W2Sums {
    let (m, nb, q) = (w2.nrows(), w2.ncols(), xc.ncols());
    let mut out = W2Sums::zeros(m, q);
    let mut cols = vec![0.0; nb];
    for (j, c) in cols.iter_mut().enumerate() {
        let col = w2.col(j);
        let mut s = 0.0;
        for (r, &v) in out.rows.iter_mut().zip(col.iter()) {
            *r += v;
            s += v;
        }
        *c = s;
    }
    matmul(out.w2x.as_mut(), Accum::Replace, w2, xc, 1.0, Par::Seq);
    let mut w2tz = Mat::zeros(nb, q);
    matmul(
        w2tz.as_mut(),
        Accum::Replace,
        w2.transpose(),
        zc,
        1.0,
        Par::Seq,
    );
    clear_upper_simd_state();
    let mut dx = dx;
    for t in 0..q {
        let l2 = kern.lengthscale[t] * kern.lengthscale[t];
        // Σ_ij W2_ij (z_i − x_j)² = Σ_i z_i (r2_i z_i − (W2 X)_i) + Σ_j x_j (c2_j x_j − (W2ᵀZ)_j).
        let mut s = 0.0;
        for j in 0..nb {
            s += xc[(j, t)] * (cols[j] * xc[(j, t)] - w2tz[(j, t)]);
        }
        out.from_x[t] = s;
        if let Some(dx) = dx.as_deref_mut() {
            // ∂k(z_i, x_j)/∂x_j = k (z_i − x_j)/ℓ².
            for j in 0..nb {
                dx[j * q + t] += (w2tz[(j, t)] - cols[j] * xc[(j, t)]) / l2;
            }
        }
    }
    out
}

/// From W1 = ∂L/∂K_mm ∘ K_mm (M×M, symmetric) and the summed blocks of W2 = ∂L/∂Φ ∘ Φ:
/// Σ W1 + Σ W2 (for ∂L/∂α²) and ∂L/∂ℓ_t; ∂L/∂Z added to `dz` (row-major) when given.
/// Coordinates are centred on Z's mean (`zc`; the kernel is translation invariant) to limit
/// cancellation.
fn chain(
    w1: MatRef<'_, f64>,
    w2: &W2Sums,
    zc: MatRef<'_, f64>,
    kern: &KernelParams,
    mut dz: Option<&mut [f64]>,
) -> (f64, Vec<f64>) {
    let (m, q) = (zc.nrows(), zc.ncols());
    let r1: Vec<f64> = (0..m).map(|i| (0..m).map(|j| w1[(i, j)]).sum()).collect();
    let r2 = &w2.rows;
    let mut w1z = Mat::zeros(m, q);
    matmul(w1z.as_mut(), Accum::Replace, w1, zc, 1.0, Par::Seq);
    clear_upper_simd_state();
    let sum_w = r1.iter().sum::<f64>() + r2.iter().sum::<f64>();
    let mut d_l = vec![0.0; q];
    for t in 0..q {
        let l = kern.lengthscale[t];
        let l2 = l * l;
        // Σ_ij W1_ij (z_i − z_j)² = 2 Σ_i z_i (r1_i z_i − (W1 Z)_i).
        let mut s = 0.0;
        for i in 0..m {
            s += 2.0 * zc[(i, t)] * (r1[i] * zc[(i, t)] - w1z[(i, t)]);
        }
        for i in 0..m {
            s += zc[(i, t)] * (r2[i] * zc[(i, t)] - w2.w2x[(i, t)]);
        }
        s += w2.from_x[t];
        d_l[t] = s / (l2 * l);
        if let Some(dz) = dz.as_deref_mut() {
            for i in 0..m {
                let from_kmm = -2.0 * (r1[i] * zc[(i, t)] - w1z[(i, t)]);
                let from_kmn = -(r2[i] * zc[(i, t)] - w2.w2x[(i, t)]);
                dz[i * q + t] += (from_kmm + from_kmn) / l2;
            }
        }
    }
    (sum_w, d_l)
}
