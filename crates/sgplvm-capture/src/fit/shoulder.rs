//! The shoulder's Euler solutions: angles moved by whole turns into the limits, the two
//! solutions of one orientation, and which the fit prefers (continuity with the previous frame,
//! unless the other lies within the limits by a margin, or keeps the arm's direction where a
//! limit makes the preferred one give it up).

use nalgebra::Matrix3;

use super::{rx, ry, rz};

/// `v` moved by whole turns to lie nearest `near`.
pub(super) fn nearest_turn(v: f64, near: f64) -> f64 {
    let tau = std::f64::consts::TAU;
    v + ((near - v) / tau).round() * tau
}

/// How far `v` lies outside `(lo, hi)`.
pub(super) fn outside(v: f64, (lo, hi): (f64, f64)) -> f64 {
    (lo - v).max(v - hi).max(0.0)
}

/// `v` moved by whole turns into `(lo, hi)` if some turn lies there, else nearest `near`.
pub(super) fn choose_turn(v: f64, near: f64, lim: (f64, f64)) -> f64 {
    let n = nearest_turn(v, near);
    if outside(n, lim) == 0.0 {
        return n;
    }
    let c = nearest_turn(v, 0.5 * (lim.0 + lim.1));
    if outside(c, lim) < outside(n, lim) {
        c
    } else {
        n
    }
}

/// How much further outside the limits (radians, summed over the three angles) the Euler
/// solution nearest the previous frame may be than the other before the shoulder switches to
/// the other: continuity first, so that angles do not flip by half a turn at a limit.
pub(super) const BRANCH_SWITCH_MARGIN: f64 = 0.5;

/// Shoulder angles `(f, a, r)` with `Ry(−f) Rx(a) Rz(−r) = m`, every Euler solution (and at
/// the gimbal point, the flexion kept from `prev`), the preferred first: the one nearest `prev`
/// unless another lies within the limits by [`BRANCH_SWITCH_MARGIN`] more; without `prev` the
/// one least outside `limits`.
pub(super) fn shoulder_angles(
    m: &Matrix3<f64>,
    prev: Option<[f64; 3]>,
    limits: &[(f64, f64)],
) -> Vec<[f64; 3]> {
    // m = Ry(α) Rx(β) Rz(γ), α = −f, β = a, γ = −r.
    let cb = m[(0, 2)].hypot(m[(2, 2)]);
    let alpha0 = m[(0, 2)].atan2(m[(2, 2)]);
    let mut candidates: Vec<f64> = if cb > 1e-6 {
        vec![alpha0, alpha0 + std::f64::consts::PI]
    } else {
        vec![prev.map(|p| -p[0]).unwrap_or(0.0)]
    };
    if let Some(p) = prev {
        candidates.push(-p[0]); // near the gimbal point: keep the flexion
    }
    let reference = prev.unwrap_or([0.5 * (limits[0].0 + limits[0].1).clamp(-1.0, 1.0), 0.0, 0.0]);
    let mut solutions: Vec<([f64; 3], f64, f64)> = Vec::with_capacity(3);
    for alpha in candidates {
        // Given α, β and γ follow from Ry(α)ᵀ m = Rx(β) Rz(γ).
        let n = ry(alpha).matrix().transpose() * m;
        let gamma = (-n[(0, 1)]).atan2(n[(0, 0)]);
        let beta = (-n[(1, 2)]).atan2(n[(2, 2)]);
        // Reject a candidate α that does not reproduce m (only the gimbal guess can fail).
        let rebuilt = ry(alpha) * rx(beta) * rz(gamma);
        if (rebuilt.matrix() - m).norm() > 1e-6 {
            continue;
        }
        let raw = [-alpha, beta, -gamma];
        let mut angles = [0.0; 3];
        for k in 0..3 {
            angles[k] = choose_turn(raw[k], reference[k], limits[k]);
        }
        let violation: f64 = (0..3).map(|k| outside(angles[k], limits[k])).sum();
        let distance: f64 = (0..3).map(|k| (angles[k] - reference[k]).powi(2)).sum();
        solutions.push((angles, violation, distance));
    }
    let least_outside = |a: &([f64; 3], f64, f64), b: &([f64; 3], f64, f64)| {
        a.1.total_cmp(&b.1).then(a.2.total_cmp(&b.2))
    };
    let best = if prev.is_some() {
        let nearest = solutions.iter().min_by(|a, b| a.2.total_cmp(&b.2));
        let inside = solutions.iter().min_by(|a, b| least_outside(a, b));
        match (nearest, inside) {
            (Some(n), Some(i)) if i.1 < n.1 - BRANCH_SWITCH_MARGIN => Some(i),
            (n, _) => n,
        }
    } else {
        solutions.iter().min_by(|a, b| least_outside(a, b))
    };
    let Some(best) = best.map(|b| b.0) else {
        return vec![reference];
    };
    std::iter::once(best)
        .chain(solutions.iter().map(|s| s.0).filter(|s| *s != best))
        .collect()
}

/// How much nearer (metres: the farther of the elbow and the wrist from the capture) a shoulder
/// solution that a limit held must bring the arm than the preferred one for the fit to take
/// it, and how far the preferred one must be for another to be tried: the other Euler branch,
/// clamped, may keep the arm's direction where the preferred one, clamped, gives it up (FAIR's
/// zombie take: a left arm held forward came out at the flexion's lower limit, 52° off). A
/// frame the preferred branch fits faithfully (within the import's 3 cm) keeps it: a switch
/// of branch is a jump of the angles a model learns from (at 1 cm, CMU 13_26 gained two
/// switches for 2 cm, and its per-arm G1 model's test error rose from 0.79° to 2.9°).
pub(super) const BRANCH_POSITION_GAIN: f64 = crate::WORST_RESIDUAL_LIMIT_M;
