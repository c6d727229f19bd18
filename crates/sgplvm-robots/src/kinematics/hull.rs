//! Convex hulls whose support points are found by climbing the hull's edges, for the distance
//! queries of self-collision (GJK asks a shape for its support point, the point furthest along a
//! direction, a few times per iteration). parry's convex polyhedron scans every vertex for it;
//! the hulls of published collision meshes have hundreds to thousands of vertices (a G1 link's
//! median is about 900), which made the scan most of retargeting's time. On a convex polytope a
//! vertex that no neighbour improves on is the furthest of all (the surface climbed over is
//! checked convex first: a folded one is scanned, [`convex_triangulation`]), so the climb from the last
//! support vertex found for a direction like this one (GJK's directions change little from one
//! query to the next) gives the same point after a few dot products. "Like" is one of 24 cones
//! of directions (the octant and the largest component): a hull checked against several shapes
//! is asked along several directions in turn, and one shared start would send each climb
//! across the hull from the last pair's side.

use std::sync::atomic::{AtomicU32, Ordering};

use rapier3d::parry;
use rapier3d::parry::math::Vector;
use rapier3d::parry::shape::{ConvexPolyhedron, SupportMap};

/// Below this many vertices a scan is as fast as a climb.
const SCAN_BELOW: usize = 48;

/// A convex polyhedron's vertices and edges, its support points found by hill climbing.
#[derive(Debug)]
pub(crate) struct ClimbingHull {
    points: Vec<Vector>,
    /// Neighbours of vertex `v`: `neighbours[offsets[v]..offsets[v + 1]]`.
    offsets: Vec<u32>,
    neighbours: Vec<u32>,
    /// The last support vertex found for each cone of directions ([`cone_of`]): GJK asks along
    /// directions that change little from one iteration (and one IK step) to the next, so a
    /// climb from it is short. Only a start: the climb is exact from any vertex, whichever
    /// thread wrote it last.
    last: [AtomicU32; CONES],
}

/// The hull of `points` as triangles (its vertices and their indices), checked convex: every
/// triangle's plane has every vertex behind it, within [`FLAT_TOLERANCE`] of the hull's size.
/// `None` where it is not. parry's hull of a published mesh can fold some of its triangles
/// inwards (f32 rounding over near-coplanar points: 86 of the 348 hulls and parts of Galaxea's
/// R1, 84 of 392 of the G1 with hands, 10 of 374 of Kinova's MOVO; 7 of 904 triangles on one
/// of R1's arm links); its vertices are still the hull's, so a scan finds the support points,
/// but a climb over the folded surface stopped up to 0.43 m short of them, and GJK took the
/// shapes for further apart than they were.
fn convex_triangulation(points: &[Vector]) -> Option<(Vec<Vector>, Vec<[u32; 3]>)> {
    let (points, triangles) = parry::transformation::try_convex_hull(points).ok()?;
    convex(&points, &triangles).then_some((points, triangles))
}

/// Whether `triangles` (outward by their winding) over `points` bound a convex solid: every
/// vertex behind every triangle's plane, within [`FLAT_TOLERANCE`] of the points' size.
fn convex(points: &[Vector], triangles: &[[u32; 3]]) -> bool {
    let (lo, hi) = points.iter().fold(
        (Vector::splat(f32::MAX), Vector::splat(f32::MIN)),
        |(lo, hi), p| (lo.min(*p), hi.max(*p)),
    );
    let tolerance = FLAT_TOLERANCE * (hi - lo).length();
    !triangles.is_empty()
        && triangles.iter().all(|t| {
            let [a, b, c] = t.map(|i| points[i as usize]);
            let Some(normal) = (b - a).cross(c - a).try_normalize() else {
                return true; // a sliver: its neighbours' planes hold the surface
            };
            points.iter().all(|p| (*p - a).dot(normal) <= tolerance)
        })
}

/// How far (relative to the hull's diagonal) a vertex may stand in front of a triangle's plane
/// of a hull still taken as convex: the f32 rounding of a hull's planes, far below a
/// millimetre on a link.
const FLAT_TOLERANCE: f32 = 1e-4;

/// How many cones the directions are sorted into: 8 octants × 3 largest components.
const CONES: usize = 24;

/// The cone of direction `dir`: its octant and which component is largest in magnitude.
fn cone_of(dir: Vector) -> usize {
    let (x, y, z) = (dir.x.abs(), dir.y.abs(), dir.z.abs());
    let largest = if x >= y && x >= z {
        0
    } else if y >= z {
        1
    } else {
        2
    };
    let octant =
        usize::from(dir.x < 0.0) | usize::from(dir.y < 0.0) << 1 | usize::from(dir.z < 0.0) << 2;
    largest * 8 + octant
}

/// A direction inside cone `cone` (its largest component twice the others).
fn inside_cone(cone: usize) -> Vector {
    let mut v = [1.0f32; 3];
    v[cone / 8] = 2.0;
    for (axis, c) in v.iter_mut().enumerate() {
        if cone >> axis & 1 == 1 {
            *c = -*c;
        }
    }
    Vector::new(v[0], v[1], v[2])
}

impl ClimbingHull {
    /// The climbing form of `hull`; `None` when it is small enough to scan, or when no
    /// triangulation of its surface is found convex ([`convex_triangulation`]): a climb is exact
    /// only over a convex surface.
    pub(crate) fn of(hull: &ConvexPolyhedron) -> Option<ClimbingHull> {
        if hull.points().len() < SCAN_BELOW {
            return None;
        }
        let (points, triangles) = convex_triangulation(hull.points())?;
        let mut adjacent: Vec<Vec<u32>> = vec![Vec::new(); points.len()];
        for t in &triangles {
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                if !adjacent[a as usize].contains(&b) {
                    adjacent[a as usize].push(b);
                    adjacent[b as usize].push(a);
                }
            }
        }
        // A vertex without an edge could never be reached: scan instead.
        if adjacent.iter().any(Vec::is_empty) {
            return None;
        }
        let mut offsets = Vec::with_capacity(points.len() + 1);
        let mut neighbours = Vec::new();
        offsets.push(0);
        for a in &adjacent {
            neighbours.extend_from_slice(a);
            offsets.push(u32::try_from(neighbours.len()).ok()?);
        }
        // Each cone's first start: its furthest vertex along a direction inside it.
        let last = std::array::from_fn(|cone| {
            let dir = inside_cone(cone);
            let furthest = (0..points.len())
                .max_by(|&a, &b| points[a].dot(dir).total_cmp(&points[b].dot(dir)))
                .unwrap_or(0);
            AtomicU32::new(u32::try_from(furthest).unwrap_or(0))
        });
        Some(ClimbingHull {
            points,
            offsets,
            neighbours,
            last,
        })
    }

    /// The index of the vertex furthest along `dir`.
    fn support_id(&self, dir: Vector) -> usize {
        let last = &self.last[cone_of(dir)];
        let mut best = (last.load(Ordering::Relaxed) as usize).min(self.points.len() - 1);
        let mut best_dot = self.points[best].dot(dir);
        // Each move strictly increases the dot product, so the climb ends.
        loop {
            let mut next = best;
            let range = self.offsets[best] as usize..self.offsets[best + 1] as usize;
            for &n in &self.neighbours[range] {
                let d = self.points[n as usize].dot(dir);
                if d > best_dot {
                    next = n as usize;
                    best_dot = d;
                }
            }
            if next == best {
                last.store(u32::try_from(best).unwrap_or(0), Ordering::Relaxed);
                return best;
            }
            best = next;
        }
    }
}

impl SupportMap for ClimbingHull {
    fn local_support_point(&self, dir: Vector) -> Vector {
        self.points[self.support_id(dir)]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rapier3d::parry::shape::SharedShape;

    #[test]
    fn each_cone_holds_its_own_inside_direction() {
        for cone in 0..CONES {
            assert_eq!(cone_of(inside_cone(cone)), cone);
        }
        assert_eq!(cone_of(Vector::new(0.1, -0.9, 0.3)), 8 + 0b010);
    }

    #[test]
    fn the_climb_finds_the_scan_s_support_point_on_a_many_sided_hull() {
        // Points on an ellipsoid and a few inside: a hull of a few hundred vertices.
        let mut points = Vec::new();
        let mut state = 12345u64;
        let mut next = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((state >> 33) as f32) / (u32::MAX >> 1) as f32 * 2.0 - 1.0
        };
        for _ in 0..600 {
            let v = Vector::new(next(), next(), next());
            let inside = next() > 0.8;
            let v = if inside { v * 0.5 } else { v.normalize() };
            points.push(Vector::new(0.3 * v.x, 0.1 * v.y, 0.05 * v.z));
        }
        let shape = SharedShape::convex_hull(&points).unwrap();
        let poly = shape.as_convex_polyhedron().unwrap();
        let hull = ClimbingHull::of(poly).expect("large enough to climb");
        assert!(hull.points.len() > 100);
        for _ in 0..2000 {
            let dir = Vector::new(next(), next(), next());
            let climbed = hull.local_support_point(dir).dot(dir);
            let scanned = poly.local_support_point(dir).dot(dir);
            assert!((climbed - scanned).abs() <= 1e-6, "{climbed} vs {scanned}");
        }
        // Axis directions (faces perpendicular to them are possible) too.
        for d in [
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 0.0, 1.0],
            [-1.0, 0.0, 0.0],
            [0.0, -1.0, 0.0],
            [0.0, 0.0, -1.0],
        ] {
            let dir = Vector::new(d[0], d[1], d[2]);
            let climbed = hull.local_support_point(dir).dot(dir);
            let scanned = poly.local_support_point(dir).dot(dir);
            assert!((climbed - scanned).abs() <= 1e-6);
        }
    }

    #[test]
    fn a_folded_triangulation_is_not_climbed() {
        // A cube's hull is convex; the same triangles with a corner pushed in (a fold, as
        // parry's hull of some published meshes has) are not, and would stop a climb there.
        let corners: Vec<Vector> = (0..8)
            .map(|n| Vector::new((n & 1) as f32, (n >> 1 & 1) as f32, (n >> 2 & 1) as f32))
            .collect();
        let (points, triangles) = parry::transformation::try_convex_hull(&corners).unwrap();
        assert!(convex(&points, &triangles));
        let mut folded = points.clone();
        folded[0] = folded[0] * 0.2 + Vector::splat(0.4);
        assert!(!convex(&folded, &triangles));
    }
}
