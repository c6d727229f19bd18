//! How near two collision shapes of a robot are at a configuration (parry): the contact with
//! its closest points and normal, or, where only whether they overlap matters, GJK without the
//! depth search. The queries the collision model (`collision`) asks of each pair.

use rapier3d::parry;
use rapier3d::parry::query::gjk::{self, CsoPoint, GJKResult, VoronoiSimplex};

use super::collision::{pose_to_parry, LinkShape};
use super::frames::RobotFrames;

/// What two shapes' whole hulls say of a pair before their parts are asked.
pub(super) enum Whole {
    /// Further apart than asked.
    Beyond,
    /// Overlapping (how deep not measured: the parts tell).
    Overlapping,
    /// Within the distance asked (negative: penetrating): the contact and the distance.
    Near(parry::query::Contact, f64),
}

impl From<Option<(parry::query::Contact, f64)>> for Whole {
    fn from(c: Option<(parry::query::Contact, f64)>) -> Whole {
        c.map_or(Whole::Beyond, |(c, d)| Whole::Near(c, d))
    }
}

/// How near shapes `a` and `b` placed by `frames` are, as [`contact`] measures it, but with
/// no depth measured where they overlap (the expanding-polytope search after GJK is the costly
/// part of a query between shapes that overlap, and the pair's parts measure it anyway).
pub(super) fn closeness(frames: &RobotFrames, a: &LinkShape, b: &LinkShape, within: f64) -> Whole {
    let (Some(ga), Some(gb)) = (a.support_map(), b.support_map()) else {
        return Whole::from(contact(frames, a, b, within));
    };
    let pa = pose_to_parry(&(frames.link(a.link) * a.local));
    let pb = pose_to_parry(&(frames.link(b.link) * b.local));
    let pos12 = pa.inv_mul(&pb);
    let dir = pos12
        .translation
        .try_normalize()
        .unwrap_or(parry::math::Vector::X);
    let mut simplex = VoronoiSimplex::new();
    simplex.reset(CsoPoint::from_shapes(&pos12, ga, gb, dir));
    match gjk::closest_points(&pos12, ga, gb, within as f32, true, &mut simplex) {
        GJKResult::ClosestPoints(point1, point2_1, normal1) => {
            let dist = (point2_1 - point1).dot(normal1);
            let point2 = pos12.inverse_transform_point(point2_1);
            let normal2 = pos12.rotation.inverse() * -normal1;
            let mut c = parry::query::Contact::new(point1, point2, normal1, normal2, dist);
            c.transform_by_mut(&pa, &pb);
            Whole::Near(c, f64::from(dist))
        }
        GJKResult::Intersection => Whole::Overlapping,
        GJKResult::NoIntersection(_) | GJKResult::Proximity(_) => Whole::Beyond,
    }
}

/// The contact of shapes `a` and `b` placed by `frames` when within `within` metres:
/// (normal-carrying contact, distance).
pub(super) fn contact(
    frames: &RobotFrames,
    a: &LinkShape,
    b: &LinkShape,
    within: f64,
) -> Option<(parry::query::Contact, f64)> {
    let pa = pose_to_parry(&(frames.link(a.link) * a.local));
    let pb = pose_to_parry(&(frames.link(b.link) * b.local));
    let c = match (a.support_map(), b.support_map()) {
        (Some(ga), Some(gb)) if a.is_hull() || b.is_hull() => {
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
