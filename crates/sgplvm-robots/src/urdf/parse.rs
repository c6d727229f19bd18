//! Loading a URDF text (see the [module documentation](super)): the nesting depth guard, the
//! XML parser's errors, then the three steps — checking the element tree
//! ([`check`](super::check)), repairing what breaks the specification where its meaning is
//! clear ([`repair`](super::repair)) and parsing the repaired text with urdf-rs (here), and
//! assembling the joints into a tree ([`tree`](super::tree)).

use super::check::{read_joints, read_links, Ctx};
use super::repair::repair;
use super::tree::{build_tree, find_root, Tree};
use super::Robot;
use crate::error::{RobotError, RobotResult};

/// The XML parser's error as ours: the file, the line and column, the reason (without the
/// parser's own position suffix).
fn xml_error(file: &str, err: &roxmltree::Error) -> RobotError {
    let pos = err.pos();
    let message = match err {
        roxmltree::Error::NoRootNode => "no XML element found, expected <robot>".to_string(),
        other => {
            let m = other.to_string();
            let suffix = format!(" at {}:{}", pos.row, pos.col);
            m.replace(&suffix, "")
        }
    };
    RobotError::Xml {
        file: file.to_string(),
        line: pos.row,
        column: pos.col,
        message,
    }
}

/// The deepest element nesting a URDF may have. A URDF needs five levels (`robot`, `link`,
/// `visual`, `geometry`, `box`); vendor blocks (`<gazebo>`, `<transmission>`) a few more. The
/// XML parser and urdf-rs recurse once per level, so a deeper document is refused before they
/// see it.
pub const MAX_DEPTH: usize = 64;

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
    let options = roxmltree::ParsingOptions {
        allow_dtd: true,
        ..roxmltree::ParsingOptions::default()
    };
    let doc =
        roxmltree::Document::parse_with_options(text, options).map_err(|e| xml_error(file, &e))?;
    let root = doc.root_element();
    let version = root
        .attribute("version")
        .and_then(|v| {
            let (major, minor) = v.trim().split_once('.')?;
            Some((major.parse::<u32>().ok()?, minor.parse::<u32>().ok()?))
        })
        .unwrap_or((1, 0));
    let ctx = Ctx {
        file,
        quat: version >= (1, 1),
    };
    if root.tag_name().name() != "robot" {
        return Err(ctx.invalid(
            root,
            format!("<{}>", root.tag_name().name()),
            "the document element must be <robot>",
        ));
    }
    let robot_name = root.attribute("name").unwrap_or_default().to_string();
    let (links, link_index) = read_links(&ctx, root)?;
    let raw = read_joints(&ctx, root)?;
    let Tree {
        joints,
        parent_joint,
        movable,
    } = build_tree(&ctx, &links, &link_index, raw)?;
    let root_link = find_root(file, &links, &joints, &parent_joint)?;

    let stem = std::path::Path::new(file)
        .file_stem()
        .and_then(|s| s.to_str())
        .unwrap_or("robot");
    let (repaired, repairs) = repair(text, root, stem, ctx.quat);
    let urdf = urdf_rs::read_from_string(repaired.as_deref().unwrap_or(text)).map_err(|e| {
        RobotError::UrdfRs {
            file: file.to_string(),
            message: e.to_string(),
        }
    })?;
    let name = if robot_name.is_empty() {
        urdf.name.clone()
    } else {
        robot_name
    };

    Ok(Robot {
        name,
        source: file.to_string(),
        links,
        link_index,
        joints,
        parent_joint,
        root: root_link,
        movable,
        urdf,
        repairs,
    })
}
