//! The three steps of loading a URDF (see the [module documentation](super)): checking the
//! element tree with precise messages, normalising the quirks urdf-rs would reject and parsing
//! with it, and assembling the joints into a tree.

use std::collections::HashMap;

use nalgebra::{Isometry3, Translation3, Unit, UnitQuaternion, Vector3};
use xml::{Element, Xml};

use super::{JointInfo, JointKind, Robot};
use crate::error::{RobotError, RobotResult};

struct Ctx<'a> {
    file: &'a str,
    /// URDF ≥ 1.1 (`<robot version>`): `<origin quat_xyzw>` is read, as urdfdom does.
    quat: bool,
}

impl Ctx<'_> {
    fn invalid(&self, element: impl Into<String>, message: impl Into<String>) -> RobotError {
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

struct RawJoint {
    name: String,
    kind: JointKind,
    parent: String,
    child: String,
    origin: Isometry3<f64>,
    axis: Unit<Vector3<f64>>,
    limits: (f64, f64),
    velocity: f64,
    effort: f64,
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

/// Fills in what urdf-rs 0.9 insists on but real files omit, and drops what it cannot read.
fn normalise_for_urdf_rs(el: &mut Element) {
    for c in &mut el.children {
        if let Xml::ElementNode(child) = c {
            match child.name.as_str() {
                "limit" => {
                    for attr in ["velocity", "effort"] {
                        if child.get_attribute(attr, None).is_none() {
                            child.set_attribute(attr.to_string(), None, "0".to_string());
                        }
                    }
                }
                "safety_controller" if child.get_attribute("k_velocity", None).is_none() => {
                    child.set_attribute("k_velocity".to_string(), None, "0".to_string());
                }
                _ => {}
            }
            normalise_for_urdf_rs(child);
        }
    }
}

fn xml_error(file: &str, err: xml::BuilderError) -> RobotError {
    match err {
        xml::BuilderError::Parser(p) => RobotError::Xml {
            file: file.to_string(),
            line: p.line,
            column: p.col,
            message: p.msg.to_string(),
        },
        xml::BuilderError::ImproperNesting => RobotError::Xml {
            file: file.to_string(),
            line: 0,
            column: 0,
            message:
                "elements are not properly nested (a closing tag does not match its opening tag)"
                    .into(),
        },
        xml::BuilderError::NoElement => RobotError::Xml {
            file: file.to_string(),
            line: 0,
            column: 0,
            message: "no XML element found, expected <robot>".into(),
        },
    }
}

/// The deepest element nesting a URDF may have. A URDF needs five levels (`robot`, `link`,
/// `visual`, `geometry`, `box`); vendor blocks (`<gazebo>`, `<transmission>`) a few more. The
/// XML parser and urdf-rs recurse once per level, so a deeper document is refused before they
/// see it.
pub const MAX_DEPTH: usize = 64;

/// The largest length a URDF may state, metres (shape sizes, origins, prismatic limits):
/// the physics engine computes in `f32`, where a cylinder of 1e29 m overflows.
pub const MAX_LENGTH_M: f64 = 1e4;

/// The largest mass a link may declare, kg.
pub const MAX_MASS_KG: f64 = 1e6;

/// The largest inertia component a link may declare, kg·m².
pub const MAX_INERTIA: f64 = 1e9;

/// Refuses `text` if its elements nest deeper than [`MAX_DEPTH`], naming the line and column
/// of the first element too deep. One linear pass over the bytes, no allocation: comments,
/// CDATA sections, processing instructions, declarations and quoted attribute values are
/// skipped; whether the rest is well-formed is the XML parser's business.
fn check_depth(text: &str, file: &str) -> RobotResult<()> {
    let b = text.as_bytes();
    let skip_to = |from: usize, end: &[u8]| -> usize {
        b[from..]
            .windows(end.len())
            .position(|w| w == end)
            .map_or(b.len(), |p| from + p + end.len())
    };
    let mut depth = 0usize;
    let mut i = 0;
    while let Some(p) = b[i..].iter().position(|&c| c == b'<') {
        let at = i + p;
        let rest = &b[at..];
        i = if rest.starts_with(b"<!--") {
            skip_to(at + 4, b"-->")
        } else if rest.starts_with(b"<![CDATA[") {
            skip_to(at + 9, b"]]>")
        } else if rest.starts_with(b"<?") {
            skip_to(at + 2, b"?>")
        } else if rest.starts_with(b"<!") {
            skip_to(at + 2, b">")
        } else if rest.starts_with(b"</") {
            depth = depth.saturating_sub(1);
            skip_to(at + 2, b">")
        } else {
            // A start tag: find its end outside quoted attribute values.
            let mut j = at + 1;
            let mut quote = None;
            while j < b.len() {
                match (quote, b[j]) {
                    (None, b'"' | b'\'') => quote = Some(b[j]),
                    (Some(q), c) if c == q => quote = None,
                    (None, b'>') => break,
                    _ => {}
                }
                j += 1;
            }
            if j < b.len() && b[j - 1] != b'/' {
                depth += 1;
                if depth > MAX_DEPTH {
                    let line = b[..at].iter().filter(|&&c| c == b'\n').count() + 1;
                    let line_start = b[..at]
                        .iter()
                        .rposition(|&c| c == b'\n')
                        .map_or(0, |p| p + 1);
                    let column = text[line_start..at].chars().count() + 1;
                    return Err(RobotError::Xml {
                        file: file.to_string(),
                        line: u32::try_from(line).unwrap_or(u32::MAX),
                        column: u32::try_from(column).unwrap_or(u32::MAX),
                        message: format!(
                            "elements nest deeper than {MAX_DEPTH} levels, expected a URDF (5 levels)"
                        ),
                    });
                }
            }
            j + 1
        };
        if i >= b.len() {
            break;
        }
    }
    Ok(())
}

pub(super) fn parse(text: &str, file: &str) -> RobotResult<Robot> {
    check_depth(text, file)?;
    let mut root: Element = text.parse().map_err(|e| xml_error(file, e))?;
    let version = root
        .get_attribute("version", None)
        .and_then(|v| {
            let (major, minor) = v.trim().split_once('.')?;
            Some((major.parse::<u32>().ok()?, minor.parse::<u32>().ok()?))
        })
        .unwrap_or((1, 0));
    let ctx = Ctx {
        file,
        quat: version >= (1, 1),
    };
    if root.name != "robot" {
        return Err(ctx.invalid(
            format!("<{}>", root.name),
            "the document element must be <robot>",
        ));
    }
    let robot_name = root
        .get_attribute("name", None)
        .unwrap_or_default()
        .to_string();
    let (links, link_index) = read_links(&ctx, &root)?;
    let raw = read_joints(&ctx, &root)?;
    let Tree {
        joints,
        parent_joint,
        movable,
    } = build_tree(&ctx, &links, &link_index, raw)?;
    let root_link = find_root(file, &links, &joints, &parent_joint)?;

    normalise_for_urdf_rs(&mut root);
    let urdf = urdf_rs::read_from_string(&root.to_string()).map_err(|e| RobotError::UrdfRs {
        file: file.to_string(),
        message: e.to_string(),
    })?;

    Ok(Robot {
        name: robot_name,
        source: file.to_string(),
        links,
        link_index,
        joints,
        parent_joint,
        root: root_link,
        movable,
        urdf,
    })
}

/// The link names in document order and their index, each link checked.
fn read_links(ctx: &Ctx, root: &Element) -> RobotResult<(Vec<String>, HashMap<String, usize>)> {
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
fn read_joints(ctx: &Ctx, root: &Element) -> RobotResult<Vec<RawJoint>> {
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

/// Joints resolved onto link indices.
struct Tree {
    joints: Vec<JointInfo>,
    /// Per link, the joint whose child it is.
    parent_joint: Vec<Option<usize>>,
    /// Indices of the movable joints, in configuration order.
    movable: Vec<usize>,
}

/// Resolves each joint's links and checks that no link has two parents or is its own parent.
fn build_tree(
    ctx: &Ctx,
    links: &[String],
    link_index: &HashMap<String, usize>,
    raw: Vec<RawJoint>,
) -> RobotResult<Tree> {
    let file = ctx.file;
    let mut parent_joint: Vec<Option<usize>> = vec![None; links.len()];
    let mut joints = Vec::with_capacity(raw.len());
    let mut movable = Vec::new();
    for (ji, j) in raw.into_iter().enumerate() {
        let find = |role: &'static str, l: &str| {
            link_index
                .get(l)
                .copied()
                .ok_or_else(|| RobotError::UnknownLink {
                    file: file.to_string(),
                    joint: j.name.clone(),
                    role,
                    link: l.to_string(),
                })
        };
        let parent = find("parent", &j.parent)?;
        let child = find("child", &j.child)?;
        if parent == child {
            return Err(RobotError::Cycle {
                file: file.to_string(),
                links: vec![j.child.clone()],
            });
        }
        if let Some(other) = parent_joint[child] {
            let other: &JointInfo = &joints[other];
            return Err(ctx.invalid(
                format!("<joint name=\"{}\">", j.name),
                format!(
                    "link \"{}\" is already the child of joint \"{}\", expected each link to have at most one parent joint",
                    j.child, other.name
                ),
            ));
        }
        parent_joint[child] = Some(ji);
        let q_index = if j.kind.is_movable() {
            movable.push(ji);
            Some(movable.len() - 1)
        } else {
            None
        };
        joints.push(JointInfo {
            name: j.name,
            kind: j.kind,
            parent,
            child,
            origin: j.origin,
            axis: j.axis,
            limits: j.limits,
            velocity: j.velocity,
            effort: j.effort,
            q_index,
        });
    }
    Ok(Tree {
        joints,
        parent_joint,
        movable,
    })
}

/// The root link: the only link without a parent joint, with every link reaching it.
fn find_root(
    file: &str,
    links: &[String],
    joints: &[JointInfo],
    parent_joint: &[Option<usize>],
) -> RobotResult<usize> {
    let roots: Vec<usize> = (0..links.len())
        .filter(|&l| parent_joint[l].is_none())
        .collect();
    if roots.len() > 1 {
        return Err(RobotError::MultipleRoots {
            file: file.to_string(),
            roots: roots.iter().map(|&l| links[l].clone()).collect(),
        });
    }
    // Every link has at most one parent; a link that does not reach the root by following
    // parents lies on (or below) a cycle.
    // One pass: a link is `Done` once its chain of parents is known to end at a root, so each
    // link is walked once (a per-start walk is quadratic on a long chain).
    #[derive(Clone, Copy, PartialEq)]
    enum Mark {
        New,
        OnPath,
        Done,
    }
    let mut mark = vec![Mark::New; links.len()];
    for start in 0..links.len() {
        let mut cur = start;
        while mark[cur] == Mark::New {
            mark[cur] = Mark::OnPath;
            match parent_joint[cur] {
                Some(j) => cur = joints[j].parent,
                None => break,
            }
        }
        if let (Mark::OnPath, Some(pj)) = (mark[cur], parent_joint[cur]) {
            let mut cycle = vec![links[cur].clone()];
            let mut c = joints[pj].parent;
            while c != cur {
                cycle.push(links[c].clone());
                match parent_joint[c] {
                    Some(pj) => c = joints[pj].parent,
                    None => break,
                }
            }
            cycle.reverse();
            return Err(RobotError::Cycle {
                file: file.to_string(),
                links: cycle,
            });
        }
        let mut c = start;
        while mark[c] == Mark::OnPath {
            mark[c] = Mark::Done;
            match parent_joint[c] {
                Some(j) => c = joints[j].parent,
                None => break,
            }
        }
    }
    let Some(&root_link) = roots.first() else {
        // Unreachable in practice: no root means a cycle, which the loop above reports.
        return Err(RobotError::Cycle {
            file: file.to_string(),
            links: links.to_vec(),
        });
    };
    Ok(root_link)
}
