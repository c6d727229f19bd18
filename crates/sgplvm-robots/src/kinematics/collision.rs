//! A robot's own collision shapes and the pairs of them that can meet, with their distances
//! and closest points at a configuration (parry, which rapier already uses): what the
//! self-collision limit of differential IK and the live safety step are made of.
//!
//! Shapes are the URDF's `<collision>` elements: boxes, cylinders, capsules and spheres, and
//! meshes where a loader turns them into convex hulls; what cannot be checked (a mesh not
//! found) is listed, never silently dropped. A mesh in a pair that can meet is also split into
//! convex parts, checked where the two hulls come near (a hull fills a mesh's concave places:
//! the PR2's forearm hull meets its upper arm's long before the meshes do). A pair of shapes
//! *can meet* when their links move relative to each other through the moving joints, are not
//! neighbours (`adjacency::neighbour_matrix`: one moving joint apart) and are not the model's own
//! closeness at the reference posture (`own_closeness`, on the meshes' parts: touching there,
//! like an upper arm's capsule reaching into the shoulder's, or a joint's housing beside the
//! next link's), as in MoveIt's "adjacent / default" lists and as the physics replay judges
//! them at rest. A pair nearer than the margin there keeps the distance it has there
//! ([`CollisionModel::margin_of`]).

use std::sync::Arc;

use nalgebra::{Isometry3, UnitQuaternion, Vector3};
use rapier3d::parry;
use rapier3d::parry::shape::{SharedShape, SupportMap};

use super::adjacency::{neighbour_matrix, own_closeness, TOUCHING_M};
use super::apart::{kept_apart, ApartProofs, MODEL_SURFACE_BUDGET};
use super::bounds::{Obb, Placed};
use super::contact::{closeness, contact, Whole};
use super::frames::{Ancestry, RobotFrames};
use super::hull::ClimbingHull;
use crate::physics::MeshShapes;
use crate::urdf::{pose_from_xyz_rpy, Robot};

/// One collision shape of a link.
#[derive(Clone)]
pub struct LinkShape {
    /// The link (index into [`Robot::link_names`]).
    pub link: usize,
    /// The shape (parry, single precision).
    pub shape: SharedShape,
    /// Its pose in the link's frame.
    pub local: Isometry3<f64>,
    /// The centre of a sphere holding it, in the link's frame, and its radius: a cheap test
    /// before parry's.
    pub bound: (Vector3<f64>, f64),
    /// A mesh's hull in the form whose support points are climbed to, not scanned for.
    hull: Option<Arc<ClimbingHull>>,
    /// The mesh the shape is the hull of: its triangles, for proving a pair apart, and its
    /// convex parts, for checking a pair the hull is too coarse for.
    mesh: Option<MeshShapes>,
    /// A box holding it, in the link's frame: the second, tighter test before parry's.
    obb: Obb,
}

impl LinkShape {
    /// Shape `shape` of link `link` at `local` in the link's frame, the hull of `mesh` if given.
    fn new(
        link: usize,
        shape: SharedShape,
        local: Isometry3<f64>,
        mesh: Option<MeshShapes>,
    ) -> LinkShape {
        let sphere = shape.compute_local_bounding_sphere();
        let centre = (local * nalgebra::Point3::from(vec_from_parry(sphere.center))).coords;
        let hull = shape
            .as_convex_polyhedron()
            .and_then(ClimbingHull::of)
            .map(Arc::new);
        let obb = Obb::of(&shape, &local);
        LinkShape {
            link,
            shape,
            local,
            bound: (centre, f64::from(sphere.radius)),
            hull,
            mesh,
            obb,
        }
    }

    /// Its bounding sphere and box placed by `frames`.
    fn placed(&self, frames: &RobotFrames) -> Placed {
        let pose = frames.link(self.link);
        Placed {
            centre: (pose * nalgebra::Point3::from(self.bound.0)).coords,
            radius: self.bound.1,
            obb: self.obb.placed(&pose),
        }
    }

    /// A mesh's own triangles (the shape is their hull).
    pub(super) fn surface(&self) -> Option<&SharedShape> {
        self.mesh.as_ref()?.surface.as_ref()
    }

    /// The convex parts of the shape's mesh as shapes of its link (none: the shape is checked
    /// whole).
    fn parts(&self) -> Vec<LinkShape> {
        let Some(mesh) = &self.mesh else {
            return Vec::new();
        };
        mesh.convex_parts()
            .iter()
            .map(|part| LinkShape::new(self.link, part.clone(), self.local, None))
            .collect()
    }

    /// The corners of a box holding the shape, in its link's frame.
    pub(super) fn corners(&self) -> [Vector3<f64>; 8] {
        let o = &self.obb;
        std::array::from_fn(|n| {
            let sign = |bit: usize| if n >> bit & 1 == 1 { 1.0 } else { -1.0 };
            o.centre
                + o.axes.column(0) * (sign(0) * o.half.x)
                + o.axes.column(1) * (sign(1) * o.half.y)
                + o.axes.column(2) * (sign(2) * o.half.z)
        })
    }

    /// The triangles of a mesh's surface (1 for a shape without: a primitive, a hull alone).
    pub(super) fn triangles(&self) -> usize {
        self.surface()
            .and_then(|s| s.as_trimesh())
            .map_or(1, |t| t.indices().len())
    }

    /// Whether the shape is a mesh's hull (climbed, not scanned, for its support points).
    pub(super) fn is_hull(&self) -> bool {
        self.hull.is_some()
    }

    /// The shape as GJK queries it: the climbing hull where there is one.
    pub(super) fn support_map(&self) -> Option<&dyn SupportMap> {
        match &self.hull {
            Some(h) => Some(h.as_ref()),
            None => self.shape.as_support_map(),
        }
    }
}

/// Two shapes near each other at a configuration.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Proximity {
    /// The pair (index into [`CollisionModel::pairs`]).
    pub pair: usize,
    /// Signed distance, metres (negative: penetrating).
    pub distance: f64,
    /// The closest point on the first shape (root frame).
    pub point_a: Vector3<f64>,
    /// The closest point on the second shape (root frame).
    pub point_b: Vector3<f64>,
    /// Unit normal from the first shape towards the second.
    pub normal: Vector3<f64>,
}

/// A robot's collision shapes and the pairs of them that can meet.
#[derive(Clone)]
pub struct CollisionModel {
    shapes: Vec<LinkShape>,
    /// Each shape's convex parts where it is a mesh in a pair that can meet (empty: whole).
    parts: Vec<Vec<LinkShape>>,
    /// Below this distance of their hulls two meshes are checked on their parts (further, the
    /// hulls' distance is a bound that does not hold a step back).
    parts_below: f64,
    pairs: Vec<(usize, usize)>,
    /// Each pair's distance at the reference where nearer than the margin there (infinite
    /// where not): what it keeps instead of the margin.
    at_reference: Vec<f64>,
    unchecked: Vec<String>,
    overlapping_at_reference: usize,
    kept_apart_by_limits: usize,
}

/// Turns a mesh collision element (file name as written in the URDF, scale) into its hull and
/// triangles, or says why it cannot.
pub type MeshLoader<'a> = dyn Fn(&str, [f64; 3]) -> Result<MeshShapes, String> + 'a;

pub(super) fn pose_to_parry(p: &Isometry3<f64>) -> parry::math::Pose {
    let t = p.translation.vector;
    let q = p.rotation;
    parry::math::Pose::from_parts(
        parry::math::Vector::new(t.x as f32, t.y as f32, t.z as f32),
        parry::math::Rot3::from_xyzw(q.i as f32, q.j as f32, q.k as f32, q.w as f32),
    )
}

pub(super) fn vec_from_parry(v: parry::math::Vector) -> Vector3<f64> {
    Vector3::new(f64::from(v.x), f64::from(v.y), f64::from(v.z))
}

/// The shape of one URDF collision geometry (URDF cylinders and capsules lie along z; parry's
/// cylinder along y, hence a turn), a mesh's triangles beside its hull.
fn shape_of(
    geometry: &urdf_rs::Geometry,
    meshes: Option<&MeshLoader<'_>>,
) -> Result<(SharedShape, Option<MeshShapes>, Isometry3<f64>), String> {
    let z_to_y = Isometry3::from_parts(
        nalgebra::Translation3::identity(),
        UnitQuaternion::from_axis_angle(&Vector3::x_axis(), std::f64::consts::FRAC_PI_2),
    );
    let primitive = match geometry {
        urdf_rs::Geometry::Box { size } => (
            SharedShape::cuboid(
                (size[0] / 2.0) as f32,
                (size[1] / 2.0) as f32,
                (size[2] / 2.0) as f32,
            ),
            Isometry3::identity(),
        ),
        urdf_rs::Geometry::Cylinder { radius, length } => (
            SharedShape::cylinder((length / 2.0) as f32, *radius as f32),
            z_to_y,
        ),
        urdf_rs::Geometry::Capsule { radius, length } => (
            SharedShape::capsule_z((length / 2.0) as f32, *radius as f32),
            Isometry3::identity(),
        ),
        urdf_rs::Geometry::Sphere { radius } => {
            (SharedShape::ball(*radius as f32), Isometry3::identity())
        }
        urdf_rs::Geometry::Mesh { filename, scale } => {
            let scale = scale.as_ref().map_or([1.0; 3], |s| [s[0], s[1], s[2]]);
            let loader = meshes.ok_or_else(|| format!("mesh {filename} (meshes not loaded)"))?;
            let mesh = loader(filename, scale)?;
            return Ok((mesh.hull.clone(), Some(mesh), Isometry3::identity()));
        }
    };
    Ok((primitive.0, None, primitive.1))
}

impl CollisionModel {
    /// The collision model of `robot`: its shapes (meshes through `meshes`, when given) and
    /// the pairs that can meet when the joints `moving` (indices into [`Robot::joints`]) move,
    /// judged at the reference configuration `reference`: pairs that are the model's own
    /// closeness there (on the meshes' parts) are left out, other pairs nearer than `apart`
    /// keep their distance there instead ([`CollisionModel::margin_of`]), and pairs the joint
    /// limits keep apart (proven, see [`CollisionModel::kept_apart_by_limits`]; the proofs kept
    /// in `proofs`, when given, for the next model of the same robot and reference).
    pub fn new(
        robot: &Robot,
        ancestry: &Ancestry,
        moving: &[usize],
        reference: &[f64],
        apart: f64,
        meshes: Option<&MeshLoader<'_>>,
        proofs: Option<&ApartProofs>,
    ) -> CollisionModel {
        let mut shapes = Vec::new();
        let mut unchecked = Vec::new();
        for link in &robot.urdf.links {
            let Some(&l) = robot.link_index.get(&link.name) else {
                continue;
            };
            for c in &link.collision {
                let origin = pose_from_xyz_rpy(
                    [c.origin.xyz[0], c.origin.xyz[1], c.origin.xyz[2]],
                    [c.origin.rpy[0], c.origin.rpy[1], c.origin.rpy[2]],
                );
                match shape_of(&c.geometry, meshes) {
                    Ok((shape, mesh, turn)) => {
                        shapes.push(LinkShape::new(l, shape, origin * turn, mesh));
                    }
                    Err(why) => unchecked.push(format!("{}: {why}", link.name)),
                }
            }
        }
        let moves = |link: usize| -> Vec<usize> {
            ancestry
                .above(link)
                .iter()
                .copied()
                .filter(|j| moving.contains(j))
                .collect()
        };
        // A link drawn but given no collision element, on a body (the links the joints held
        // still weld to it) with no collision shape at all, is not checked either: said
        // (K-Scale's KBot gives 14 of its 18 links visuals alone). A wrist link without one,
        // welded to a palm with one, is checked as that body.
        let bodies: Vec<Vec<usize>> = shapes.iter().map(|s| moves(s.link)).collect();
        for link in &robot.urdf.links {
            let Some(&l) = robot.link_index.get(&link.name) else {
                continue;
            };
            if link.collision.is_empty() && !link.visual.is_empty() && !bodies.contains(&moves(l)) {
                unchecked.push(format!(
                    "{}: a <visual> but no <collision> on its body (a visual is not taken for one)",
                    link.name
                ));
            }
        }
        let parent_of: Vec<Option<(usize, usize)>> = robot
            .parent_joint
            .iter()
            .map(|p| p.map(|j| (j, robot.joints[j].parent)))
            .collect();
        let mut has_shape = vec![false; parent_of.len()];
        for s in &shapes {
            has_shape[s.link] = true;
        }
        let n_links = parent_of.len();
        // Joints that do not move here (a neck, a waist, legs held by their controllers) join
        // their links into one body, as the physics replay welds them.
        let adjacent = neighbour_matrix(&parent_of, |j| moving.contains(&j), &has_shape);
        let neighbours = |a: usize, b: usize| adjacent[a * n_links + b];
        let mut model = CollisionModel {
            parts: vec![Vec::new(); shapes.len()],
            parts_below: apart.max(0.0) + PARTS_BEYOND_MARGIN_M,
            shapes,
            pairs: Vec::new(),
            at_reference: Vec::new(),
            unchecked,
            overlapping_at_reference: 0,
            kept_apart_by_limits: 0,
        };
        let frames = RobotFrames::new(robot, ancestry, reference);
        let mut candidates = Vec::new();
        let mut near = Vec::new();
        for i in 0..model.shapes.len() {
            for k in (i + 1)..model.shapes.len() {
                let (a, b) = (model.shapes[i].link, model.shapes[k].link);
                if a == b || neighbours(a, b) || moves(a) == moves(b) {
                    continue;
                }
                match contact(&frames, &model.shapes[i], &model.shapes[k], apart) {
                    Some((_, d)) if d <= apart => near.push((i, k)),
                    _ => candidates.push((i, k)),
                }
            }
        }
        // Pairs near at the reference are judged on their meshes' parts: the model's own
        // closeness (`own_closeness`) is left out, the others keep the distance they have there
        // (nearer than the margin) or the margin.
        model.split_meshes(near.iter().flat_map(|&(i, k)| [i, k]));
        let mut at_reference = std::collections::HashMap::new();
        let mut own_links = std::collections::HashSet::new();
        for (i, k) in near {
            let links = (model.shapes[i].link, model.shapes[k].link);
            match model.distance(&frames, i, k, apart) {
                None => candidates.push((i, k)),
                Some(d) if own_closeness(&parent_of, |j| moving.contains(&j), links, d) => {
                    model.overlapping_at_reference += 1;
                    if d <= TOUCHING_M {
                        own_links.insert(links);
                    }
                }
                Some(d) => {
                    at_reference.insert((i, k), d);
                }
            }
        }
        // Two links one of whose shapes touches the other's at rest are the model's own
        // closeness whole, as MoveIt leaves out a pair of links in contact at rest: Galbot's
        // wrist camera, 33 convex pieces, touches its forearm with two and passes 1.5 mm from it
        // with four more, which then held the arm wherever the wrist turned.
        let own = |&(i, k): &(usize, usize)| {
            own_links.contains(&(model.shapes[i].link, model.shapes[k].link))
        };
        let before = candidates.len() + at_reference.len();
        candidates.retain(|p| !own(p));
        at_reference.retain(|p, _| !own(p));
        model.overlapping_at_reference += before - candidates.len() - at_reference.len();
        candidates.sort_unstable();
        // The proofs in order of their meshes' size, so that the model's budget goes first to
        // the pairs it proves cheapest; the pairs kept stay in shape order.
        let mut by_cost = candidates.clone();
        by_cost.sort_by_key(|&(i, k)| model.shapes[i].triangles() + model.shapes[k].triangles());
        let mut budget = MODEL_SURFACE_BUDGET;
        let mut proven = std::collections::HashSet::new();
        for (i, k) in by_cost {
            let (sa, sb) = (&model.shapes[i], &model.shapes[k]);
            let pair = ((i, sa), (k, sb));
            if kept_apart(
                robot,
                ancestry,
                moving,
                (reference, &frames),
                pair,
                proofs,
                &mut budget,
            ) {
                proven.insert((i, k));
            }
        }
        model.kept_apart_by_limits = proven.len();
        // Kept: the pairs not proven apart and those near at the reference (never proven).
        model.pairs = candidates
            .into_iter()
            .filter(|p| !proven.contains(p))
            .chain(at_reference.keys().copied())
            .collect();
        model.pairs.sort_unstable();
        model.at_reference = model
            .pairs
            .iter()
            .map(|p| at_reference.get(p).copied().unwrap_or(f64::INFINITY))
            .collect();
        // The meshes of the pairs kept are checked on their convex parts.
        let kept: Vec<usize> = model.pairs.iter().flat_map(|&(i, k)| [i, k]).collect();
        model.split_meshes(kept.into_iter());
        model
    }

    /// Splits the meshes among `shapes` (indices) not split yet into their convex parts
    /// (decomposed on every core).
    fn split_meshes(&mut self, shapes: impl Iterator<Item = usize>) {
        let mut todo: Vec<usize> = shapes
            .filter(|&i| self.parts[i].is_empty() && self.shapes[i].mesh.is_some())
            .collect();
        todo.sort_unstable();
        todo.dedup();
        let meshes: Vec<&MeshShapes> = todo
            .iter()
            .filter_map(|&i| self.shapes[i].mesh.as_ref())
            .collect();
        crate::physics::decompose_all(&meshes);
        for i in todo {
            self.parts[i] = self.shapes[i].parts();
        }
    }

    /// The distance of shapes `i` and `k` placed by `frames`, on their parts where split, when
    /// within `within`.
    fn distance(&self, frames: &RobotFrames, i: usize, k: usize, within: f64) -> Option<f64> {
        let (pa, pb) = (self.shapes[i].placed(frames), self.shapes[k].placed(frames));
        let mut found = Vec::new();
        self.nearest_parts((i, &pa), (k, &pb), frames, within, &mut found);
        found.first().map(|f| f.1)
    }

    /// The shapes.
    pub fn shapes(&self) -> &[LinkShape] {
        &self.shapes
    }

    /// The pairs of shapes (indices into [`CollisionModel::shapes`]) that can meet.
    pub fn pairs(&self) -> &[(usize, usize)] {
        &self.pairs
    }

    /// What could not be checked, one line each beginning with its link's name: collision
    /// elements that gave no shape, and links drawn with no collision element on a body that
    /// has none.
    pub fn unchecked(&self) -> &[String] {
        &self.unchecked
    }

    /// Pairs left out as the model's own closeness at the reference posture: touching there (on
    /// the meshes' parts, within a millimetre; every other pair of the two links' shapes with
    /// them), or within a centimetre with at most two moving joints between.
    pub fn overlapping_at_reference(&self) -> usize {
        self.overlapping_at_reference
    }

    /// The distance pair `pair` is kept apart by, for a margin of `margin`: the margin, or less
    /// where the pair is nearer at the reference posture (which must stay within the limit).
    pub fn margin_of(&self, pair: usize, margin: f64) -> f64 {
        margin.min(self.at_reference[pair])
    }

    /// Pairs left out because the joint limits keep them apart: proven, over the joints between
    /// their links (at most two) within their limits, never to come within a millimetre (on the
    /// meshes' own triangles where the hulls do not settle it), as MoveIt's "never in
    /// collision" pairs are left out.
    pub fn kept_apart_by_limits(&self) -> usize {
        self.kept_apart_by_limits
    }

    /// The pair's two link indices.
    pub fn pair_links(&self, pair: usize) -> (usize, usize) {
        let (i, k) = self.pairs[pair];
        (self.shapes[i].link, self.shapes[k].link)
    }

    /// Shape `i` (placed at `own`) as it is checked, placed by `frames`: its parts that may
    /// come within `within` of the shape placed at `other`, or itself whole when it has none.
    fn nearing(
        &self,
        (i, own): (usize, &Placed),
        other: &Placed,
        frames: &RobotFrames,
        within: f64,
    ) -> Vec<(&LinkShape, Placed)> {
        if self.parts[i].is_empty() {
            return vec![(&self.shapes[i], *own)];
        }
        self.parts[i]
            .iter()
            .map(|s| (s, s.placed(frames)))
            .filter(|(_, placed)| placed.may_near(other, within))
            .collect()
    }

    /// The [`PARTS_PER_PAIR`] nearest contacts within `within` of shapes `i` and `k` (placed at
    /// `pa` and `pb`) on their parts, into `found`.
    fn nearest_parts(
        &self,
        (i, pa): (usize, &Placed),
        (k, pb): (usize, &Placed),
        frames: &RobotFrames,
        within: f64,
        found: &mut Vec<(parry::query::Contact, f64)>,
    ) {
        // Each mesh's parts that may near the other shape at all, then their pairs.
        let parts_a = self.nearing((i, pa), pb, frames, within);
        let parts_b = self.nearing((k, pb), pa, frames, within);
        // The pairs of parts nearest first by their spheres (a lower bound of their
        // distance), until the next cannot be nearer than the nearest found.
        let mut order: Vec<(f64, &LinkShape, &LinkShape)> = Vec::new();
        for (sa, qa) in &parts_a {
            for (sb, qb) in &parts_b {
                if qa.may_near(qb, within) {
                    order.push((qa.gap(qb), sa, sb));
                }
            }
        }
        order.sort_by(|x, y| x.0.total_cmp(&y.0));
        for (bound, sa, sb) in order {
            if found.len() == PARTS_PER_PAIR && found.iter().all(|f: &(_, f64)| f.1 <= bound) {
                break;
            }
            found.extend(contact(frames, sa, sb, within));
            found.sort_by(|x, y| x.1.total_cmp(&y.1));
            found.truncate(PARTS_PER_PAIR);
        }
    }

    /// Every pair within `within` metres at `frames`, with its closest points and normal (a
    /// pair of meshes whose hulls come near is checked on their convex parts: a proximity for
    /// each of the two nearest pairs of parts).
    pub fn proximities(&self, frames: &RobotFrames, within: f64) -> Vec<Proximity> {
        let placed: Vec<Placed> = self.shapes.iter().map(|s| s.placed(frames)).collect();
        let mut near = Vec::new();
        let mut found = Vec::new();
        for (p, &(i, k)) in self.pairs.iter().enumerate() {
            let (a, b) = (&self.shapes[i], &self.shapes[k]);
            let (pa, pb) = (&placed[i], &placed[k]);
            if !pa.may_near(pb, within) {
                continue;
            }
            let coarse = self.parts[i].is_empty() && self.parts[k].is_empty();
            let whole = if coarse {
                Whole::from(contact(frames, a, b, within))
            } else {
                closeness(frames, a, b, within)
            };
            match whole {
                Whole::Beyond => {}
                Whole::Near(c, d) if coarse || d >= self.parts_below => found.push((c, d)),
                _ => self.nearest_parts((i, pa), (k, pb), frames, within, &mut found),
            }
            near.extend(found.drain(..).map(|(c, d)| Proximity {
                pair: p,
                distance: d,
                point_a: vec_from_parry(c.point1),
                point_b: vec_from_parry(c.point2),
                normal: vec_from_parry(c.normal1),
            }));
        }
        near
    }
}

/// How far beyond the margin two meshes' hulls may come before their parts are checked, metres.
const PARTS_BEYOND_MARGIN_M: f64 = 0.01;

/// The nearest contacts of two meshes' parts a pair gives (the rest are further, and come in
/// when they are nearest: one step moves little).
const PARTS_PER_PAIR: usize = 2;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_concave_mesh_is_checked_on_parts_that_hold_its_surface_and_not_its_hull() {
        use super::super::apart::tests::{model_with_mesh, slider_into_a_u};
        let (robot, mesh) = slider_into_a_u(0.5);
        let model = model_with_mesh(&robot, &mesh);
        let ancestry = Ancestry::of(&robot);
        assert_eq!(model.pairs().len(), 1);
        let u = model
            .shapes()
            .iter()
            .position(|s| s.mesh.is_some())
            .unwrap();
        let parts = &model.parts[u];
        assert!(parts.len() >= 3, "{} parts", parts.len());
        // Every point of the surface is in a part (the parts are checked instead of the mesh).
        let surface = mesh.surface.as_ref().and_then(|s| s.as_trimesh()).unwrap();
        let identity = pose_to_parry(&Isometry3::identity());
        for v in surface.vertices() {
            let inside = parts
                .iter()
                .any(|p| p.shape.distance_to_point(&identity, *v, true) < 1e-4);
            assert!(inside, "{v:?} in no part");
        }
        let near_at = |slide: f64| {
            let frames = RobotFrames::new(&robot, &ancestry, &[slide, 0.0]);
            model.proximities(&frames, 0.05)
        };
        // 0.3 m in, the block (x 0.55–0.65, |y| ≤ 0.025) is inside the hull, 0.13 m from the
        // back wall and 0.155 m from the side walls: nothing near.
        let within_hull = near_at(0.3);
        assert!(within_hull.is_empty(), "{within_hull:?}");
        // 0.44 m in it reaches into the back wall (x ≥ 0.78).
        let touching = near_at(0.44);
        assert!(touching.iter().any(|p| p.distance < 0.0), "{touching:?}");
    }

    /// A base box and, `joints` revolute joints on (the links between with a speck of a shape,
    /// `SPECK`), a block whose face is `gap` metres
    /// from the base's at zero.
    fn block_near_base(joints: usize, gap: f64) -> Robot {
        block_near_base_shapes(joints, &[gap])
    }

    /// [`block_near_base`] with a block shape for each of `gaps`, stacked 0.2 m apart along z.
    fn block_near_base_shapes(joints: usize, gaps: &[f64]) -> Robot {
        let mut links = String::new();
        let mut chain = String::new();
        let mut parent = "base".to_string();
        for j in 0..joints {
            let child = if j + 1 == joints {
                "block".to_string()
            } else {
                format!("l{j}")
            };
            if child != "block" {
                links += &format!(
                    r#"<link name="{child}">{}</link>"#,
                    super::super::apart::tests::SPECK
                );
            }
            let axis = ["0 0 1", "0 1 0", "1 0 0"][j % 3];
            chain += &format!(
                r#"<joint name="j{j}" type="revolute"><parent link="{parent}"/><child link="{child}"/><axis xyz="{axis}"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint>"#
            );
            parent = child;
        }
        let (mut base, mut block) = (String::new(), String::new());
        for (n, gap) in gaps.iter().enumerate() {
            let (x, z) = (0.1 + gap, 0.2 * n as f64);
            base += &format!(
                r#"<collision><origin xyz="0 0 {z}"/><geometry><box size="0.1 0.1 0.1"/></geometry></collision>"#
            );
            block += &format!(
                r#"<collision><origin xyz="{x} 0 {z}"/><geometry><box size="0.1 0.1 0.1"/></geometry></collision>"#
            );
        }
        let xml = format!(
            r#"<robot name="near">
  <link name="base">{base}</link>
  {links}
  <link name="block">{block}</link>
  {chain}
</robot>"#
        );
        Robot::from_urdf_str(&xml, "near.urdf").unwrap()
    }

    #[test]
    fn a_pair_near_at_the_reference_keeps_its_distance_there_unless_it_is_the_models_own() {
        // The model, and its pair of the base and the block if kept.
        let model_of = |joints: usize, gap: f64| {
            let robot = block_near_base(joints, gap);
            let ancestry = Ancestry::of(&robot);
            let zero = vec![0.0; robot.dof()];
            let m = CollisionModel::new(&robot, &ancestry, &robot.movable, &zero, 0.01, None, None);
            let pair = (0..m.pairs().len()).find(|&p| {
                let (a, b) = m.pair_links(p);
                (robot.links[a].as_str(), robot.links[b].as_str()) == ("base", "block")
            });
            (m, pair)
        };
        // Three moving joints between, 5 mm apart at the reference: kept, at 5 mm, not 10.
        let (m, pair) = model_of(3, 0.005);
        let kept = m.margin_of(pair.expect("kept"), 0.01);
        assert!((kept - 0.005).abs() < 1e-5, "{kept}");
        assert_eq!(m.overlapping_at_reference(), 0);
        // Touching there: the model's own overlap, left out.
        let (m, pair) = model_of(3, -0.005);
        assert_eq!((pair, m.overlapping_at_reference()), (None, 1));
        // Two joints between, 5 mm apart: a joint's housing next to the next link's, left out
        // (and so is the same pair in the physics replay: `own_closeness`).
        let (m, pair) = model_of(2, 0.005);
        assert_eq!((pair, m.overlapping_at_reference()), (None, 1));
        // Two joints, 3 cm apart: checked, at the margin.
        let (m, pair) = model_of(2, 0.03);
        assert_eq!(m.margin_of(pair.expect("kept"), 0.01), 0.01);
    }

    #[test]
    fn a_link_drawn_without_a_collision_element_on_a_body_without_one_is_said_unchecked() {
        let xml = r#"<robot name="drawn">
  <link name="base"><collision><geometry><box size="0.1 0.1 0.1"/></geometry></collision></link>
  <link name="arm"><visual><geometry><box size="0.1 0.1 0.1"/></geometry></visual></link>
  <link name="frame"/>
  <joint name="j" type="revolute"><parent link="base"/><child link="arm"/><axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
  <joint name="f" type="fixed"><parent link="arm"/><child link="frame"/></joint>
</robot>"#;
        let robot = Robot::from_urdf_str(xml, "drawn.urdf").unwrap();
        let ancestry = Ancestry::of(&robot);
        let m = CollisionModel::new(&robot, &ancestry, &robot.movable, &[0.0], 0.01, None, None);
        assert_eq!(
            m.unchecked(),
            ["arm: a <visual> but no <collision> on its body (a visual is not taken for one)"]
        );
        // Held still, it is part of the base's body, which has a shape: nothing to say.
        let m = CollisionModel::new(&robot, &ancestry, &[], &[0.0], 0.01, None, None);
        assert!(m.unchecked().is_empty());
        // Moving, with a shape on a link welded to it: checked as that body.
        let welded = xml.replace(
            r#"<link name="frame"/>"#,
            r#"<link name="frame"><collision><geometry><sphere radius="0.01"/></geometry></collision></link>"#,
        );
        let robot = Robot::from_urdf_str(&welded, "drawn.urdf").unwrap();
        let ancestry = Ancestry::of(&robot);
        let m = CollisionModel::new(&robot, &ancestry, &robot.movable, &[0.0], 0.01, None, None);
        assert!(m.unchecked().is_empty(), "{:?}", m.unchecked());
    }

    #[test]
    fn shapes_within_a_millimetre_touch_and_leave_their_links_out_whole() {
        let model_of = |gaps: &[f64]| {
            let robot = block_near_base_shapes(3, gaps);
            let ancestry = Ancestry::of(&robot);
            let zero = vec![0.0; robot.dof()];
            CollisionModel::new(&robot, &ancestry, &robot.movable, &zero, 0.01, None, None)
        };
        // Three moving joints between, 0.5 mm apart at the reference: touching, left out.
        let m = model_of(&[0.0005]);
        assert_eq!((m.pairs().len(), m.overlapping_at_reference()), (0, 1));
        // 5 mm apart alone: kept at its distance there.
        assert_eq!(model_of(&[0.005]).pairs().len(), 1);
        // Both on the same two links: the links touch, every pair of their shapes left out
        // (the 5 mm pair with the touching one, and the two crosswise pairs).
        let m = model_of(&[0.0005, 0.005]);
        assert!(m.pairs().is_empty(), "{:?}", m.pairs());
        assert!(m.overlapping_at_reference() >= 2);
    }

    #[test]
    fn a_joint_that_does_not_move_joins_its_links_into_one_body() {
        // Two joints between the base and the block, 3 cm apart: checked while both move.
        let robot = block_near_base(2, 0.03);
        let ancestry = Ancestry::of(&robot);
        let zero = vec![0.0; robot.dof()];
        let pairs_moving = |moving: &[usize]| {
            CollisionModel::new(&robot, &ancestry, moving, &zero, 0.01, None, None)
                .pairs()
                .len()
        };
        let (first, second) = (robot.movable[0], robot.movable[1]);
        assert_eq!(pairs_moving(&[first, second]), 1);
        // The first held (a neck, a waist): one moving joint between, neighbours, as the
        // physics replay welds a held joint.
        assert_eq!(pairs_moving(&[second]), 0);
    }

    #[test]
    fn coman_arms_crossing_in_front_of_the_torso_touch_and_are_measured() {
        let robot = Robot::builtin("coman").unwrap();
        let ancestry = Ancestry::of(&robot);
        let moving = robot.movable.clone();
        let zero = robot.neutral_configuration();
        let model = CollisionModel::new(&robot, &ancestry, &moving, &zero, 0.0, None, None);
        assert!(model.unchecked().is_empty());
        assert!(!model.pairs().is_empty());
        let frames = RobotFrames::new(&robot, &ancestry, &zero);
        // Arms hanging: nothing within 1 mm.
        assert!(model.proximities(&frames, 0.001).is_empty());
        // Both hands brought to one point in front of the chest: they meet.
        let mut q = zero.clone();
        for hand in ["left_hand", "right_hand"] {
            let chain = robot.chain("DWYTorso", hand).unwrap();
            let target = crate::IkTarget::Position(Vector3::new(0.22, 0.0, 0.0));
            let sol = chain.inverse_kinematics(
                &target,
                &chain.extract(&zero).unwrap(),
                &crate::IkOptions::default(),
            );
            assert!(sol.converged, "{hand}");
            for (k, &i) in chain.robot_indices().iter().enumerate() {
                q[i] = sol.q[k];
            }
        }
        let frames = RobotFrames::new(&robot, &ancestry, &q);
        let near = model.proximities(&frames, 0.0);
        assert!(near.iter().any(|p| p.distance < 0.0), "{near:?}");
        for p in &near {
            assert!((p.normal.norm() - 1.0).abs() < 1e-5);
        }
    }
}
