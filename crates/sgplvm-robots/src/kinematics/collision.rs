//! A robot's own collision shapes and the pairs of them that can meet, with their distances
//! and closest points at a configuration (parry, which rapier already uses): what the
//! self-collision limit of differential IK and the live safety step are made of.
//!
//! Shapes are the URDF's `<collision>` elements: boxes, cylinders, capsules and spheres, and
//! meshes where a loader turns them into convex hulls; what cannot be checked (a mesh not
//! found) is listed, never silently dropped. A pair of shapes *can meet* when their links move
//! relative to each other through the moving joints, are not neighbours (one joint apart) and
//! are apart at the reference posture (pairs already touching there, like an upper arm's
//! capsule reaching into the shoulder's, are the model's own overlap, as in MoveIt's "never in
//! collision / adjacent" lists).

use std::sync::Arc;

use nalgebra::{Isometry3, UnitQuaternion, Vector3};
use rapier3d::parry;
use rapier3d::parry::shape::{SharedShape, SupportMap};

use super::apart::{kept_apart, ApartProofs, MODEL_SURFACE_BUDGET};
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
    /// A mesh's own triangles (the shape is their hull), for proving a pair apart.
    pub(super) surface: Option<SharedShape>,
    /// A box holding it, in the link's frame: the second, tighter test before parry's.
    obb: Obb,
}

/// An oriented box: centre, axes (columns) and half extents, in some frame.
#[derive(Debug, Clone, Copy)]
struct Obb {
    centre: Vector3<f64>,
    axes: nalgebra::Matrix3<f64>,
    half: Vector3<f64>,
}

impl Obb {
    /// The box of `shape` (its own axis-aligned box) placed at `local` in its link.
    fn of(shape: &SharedShape, local: &Isometry3<f64>) -> Obb {
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
    fn placed(&self, pose: &Isometry3<f64>) -> Obb {
        Obb {
            centre: (pose * nalgebra::Point3::from(self.centre)).coords,
            axes: pose.rotation.to_rotation_matrix().matrix() * self.axes,
            half: self.half,
        }
    }

    /// Whether a plane separates the boxes by more than `gap` (the separating-axis test over
    /// the 15 axes of two boxes): then no two points of them are within `gap`.
    fn apart(&self, other: &Obb, gap: f64) -> bool {
        let (a, b) = (self, other);
        // b's axes in a's frame, and the centres' offset in a's frame.
        let r = a.axes.transpose() * b.axes;
        let t = a.axes.transpose() * (b.centre - a.centre);
        let abs_r = r.map(|v| v.abs() + 1e-9);
        for i in 0..3 {
            let ra = a.half[i];
            let rb = b.half.dot(&abs_r.row(i).transpose());
            if t[i].abs() > ra + rb + gap {
                return true;
            }
        }
        for j in 0..3 {
            let ra = a.half.dot(&abs_r.column(j));
            let rb = b.half[j];
            if t.dot(&r.column(j)).abs() > ra + rb + gap {
                return true;
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
                if len > 1e-6 && dist > ra + rb + gap * len {
                    return true;
                }
            }
        }
        false
    }
}

impl LinkShape {
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
        self.surface
            .as_ref()
            .and_then(|s| s.as_trimesh())
            .map_or(1, |t| t.indices().len())
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
    pairs: Vec<(usize, usize)>,
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

fn vec_from_parry(v: parry::math::Vector) -> Vector3<f64> {
    Vector3::new(f64::from(v.x), f64::from(v.y), f64::from(v.z))
}

/// The shape of one URDF collision geometry (URDF cylinders and capsules lie along z; parry's
/// cylinder along y, hence a turn), a mesh's triangles beside its hull.
fn shape_of(
    geometry: &urdf_rs::Geometry,
    meshes: Option<&MeshLoader<'_>>,
) -> Result<(SharedShape, Option<SharedShape>, Isometry3<f64>), String> {
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
            return Ok((mesh.hull, mesh.surface, Isometry3::identity()));
        }
    };
    Ok((primitive.0, None, primitive.1))
}

impl CollisionModel {
    /// The collision model of `robot`: its shapes (meshes through `meshes`, when given) and
    /// the pairs that can meet when the joints `moving` (indices into [`Robot::joints`]) move,
    /// judged at the reference configuration `reference`: pairs nearer than `apart` there (their
    /// own overlap, or the margin a step will keep) are left out, and so are pairs the joint
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
                    Ok((shape, surface, turn)) => {
                        let local = origin * turn;
                        let sphere = shape.compute_local_bounding_sphere();
                        let centre =
                            (local * nalgebra::Point3::from(vec_from_parry(sphere.center))).coords;
                        let hull = shape
                            .as_convex_polyhedron()
                            .and_then(ClimbingHull::of)
                            .map(Arc::new);
                        let obb = Obb::of(&shape, &local);
                        shapes.push(LinkShape {
                            link: l,
                            shape,
                            local,
                            bound: (centre, f64::from(sphere.radius)),
                            hull,
                            surface,
                            obb,
                        });
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
        let neighbours = |a: usize, b: usize| {
            let one_apart = |child: usize, parent: usize| {
                robot.parent_joint[child].is_some_and(|j| robot.joints[j].parent == parent)
            };
            one_apart(a, b) || one_apart(b, a)
        };
        let mut model = CollisionModel {
            shapes,
            pairs: Vec::new(),
            unchecked,
            overlapping_at_reference: 0,
            kept_apart_by_limits: 0,
        };
        let frames = RobotFrames::new(robot, ancestry, reference);
        let mut candidates = Vec::new();
        for i in 0..model.shapes.len() {
            for k in (i + 1)..model.shapes.len() {
                let (a, b) = (model.shapes[i].link, model.shapes[k].link);
                if a == b || neighbours(a, b) || moves(a) == moves(b) {
                    continue;
                }
                if model
                    .distance(&frames, i, k, apart)
                    .is_some_and(|p| p.1 <= apart)
                {
                    model.overlapping_at_reference += 1;
                    continue;
                }
                candidates.push((i, k));
            }
        }
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
        model.pairs = candidates
            .into_iter()
            .filter(|p| !proven.contains(p))
            .collect();
        model
    }

    /// The shapes.
    pub fn shapes(&self) -> &[LinkShape] {
        &self.shapes
    }

    /// The pairs of shapes (indices into [`CollisionModel::shapes`]) that can meet.
    pub fn pairs(&self) -> &[(usize, usize)] {
        &self.pairs
    }

    /// What could not be checked (collision elements that gave no shape), one line each.
    pub fn unchecked(&self) -> &[String] {
        &self.unchecked
    }

    /// Pairs left out because their shapes overlap, or come nearer than the margin, at the
    /// reference posture.
    pub fn overlapping_at_reference(&self) -> usize {
        self.overlapping_at_reference
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

    /// The contact of shapes `i` and `k` when within `within` metres: (normal-carrying contact,
    /// distance).
    fn distance(
        &self,
        frames: &RobotFrames,
        i: usize,
        k: usize,
        within: f64,
    ) -> Option<(parry::query::Contact, f64)> {
        let (a, b) = (&self.shapes[i], &self.shapes[k]);
        let pa = pose_to_parry(&(frames.link(a.link) * a.local));
        let pb = pose_to_parry(&(frames.link(b.link) * b.local));
        let c = match (a.support_map(), b.support_map()) {
            (Some(ga), Some(gb)) if a.hull.is_some() || b.hull.is_some() => {
                let pos12 = pa.inv_mul(&pb);
                let mut c = parry::query::contact::contact_support_map_support_map(
                    &pos12,
                    ga,
                    gb,
                    within as f32,
                )?;
                c.transform_by_mut(&pa, &pb);
                c
            }
            _ => parry::query::contact(&pa, a.shape.as_ref(), &pb, b.shape.as_ref(), within as f32)
                .ok()??,
        };
        let d = f64::from(c.dist);
        Some((c, d))
    }

    /// Every pair within `within` metres at `frames`, with its closest points and normal.
    pub fn proximities(&self, frames: &RobotFrames, within: f64) -> Vec<Proximity> {
        let centres: Vec<Vector3<f64>> = self
            .shapes
            .iter()
            .map(|s| (frames.link(s.link) * nalgebra::Point3::from(s.bound.0)).coords)
            .collect();
        self.pairs
            .iter()
            .enumerate()
            .filter(|&(_, &(i, k))| {
                let reach = self.shapes[i].bound.1 + self.shapes[k].bound.1 + within;
                reach >= 0.0 && (centres[i] - centres[k]).norm_squared() <= reach * reach
            })
            .filter(|&(_, &(i, k))| {
                let (a, b) = (&self.shapes[i], &self.shapes[k]);
                let oa = a.obb.placed(frames.link(a.link));
                !oa.apart(&b.obb.placed(frames.link(b.link)), within)
            })
            .filter_map(|(p, &(i, k))| {
                let (c, d) = self.distance(frames, i, k, within)?;
                Some(Proximity {
                    pair: p,
                    distance: d,
                    point_a: vec_from_parry(c.point1),
                    point_b: vec_from_parry(c.point2),
                    normal: vec_from_parry(c.normal1),
                })
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn boxes_said_apart_are_further_apart_than_the_gap() {
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
            let said = Obb::of(&sa, &ident)
                .placed(&pa)
                .apart(&Obb::of(&sb, &ident).placed(&pb), gap);
            let d = parry::query::distance(
                &pose_to_parry(&pa),
                sa.as_ref(),
                &pose_to_parry(&pb),
                sb.as_ref(),
            )
            .unwrap()
            .distance;
            if said {
                apart += 1;
                assert!(f64::from(d) > gap - 1e-5, "apart by {gap} said, {d} found");
            } else {
                near += 1;
            }
        }
        assert!(apart > 300 && near > 300, "{apart} apart, {near} near");
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
