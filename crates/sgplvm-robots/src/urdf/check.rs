//! Step 1 of loading a URDF (see the [module documentation](super)): checking the element
//! tree with precise messages — numbers, sizes, masses, origins, shapes, joint types and
//! limits — before urdf-rs or the kinematics sees it, and reading the links and joints in
//! document order. Also the URDF pose convention and the largest lengths, masses and inertias
//! a URDF may state.

use std::collections::HashMap;

use nalgebra::{Isometry3, Translation3, Unit, UnitQuaternion, Vector3};

use super::JointKind;
use crate::error::{RobotError, RobotResult};

pub(super) struct Ctx<'a> {
    pub(super) file: &'a str,
    /// URDF ≥ 1.1 (`<robot version>`): `<origin quat_xyzw>` is read, as urdfdom does.
    pub(super) quat: bool,
}

/// An element of the document being checked.
pub(super) type El<'a, 'i> = roxmltree::Node<'a, 'i>;

impl Ctx<'_> {
    /// The error of element `node` (its line), described as `element`.
    pub(super) fn invalid(
        &self,
        node: El,
        element: impl Into<String>,
        message: impl Into<String>,
    ) -> RobotError {
        self.invalid_at(line_of(node), element, message)
    }

    /// The error of an element at `line`, described as `element`.
    pub(super) fn invalid_at(
        &self,
        line: u32,
        element: impl Into<String>,
        message: impl Into<String>,
    ) -> RobotError {
        RobotError::InvalidElement {
            file: self.file.to_string(),
            line,
            element: element.into(),
            message: message.into(),
        }
    }
}

/// The 1-based line an element starts on.
pub(super) fn line_of(node: El) -> u32 {
    node.document().text_pos_at(node.range().start).row
}

/// `<name>` or `<name name="…">`.
pub(super) fn describe(el: El) -> String {
    match el.attribute("name") {
        Some(n) => format!("<{} name=\"{}\">", el.tag_name().name(), n),
        None => format!("<{}>", el.tag_name().name()),
    }
}

/// The child elements of `el` called `name`.
pub(super) fn children<'a, 'i: 'a>(
    el: El<'a, 'i>,
    name: &'static str,
) -> impl Iterator<Item = El<'a, 'i>> + 'a {
    el.children()
        .filter(move |c| c.is_element() && c.tag_name().name() == name)
}
/// Where a check is: the element (for its line) and its description for messages, e.g.
/// `<joint name="elbow"> <limit>`.
#[derive(Clone, Copy)]
struct At<'s, 'a, 'i> {
    node: El<'a, 'i>,
    desc: &'s str,
}

impl<'a, 'i> At<'_, 'a, 'i> {
    fn new<'s>(node: El<'a, 'i>, desc: &'s str) -> At<'s, 'a, 'i> {
        At { node, desc }
    }

    /// The error of this element's attribute `attr`.
    fn attr_error(self, ctx: &Ctx, attr: &str, message: impl Into<String>) -> RobotError {
        ctx.invalid(self.node, format!("{} @{attr}", self.desc), message)
    }

    /// The error of this element.
    fn error(self, ctx: &Ctx, message: impl Into<String>) -> RobotError {
        ctx.invalid(self.node, self.desc, message)
    }
}

fn parse_number(ctx: &Ctx, at: At, attr: &str, text: &str) -> RobotResult<f64> {
    match text.trim().parse::<f64>() {
        Ok(v) if v.is_finite() => Ok(v),
        _ => Err(at.attr_error(
            ctx,
            attr,
            format!(
                "bad number \"{text}\", expected a finite decimal number such as 0.25 or 1.6E-4"
            ),
        )),
    }
}

fn parse_numbers<const N: usize>(
    ctx: &Ctx,
    at: At,
    attr: &str,
    text: &str,
) -> RobotResult<[f64; N]> {
    let parts: Vec<&str> = text.split_whitespace().collect();
    if parts.len() != N {
        return Err(at.attr_error(
            ctx,
            attr,
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
    at: At,
    attr: &str,
) -> RobotResult<Option<[f64; N]>> {
    at.node
        .attribute(attr)
        .map(|t| parse_numbers::<N>(ctx, at, attr, t))
        .transpose()
}

fn opt_attr_number(ctx: &Ctx, at: At, attr: &str) -> RobotResult<Option<f64>> {
    at.node
        .attribute(attr)
        .map(|t| parse_number(ctx, at, attr, t))
        .transpose()
}

fn req_attr<'a, 'i>(ctx: &Ctx, at: At<'_, 'a, 'i>, attr: &str) -> RobotResult<&'a str> {
    match at.node.attribute(attr) {
        Some(v) if !v.trim().is_empty() => Ok(v),
        Some(_) => Err(at.error(ctx, format!("empty attribute \"{attr}\", expected a name"))),
        None => Err(at.error(ctx, format!("missing attribute \"{attr}\""))),
    }
}

/// The first child of `at` called `name`, as urdfdom reads it (`FirstChildElement`): a file
/// that repeats the element (PAL's REEM-C expands two `<dynamics>` into a joint) loads, and the
/// repair pass says which it left out (`repair.rs`).
fn first_child<'a, 'i>(at: At<'_, 'a, 'i>, name: &'static str) -> Option<El<'a, 'i>> {
    children(at.node, name).next()
}

/// Reads an `<origin>` child (absent → identity; absent `xyz`/`rpy` → zeros).
fn origin_of(ctx: &Ctx, el: At) -> RobotResult<Isometry3<f64>> {
    let Some(o) = first_child(el, "origin") else {
        return Ok(Isometry3::identity());
    };
    let desc = format!("{} <origin>", el.desc);
    let at = At::new(o, &desc);
    let xyz = opt_attr_numbers::<3>(ctx, at, "xyz")?.unwrap_or([0.0; 3]);
    for v in xyz {
        check_length(ctx, at, "xyz", v.abs(), "an offset")?;
    }
    let rpy = opt_attr_numbers::<3>(ctx, at, "rpy")?;
    let quat = if ctx.quat {
        opt_attr_numbers::<4>(ctx, at, "quat_xyzw")?
    } else {
        None
    };
    match (rpy, quat) {
        (Some(_), Some(_)) => Err(at.error(
            ctx,
            "both rpy and quat_xyzw are given, expected one orientation",
        )),
        (_, Some([x, y, z, w])) => {
            let q = nalgebra::Quaternion::new(w, x, y, z);
            if q.norm() < 1e-12 {
                return Err(at.attr_error(
                    ctx,
                    "quat_xyzw",
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
fn check_length(ctx: &Ctx, at: At, attr: &str, v: f64, what: &str) -> RobotResult<()> {
    if v > MAX_LENGTH_M {
        return Err(at.attr_error(
            ctx,
            attr,
            format!("{v} m is too large, expected {what} of at most {MAX_LENGTH_M} m"),
        ));
    }
    Ok(())
}

/// A shape size: finite, not negative and at most [`MAX_LENGTH_M`]. A zero size is a shape
/// with no extent, which ROS's parser loads (Pollen's Reachy: five cylinders of radius 0): the
/// repair pass leaves it out and says so ([`zero_size_shape`]).
fn check_size(ctx: &Ctx, at: At, attr: &str, v: f64) -> RobotResult<f64> {
    if v < 0.0 {
        return Err(at.attr_error(ctx, attr, format!("{v} is negative, expected a size ≥ 0")));
    }
    check_length(ctx, at, attr, v, "a size")?;
    Ok(v)
}

/// Whether the `<visual>` or `<collision>` `holder`'s shape is a box, cylinder, capsule or
/// sphere with a size of zero (no extent: nothing to draw or to touch).
pub(super) fn zero_size_shape(holder: El) -> bool {
    let Some(shape) = children(holder, "geometry")
        .next()
        .and_then(|g| g.children().find(El::is_element))
    else {
        return false;
    };
    let zero = |attr: &str| {
        shape.attribute(attr).is_some_and(|t| {
            t.split_whitespace()
                .any(|v| v.parse::<f64>().is_ok_and(|v| v == 0.0))
        })
    };
    match shape.tag_name().name() {
        "box" => zero("size"),
        "cylinder" | "capsule" => zero("radius") || zero("length"),
        "sphere" => zero("radius"),
        _ => false,
    }
}

fn check_geometry(ctx: &Ctx, holder: At) -> RobotResult<()> {
    origin_of(ctx, holder)?;
    let Some(g) = first_child(holder, "geometry") else {
        return Err(holder.error(ctx, "missing <geometry>"));
    };
    let gdesc = format!("{} <geometry>", holder.desc);
    let shapes: Vec<El> = g.children().filter(El::is_element).collect();
    let [shape] = shapes.as_slice() else {
        return Err(At::new(g, &gdesc).error(
            ctx,
            format!(
                "{} shapes, expected exactly one of <box>, <cylinder>, <capsule>, <sphere>, <mesh>",
                shapes.len()
            ),
        ));
    };
    let name = shape.tag_name().name();
    let sdesc = format!("{gdesc} <{name}>");
    let sat = At::new(*shape, &sdesc);
    let need = |attr: &str| -> RobotResult<f64> {
        let t = req_attr(ctx, sat, attr)?;
        let v = parse_number(ctx, sat, attr, t)?;
        check_size(ctx, sat, attr, v)
    };
    match name {
        "box" => {
            let t = req_attr(ctx, sat, "size")?;
            for v in parse_numbers::<3>(ctx, sat, "size", t)? {
                check_size(ctx, sat, "size", v)?;
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
            req_attr(ctx, sat, "filename")?;
            for v in opt_attr_numbers::<3>(ctx, sat, "scale")?.unwrap_or([1.0; 3]) {
                if v.abs() > MAX_LENGTH_M || v == 0.0 {
                    return Err(sat.attr_error(
                        ctx,
                        "scale",
                        format!("{v} is not a usable scale, expected a non-zero factor of at most {MAX_LENGTH_M} in size"),
                    ));
                }
            }
        }
        other => {
            return Err(At::new(*shape, &gdesc).error(
                ctx,
                format!("unknown shape <{other}>, expected <box>, <cylinder>, <capsule>, <sphere> or <mesh>"),
            ))
        }
    }
    Ok(())
}

/// Why an `<inertial>` that reads is of no use: an origin, mass or inertia beyond any robot's
/// ([`MAX_LENGTH_M`], [`MAX_MASS_KG`], [`MIN_MASS_KG`], [`MAX_INERTIA`], [`MAX_GYRATION_M`]; an exporter's
/// garbage, as UBTech Walker's palm at 3.8e12 m), which ROS's parser loads; `None` when usable or when it does
/// not read (the check says why). The repair leaves such an element out: its link then
/// declares no mass (kinematics never reads it; `simulate` says what it does instead).
pub(super) fn unusable_inertial(inertial: El) -> Option<String> {
    let numbers = |el: El, attr: &str| -> Vec<f64> {
        el.attribute(attr)
            .map(|t| {
                t.split_whitespace()
                    .filter_map(|v| v.parse().ok())
                    .collect()
            })
            .unwrap_or_default()
    };
    let first = |tag: &'static str| children(inertial, tag).next();
    if let Some(v) = first("origin")
        .map(|o| numbers(o, "xyz"))
        .and_then(|xyz| xyz.into_iter().find(|v| v.abs() > MAX_LENGTH_M))
    {
        return Some(format!("its origin {v:e} m away"));
    }
    if let Some(v) = first("mass")
        .map(|m| numbers(m, "value"))
        .and_then(|m| m.into_iter().find(|v| *v > MAX_MASS_KG))
    {
        return Some(format!("a mass of {v:e} kg"));
    }
    // A mote for a mass (RobotEra's STAR1: 1.4e-8 kg on its hands' bases and tips, an
    // exporter's placeholder): beside an arm's kilograms the physics engine's solver, in f32,
    // fails on it (NaN) and names nothing.
    if let Some(v) = first("mass")
        .map(|m| numbers(m, "value"))
        .and_then(|m| m.into_iter().find(|v| *v > 0.0 && *v < MIN_MASS_KG))
    {
        return Some(format!("a mass of {v:e} kg, under a milligram"));
    }
    let inertia = first("inertia")?;
    if let Some(v) = ["ixx", "ixy", "ixz", "iyy", "iyz", "izz"]
        .iter()
        .flat_map(|a| numbers(inertia, a))
        .find(|v| v.abs() > MAX_INERTIA)
    {
        return Some(format!("an inertia of {v:e} kg·m²"));
    }
    // A moment far beyond what the link's mass can make within a robot's size (Pollen's Reachy:
    // 6.9e4 kg·m² on 0.158 kg, a CAD's g·mm² written as kg·m²): the physics engine's solver
    // fails on it.
    let mass = first("mass")
        .map(|m| numbers(m, "value"))
        .and_then(|m| m.first().copied())
        .filter(|m| *m > 0.0)?;
    ["ixx", "iyy", "izz"]
        .iter()
        .flat_map(|a| numbers(inertia, a))
        .find(|v| (v / mass).sqrt() > MAX_GYRATION_M)
        .map(|v| {
            format!(
                "an inertia of {v:e} kg·m² on {mass} kg: its mass {:.0} m from the axis",
                (v / mass).sqrt()
            )
        })
}

fn check_inertial(ctx: &Ctx, inertial: El, desc: &str) -> RobotResult<()> {
    let iat = At::new(inertial, desc);
    origin_of(ctx, iat)?;
    match first_child(iat, "mass") {
        Some(m) => {
            let mdesc = format!("{desc} <mass>");
            let mat = At::new(m, &mdesc);
            let t = req_attr(ctx, mat, "value")?;
            let v = parse_number(ctx, mat, "value", t)?;
            if v < 0.0 {
                return Err(mat.attr_error(
                    ctx,
                    "value",
                    format!("{v} is negative, expected a mass ≥ 0"),
                ));
            }
        }
        None => return Err(iat.error(ctx, "missing <mass>")),
    }
    match first_child(iat, "inertia") {
        Some(i) => {
            let idesc = format!("{desc} <inertia>");
            let inat = At::new(i, &idesc);
            for attr in ["ixx", "ixy", "ixz", "iyy", "iyz", "izz"] {
                let t = req_attr(ctx, inat, attr)?;
                parse_number(ctx, inat, attr, t)?;
            }
        }
        None => return Err(iat.error(ctx, "missing <inertia>")),
    }
    Ok(())
}

fn check_link(ctx: &Ctx, link: At) -> RobotResult<()> {
    if let Some(inertial) = first_child(link, "inertial") {
        if unusable_inertial(inertial).is_none() {
            check_inertial(ctx, inertial, &format!("{} <inertial>", link.desc))?;
        }
    }
    for (kind, label) in [("visual", "<visual>"), ("collision", "<collision>")] {
        for v in children(link.node, kind) {
            check_geometry(ctx, At::new(v, &format!("{} {label}", link.desc)))?;
        }
    }
    Ok(())
}

pub(super) struct RawJoint {
    pub(super) name: String,
    /// The line the `<joint>` element starts on.
    pub(super) line: u32,
    pub(super) kind: JointKind,
    pub(super) parent: String,
    pub(super) child: String,
    pub(super) origin: Isometry3<f64>,
    pub(super) axis: Unit<Vector3<f64>>,
    pub(super) limits: (f64, f64),
    pub(super) velocity: f64,
    pub(super) effort: f64,
}

/// A joint's `<limit>`: `(lower, upper)`, velocity and effort (0: none given), checked.
fn check_limit(
    ctx: &Ctx,
    at: At,
    kind: JointKind,
    ty: &str,
) -> RobotResult<((f64, f64), f64, f64)> {
    let Some(l) = first_child(at, "limit") else {
        if matches!(kind, JointKind::Revolute | JointKind::Prismatic) {
            return Err(at.error(
                ctx,
                format!("missing <limit lower=... upper=...>, required for a {ty} joint"),
            ));
        }
        return Ok(((0.0, 0.0), 0.0, 0.0));
    };
    let ldesc = format!("{} <limit>", at.desc);
    let lat = At::new(l, &ldesc);
    let lower = opt_attr_number(ctx, lat, "lower")?.unwrap_or(0.0);
    let upper = opt_attr_number(ctx, lat, "upper")?.unwrap_or(0.0);
    let velocity = opt_attr_number(ctx, lat, "velocity")?.unwrap_or(0.0);
    let effort = opt_attr_number(ctx, lat, "effort")?.unwrap_or(0.0);
    // Limits written the wrong way round (InMoov's head roll: lower 0.3, upper -0.3) are read
    // swapped, and the repair pass says so (see `repair.rs`).
    let (lower, upper) =
        if lower > upper && matches!(kind, JointKind::Revolute | JointKind::Prismatic) {
            (upper, lower)
        } else {
            (lower, upper)
        };
    if kind == JointKind::Prismatic {
        check_length(ctx, lat, "lower", lower.abs(), "a travel")?;
        check_length(ctx, lat, "upper", upper.abs(), "a travel")?;
    }
    // A zero velocity limit on a joint that has room to move would forbid all motion, and a
    // negative one is no limit at all: makers write either for "not given" (ROS's parser
    // reads them, and the physics takes 0 for no limit); the repair pass notes them (see
    // `repair.rs`).
    Ok(((lower, upper), velocity.max(0.0), effort.max(0.0)))
}

fn check_joint(ctx: &Ctx, joint: At) -> RobotResult<RawJoint> {
    let name = req_attr(ctx, joint, "name")?.to_string();
    let ty = req_attr(ctx, joint, "type")?;
    let kind = JointKind::parse(ty.trim()).ok_or_else(|| {
        joint.attr_error(
            ctx,
            "type",
            format!("unknown joint type \"{ty}\", expected one of revolute, continuous, prismatic, fixed, floating, planar"),
        )
    })?;
    let link_of = |role: &'static str| -> RobotResult<String> {
        let el = first_child(joint, role)
            .ok_or_else(|| joint.error(ctx, format!("missing <{role} link=\"...\">")))?;
        let desc = format!("{} <{role}>", joint.desc);
        Ok(req_attr(ctx, At::new(el, &desc), "link")?
            .trim()
            .to_string())
    };
    let parent = link_of("parent")?;
    let child = link_of("child")?;
    let origin = origin_of(ctx, joint)?;
    let axis = match first_child(joint, "axis") {
        None => Vector3::x_axis(),
        Some(a) => {
            let adesc = format!("{} <axis>", joint.desc);
            let aat = At::new(a, &adesc);
            let xyz = opt_attr_numbers::<3>(ctx, aat, "xyz")?.unwrap_or([1.0, 0.0, 0.0]);
            let v = Vector3::from(xyz);
            if kind.is_movable() && v.norm() < 1e-12 {
                return Err(aat.attr_error(
                    ctx,
                    "xyz",
                    "the axis is zero, expected a non-zero direction",
                ));
            }
            Unit::try_new(v, 1e-12).unwrap_or_else(Vector3::x_axis)
        }
    };
    let (mut limits, velocity, effort) = check_limit(ctx, joint, kind, ty)?;
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
        if let Some(el) = first_child(joint, tag) {
            let tdesc = format!("{} <{tag}>", joint.desc);
            let tat = At::new(el, &tdesc);
            for a in attrs {
                opt_attr_number(ctx, tat, a)?;
            }
            if tag == "mimic" {
                req_attr(ctx, tat, "joint")?;
            }
        }
    }
    Ok(RawJoint {
        name,
        line: line_of(joint.node),
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

/// The least positive mass a link may declare, kg (a milligram; 0 declares none).
pub const MIN_MASS_KG: f64 = 1e-6;

/// The largest inertia component a link may declare, kg·m².
pub const MAX_INERTIA: f64 = 1e9;

/// The largest radius of gyration a link's moment of inertia may mean for its mass, metres
/// (`sqrt(I / m)`; a link's mass lies within a robot's size).
pub const MAX_GYRATION_M: f64 = 10.0;
/// The link names in document order and their index, each link checked.
pub(super) fn read_links(
    ctx: &Ctx,
    root: El,
) -> RobotResult<(Vec<String>, HashMap<String, usize>)> {
    let mut links = Vec::new();
    let mut link_index = HashMap::new();
    for link in children(root, "link") {
        let desc = describe(link);
        let at = At::new(link, &desc);
        let name = req_attr(ctx, at, "name")?.trim().to_string();
        check_link(ctx, at)?;
        if link_index.insert(name.clone(), links.len()).is_some() {
            return Err(at.error(
                ctx,
                "a second link with this name, expected unique link names",
            ));
        }
        links.push(name);
    }
    if links.is_empty() {
        return Err(ctx.invalid(root, "<robot>", "no <link> elements, expected at least one"));
    }
    Ok((links, link_index))
}

/// The joints in document order, each checked, names unique.
pub(super) fn read_joints(ctx: &Ctx, root: El) -> RobotResult<Vec<RawJoint>> {
    let mut raw = Vec::new();
    let mut joint_names = HashMap::new();
    for joint in children(root, "joint") {
        let desc = describe(joint);
        let at = At::new(joint, &desc);
        let j = check_joint(ctx, at)?;
        if joint_names.insert(j.name.clone(), raw.len()).is_some() {
            return Err(at.error(
                ctx,
                "a second joint with this name, expected unique joint names",
            ));
        }
        raw.push(j);
    }
    Ok(raw)
}
