//! Cheap bounds of a collision shape, tested before parry's distance queries: an oriented box
//! (the separating-axis test with a gap) and a bounding sphere, placed at a configuration.

use nalgebra::{Isometry3, Matrix3, Vector3};
use rapier3d::parry::shape::SharedShape;

use super::collision::vec_from_parry;

/// An oriented box: centre, axes (columns) and half extents, in some frame.
#[derive(Debug, Clone, Copy)]
pub(super) struct Obb {
    /// The centre.
    pub(super) centre: Vector3<f64>,
    /// The axes, as columns.
    pub(super) axes: Matrix3<f64>,
    /// The half extents along the axes.
    pub(super) half: Vector3<f64>,
}

impl Obb {
    /// The box of `shape` (its own axis-aligned box) placed at `local` in its link.
    pub(super) fn of(shape: &SharedShape, local: &Isometry3<f64>) -> Obb {
        let aabb = shape.compute_local_aabb();
        let centre = vec_from_parry((aabb.mins + aabb.maxs) * 0.5);
        let half = vec_from_parry((aabb.maxs - aabb.mins) * 0.5);
        Obb {
            centre: (local * nalgebra::Point3::from(centre)).coords,
            axes: *local.rotation.to_rotation_matrix().matrix(),
            half,
        }
    }

    /// This box moved by `pose`.
    pub(super) fn placed(&self, pose: &Isometry3<f64>) -> Obb {
        Obb {
            centre: (pose * nalgebra::Point3::from(self.centre)).coords,
            axes: pose.rotation.to_rotation_matrix().matrix() * self.axes,
            half: self.half,
        }
    }

    /// Whether a plane separates the boxes by more than `gap` (the separating-axis test over
    /// the 15 axes of two boxes): then no two points of them are within `gap`.
    pub(super) fn apart(&self, other: &Obb, gap: f64) -> bool {
        let mut apart = false;
        self.each_separation(other, |s| {
            apart = s > gap;
            apart
        });
        apart
    }

    /// How far apart the boxes are along the axis of the 15 that separates them most (negative
    /// where none does): no two points of them are nearer.
    pub(super) fn separation(&self, other: &Obb) -> f64 {
        let mut most = f64::NEG_INFINITY;
        self.each_separation(other, |s| {
            most = most.max(s);
            false
        });
        most
    }

    /// The boxes' separation along each of the separating-axis test's 15 axes (the gap between
    /// their projections, per unit length of the axis), until `enough` says so.
    fn each_separation(&self, other: &Obb, mut enough: impl FnMut(f64) -> bool) {
        let (a, b) = (self, other);
        // b's axes in a's frame, and the centres' offset in a's frame.
        let r = a.axes.transpose() * b.axes;
        let t = a.axes.transpose() * (b.centre - a.centre);
        let abs_r = r.map(|v| v.abs() + 1e-9);
        for i in 0..3 {
            let ra = a.half[i];
            let rb = b.half.dot(&abs_r.row(i).transpose());
            if enough(t[i].abs() - ra - rb) {
                return;
            }
        }
        for j in 0..3 {
            let ra = a.half.dot(&abs_r.column(j));
            let rb = b.half[j];
            if enough(t.dot(&r.column(j)).abs() - ra - rb) {
                return;
            }
        }
        for i in 0..3 {
            for j in 0..3 {
                let (i1, i2) = ((i + 1) % 3, (i + 2) % 3);
                let (j1, j2) = ((j + 1) % 3, (j + 2) % 3);
                let ra = a.half[i1] * abs_r[(i2, j)] + a.half[i2] * abs_r[(i1, j)];
                let rb = b.half[j1] * abs_r[(i, j2)] + b.half[j2] * abs_r[(i, j1)];
                let dist = (t[i2] * r[(i1, j)] - t[i1] * r[(i2, j)]).abs();
                // The axis aᵢ × bⱼ has length sin(angle): the gap scales with it.
                let len = (1.0 - r[(i, j)] * r[(i, j)]).max(0.0).sqrt();
                if len > 1e-6 && enough((dist - ra - rb) / len) {
                    return;
                }
            }
        }
    }
}

/// A shape's bounding sphere and box placed by a configuration's frames.
#[derive(Debug, Clone, Copy)]
pub(super) struct Placed {
    /// The sphere's centre.
    pub(super) centre: Vector3<f64>,
    /// The sphere's radius.
    pub(super) radius: f64,
    /// The box.
    pub(super) obb: Obb,
}

impl Placed {
    /// A lower bound of the shapes' distance: the spheres' or the boxes' separation, the
    /// larger.
    pub(super) fn gap(&self, other: &Placed) -> f64 {
        let spheres = (self.centre - other.centre).norm() - self.radius - other.radius;
        spheres.max(self.obb.separation(&other.obb))
    }

    /// Whether the spheres and boxes (cheap) do not rule out the shapes being within `within`.
    pub(super) fn may_near(&self, other: &Placed, within: f64) -> bool {
        let reach = self.radius + other.radius + within;
        reach >= 0.0
            && (self.centre - other.centre).norm_squared() <= reach * reach
            && !self.obb.apart(&other.obb, within)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kinematics::collision::pose_to_parry;
    use rapier3d::parry;

    #[test]
    fn boxes_said_apart_are_further_apart_than_the_gap_and_their_separation_bounds_it() {
        let mut seed = 99u64;
        let mut rand = || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((seed >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
        };
        let (mut apart, mut near) = (0, 0);
        for _ in 0..3000 {
            let shape = |r: &mut dyn FnMut() -> f64| {
                SharedShape::cuboid(
                    (0.02 + 0.1 * r().abs()) as f32,
                    (0.02 + 0.1 * r().abs()) as f32,
                    (0.02 + 0.1 * r().abs()) as f32,
                )
            };
            let (sa, sb) = (shape(&mut rand), shape(&mut rand));
            let pose = |r: &mut dyn FnMut() -> f64| {
                Isometry3::new(
                    Vector3::new(0.15 * r(), 0.15 * r(), 0.15 * r()),
                    Vector3::new(3.0 * r(), 3.0 * r(), 3.0 * r()),
                )
            };
            let (pa, pb) = (pose(&mut rand), pose(&mut rand));
            let gap = 0.05 * rand().abs();
            let ident = Isometry3::identity();
            let (ba, bb) = (
                Obb::of(&sa, &ident).placed(&pa),
                Obb::of(&sb, &ident).placed(&pb),
            );
            let said = ba.apart(&bb, gap);
            let d = parry::query::distance(
                &pose_to_parry(&pa),
                sa.as_ref(),
                &pose_to_parry(&pb),
                sb.as_ref(),
            )
            .unwrap()
            .distance;
            // The separation is a lower bound of the distance (apart: beyond the gap).
            let separation = ba.separation(&bb);
            assert!(f64::from(d) > separation - 1e-5, "{separation} > {d}");
            assert_eq!(said, separation > gap);
            if said {
                apart += 1;
                assert!(f64::from(d) > gap - 1e-5, "apart by {gap} said, {d} found");
            } else {
                near += 1;
            }
        }
        assert!(apart > 300 && near > 300, "{apart} apart, {near} near");
    }
}
