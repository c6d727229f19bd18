//! Pairs of a robot's own shapes that its joint limits keep apart: proven once, when the
//! collision model is made, so that they are never checked (MoveIt's Setup Assistant calls
//! them "never in collision" and finds them by sampling the whole robot; here the proof is over
//! the joints between the two links alone, with their limits: a bound, not a sample).
//!
//! Only the joints between two links (above one and not the other) move them relative to each
//! other. Over a box of those joints' values, a point of a shape moves by at most
//! `Σⱼ rⱼ |Δqⱼ|`, where `rⱼ` bounds the point's distance from joint j's axis (from the corners of
//! a box holding the shape: see `reach_below`; 1 for a prismatic joint). So if
//! the shapes are `d` apart at the box's centre and `d − Σⱼ rⱼ hⱼ` (hⱼ the half-widths) is more
//! than the clearance, they keep that clearance everywhere in the box. The whole range is split
//! into such boxes (branch and bound, within a budget of distance queries); a box whose centre
//! is within the clearance ends the proof: the pair can meet and is kept.
//!
//! The shapes are the meshes' own triangles where the hulls do not settle it (the hull checked
//! every step reaches into a mesh's concave places: IIT's ergoCub's forearm hull comes within
//! 10 mm of its wrist's in nearly every posture, their triangles never within 1 mm), else the
//! shapes themselves. A pair apart at the reference posture that
//! came to overlap somewhere in the range would pass through touching on the way there (the
//! box is connected and holds the reference), so surfaces suffice.

use std::collections::HashMap;
use std::sync::{Arc, Mutex};

use rapier3d::parry;
use rapier3d::parry::query::ClosestPoints;

use super::collision::{pose_to_parry, LinkShape};
use super::frames::{Ancestry, RobotFrames};
use crate::urdf::{JointKind, Robot};

/// The most joints that may lie between two links for the proof to be tried (beyond, the
/// boxes multiply: a hand and a torso are checked as they are).
pub(super) const MAX_JOINTS_BETWEEN: usize = 2;

/// Distance queries one pair's proof may take on the hulls (microseconds each) ...
const BUDGET: usize = 1_000;

/// ... and on the meshes' triangles ...
const SURFACE_BUDGET: usize = 300;

/// ... and all the pairs of one collision model on triangles, counted as the triangles of the
/// two meshes queried (a query's cost grows with them: 1–7 µs a triangle, 2–3 ms a query on
/// Fetch's meshes of 1,000): at most a few seconds more at a robot's start, and the count is
/// deterministic (not a clock: the same robot gets the same pairs on any machine).
pub(super) const MODEL_SURFACE_BUDGET: usize = 2_000_000;

/// The distance the limits must keep between the shapes, metres.
const CLEARANCE_M: f64 = 0.001;

/// The joints between two shapes' links, their ranges and Lipschitz factors.
struct Between {
    /// Configuration indices.
    q_index: Vec<usize>,
    /// Each joint's range, `(lo, hi)`, holding the reference value.
    range: Vec<(f64, f64)>,
    /// How far a point of the shape moves per unit of the joint (metres per radian or metre).
    reach: Vec<f64>,
}

/// Proofs already made for one robot at one reference posture, shared by its collision models
/// (and clones of its anatomy): (the two shapes' indices, the joints between) → kept apart.
#[derive(Clone, Default)]
pub struct ApartProofs(Arc<Mutex<HashMap<ProofKey, bool>>>);

/// Two shapes of a collision model (indices) and the joints between their links.
type ProofKey = (usize, usize, Vec<usize>);

impl std::fmt::Debug for ApartProofs {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let n = self.0.lock().map_or(0, |m| m.len());
        write!(f, "ApartProofs({n} pairs)")
    }
}

/// Whether the joint limits keep shapes `a` and `b` (indices `ia`, `ib` of their model) apart
/// by more than a millimetre for every value of the joints between their links (of the joints
/// `moving`, indices into [`Robot::joints`]; the others at `reference`, whose frames are
/// `at_reference`). False when it cannot be proven: a posture brings them that close, too many
/// joints lie between, a range is unbounded, or a budget ran out (`surface_budget`: the
/// model's triangle queries left).
pub(super) fn kept_apart(
    robot: &Robot,
    ancestry: &Ancestry,
    moving: &[usize],
    (reference, at_reference): (&[f64], &RobotFrames),
    ((ia, a), (ib, b)): ((usize, &LinkShape), (usize, &LinkShape)),
    proofs: Option<&ApartProofs>,
    surface_budget: &mut usize,
) -> bool {
    let Some(between) = joints_between(robot, ancestry, moving, (reference, at_reference), a, b)
    else {
        return false;
    };
    let key = (ia, ib, between.q_index.clone());
    let known = proofs.and_then(|p| p.0.lock().ok().and_then(|m| m.get(&key).copied()));
    if let Some(known) = known {
        return known;
    }
    let apart = proven(robot, ancestry, reference, &between, (a, b), surface_budget);
    if let Some(mut m) = proofs.and_then(|p| p.0.lock().ok()) {
        m.insert(key, apart);
    }
    apart
}

/// The joints between the links of `a` and `b`, or `None` when the proof is not tried.
fn joints_between(
    robot: &Robot,
    ancestry: &Ancestry,
    moving: &[usize],
    (reference, at_reference): (&[f64], &RobotFrames),
    a: &LinkShape,
    b: &LinkShape,
) -> Option<Between> {
    let (above_a, above_b) = (ancestry.above(a.link), ancestry.above(b.link));
    let mut between = Between {
        q_index: Vec::new(),
        range: Vec::new(),
        reach: Vec::new(),
    };
    for (side, above, other) in [(a, above_a, above_b), (b, above_b, above_a)] {
        for &j in above.iter().filter(|j| !other.contains(j)) {
            if !moving.contains(&j) {
                continue;
            }
            if between.q_index.len() == MAX_JOINTS_BETWEEN {
                return None;
            }
            let joint = &robot.joints[j];
            let i = joint.q_index?;
            let now = reference.get(i).copied().unwrap_or(0.0);
            let (lo, hi) = joint.limits;
            let range = match joint.kind {
                JointKind::Prismatic if lo.is_finite() && hi.is_finite() && lo <= hi => {
                    (lo.min(now), hi.max(now))
                }
                JointKind::Prismatic => return None,
                _ if lo <= hi && hi - lo < std::f64::consts::TAU => (lo.min(now), hi.max(now)),
                // A whole turn or more, or no limits: every angle.
                _ => (now - std::f64::consts::PI, now + std::f64::consts::PI),
            };
            let reach = match joint.kind {
                JointKind::Prismatic => 1.0,
                _ => reach_below(robot, moving, at_reference, j, side)?,
            };
            between.q_index.push(i);
            between.range.push(range);
            between.reach.push(reach);
        }
    }
    (!between.q_index.is_empty()).then_some(between)
}

/// A bound on the distance of any point of `shape` from the axis of joint `j` above its link,
/// whatever the joints between, from the corners of a box holding the shape (at the reference
/// posture, `frames`):
/// where no moving joint lies between `j` and the link, the farthest corner's distance from
/// the axis line; where one does (`k`: at most two joints lie between), the distance from `j`'s
/// origin to `k`'s (rigid in `j`'s child), plus the farthest corner's from `k`'s origin (which
/// `k`'s turn keeps; a prismatic `k` adds its travel).
fn reach_below(
    robot: &Robot,
    moving: &[usize],
    frames: &RobotFrames,
    j: usize,
    shape: &LinkShape,
) -> Option<f64> {
    let path = robot.path_to(shape.link);
    let after = path.iter().position(|&k| k == j)? + 1;
    let place = frames.link(shape.link);
    let corners: Vec<_> = shape
        .corners()
        .iter()
        .map(|c| (place * nalgebra::Point3::from(*c)).coords)
        .collect();
    let joint_at = |k: usize| {
        let frame = frames.link(robot.joints[k].parent) * robot.joints[k].origin;
        let axis = frame.rotation * robot.joints[k].axis.into_inner();
        (frame.translation.vector, axis)
    };
    let (origin, axis) = joint_at(j);
    let mut below = path[after..].iter().copied().filter(|k| moving.contains(k));
    let reach = match (below.next(), below.next()) {
        (None, _) => corners
            .iter()
            .map(|c| {
                let offset = c - origin;
                (offset - axis * axis.dot(&offset)).norm()
            })
            .fold(0.0, f64::max),
        (Some(k), None) => {
            let (next, _) = joint_at(k);
            let farthest = corners
                .iter()
                .map(|c| (c - next).norm())
                .fold(0.0, f64::max);
            let joint = &robot.joints[k];
            let travel = match joint.kind {
                JointKind::Prismatic => (joint.limits.1 - joint.limits.0).abs(),
                _ => 0.0,
            };
            (next - origin).norm() + farthest + travel
        }
        _ => return None,
    };
    reach.is_finite().then_some(reach)
}

/// Branch and bound over `between`'s box: true when every part of it is proven to keep the
/// shapes of `pair` more than the clearance apart within the budgets. Each box is judged on
/// the shapes checked every step (hulls: cheap, never nearer than the truth), then, where they
/// do not settle it, on the meshes' triangles (each such query taken from `surface_budget`).
fn proven(
    robot: &Robot,
    ancestry: &Ancestry,
    reference: &[f64],
    between: &Between,
    pair: (&LinkShape, &LinkShape),
    surface_budget: &mut usize,
) -> bool {
    let surfaces = (pair.0.surface().is_some() || pair.1.surface().is_some()).then(|| {
        let truly = |s: &LinkShape| s.surface().cloned().unwrap_or_else(|| s.shape.clone());
        (truly(pair.0), truly(pair.1))
    });
    let mut q = reference.to_vec();
    // Best first: the box whose parent came nearest (the least lower bound on its distance)
    // is split next, so that a pair that can meet is found meeting within few queries.
    let mut boxes = std::collections::BinaryHeap::new();
    boxes.push(Cell(f64::NEG_INFINITY, between.range.clone()));
    let (mut queries, mut surface_queries) = (0, 0);
    while let Some(Cell(_, cell)) = boxes.pop() {
        if queries == BUDGET {
            return false;
        }
        queries += 1;
        for (&i, &(lo, hi)) in between.q_index.iter().zip(&cell) {
            if let Some(v) = q.get_mut(i) {
                *v = 0.5 * (lo + hi);
            }
        }
        let frames = RobotFrames::new(robot, ancestry, &q);
        let place = |s: &LinkShape| pose_to_parry(&(frames.link(s.link) * s.local));
        let (pa, pb) = (place(pair.0), place(pair.1));
        let moves: Vec<f64> = cell
            .iter()
            .zip(&between.reach)
            .map(|(&(lo, hi), r)| r * 0.5 * (hi - lo))
            .collect();
        let slack = CLEARANCE_M + moves.iter().sum::<f64>();
        let Some(mut apart) = (match (pair.0.support_map(), pair.1.support_map()) {
            (Some(ga), Some(gb)) => Some(parry::query::details::distance_support_map_support_map(
                &pa.inv_mul(&pb),
                ga,
                gb,
            )),
            _ => parry::query::distance(&pa, pair.0.shape.as_ref(), &pb, pair.1.shape.as_ref())
                .ok()
                .map(|d| d.distance),
        })
        .map(f64::from) else {
            return false;
        };
        if apart <= slack {
            if let Some((sa, sb)) = &surfaces {
                let cost = pair.0.triangles() + pair.1.triangles();
                if surface_queries == SURFACE_BUDGET || *surface_budget < cost {
                    return false;
                }
                surface_queries += 1;
                *surface_budget -= cost;
                let Some(on_surfaces) = surface_distance((&pa, sa), (&pb, sb), apart, slack) else {
                    return false;
                };
                apart = on_surfaces;
            }
        }
        if apart <= CLEARANCE_M {
            return false;
        }
        if apart > slack {
            continue;
        }

        // Halve the joint that moves the shapes most over the box.
        let widest = (0..moves.len())
            .max_by(|&x, &y| moves[x].total_cmp(&moves[y]))
            .unwrap_or(0);
        let (lo, hi) = cell[widest];
        let mid = 0.5 * (lo + hi);
        let mut lower = cell.clone();
        lower[widest] = (lo, mid);
        let mut upper = cell;
        upper[widest] = (mid, hi);
        let bound = apart - slack;
        boxes.push(Cell(bound, lower));
        boxes.push(Cell(bound, upper));
    }
    true
}

/// The distance of the triangles of `a` and `b` when at most `up_to` (infinite when more; `None`
/// when they intersect), knowing it is at least `from` (their hulls' distance).
///
/// Only whether they are nearer than `up_to`, and then how near: parry's trees skip every pair
/// of triangles farther apart than the margin asked, but a query's cost grows with the pairs
/// within it (80 ms at 8 cm on iCub's shoulder and upper arm, against 0.3 ms at 1 mm). So the
/// margin grows from just beyond the hulls' distance, fourfold a time, up to `up_to`: where the
/// triangles are about as near as the hulls (most pairs of shoulders and arms) the first,
/// cheap query finds them; only a box that may be proven pays for the whole margin.
fn surface_distance(
    (pa, a): (&parry::math::Pose, &parry::shape::SharedShape),
    (pb, b): (&parry::math::Pose, &parry::shape::SharedShape),
    from: f64,
    up_to: f64,
) -> Option<f64> {
    let mut beyond = CLEARANCE_M;
    loop {
        let margin = (from.max(0.0) + beyond).min(up_to);
        match parry::query::closest_points(pa, a.as_ref(), pb, b.as_ref(), margin as f32) {
            Ok(ClosestPoints::WithinMargin(p1, p2)) => return Some(f64::from((p1 - p2).length())),
            Ok(ClosestPoints::Disjoint) if margin >= up_to => return Some(f64::INFINITY),
            Ok(ClosestPoints::Disjoint) => beyond *= 4.0,
            Ok(ClosestPoints::Intersecting) | Err(_) => return None,
        }
    }
}

/// A box of joint values and a lower bound on the shapes' distance over it (its parent's
/// distance less its parent's slack), ordered so that the least bound comes first.
struct Cell(f64, Vec<(f64, f64)>);

impl PartialEq for Cell {
    fn eq(&self, other: &Cell) -> bool {
        self.0.total_cmp(&other.0).is_eq()
    }
}

impl Eq for Cell {}

impl PartialOrd for Cell {
    fn partial_cmp(&self, other: &Cell) -> Option<std::cmp::Ordering> {
        Some(self.cmp(other))
    }
}

impl Ord for Cell {
    fn cmp(&self, other: &Cell) -> std::cmp::Ordering {
        other.0.total_cmp(&self.0)
    }
}

#[cfg(test)]
pub(super) mod tests {
    use super::super::collision::CollisionModel;
    use super::*;
    use crate::physics::MeshShapes;
    use rapier3d::parry::shape::SharedShape;

    #[test]
    fn surface_distance_is_exact_within_its_reach_and_infinite_beyond() {
        // Two unit cubes' surfaces, centres 1.3 m apart along x: their faces 0.3 m apart.
        let cube = || {
            let (v, i) = SharedShape::cuboid(0.5, 0.5, 0.5)
                .as_cuboid()
                .unwrap()
                .to_trimesh();
            SharedShape::trimesh(v, i).unwrap()
        };
        let (a, b) = (cube(), cube());
        let at = |x: f32| parry::math::Pose::translation(x, 0.0, 0.0);
        let (pa, pb) = (at(0.0), at(1.3));
        // 0.3 apart: found from any lower bound, whatever the reach beyond it.
        for from in [0.0, 0.1, 0.29] {
            let d = surface_distance((&pa, &a), (&pb, &b), from, 1.0).unwrap();
            assert!((d - 0.3).abs() < 1e-5, "{d}");
        }
        assert_eq!(
            surface_distance((&pa, &a), (&pb, &b), 0.0, 0.25),
            Some(f64::INFINITY)
        );
        // Overlapping: none.
        assert_eq!(surface_distance((&pa, &a), (&at(0.9), &b), 0.0, 1.0), None);
    }

    /// A speck of a shape 2 m up, for a link between two others: with no shape there the two
    /// would be neighbours (`neighbour_matrix`), never checked.
    pub(in crate::kinematics) const SPECK: &str = r#"<collision><origin xyz="0 0 2"/><geometry><sphere radius="0.001"/></geometry></collision>"#;

    /// A post on the base at x = −0.4 and a two-joint arm (a yaw, then a pitch) whose forearm
    /// box reaches 0.3–0.5 m out along x: the yaw's limits `±yaw` decide whether it can swing
    /// round to the post.
    fn arm_and_post(yaw: f64) -> Robot {
        let xml = format!(
            r#"<robot name="post">
  <link name="base"><collision><origin xyz="-0.4 0 0.1"/><geometry><box size="0.1 0.1 0.4"/></geometry></collision></link>
  <link name="yaw_link">{SPECK}</link>
  <link name="forearm"><collision><origin xyz="0.4 0 0"/><geometry><box size="0.2 0.05 0.05"/></geometry></collision></link>
  <joint name="yaw" type="revolute"><parent link="base"/><child link="yaw_link"/><origin xyz="0 0 0.1"/><axis xyz="0 0 1"/><limit lower="-{yaw}" upper="{yaw}" effort="1" velocity="1"/></joint>
  <joint name="pitch" type="revolute"><parent link="yaw_link"/><child link="forearm"/><axis xyz="0 1 0"/><limit lower="-0.3" upper="0.3" effort="1" velocity="1"/></joint>
</robot>"#
        );
        Robot::from_urdf_str(&xml, "post.urdf").unwrap()
    }

    fn model(robot: &Robot) -> CollisionModel {
        let ancestry = Ancestry::of(robot);
        let zero = vec![0.0; robot.dof()];
        CollisionModel::new(robot, &ancestry, &robot.movable, &zero, 0.01, None, None)
    }

    #[test]
    fn a_pair_the_limits_keep_apart_is_left_out_and_one_they_let_meet_is_kept() {
        // Within ±1 rad of yaw the forearm stays ≥ 0.1 m from the post.
        let held = arm_and_post(1.0);
        let m = model(&held);
        assert_eq!((m.pairs().len(), m.kept_apart_by_limits()), (0, 1));
        // Within ±3 rad it swings into the post (at yaw = π it would pass through it).
        let free = arm_and_post(3.0);
        let m = model(&free);
        assert_eq!((m.pairs().len(), m.kept_apart_by_limits()), (1, 0));
    }

    /// A U-shaped bracket (three boxes' triangles, its opening towards the base) on the base
    /// and a slider carrying a box into the opening, `travel` metres from x = 0.25–0.35, with a
    /// small yaw between: the hull of the U fills its opening, its triangles do not.
    pub(in crate::kinematics) fn slider_into_a_u(travel: f64) -> (Robot, MeshShapes) {
        let xml = format!(
            r#"<robot name="u">
  <link name="base"><collision><geometry><mesh filename="u.stl"/></geometry></collision></link>
  <link name="carriage">{SPECK}</link>
  <link name="block"><collision><origin xyz="0.3 0 0"/><geometry><box size="0.1 0.05 0.03"/></geometry></collision></link>
  <joint name="slide" type="prismatic"><parent link="base"/><child link="carriage"/><axis xyz="1 0 0"/><limit lower="0" upper="{travel}" effort="1" velocity="1"/></joint>
  <joint name="yaw" type="revolute"><parent link="carriage"/><child link="block"/><axis xyz="0 0 1"/><limit lower="-0.1" upper="0.1" effort="1" velocity="1"/></joint>
</robot>"#
        );
        let robot = Robot::from_urdf_str(&xml, "u.urdf").unwrap();
        // Two walls at |y| = 0.18–0.22 from x = 0.4 to 0.8 and the back wall at x = 0.78–0.8.
        let walls = [
            ([0.4, 0.18, -0.05], [0.8, 0.22, 0.05]),
            ([0.4, -0.22, -0.05], [0.8, -0.18, 0.05]),
            ([0.78, -0.22, -0.05], [0.8, 0.22, 0.05]),
        ];
        let (mut points, mut triangles) = (Vec::new(), Vec::new());
        for (lo, hi) in walls {
            let base = points.len() as u32;
            for n in 0..8 {
                let pick = |axis: usize| {
                    if n >> axis & 1 == 1 {
                        hi[axis]
                    } else {
                        lo[axis]
                    }
                };
                points.push(parry::math::Vector::new(pick(0), pick(1), pick(2)));
            }
            for face in [
                [0, 1, 3],
                [0, 3, 2],
                [4, 6, 7],
                [4, 7, 5],
                [0, 4, 5],
                [0, 5, 1],
                [2, 3, 7],
                [2, 7, 6],
                [0, 2, 6],
                [0, 6, 4],
                [1, 5, 7],
                [1, 7, 3],
            ] {
                triangles.push(face.map(|i: u32| base + i));
            }
        }
        let hull = SharedShape::convex_hull(&points).unwrap();
        let surface = SharedShape::trimesh(points, triangles).ok();
        (robot, MeshShapes::new(hull, surface))
    }

    /// The collision model of `robot` (a 1 cm margin, every joint moving) whose mesh is `mesh`.
    pub(in crate::kinematics) fn model_with_mesh(
        robot: &Robot,
        mesh: &MeshShapes,
    ) -> CollisionModel {
        let loader = |_: &str, _: [f64; 3]| Ok(mesh.clone());
        let ancestry = Ancestry::of(robot);
        let zero = vec![0.0; robot.dof()];
        CollisionModel::new(
            robot,
            &ancestry,
            &robot.movable,
            &zero,
            0.01,
            Some(&loader),
            None,
        )
    }

    #[test]
    fn a_hull_that_fills_a_concave_mesh_does_not_keep_a_pair_its_triangles_keep_apart() {
        let count_with = |travel: f64, triangles: bool| {
            let (robot, mut mesh) = slider_into_a_u(travel);
            if !triangles {
                mesh.surface = None;
            }
            let m = model_with_mesh(&robot, &mesh);
            (m.pairs().len(), m.kept_apart_by_limits())
        };
        // 0.3 m in: the block (to x = 0.65, |y| ≤ 0.09) is inside the hull, between the walls.
        assert_eq!(count_with(0.3, true), (0, 1));
        // The hull alone cannot tell.
        assert_eq!(count_with(0.3, false), (1, 0));
        // 0.5 m in: it reaches the back wall.
        assert_eq!(count_with(0.5, true), (1, 0));
    }

    #[test]
    fn what_is_proven_apart_is_apart_everywhere_in_the_limits() {
        // The largest yaw range still proven: sampled densely, no posture comes within the
        // clearance (the Lipschitz bound is a bound, not an estimate).
        let mut widest = 0.0;
        for step in 1..=30 {
            let yaw = 0.1 * f64::from(step);
            if model(&arm_and_post(yaw)).kept_apart_by_limits() == 1 {
                widest = yaw;
            }
        }
        assert!(widest >= 1.0, "proven up to ±{widest} rad only");
        let robot = arm_and_post(widest);
        let ancestry = Ancestry::of(&robot);
        let m = model(&arm_and_post(3.0));
        let mut least = f64::INFINITY;
        for i in 0..=200 {
            for k in 0..=20 {
                let q = [
                    -widest + 2.0 * widest * f64::from(i) / 200.0,
                    -0.3 + 0.6 * f64::from(k) / 20.0,
                ];
                let frames = RobotFrames::new(&robot, &ancestry, &q);
                if let Some(p) = m.proximities(&frames, 1.0).first() {
                    least = least.min(p.distance);
                }
            }
        }
        assert!(least > CLEARANCE_M, "{least} m at ±{widest} rad");
        // The post is 0.4 m out and the forearm reaches 0.5 m: at yaw π − 0.4 they are close;
        // the proof cannot claim much beyond where they actually come within the clearance.
        assert!(widest < 3.0, "{widest}");
    }
}
