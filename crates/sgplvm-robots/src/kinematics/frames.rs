//! The whole robot at one configuration: every link's pose in the root frame and every movable
//! joint's origin and axis there, in one pass over the tree (bare frames on fixed joints, which
//! nothing but a name hangs on, are found from their body when asked), so that the Jacobian of
//! any point on any link with respect to any set of joints is a few cross products.
//!
//! For a point p on link L and a revolute joint j above L (origin oⱼ, unit axis aⱼ), the
//! column of ∂p/∂qⱼ is aⱼ × (p − oⱼ); for a prismatic joint it is aⱼ; for a joint not above L
//! it is 0.

use std::sync::Arc;

use nalgebra::{Isometry3, Matrix3xX, Vector3};

use crate::urdf::{JointKind, Robot};

/// A robot's links and joints at one configuration (root frame).
#[derive(Debug, Clone)]
pub struct RobotFrames {
    /// Pose of each link (index as [`Robot::link_names`]).
    links: Vec<Isometry3<f64>>,
    /// Origin of each joint's frame (index as [`Robot::joints`]), before its motion.
    origins: Vec<Vector3<f64>>,
    /// Unit axis of each joint in the root frame.
    axes: Vec<Vector3<f64>>,
    /// The bare frames, whose poses are left out of `links` (shared with the ancestry).
    bare: Arc<BareFrames>,
}

/// A robot's bare frames: links on fixed joints with no mass, shape or look and no body below
/// them (a sensor's or a skin patch's frame: iCub has 174 of its 213 links so), each its
/// body's pose times a fixed offset. Retargeting takes the frames at every step; it need not
/// place them.
#[derive(Debug, Default)]
struct BareFrames {
    /// Per link: its place in `offsets`, or `u32::MAX` for a body.
    of_link: Vec<u32>,
    /// The link each bare frame hangs on (a body) and its offset from it.
    offsets: Vec<(usize, Isometry3<f64>)>,
}

/// For each link, the movable joints above it (configuration indices) and their joint indices:
/// computed once per robot.
#[derive(Debug, Clone)]
pub struct Ancestry {
    /// Per link: the joint indices (into [`Robot::joints`]) of the movable joints above it.
    above: Vec<Vec<usize>>,
    /// The joints whose child is a body, each after the one above it.
    order: Vec<usize>,
    /// The links left out of the pass.
    bare: Arc<BareFrames>,
}

impl Ancestry {
    /// The ancestry of `robot`'s links.
    pub fn of(robot: &Robot) -> Ancestry {
        let above = (0..robot.links.len())
            .map(|l| {
                robot
                    .path_to(l)
                    .into_iter()
                    .filter(|&j| robot.joints[j].kind.is_movable())
                    .collect()
            })
            .collect();
        let mut order: Vec<usize> = (0..robot.joints.len()).collect();
        order.sort_by_key(|&j| robot.path_to(robot.joints[j].child).len());
        // A body has mass, a shape or a look, or a body below it, or moves (deepest first, so
        // that a child is settled before its parent).
        let mut body = vec![false; robot.links.len()];
        for link in &robot.urdf.links {
            if let Some(&l) = robot.link_index.get(&link.name) {
                let massless = link.inertial.mass.value == 0.0;
                body[l] = !(massless && link.collision.is_empty() && link.visual.is_empty());
            }
        }
        for &j in order.iter().rev() {
            let joint = &robot.joints[j];
            if body[joint.child] || joint.kind.is_movable() {
                body[joint.parent] = true;
            }
        }
        let mut bare = BareFrames {
            of_link: vec![u32::MAX; robot.links.len()],
            offsets: Vec::new(),
        };
        order.retain(|&j| {
            let joint = &robot.joints[j];
            if body[joint.child] || joint.kind.is_movable() {
                return true;
            }
            // Parents come first: a bare parent's own offset is known.
            let (on, offset) = match bare.of_link[joint.parent] {
                u32::MAX => (joint.parent, joint.origin),
                b => {
                    let (on, above) = bare.offsets[b as usize];
                    (on, above * joint.origin)
                }
            };
            bare.of_link[joint.child] = u32::try_from(bare.offsets.len()).unwrap_or(u32::MAX);
            bare.offsets.push((on, offset));
            false
        });
        Ancestry {
            above,
            order,
            bare: Arc::new(bare),
        }
    }

    /// The movable joints (indices into [`Robot::joints`]) above link `link`.
    pub fn above(&self, link: usize) -> &[usize] {
        &self.above[link]
    }
}

impl RobotFrames {
    /// The frames of `robot` at `q` (configuration order; missing values count as 0).
    pub fn new(robot: &Robot, ancestry: &Ancestry, q: &[f64]) -> RobotFrames {
        let mut links = vec![Isometry3::identity(); robot.links.len()];
        let mut origins = vec![Vector3::zeros(); robot.joints.len()];
        let mut axes = vec![Vector3::zeros(); robot.joints.len()];
        for &j in &ancestry.order {
            let joint = &robot.joints[j];
            let frame = links[joint.parent] * joint.origin;
            origins[j] = frame.translation.vector;
            axes[j] = frame.rotation * joint.axis.into_inner();
            // The joint's motion after its origin: `frame` is the parent's pose times the
            // origin, so the child's pose is one more product (a fixed joint's is `frame`).
            let value = joint
                .q_index
                .map_or(0.0, |i| q.get(i).copied().unwrap_or(0.0));
            links[joint.child] = match joint.kind {
                // A joint at 0 (most held ones: fingers, wheels) adds nothing to its origin.
                _ if value == 0.0 => frame,
                JointKind::Revolute | JointKind::Continuous => {
                    frame * nalgebra::UnitQuaternion::from_axis_angle(&joint.axis, value)
                }
                JointKind::Prismatic => {
                    frame * nalgebra::Translation3::from(joint.axis.into_inner() * value)
                }
                _ => frame,
            };
        }
        RobotFrames {
            links,
            origins,
            axes,
            bare: Arc::clone(&ancestry.bare),
        }
    }

    /// Pose of link `link` (index) in the root frame.
    #[inline]
    pub fn link(&self, link: usize) -> Isometry3<f64> {
        match self.bare.of_link.get(link) {
            Some(&b) if b != u32::MAX => {
                let (on, offset) = &self.bare.offsets[b as usize];
                self.links[*on] * offset
            }
            _ => self.links[link],
        }
    }

    /// The Jacobian (3 × `active.len()`) of the point `point` (root frame) fixed on link
    /// `link`, with respect to the joints `active` (indices into [`Robot::joints`]).
    pub fn point_jacobian(
        &self,
        robot: &Robot,
        ancestry: &Ancestry,
        link: usize,
        point: &Vector3<f64>,
        active: &[usize],
    ) -> Matrix3xX<f64> {
        let mut jac = Matrix3xX::zeros(active.len());
        for &j in ancestry.above(link) {
            let Some(col) = active.iter().position(|&a| a == j) else {
                continue;
            };
            let c = if robot.joints[j].kind == JointKind::Prismatic {
                self.axes[j]
            } else {
                self.axes[j].cross(&(point - self.origins[j]))
            };
            jac.set_column(col, &c);
        }
        jac
    }

    /// The angular Jacobian (3 × `active.len()`) of link `link`: the root-frame axis of each
    /// revolute joint of `active` above it.
    pub fn angular_jacobian(
        &self,
        robot: &Robot,
        ancestry: &Ancestry,
        link: usize,
        active: &[usize],
    ) -> Matrix3xX<f64> {
        let mut jac = Matrix3xX::zeros(active.len());
        for &j in ancestry.above(link) {
            if robot.joints[j].kind == JointKind::Prismatic {
                continue;
            }
            if let Some(col) = active.iter().position(|&a| a == j) {
                jac.set_column(col, &self.axes[j]);
            }
        }
        jac
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Asserts that every link of `robot` is where forward kinematics puts it at `q`; returns
    /// the frames.
    fn frames_at_forward_kinematics(robot: &Robot, ancestry: &Ancestry, q: &[f64]) -> RobotFrames {
        let frames = RobotFrames::new(robot, ancestry, q);
        for (l, name) in robot.link_names().iter().enumerate() {
            let fk = robot.forward_kinematics(q, name).unwrap();
            let at = frames.link(l);
            let apart = (fk.translation.vector - at.translation.vector).norm();
            assert!(apart < 1e-12, "{name}: {apart} m");
            assert!(fk.rotation.angle_to(&at.rotation) < 1e-12, "{name}");
        }
        frames
    }

    #[test]
    fn frames_equal_forward_kinematics_and_jacobians_equal_finite_differences() {
        let robot = Robot::builtin("walkman").unwrap();
        let ancestry = Ancestry::of(&robot);
        let q: Vec<f64> = (0..robot.dof())
            .map(|i| 0.3 * (i as f64 * 0.7).sin())
            .collect();
        let frames = frames_at_forward_kinematics(&robot, &ancestry, &q);
        let hand = robot.link_index["left_hand"];
        let active: Vec<usize> = robot.movable.clone();
        let local = nalgebra::Point3::new(0.01, -0.02, 0.03);
        let at = |q: &[f64]| (robot.forward_kinematics(q, "left_hand").unwrap() * local).coords;
        let p = at(&q);
        let jac = frames.point_jacobian(&robot, &ancestry, hand, &p, &active);
        for (c, &j) in active.iter().enumerate() {
            let i = robot.joints[j].q_index.unwrap();
            let h = 1e-6;
            let (mut a, mut b) = (q.clone(), q.clone());
            a[i] += h;
            b[i] -= h;
            let fd = (at(&a) - at(&b)) / (2.0 * h);
            assert!((fd - jac.column(c)).norm() < 1e-8, "joint {i}");
        }
    }

    #[test]
    fn links_on_fixed_joints_are_where_forward_kinematics_puts_them() {
        // iCub as example-robot-data publishes it: 23 fixed joints, sensor and DH frames on
        // links that hang on other fixed links.
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../../data/urdf/published/icub.urdf");
        let robot = Robot::from_urdf_file(&path).unwrap();
        let ancestry = Ancestry::of(&robot);
        assert!(ancestry.bare.offsets.len() >= 10, "{:?}", ancestry.bare);
        let q: Vec<f64> = (0..robot.dof())
            .map(|i| 0.4 * (i as f64 * 1.3).cos())
            .collect();
        frames_at_forward_kinematics(&robot, &ancestry, &q);
    }
}
