//! Limits of differential IK: linear inequalities on the joint step `Δq` that
//! [`super::qp::Step`] keeps exactly.
//!
//! - [`position_limits`]: `lo − q ≤ Δq ≤ hi − q` (and a step bound, the trust region of one
//!   Gauss–Newton step);
//! - [`collision_limit`]: for every pair of the robot's own shapes closer than a detection
//!   distance, their distance linearised with the closest points (`d + nᵀ(J_b − J_a) Δq ≥
//!   margin`, n from shape a to shape b), so that the step keeps them at least `margin` apart,
//!   or moves them apart when they are closer.

use nalgebra::DVector;

use super::collision::{CollisionModel, Proximity};
use super::qp::Step;
use super::tasks::TaskContext;

/// Bounds the step of every active joint by its position limits (`q + Δq` within them) and,
/// when given, by `±max_step`.
pub fn position_limits(step: &mut Step, ctx: &TaskContext<'_>, max_step: Option<f64>) {
    let q = ctx.active_values();
    for (k, &j) in ctx.active.iter().enumerate() {
        let (lo, hi) = ctx.robot.joints[j].limits;
        if lo <= hi {
            step.bound(k, lo - q[k], hi - q[k]);
        }
        if let Some(m) = max_step {
            step.bound(k, -m, m);
        }
    }
}

/// Keeps every pair of `model`'s shapes at least `margin` apart, or as far as at the reference
/// where nearer there ([`CollisionModel::margin_of`]; see the module docs): one row
/// per pair within `detect` metres, the distance's linear change scaled by `gain` (1: reach the
/// margin in one step). Returns the pairs near enough to be limited.
pub fn collision_limit(
    step: &mut Step,
    ctx: &TaskContext<'_>,
    model: &CollisionModel,
    margin: f64,
    detect: f64,
    gain: f64,
) -> Vec<Proximity> {
    let near = model.proximities(ctx.frames, detect.max(margin));
    for p in &near {
        let (la, lb) = model.pair_links(p.pair);
        let ja = ctx
            .frames
            .point_jacobian(ctx.robot, ctx.ancestry, la, &p.point_a, ctx.active);
        let jb = ctx
            .frames
            .point_jacobian(ctx.robot, ctx.ancestry, lb, &p.point_b, ctx.active);
        let row = (jb - ja).transpose() * p.normal;
        if row.norm() < 1e-12 {
            continue;
        }
        // −nᵀ(J_b − J_a) Δq ≤ gain (d − margin)
        step.add_row(
            DVector::from_iterator(row.len(), row.iter().map(|v| -v)),
            gain * (p.distance - model.margin_of(p.pair, margin)),
        );
    }
    near
}
