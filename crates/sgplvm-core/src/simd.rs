//! Element-wise numerics compiled for the CPU's widest SIMD: the `exp` of kernel values.
//!
//! `exp_neg(x) = eˣ` for x ≤ 0 to a few ulp (Cody–Waite reduction, degree-13 polynomial in
//! Estrin's scheme); [`vectorized`] runs a closure under pulp's runtime dispatch (AVX-512, AVX2
//! or the baseline) without fused multiply-adds, so every path rounds the same.

/// Clears the upper halves of the AVX registers (`vzeroupper`).
///
/// faer's AVX-512 matrix kernels can return with the upper register halves dirty; on Intel
/// cores every following SSE-encoded instruction (libm's `exp`, our scalar loops) then pays a
/// transition penalty — measured here as `exp` going from 9 ns to 450 ns and one evaluation at
/// N = 300 from ~3 ms to ~30 ms. Called after faer calls and before exp-heavy loops.
#[inline]
pub(crate) fn clear_upper_simd_state() {
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx") {
            // SAFETY: AVX support was checked just above; vzeroupper has no other precondition.
            unsafe { zeroupper() }
        }
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
unsafe fn zeroupper() {
    std::arch::x86_64::_mm256_zeroupper();
}

/// `exp(x)` for `x ≤ 0` (kernel values), branch-free so that loops over slices vectorise.
///
/// Cody–Waite reduction `x = k ln2 + r`, |r| ≤ ln2/2, degree-13 Taylor polynomial for e^r
/// (truncation error < 2e-17 relative), and 2^k assembled in the exponent bits. Arguments
/// below −708 are clamped to −708 (result ≈ 3e-308 instead of a smaller subnormal or 0: an
/// absolute difference below 1e-307, irrelevant for kernel matrices). Accurate to a few ulp;
/// checked against `f64::exp` in the tests.
#[inline(always)]
pub(crate) fn exp_neg(x: f64) -> f64 {
    const LOG2E: f64 = std::f64::consts::LOG2_E;
    const LN2_HI: f64 = f64::from_bits(0x3fe6_2e42_fee0_0000); // fdlibm ln2_hi
    const LN2_LO: f64 = f64::from_bits(0x3dea_39ef_3579_3c76); // fdlibm ln2_lo
    const MAGIC: f64 = 6_755_399_441_055_744.0; // 1.5 · 2^52
    let x = x.max(-708.0);
    let t = x * LOG2E + MAGIC;
    let k = t - MAGIC;
    let r = (x - k * LN2_HI) - k * LN2_LO;
    // sum_{i=0}^{13} r^i / i! in Estrin's scheme: pairs, then pairs of pairs with r², r⁴, r⁸.
    // Its dependency chain is 8 operations deep instead of Horner's 26, which lets the
    // vectorised loops keep several blocks in flight.
    let r2 = r * r;
    let r4 = r2 * r2;
    let r8 = r4 * r4;
    let p01 = 1.0 + r;
    let p23 = 0.5 + r * (1.0 / 6.0);
    let p45 = 1.0 / 24.0 + r * (1.0 / 120.0);
    let p67 = 1.0 / 720.0 + r * (1.0 / 5_040.0);
    let p89 = 1.0 / 40_320.0 + r * (1.0 / 362_880.0);
    let p1011 = 1.0 / 3_628_800.0 + r * (1.0 / 39_916_800.0);
    let p1213 = 1.0 / 479_001_600.0 + r * (1.0 / 6_227_020_800.0);
    let q0 = p01 + r2 * p23;
    let q1 = p45 + r2 * p67;
    let q2 = p89 + r2 * p1011;
    let p = (q0 + r4 * q1) + r8 * (q2 + r4 * p1213);
    // The low bits of t hold k (two's complement); k + 1023 ∈ [2, 1023] here.
    let scale = f64::from_bits((t.to_bits() << 52).wrapping_add(1023u64 << 52));
    p * scale
}

/// Runs `f` compiled for the best SIMD instruction set of this CPU (AVX-512, AVX2+FMA or the
/// baseline), so that the plain slice loops inside it are auto-vectorised 8, 4 or 2 wide.
///
/// pulp's runtime dispatch (already in the tree through faer). The closure must be marked
/// `#[inline(always)]` at the call site for its loops to be compiled with the wider
/// instructions. Results do not depend on the path taken: no fused multiply-adds are formed
/// (Rust does not contract `a * b + c`), so every path rounds the same way.
#[inline(always)]
pub(crate) fn vectorized<R>(f: impl FnOnce() -> R) -> R {
    pulp::Arch::new().dispatch(f)
}

/// Applies [`exp_neg`] to every element.
#[inline]
pub(crate) fn exp_neg_slice(v: &mut [f64]) {
    vectorized(
        #[inline(always)]
        || {
            for x in v.iter_mut() {
                *x = exp_neg(*x);
            }
        },
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fast_exp_matches_libm() {
        let mut worst = 0.0f64;
        for i in 0..200_000 {
            let x = -(i as f64) * 3.5e-3 - 1e-9 * (i % 7) as f64;
            let (a, b) = (exp_neg(x), x.exp());
            if b > 1e-300 {
                worst = worst.max((a - b).abs() / b);
            }
        }
        assert!(worst < 4.0 * f64::EPSILON, "worst relative error {worst:e}");
        assert_eq!(exp_neg(0.0), 1.0);
        assert!(exp_neg(-1e6) < 1e-307 && exp_neg(-1e6) >= 0.0);
    }
}
