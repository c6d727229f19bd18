//! The tolerant pass of loading a URDF (see the [module documentation](super)): what a
//! published file breaks of the URDF specification where its meaning is clear, read as ROS's
//! parser (urdfdom) and Pinocchio read it, with every place recorded by line
//! ([`UrdfRepair`]); and what urdf-rs 0.9 insists on that the specification lets a file leave
//! out, filled in silently with the specification's defaults.
//!
//! The repairs are edits of the text (an attribute inserted, an element blanked) that keep
//! every line where it was, so that the line of any later message is the file's own.

use std::fmt;

use super::check::{children, describe, line_of, unusable_inertial, zero_size_shape, El};

/// One kind of departure from the URDF specification that loading repaired, with every place
/// it was found.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct UrdfRepair {
    /// What the file does, e.g. `<material> without a name`.
    pub problem: String,
    /// What loading made of it, e.g. `named "material_line_12" …`.
    pub repair: String,
    /// Where: the line of each element and the element it belongs to (e.g.
    /// `<link name="torso"> <visual>`).
    pub places: Vec<(u32, String)>,
}

impl fmt::Display for UrdfRepair {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let n = self.places.len();
        let shown: Vec<String> = self
            .places
            .iter()
            .take(3)
            .map(|(line, owner)| format!("line {line} ({owner})"))
            .collect();
        let more = if n > 3 {
            format!(" and {} more", n - 3)
        } else {
            String::new()
        };
        let times = if n == 1 {
            String::new()
        } else {
            format!("{n} × ")
        };
        write!(
            f,
            "{times}{} at {}{more}: {}",
            self.problem,
            shown.join(", "),
            self.repair
        )
    }
}

/// An edit of the text: at byte `at`, remove `remove` bytes and insert `insert`.
struct Edit {
    at: usize,
    remove: usize,
    insert: String,
}

/// The repairs of one document: the edits and what they mean.
#[derive(Default)]
struct Repairs {
    edits: Vec<Edit>,
    found: Vec<UrdfRepair>,
}

impl Repairs {
    /// Records `problem` at `node` (described as belonging to `owner`), repaired as `repair`.
    fn note(&mut self, problem: &str, repair: &str, node: El, owner: String) {
        self.note_at(problem, repair, line_of(node), owner);
    }

    /// Records `problem` at `line` (in what `owner` describes), repaired as `repair`.
    fn note_at(&mut self, problem: &str, repair: &str, line: u32, owner: String) {
        let place = (line, owner);
        match self
            .found
            .iter_mut()
            .find(|r| r.problem == problem && r.repair == repair)
        {
            Some(r) => r.places.push(place),
            None => self.found.push(UrdfRepair {
                problem: problem.to_string(),
                repair: repair.to_string(),
                places: vec![place],
            }),
        }
    }

    /// Inserts ` attr="value"` into the start tag of `node`.
    fn set(&mut self, text: &str, node: El, attr: &str, value: &str) {
        let start = node.range().start;
        let name_end = text[start + 1..]
            .find(|c: char| c.is_whitespace() || c == '/' || c == '>')
            .map_or(text.len(), |p| start + 1 + p);
        self.edits.push(Edit {
            at: name_end,
            remove: 0,
            insert: format!(" {attr}=\"{value}\""),
        });
    }

    /// Replaces the value of `node`'s attribute `attr` (which it has) with `value`.
    fn replace(&mut self, node: El, attr: &str, value: &str) {
        if let Some(a) = node.attributes().find(|a| a.name() == attr) {
            let r = a.range_value();
            self.edits.push(Edit {
                at: r.start,
                remove: r.len(),
                insert: value.to_string(),
            });
        }
    }

    /// Fills every attribute of `attrs` that `node` lacks with `value` (the specification's
    /// default), silently.
    fn default_attrs(&mut self, text: &str, node: El, attrs: &[&str], value: &str) {
        for a in attrs {
            if node.attribute(*a).is_none() {
                self.set(text, node, a, value);
            }
        }
    }

    /// Blanks `node` out of the text, keeping its line ends.
    fn remove(&mut self, text: &str, node: El) {
        let r = node.range();
        self.edits.push(Edit {
            at: r.start,
            remove: r.len(),
            insert: text[r].chars().filter(|&c| c == '\n').collect(),
        });
    }
}

/// The document's repairs: the repaired text (`None`: nothing to change) and what was
/// repaired where. `urdf_1_1`: the document is URDF ≥ 1.1 (`<origin quat_xyzw>` read).
pub(super) fn repair(
    text: &str,
    root: El,
    file_stem: &str,
    urdf_1_1: bool,
) -> (Option<String>, Vec<UrdfRepair>) {
    let mut r = Repairs::default();
    if root.attribute("name").is_none() {
        r.note(
            "<robot> without a name",
            &format!("named \"{file_stem}\" after the file"),
            root,
            "<robot>".into(),
        );
        r.set(text, root, "name", &xml_escape(file_stem));
    }
    for m in children(root, "material") {
        material(&mut r, text, m, "<robot>".into());
    }
    for link in children(root, "link") {
        let owner = describe(link);
        later_repeats(&mut r, text, link, first_read("link"), &owner);
        for v in children(link, "visual") {
            for m in children(v, "material").take(1) {
                material(&mut r, text, m, format!("{owner} <visual>"));
            }
        }
        for part in ["inertial", "visual", "collision"] {
            let within = format!("{owner} <{part}>");
            for p in children(link, part).take(if part == "inertial" { 1 } else { usize::MAX }) {
                later_repeats(&mut r, text, p, first_read(part), &within);
                if part != "inertial" && zero_size_shape(p) {
                    r.note(
                        &format!("<{part}> whose shape has a size of zero"),
                        "left out: it has no extent to draw or to touch",
                        p,
                        owner.clone(),
                    );
                    r.remove(text, p);
                    continue;
                }
                if let Some(why) = (part == "inertial").then(|| unusable_inertial(p)).flatten() {
                    r.note(
                        &format!("<inertial> of no use ({why})"),
                        "left out: the link declares no mass (retargeting never reads it; simulate gives the link's collision shapes a density)",
                        p,
                        owner.clone(),
                    );
                    r.remove(text, p);
                    continue;
                }
                origins(&mut r, text, p, urdf_1_1);
                for g in children(p, "geometry").take(1) {
                    stray_text(&mut r, text, g, format!("{owner} <{part}>"));
                }
            }
        }
    }
    for joint in children(root, "joint") {
        self::joint(&mut r, text, joint, urdf_1_1);
    }
    if r.edits.is_empty() {
        return (None, r.found);
    }
    r.edits.sort_by_key(|e| e.at);
    let mut out = String::with_capacity(text.len() + 32 * r.edits.len());
    let mut at = 0;
    for e in &r.edits {
        if e.at < at {
            continue; // inside an element already blanked
        }
        out.push_str(&text[at..e.at]);
        out.push_str(&e.insert);
        at = e.at + e.remove;
    }
    out.push_str(&text[at..]);
    (Some(out), r.found)
}

/// A `<material>`: a name where it has none (urdfdom drops the visual, urdf-rs refuses the
/// file; its colour is clear), textures without a file dropped.
fn material(r: &mut Repairs, text: &str, m: El, owner: String) {
    if m.attribute("name").is_none() {
        let name = format!("material_line_{}", line_of(m));
        r.note(
            "<material> without a name (the specification requires one)",
            "given one (material_line_N) so that its colour is kept",
            m,
            owner.clone(),
        );
        r.set(text, m, "name", &name);
    }
    for t in children(m, "texture") {
        if t.attribute("filename").is_none() {
            r.note(
                "<texture> without a filename",
                "left out (it names no image)",
                t,
                owner.clone(),
            );
            r.remove(text, t);
        }
    }
}

/// Text inside a `<geometry>` beside its shape (AgileX's Tracer wheels: `<geometry>-->`, a
/// comment's end left behind): urdfdom reads the shape and ignores the text, urdf-rs takes the
/// text for a shape and refuses the file. Left out.
fn stray_text(r: &mut Repairs, text: &str, geometry: El, owner: String) {
    for t in geometry.children().filter(|c| c.is_text()) {
        let Some(s) = t.text().filter(|s| !s.trim().is_empty()) else {
            continue;
        };
        // The line of the text itself, not of the line end before it.
        let start = t.range().start + (s.len() - s.trim_start().len());
        r.note_at(
            "text inside a <geometry> beside its shape",
            "left out, as ROS's parser ignores it",
            t.document().text_pos_at(start).row,
            owner.clone(),
        );
        r.remove(text, t);
    }
}

/// `<origin>` children of `el` without `xyz` or `rpy`: zeros, as the specification says.
fn origins(r: &mut Repairs, text: &str, el: El, urdf_1_1: bool) {
    for o in children(el, "origin").take(1) {
        r.default_attrs(text, o, &["xyz"], "0 0 0");
        if !(urdf_1_1 && o.attribute("quat_xyzw").is_some()) {
            r.default_attrs(text, o, &["rpy"], "0 0 0");
        }
    }
}

/// The children ROS's parser reads once in an element called `parent`: only the first of each
/// (urdfdom's `FirstChildElement`); a link's `<visual>` and `<collision>` elements may repeat.
fn first_read(parent: &str) -> &'static [&'static str] {
    match parent {
        "link" => &["inertial"],
        "inertial" => &["origin", "mass", "inertia"],
        "visual" => &["origin", "geometry", "material"],
        "collision" => &["origin", "geometry"],
        "joint" => &[
            "origin",
            "parent",
            "child",
            "axis",
            "limit",
            "dynamics",
            "calibration",
            "safety_controller",
            "mimic",
        ],
        _ => &[],
    }
}

/// The children of `el` called one of `tags` after the first of each, left out as ROS's parser
/// leaves them (it reads the first; urdf-rs refuses a repeat) and said, `within` naming `el`.
fn later_repeats(r: &mut Repairs, text: &str, el: El, tags: &[&str], within: &str) {
    for tag in tags {
        for repeat in el
            .children()
            .filter(|c| c.is_element() && c.tag_name().name() == *tag)
            .skip(1)
        {
            r.note(
                &format!("a second <{tag}>"),
                "left out: ROS's parser reads the first",
                repeat,
                within.to_string(),
            );
            r.remove(text, repeat);
        }
    }
}

/// A `<joint>`'s limits, axis, dynamics and safety controller.
fn joint(r: &mut Repairs, text: &str, joint: El, urdf_1_1: bool) {
    let owner = describe(joint);
    later_repeats(r, text, joint, first_read("joint"), &owner);
    origins(r, text, joint, urdf_1_1);
    let ty = joint.attribute("type").unwrap_or("").trim();
    for l in children(joint, "limit").take(1) {
        let number = |a: &str| l.attribute(a).and_then(|v| v.trim().parse::<f64>().ok());
        let (lower, upper) = (
            number("lower").unwrap_or(0.0),
            number("upper").unwrap_or(0.0),
        );
        // Limits written the wrong way round are read swapped (a missing one is the
        // specification's 0); else the missing ones are filled with 0 for urdf-rs.
        let swapped = matches!(ty, "revolute" | "prismatic") && lower > upper;
        if swapped {
            r.note(
                "<limit> whose lower is above its upper",
                "read the other way round",
                l,
                owner.clone(),
            );
            for (attr, value) in [("lower", upper), ("upper", lower)] {
                let value = format!("{value}");
                if l.attribute(attr).is_some() {
                    r.replace(l, attr, &value);
                } else {
                    r.set(text, l, attr, &value);
                }
            }
        } else {
            r.default_attrs(text, l, &["lower", "upper"], "0");
        }
        let (lower, upper) = if swapped {
            (upper, lower)
        } else {
            (lower, upper)
        };
        for attr in ["effort", "velocity"] {
            if l.attribute(attr).is_none() {
                r.note(
                    &format!("<limit> without {attr} (the specification requires it)"),
                    &format!("no {attr} limit"),
                    l,
                    owner.clone(),
                );
                r.set(text, l, attr, "0");
            }
        }
        for attr in ["effort", "velocity"] {
            // A limit is > 0; makers write -1 for "none" (Halodi's EVE on 23 joints), which
            // ROS's parser and Pinocchio read without a word.
            if number(attr).is_some_and(|v| v < 0.0) {
                r.note(
                    &format!(
                        "<limit {attr}=\"{}\"> is negative (a limit is > 0)",
                        l.attribute(attr).unwrap_or("").trim()
                    ),
                    &format!("read as no {attr} limit given"),
                    l,
                    owner.clone(),
                );
                r.replace(l, attr, "0");
            }
        }
        let moves = ty == "continuous" || (matches!(ty, "revolute" | "prismatic") && lower < upper);
        if moves && number("velocity") == Some(0.0) {
            r.note(
                "<limit velocity=\"0\"> on a joint whose limits let it move (it would forbid all motion)",
                "read as no velocity limit given",
                l,
                owner.clone(),
            );
        }
    }
    for a in children(joint, "axis").take(1) {
        if a.attribute("xyz").is_none() {
            r.note(
                "<axis> without xyz (the specification requires it)",
                "the default axis 1 0 0",
                a,
                owner.clone(),
            );
            r.set(text, a, "xyz", "1 0 0");
        }
    }
    for d in children(joint, "dynamics").take(1) {
        r.default_attrs(text, d, &["damping", "friction"], "0");
    }
    for s in children(joint, "safety_controller").take(1) {
        r.default_attrs(
            text,
            s,
            &["soft_lower_limit", "soft_upper_limit", "k_position"],
            "0",
        );
        if s.attribute("k_velocity").is_none() {
            r.note(
                "<safety_controller> without k_velocity (the specification requires it)",
                "k_velocity 0",
                s,
                owner.clone(),
            );
            r.set(text, s, "k_velocity", "0");
        }
    }
}

/// `text` with the five XML special characters escaped, for an attribute value.
fn xml_escape(text: &str) -> String {
    text.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
        .replace('\'', "&apos;")
}
