//! Step 1 of loading a URDF (see the [module documentation](super)): checking the element
//! tree with precise messages — numbers, sizes, masses, origins, shapes, joint types and
//! limits — before urdf-rs or the kinematics sees it, and reading the links and joints in
//! document order. Also the URDF pose convention and the largest lengths, masses and inertias
//! a URDF may state.

use std::collections::HashMap;

use nalgebra::{Isometry3, Translation3, Unit, UnitQuaternion, Vector3};
use xml::{Element, Xml};

use super::JointKind;
use crate::error::{RobotError, RobotResult};

pub(super) struct Ctx<'a> {
    pub(super) file: &'a str,
    /// URDF ≥ 1.1 (`<robot version>`): `<origin quat_xyzw>` is read, as urdfdom does.
    pub(super) quat: bool,
}

impl Ctx<'_> {
    pub(super) fn invalid(
        &self,
        element: impl Into<String>,
        message: impl Into<String>,
    ) -> RobotError {
        RobotError::Invalid {
            file: self.file.to_string(),
            element: element.into(),
            message: message.into(),
        }
    }
}

fn describe(el: &Element) -> String {
    match el.get_attribute("name", None) {
        Some(n) => format!("<{} name=\"{}\">", el.name, n),
        None => format!("<{}>", el.name),
    }
}

fn children<'e>(el: &'e Element, name: &'static str) -> impl Iterator<Item = &'e Element> + 'e {
    el.children.iter().filter_map(move |c| match c {
        Xml::ElementNode(e) if e.name == name => Some(e),
        _ => None,
    })
}

fn parse_number(ctx: &Ctx, at: &str, attr: &str, text: &str) -> RobotResult<f64> {
    match text.trim().parse::<f64>() {
        Ok(v) if v.is_finite() => Ok(v),
        _ => Err(ctx.invalid(
            format!("{at} @{attr}"),
            format!(
                "bad number \"{text}\", expected a finite decimal number such as 0.25 or 1.6E-4"
            ),
        )),
    }
}

fn parse_numbers<const N: usize>(
    ctx: &Ctx,
    at: &str,
    attr: &str,
    text: &str,
) -> RobotResult<[f64; N]> {
    let parts: Vec<&str> = text.split_whitespace().collect();
    if parts.len() != N {
        return Err(ctx.invalid(
            format!("{at} @{attr}"),
            format!(
                "\"{text}\" has {} values, expected {N} numbers separated by spaces",
                parts.len()
            ),
        ));
    }
    let mut out = [0.0; N];
    for (o, p) in out.iter_mut().zip(parts) {
        *o = parse_number(ctx, at, attr, p)?;
    }
    Ok(out)
}

fn opt_attr_numbers<const N: usize>(
    ctx: &Ctx,
    el: &Element,
    at: &str,
    attr: &str,
) -> RobotResult<Option<[f64; N]>> {
    el.get_attribute(attr, None)
        .map(|t| parse_numbers::<N>(ctx, at, attr, t))
        .transpose()
}

fn opt_attr_number(ctx: &Ctx, el: &Element, at: &str, attr: &str) -> RobotResult<Option<f64>> {
    el.get_attribute(attr, None)
        .map(|t| parse_number(ctx, at, attr, t))
        .transpose()
}

fn req_attr<'e>(ctx: &Ctx, el: &'e Element, at: &str, attr: &str) -> RobotResult<&'e str> {
    match el.get_attribute(attr, None) {
        Some(v) if !v.trim().is_empty() => Ok(v),
        Some(_) => Err(ctx.invalid(at, format!("empty attribute \"{attr}\", expected a name"))),
        None => Err(ctx.invalid(at, format!("missing attribute \"{attr}\""))),
    }
}

fn at_most_one<'e>(
    ctx: &Ctx,
    el: &'e Element,
    at: &str,
    name: &'static str,
) -> RobotResult<Option<&'e Element>> {
    let mut it = children(el, name);
    let first = it.next();
    if it.next().is_some() {
        return Err(ctx.invalid(at, format!("more than one <{name}>, expected at most one")));
    }
    Ok(first)
}

/// Reads an `<origin>` child (absent → identity; absent `xyz`/`rpy` → zeros).
fn origin_of(ctx: &Ctx, el: &Element, at: &str) -> RobotResult<Isometry3<f64>> {
    let Some(o) = at_most_one(ctx, el, at, "origin")? else {
        return Ok(Isometry3::identity());
    };
    let at = format!("{at} <origin>");
    let xyz = opt_attr_numbers::<3>(ctx, o, &at, "xyz")?.unwrap_or([0.0; 3]);
    for v in xyz {
        check_length(ctx, &at, "xyz", v.abs(), "an offset")?;
    }
    let rpy = opt_attr_numbers::<3>(ctx, o, &at, "rpy")?;
    let quat = if ctx.quat {
        opt_attr_numbers::<4>(ctx, o, &at, "quat_xyzw")?
    } else {
        None
    };
    match (rpy, quat) {
        (Some(_), Some(_)) => Err(ctx.invalid(
            at,
            "both rpy and quat_xyzw are given, expected one orientation",
        )),
        (_, Some([x, y, z, w])) => {
            let q = nalgebra::Quaternion::new(w, x, y, z);
            if q.norm() < 1e-12 {
                return Err(ctx.invalid(
                    format!("{at} @quat_xyzw"),
                    "the quaternion is zero, expected a rotation",
                ));
            }
            Ok(Isometry3::from_parts(
                Translation3::new(xyz[0], xyz[1], xyz[2]),
                UnitQuaternion::from_quaternion(q),
            ))
        }
        (rpy, None) => Ok(pose_from_xyz_rpy(xyz, rpy.unwrap_or([0.0; 3]))),
    }
}

/// The URDF pose convention: translation, then `Rz(yaw) · Ry(pitch) · Rx(roll)`.
pub fn pose_from_xyz_rpy(xyz: [f64; 3], rpy: [f64; 3]) -> Isometry3<f64> {
    Isometry3::from_parts(
        Translation3::new(xyz[0], xyz[1], xyz[2]),
        UnitQuaternion::from_euler_angles(rpy[0], rpy[1], rpy[2]),
    )
}

/// Refuses a length `v` (≥ 0) above [`MAX_LENGTH_M`].
fn check_length(ctx: &Ctx, at: &str, attr: &str, v: f64, what: &str) -> RobotResult<()> {
    if v > MAX_LENGTH_M {
        return Err(ctx.invalid(
            format!("{at} @{attr}"),
            format!("{v} m is too large, expected {what} of at most {MAX_LENGTH_M} m"),
        ));
    }
    Ok(())
}

/// A shape size: finite, positive and at most [`MAX_LENGTH_M`].
fn check_size(ctx: &Ctx, at: &str, attr: &str, v: f64) -> RobotResult<f64> {
    if v < 0.0 {
        return Err(ctx.invalid(
            format!("{at} @{attr}"),
            format!("{v} is negative, expected a size > 0"),
        ));
    }
    if v == 0.0 {
        return Err(ctx.invalid(
            format!("{at} @{attr}"),
            "the size is zero, expected a size > 0 (leave out a shape that has no extent)",
        ));
    }
    check_length(ctx, at, attr, v, "a size")?;
    Ok(v)
}

fn check_geometry(ctx: &Ctx, holder: &Element, at: &str) -> RobotResult<()> {
    origin_of(ctx, holder, at)?;
    let Some(g) = at_most_one(ctx, holder, at, "geometry")? else {
        return Err(ctx.invalid(at, "missing <geometry>"));
    };
    let at = format!("{at} <geometry>");
    let shapes: Vec<&Element> = g
        .children
        .iter()
        .filter_map(|c| match c {
            Xml::ElementNode(e) => Some(e),
            _ => None,
        })
        .collect();
    let [shape] = shapes.as_slice() else {
        return Err(ctx.invalid(
            at,
            format!(
                "{} shapes, expected exactly one of <box>, <cylinder>, <capsule>, <sphere>, <mesh>",
                shapes.len()
            ),
        ));
    };
    let sat = format!("{at} <{}>", shape.name);
    let need = |attr: &str| -> RobotResult<f64> {
        let t = req_attr(ctx, shape, &sat, attr)?;
        let v = parse_number(ctx, &sat, attr, t)?;
        check_size(ctx, &sat, attr, v)
    };
    match shape.name.as_str() {
        "box" => {
            let t = req_attr(ctx, shape, &sat, "size")?;
            for v in parse_numbers::<3>(ctx, &sat, "size", t)? {
                check_size(ctx, &sat, "size", v)?;
            }
        }
        "cylinder" | "capsule" => {
            need("radius")?;
            need("length")?;
        }
        "sphere" => {
            need("radius")?;
        }
        "mesh" => {
            req_attr(ctx, shape, &sat, "filename")?;
            for v in opt_attr_numbers::<3>(ctx, shape, &sat, "scale")?.unwrap_or([1.0; 3]) {
                if v.abs() > MAX_LENGTH_M || v == 0.0 {
                    return Err(ctx.invalid(
                        format!("{sat} @scale"),
                        format!("{v} is not a usable scale, expected a non-zero factor of at most {MAX_LENGTH_M} in size"),
                    ));
                }
            }
        }
        other => {
            return Err(ctx.invalid(
                at,
                format!("unknown shape <{other}>, expected <box>, <cylinder>, <capsule>, <sphere> or <mesh>"),
            ))
        }
    }
    Ok(())
}

fn check_link(ctx: &Ctx, link: &Element, at: &str) -> RobotResult<()> {
    if let Some(inertial) = at_most_one(ctx, link, at, "inertial")? {
        let iat = format!("{at} <inertial>");
        origin_of(ctx, inertial, &iat)?;
        match at_most_one(ctx, inertial, &iat, "mass")? {
            Some(m) => {
                let mat = format!("{iat} <mass>");
                let t = req_attr(ctx, m, &mat, "value")?;
                let v = parse_number(ctx, &mat, "value", t)?;
                if v < 0.0 {
                    return Err(ctx.invalid(
                        format!("{mat} @value"),
                        format!("{v} is negative, expected a mass ≥ 0"),
                    ));
                }
                if v > MAX_MASS_KG {
                    return Err(ctx.invalid(
                        format!("{mat} @value"),
                        format!("{v} kg is too large, expected a mass of at most {MAX_MASS_KG} kg"),
                    ));
                }
            }
            None => return Err(ctx.invalid(iat, "missing <mass>")),
        }
        match at_most_one(ctx, inertial, &iat, "inertia")? {
            Some(i) => {
                let inat = format!("{iat} <inertia>");
                for attr in ["ixx", "ixy", "ixz", "iyy", "iyz", "izz"] {
                    let t = req_attr(ctx, i, &inat, attr)?;
                    let v = parse_number(ctx, &inat, attr, t)?;
                    if v.abs() > MAX_INERTIA {
                        return Err(ctx.invalid(
                            format!("{inat} @{attr}"),
                            format!("{v} kg·m² is too large, expected at most {MAX_INERTIA} kg·m² in size"),
                        ));
                    }
                }
            }
            None => return Err(ctx.invalid(iat, "missing <inertia>")),
        }
    }
    for (kind, label) in [("visual", "<visual>"), ("collision", "<collision>")] {
        for v in link.children.iter().filter_map(|c| match c {
            Xml::ElementNode(e) if e.name == kind => Some(e),
            _ => None,
        }) {
            check_geometry(ctx, v, &format!("{at} {label}"))?;
        }
    }
    Ok(())
}

pub(super) struct RawJoint {
    pub(super) name: String,
    pub(super) kind: JointKind,
    pub(super) parent: String,
    pub(super) child: String,
    pub(super) origin: Isometry3<f64>,
    pub(super) axis: Unit<Vector3<f64>>,
    pub(super) limits: (f64, f64),
    pub(super) velocity: f64,
    pub(super) effort: f64,
}

fn check_joint(ctx: &Ctx, joint: &Element, at: &str) -> RobotResult<RawJoint> {
    let name = req_attr(ctx, joint, at, "name")?.to_string();
    let ty = req_attr(ctx, joint, at, "type")?;
    let kind = JointKind::parse(ty.trim()).ok_or_else(|| {
        ctx.invalid(
            format!("{at} @type"),
            format!("unknown joint type \"{ty}\", expected one of revolute, continuous, prismatic, fixed, floating, planar"),
        )
    })?;
    let link_of = |role: &'static str| -> RobotResult<String> {
        let el = at_most_one(ctx, joint, at, role)?
            .ok_or_else(|| ctx.invalid(at, format!("missing <{role} link=\"...\">")))?;
        Ok(req_attr(ctx, el, &format!("{at} <{role}>"), "link")?
            .trim()
            .to_string())
    };
    let parent = link_of("parent")?;
    let child = link_of("child")?;
    let origin = origin_of(ctx, joint, at)?;
    let axis = match at_most_one(ctx, joint, at, "axis")? {
        None => Vector3::x_axis(),
        Some(a) => {
            let aat = format!("{at} <axis>");
            let xyz = opt_attr_numbers::<3>(ctx, a, &aat, "xyz")?.unwrap_or([1.0, 0.0, 0.0]);
            let v = Vector3::from(xyz);
            if kind.is_movable() && v.norm() < 1e-12 {
                return Err(ctx.invalid(
                    format!("{aat} @xyz"),
                    "the axis is zero, expected a non-zero direction",
                ));
            }
            Unit::try_new(v, 1e-12).unwrap_or_else(Vector3::x_axis)
        }
    };
    let mut limits = (0.0, 0.0);
    let mut velocity = 0.0;
    let mut effort = 0.0;
    let limit = at_most_one(ctx, joint, at, "limit")?;
    if let Some(l) = limit {
        let lat = format!("{at} <limit>");
        let lower = opt_attr_number(ctx, l, &lat, "lower")?.unwrap_or(0.0);
        let upper = opt_attr_number(ctx, l, &lat, "upper")?.unwrap_or(0.0);
        velocity = opt_attr_number(ctx, l, &lat, "velocity")?.unwrap_or(0.0);
        effort = opt_attr_number(ctx, l, &lat, "effort")?.unwrap_or(0.0);
        if lower > upper && matches!(kind, JointKind::Revolute | JointKind::Prismatic) {
            return Err(ctx.invalid(
                lat,
                format!("lower {lower} > upper {upper}, expected lower ≤ upper"),
            ));
        }
        if kind == JointKind::Prismatic {
            check_length(ctx, &lat, "lower", lower.abs(), "a travel")?;
            check_length(ctx, &lat, "upper", upper.abs(), "a travel")?;
        }
        for (attr, v) in [("velocity", velocity), ("effort", effort)] {
            if v < 0.0 {
                return Err(ctx.invalid(
                    format!("{lat} @{attr}"),
                    format!("{v} is negative, expected a {attr} limit > 0 (or none)"),
                ));
            }
        }
        // A zero velocity limit on a joint that has room to move forbids all motion; the
        // physics would take it for "no limit". Leave the attribute out for that.
        let can_move = kind == JointKind::Continuous || (kind.is_movable() && lower < upper);
        if velocity == 0.0 && can_move && l.get_attribute("velocity", None).is_some() {
            return Err(ctx.invalid(
                format!("{lat} @velocity"),
                "0 forbids all motion of a joint whose limits allow it, expected a velocity limit > 0 (or no velocity attribute for no limit)",
            ));
        }
        limits = (lower, upper);
    } else if matches!(kind, JointKind::Revolute | JointKind::Prismatic) {
        return Err(ctx.invalid(
            at,
            format!("missing <limit lower=... upper=...>, required for a {ty} joint"),
        ));
    }
    match kind {
        JointKind::Continuous => limits = (f64::NEG_INFINITY, f64::INFINITY),
        JointKind::Revolute | JointKind::Prismatic => {}
        _ => limits = (0.0, 0.0),
    }
    // Optional children that urdf-rs reads: check their numbers so that its messages never show.
    for (tag, attrs) in [
        ("dynamics", &["damping", "friction"][..]),
        ("calibration", &["rising", "falling"][..]),
        (
            "safety_controller",
            &[
                "soft_lower_limit",
                "soft_upper_limit",
                "k_position",
                "k_velocity",
            ][..],
        ),
        ("mimic", &["multiplier", "offset"][..]),
    ] {
        if let Some(el) = at_most_one(ctx, joint, at, tag)? {
            let tat = format!("{at} <{tag}>");
            for a in attrs {
                opt_attr_number(ctx, el, &tat, a)?;
            }
            if tag == "mimic" {
                req_attr(ctx, el, &tat, "joint")?;
            }
        }
    }
    Ok(RawJoint {
        name,
        kind,
        parent,
        child,
        origin,
        axis,
        limits,
        velocity,
        effort,
    })
}

/// The largest length a URDF may state, metres (shape sizes, origins, prismatic limits):
/// the physics engine computes in `f32`, where a cylinder of 1e29 m overflows.
pub const MAX_LENGTH_M: f64 = 1e4;

/// The largest mass a link may declare, kg.
pub const MAX_MASS_KG: f64 = 1e6;

/// The largest inertia component a link may declare, kg·m².
pub const MAX_INERTIA: f64 = 1e9;
/// The link names in document order and their index, each link checked.
pub(super) fn read_links(
    ctx: &Ctx,
    root: &Element,
) -> RobotResult<(Vec<String>, HashMap<String, usize>)> {
    let mut links = Vec::new();
    let mut link_index = HashMap::new();
    for link in children(root, "link") {
        let at = describe(link);
        let name = req_attr(ctx, link, &at, "name")?.trim().to_string();
        check_link(ctx, link, &at)?;
        if link_index.insert(name.clone(), links.len()).is_some() {
            return Err(ctx.invalid(
                at,
                "a second link with this name, expected unique link names",
            ));
        }
        links.push(name);
    }
    if links.is_empty() {
        return Err(ctx.invalid("<robot>", "no <link> elements, expected at least one"));
    }
    Ok((links, link_index))
}

/// The joints in document order, each checked, names unique.
pub(super) fn read_joints(ctx: &Ctx, root: &Element) -> RobotResult<Vec<RawJoint>> {
    let mut raw = Vec::new();
    let mut joint_names = HashMap::new();
    for joint in children(root, "joint") {
        let at = describe(joint);
        let j = check_joint(ctx, joint, &at)?;
        if joint_names.insert(j.name.clone(), raw.len()).is_some() {
            return Err(ctx.invalid(
                at,
                "a second joint with this name, expected unique joint names",
            ));
        }
        raw.push(j);
    }
    Ok(raw)
}
