//! Acclaim ASF/AMC, the native format of CMU's motion capture database: a skeleton file (ASF:
//! bones with a rest direction, a length, a local frame `axis` and the rotations they allow)
//! and a motion file (AMC: per frame, each bone's rotation values). Read into the [`Bvh`] the
//! rest of the importer fits, so that a capture imports the same whichever format it comes in.
//!
//! The skeleton as a BVH: each bone is a joint at the bone's start; a child joint sits at its
//! parent bone's end (the offset `direction × length`, in the rest frame every joint shares);
//! a bone with no children ends in an End Site. A bone's rotation in a frame, relative to its
//! parent's, is `C · M · C⁻¹` (C from its `axis`, M from the frame's values, each composed
//! with the first listed turn applied first: `rx ry rz` gives `Rz · Ry · Rx`), written as
//! `Zrotation Yrotation Xrotation` channels; the root also moves (`TX TY TZ`). Lengths stay in
//! the file's units, as a BVH's do.
//!
//! Every problem is a [`BvhError`] naming the file, the line and what was expected.

use std::collections::HashMap;
use std::path::Path;

use nalgebra::{Rotation3, Vector3};

use crate::bvh::{axis_rotation, Bvh, BvhError, BvhJoint, Channel};

/// Most frames accepted from one AMC file (a day at 120 Hz).
const MAX_FRAMES: usize = 10_368_000;

/// One bone of an ASF skeleton.
#[derive(Debug, Clone)]
struct Bone {
    name: String,
    direction: Vector3<f64>,
    length: f64,
    /// The bone's local frame (`axis`).
    axis: Rotation3<f64>,
    /// The rotations the AMC gives, in order (axis 0, 1, 2 for rx, ry, rz).
    dof: Vec<usize>,
    line: usize,
}

/// A parsed ASF skeleton: the root (its `order`, `axis` and rest `position`) and its bones,
/// with each bone's parent (`None`: the root).
#[derive(Debug, Clone)]
struct Skeleton {
    root_order: Vec<(bool, usize)>,
    root_axis: Rotation3<f64>,
    root_position: Vector3<f64>,
    bones: Vec<Bone>,
    parent: Vec<Option<usize>>,
}

fn syntax(file: &str, line: usize, message: impl Into<String>) -> BvhError {
    BvhError::Syntax {
        file: file.to_string(),
        line,
        message: message.into(),
    }
}

fn read_text(path: &Path) -> Result<String, BvhError> {
    let bytes = std::fs::read(path).map_err(|source| BvhError::Io {
        file: path.display().to_string(),
        source,
    })?;
    Ok(String::from_utf8_lossy(&bytes).into_owned())
}

/// Numbers of `words`, each finite; an error names the line.
fn numbers(words: &[&str], file: &str, line: usize, what: &str) -> Result<Vec<f64>, BvhError> {
    words
        .iter()
        .map(|w| {
            w.parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| syntax(file, line, format!("{what}: `{w}` is not a finite number")))
        })
        .collect()
}

/// The rotation of Euler angles in degrees about `axes` (0, 1, 2), the first applied first.
fn turns(axes: &[usize], degrees: &[f64]) -> Rotation3<f64> {
    axes.iter()
        .zip(degrees)
        .fold(Rotation3::identity(), |r, (&a, &d)| {
            axis_rotation(a, d.to_radians()) * r
        })
}

/// An axis order such as `XYZ`.
fn axis_order(word: &str, file: &str, line: usize) -> Result<Vec<usize>, BvhError> {
    let order: Option<Vec<usize>> = word
        .chars()
        .map(|c| match c.to_ascii_lowercase() {
            'x' => Some(0),
            'y' => Some(1),
            'z' => Some(2),
            _ => None,
        })
        .collect();
    match order {
        Some(o) if o.len() == 3 => Ok(o),
        _ => Err(syntax(
            file,
            line,
            format!("axis order `{word}`; expected three of X, Y, Z such as XYZ"),
        )),
    }
}

/// A `dof` or root `order` word: a rotation (`rx`) or a translation (`tx`), and its axis.
fn dof_word(word: &str) -> Option<(bool, usize)> {
    let w = word.to_ascii_lowercase();
    let axis = match w.chars().nth(1)? {
        'x' => 0,
        'y' => 1,
        'z' => 2,
        _ => return None,
    };
    match (w.len(), w.chars().next()?) {
        (2, 'r') => Some((true, axis)),
        (2, 't') => Some((false, axis)),
        _ => None,
    }
}

fn parse_asf(text: &str, file: &str) -> Result<Skeleton, BvhError> {
    let mut section = String::new();
    let mut root_order = vec![
        (false, 0),
        (false, 1),
        (false, 2),
        (true, 0),
        (true, 1),
        (true, 2),
    ];
    let (mut root_axis_order, mut root_orientation) = (vec![0, 1, 2], [0.0; 3]);
    let mut root_position = Vector3::zeros();
    let mut bones: Vec<Bone> = Vec::new();
    let mut current: Option<Bone> = None;
    let mut links: Vec<(usize, Vec<String>)> = Vec::new();
    let mut in_limits = false;
    for (k, raw) in text.lines().enumerate() {
        let line = k + 1;
        let words: Vec<&str> = raw.split_whitespace().collect();
        let Some(&head) = words.first() else { continue };
        if head.starts_with('#') {
            continue;
        }
        if let Some(name) = head.strip_prefix(':') {
            section = name.to_ascii_lowercase();
            continue;
        }
        match section.as_str() {
            "root" => match head.to_ascii_lowercase().as_str() {
                "order" => {
                    root_order = words[1..]
                        .iter()
                        .map(|w| dof_word(w))
                        .collect::<Option<Vec<_>>>()
                        .ok_or_else(|| {
                            syntax(
                                file,
                                line,
                                "root order: expected words such as TX TY TZ RX RY RZ",
                            )
                        })?;
                }
                "axis" => root_axis_order = axis_order(words.get(1).unwrap_or(&""), file, line)?,
                "position" | "orientation" => {
                    let v = numbers(&words[1..], file, line, head)?;
                    let [x, y, z] = v[..] else {
                        return Err(syntax(
                            file,
                            line,
                            format!("root {head}: expected 3 numbers"),
                        ));
                    };
                    if head.eq_ignore_ascii_case("position") {
                        root_position = Vector3::new(x, y, z);
                    } else {
                        root_orientation = [x, y, z];
                    }
                }
                _ => {}
            },
            "bonedata" => {
                let key = head.to_ascii_lowercase();
                if in_limits && !matches!(key.as_str(), "end" | "begin") && head.starts_with('(') {
                    continue;
                }
                in_limits = false;
                match key.as_str() {
                    "begin" => {
                        current = Some(Bone {
                            name: String::new(),
                            direction: Vector3::zeros(),
                            length: 0.0,
                            axis: Rotation3::identity(),
                            dof: Vec::new(),
                            line,
                        })
                    }
                    "end" => {
                        let bone = current
                            .take()
                            .ok_or_else(|| syntax(file, line, "`end` without `begin`"))?;
                        if bone.name.is_empty() {
                            return Err(syntax(file, bone.line, "a bone without a name"));
                        }
                        bones.push(bone);
                    }
                    _ => {
                        let bone = current.as_mut().ok_or_else(|| {
                            syntax(file, line, format!("`{head}` outside a bone's begin … end"))
                        })?;
                        in_limits = bone_line(bone, &key, &words, file, line)?;
                    }
                }
            }
            "hierarchy" => {
                let key = head.to_ascii_lowercase();
                if key != "begin" && key != "end" {
                    links.push((line, words.iter().map(|w| w.to_string()).collect()));
                }
            }
            _ => {}
        }
    }
    if current.is_some() {
        return Err(syntax(file, 0, "the last bone has no `end`"));
    }
    if bones.is_empty() {
        return Err(syntax(
            file,
            0,
            "no :bonedata bones; expected an ASF skeleton",
        ));
    }
    let parent = resolve_hierarchy(&bones, &links, file)?;
    let root_axis = turns(
        &root_axis_order,
        &root_axis_order
            .iter()
            .map(|&a| root_orientation[a])
            .collect::<Vec<_>>(),
    );
    Ok(Skeleton {
        root_order,
        root_axis,
        root_position,
        bones,
        parent,
    })
}

/// Each bone's parent (`None`: the root) from the `:hierarchy` lines `links` (line, words).
fn resolve_hierarchy(
    bones: &[Bone],
    links: &[(usize, Vec<String>)],
    file: &str,
) -> Result<Vec<Option<usize>>, BvhError> {
    let index: HashMap<&str, usize> = bones
        .iter()
        .enumerate()
        .map(|(i, b)| (b.name.as_str(), i))
        .collect();
    let mut parent: Vec<Option<Option<usize>>> = vec![None; bones.len()];
    for (line, words) in links {
        let from = match words[0].as_str() {
            "root" => None,
            name => Some(*index.get(name).ok_or_else(|| {
                syntax(
                    file,
                    *line,
                    format!("hierarchy: no bone `{name}` in :bonedata"),
                )
            })?),
        };
        for child in &words[1..] {
            let c = *index.get(child.as_str()).ok_or_else(|| {
                syntax(
                    file,
                    *line,
                    format!("hierarchy: no bone `{child}` in :bonedata"),
                )
            })?;
            if parent[c].is_some() {
                return Err(syntax(
                    file,
                    *line,
                    format!("hierarchy: bone `{child}` has two parents"),
                ));
            }
            parent[c] = Some(from);
        }
    }
    parent
        .iter()
        .zip(bones)
        .map(|(p, b)| {
            p.ok_or_else(|| {
                syntax(
                    file,
                    b.line,
                    format!("bone `{}` is in no :hierarchy line", b.name),
                )
            })
        })
        .collect()
}

/// One line of a bone's `begin … end` block (`key` its first word, lower case) into `bone`;
/// whether it opens the bone's `limits` (whose further lines are skipped).
fn bone_line(
    bone: &mut Bone,
    key: &str,
    words: &[&str],
    file: &str,
    line: usize,
) -> Result<bool, BvhError> {
    match key {
        "name" => bone.name = words.get(1).unwrap_or(&"").to_string(),
        "direction" => {
            let v = numbers(&words[1..], file, line, "direction")?;
            let [x, y, z] = v[..] else {
                return Err(syntax(file, line, "direction: expected 3 numbers"));
            };
            bone.direction = Vector3::new(x, y, z);
        }
        "length" => {
            let v = numbers(&words[1..2.min(words.len())], file, line, "length")?;
            match v[..] {
                [l] if l >= 0.0 => bone.length = l,
                _ => return Err(syntax(file, line, "length: expected one number ≥ 0")),
            }
        }
        "axis" => {
            let v = numbers(&words[1..4.min(words.len())], file, line, "axis")?;
            if v.len() != 3 {
                return Err(syntax(
                    file,
                    line,
                    "axis: expected 3 angles and an order such as XYZ",
                ));
            }
            let order = axis_order(words.get(4).unwrap_or(&"XYZ"), file, line)?;
            bone.axis = turns(&order, &order.iter().map(|&a| v[a]).collect::<Vec<_>>());
        }
        "dof" => {
            bone.dof = words[1..]
                .iter()
                .map(|w| dof_word(w).filter(|d| d.0).map(|d| d.1))
                .collect::<Option<Vec<_>>>()
                .ok_or_else(|| {
                    syntax(
                        file,
                        line,
                        "dof: expected rotations rx, ry, rz (bone translations are not read)",
                    )
                })?;
        }
        "limits" => return Ok(true),
        _ => {}
    }
    Ok(false)
}

/// The skeleton's bones in an order with every parent before its children (a hierarchy
/// in any order, or with a cycle, is refused).
fn parents_first(s: &Skeleton, file: &str) -> Result<Vec<usize>, BvhError> {
    let mut order = Vec::with_capacity(s.bones.len());
    let mut placed = vec![false; s.bones.len()];
    while order.len() < s.bones.len() {
        let before = order.len();
        for b in 0..s.bones.len() {
            if !placed[b] && s.parent[b].is_none_or(|p| placed[p]) {
                placed[b] = true;
                order.push(b);
            }
        }
        if order.len() == before {
            return Err(syntax(file, 0, "the :hierarchy has a cycle"));
        }
    }
    Ok(order)
}

/// Reads an ASF skeleton and an AMC motion of it into a [`Bvh`] (module documentation).
pub fn read_asf_amc(asf: &Path, amc: &Path) -> Result<Bvh, BvhError> {
    let asf_file = asf.display().to_string();
    let amc_file = amc.display().to_string();
    let skeleton = parse_asf(&read_text(asf)?, &asf_file)?;
    asf_amc_to_bvh(&skeleton, &read_text(amc)?, &asf_file, &amc_file)
}

/// The rotation as `Zrotation Yrotation Xrotation` channel values, degrees.
fn zyx_degrees(r: &Rotation3<f64>) -> [f64; 3] {
    let (x, y, z) = r.euler_angles();
    [z.to_degrees(), y.to_degrees(), x.to_degrees()]
}

fn asf_amc_to_bvh(s: &Skeleton, amc: &str, asf_file: &str, file: &str) -> Result<Bvh, BvhError> {
    let order = parents_first(s, asf_file)?;
    // The BVH joints: the root, then the bones parents first.
    let rot = [Channel::Zrotation, Channel::Yrotation, Channel::Xrotation];
    let mut joints = vec![BvhJoint {
        name: "root".into(),
        parent: None,
        offset: s.root_position,
        channels: [Channel::Xposition, Channel::Yposition, Channel::Zposition]
            .into_iter()
            .chain(rot)
            .collect(),
        first_channel: 0,
        end_site: None,
        line: 0,
    }];
    let mut joint_of = vec![0usize; s.bones.len()];
    for &b in &order {
        let bone = &s.bones[b];
        let (parent, offset) = match s.parent[b] {
            None => (0, Vector3::zeros()),
            Some(p) => (joint_of[p], s.bones[p].direction * s.bones[p].length),
        };
        joint_of[b] = joints.len();
        joints.push(BvhJoint {
            name: bone.name.clone(),
            parent: Some(parent),
            offset,
            channels: rot.to_vec(),
            first_channel: 6 + 3 * (joints.len() - 1),
            end_site: None,
            line: bone.line,
        });
    }
    for (b, bone) in s.bones.iter().enumerate() {
        if !s.parent.contains(&Some(b)) {
            joints[joint_of[b]].end_site = Some(bone.direction * bone.length);
        }
    }
    let channels = 3 + 3 * joints.len();
    let index: HashMap<&str, usize> = s
        .bones
        .iter()
        .enumerate()
        .map(|(i, b)| (b.name.as_str(), i))
        .collect();
    // The frames: each a number line, then one line per bone that moves.
    let mut values: Vec<f64> = Vec::new();
    let mut frame: Option<Vec<f64>> = None;
    let mut rest = vec![0.0; channels];
    rest[..3].copy_from_slice(s.root_position.as_slice());
    let mut frames = 0usize;
    for (k, raw) in amc.lines().enumerate() {
        let line = k + 1;
        let words: Vec<&str> = raw.split_whitespace().collect();
        let Some(&head) = words.first() else { continue };
        if head.starts_with('#') || head.starts_with(':') {
            continue;
        }
        if words.len() == 1 && head.parse::<u64>().is_ok() {
            values.extend(frame.take().unwrap_or_default());
            frames += 1;
            if frames > MAX_FRAMES {
                return Err(syntax(file, line, format!("more than {MAX_FRAMES} frames")));
            }
            frame = Some(rest.clone());
            continue;
        }
        let Some(f) = frame.as_mut() else {
            return Err(syntax(
                file,
                line,
                format!("`{head}` before the first frame number"),
            ));
        };
        let v = numbers(&words[1..], file, line, head)?;
        if head == "root" {
            if v.len() != s.root_order.len() {
                return Err(syntax(
                    file,
                    line,
                    format!(
                        "root: {} values; the skeleton's root order has {}",
                        v.len(),
                        s.root_order.len()
                    ),
                ));
            }
            let (mut t, mut axes, mut degrees) = (s.root_position, Vec::new(), Vec::new());
            for (&(is_rotation, axis), &x) in s.root_order.iter().zip(&v) {
                if is_rotation {
                    axes.push(axis);
                    degrees.push(x);
                } else {
                    t[axis] = x;
                }
            }
            let r = s.root_axis * turns(&axes, &degrees) * s.root_axis.inverse();
            f[..3].copy_from_slice(t.as_slice());
            f[3..6].copy_from_slice(&zyx_degrees(&r));
            continue;
        }
        let Some(&b) = index.get(head) else {
            return Err(syntax(
                file,
                line,
                format!("no bone `{head}` in the skeleton {asf_file}"),
            ));
        };
        let bone = &s.bones[b];
        if v.len() != bone.dof.len() {
            return Err(syntax(
                file,
                line,
                format!(
                    "{head}: {} values; its dof in {asf_file} has {}",
                    v.len(),
                    bone.dof.len()
                ),
            ));
        }
        let r = bone.axis * turns(&bone.dof, &v) * bone.axis.inverse();
        let c = joints[joint_of[b]].first_channel;
        f[c..c + 3].copy_from_slice(&zyx_degrees(&r));
    }
    values.extend(frame.take().unwrap_or_default());
    if frames == 0 {
        return Err(syntax(
            file,
            0,
            "no frames; expected an AMC motion (a frame number, then a line per bone)",
        ));
    }
    Ok(Bvh {
        joints,
        // CMU captured at 120 frames a second; AMC files do not say.
        frame_time: 1.0 / 120.0,
        channels,
        values,
        frame_lines_left_out: 0,
    })
}

/// The ASF skeleton of AMC file `amc`: the `.asf` in its folder named as its subject (CMU's
/// `13_26.amc` → `13.asf`), else the only `.asf` there.
pub fn skeleton_beside(amc: &Path) -> Result<std::path::PathBuf, BvhError> {
    let folder = amc.parent().unwrap_or(Path::new("."));
    let folder = if folder.as_os_str().is_empty() {
        Path::new(".")
    } else {
        folder
    };
    let stem = amc.file_stem().and_then(|s| s.to_str()).unwrap_or("");
    let subject = stem.split('_').next().unwrap_or(stem);
    let named = folder.join(format!("{subject}.asf"));
    if named.is_file() {
        return Ok(named);
    }
    let found: Vec<std::path::PathBuf> = std::fs::read_dir(folder)
        .map(|d| {
            d.filter_map(Result::ok)
                .map(|e| e.path())
                .filter(|p| p.extension().is_some_and(|e| e.eq_ignore_ascii_case("asf")))
                .collect()
        })
        .unwrap_or_default();
    match found.as_slice() {
        [one] => Ok(one.clone()),
        _ => Err(syntax(
            &amc.display().to_string(),
            0,
            format!(
                "an AMC motion needs its ASF skeleton: expected {} or a single .asf beside it ({} found); or give the .asf before the .amc",
                named.display(),
                found.len()
            ),
        )),
    }
}

#[cfg(test)]
mod tests;
