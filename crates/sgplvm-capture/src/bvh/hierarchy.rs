//! The `HIERARCHY` section: `ROOT`, `JOINT` and `End Site` blocks with their `OFFSET` and
//! `CHANNELS`, read without recursion (a stack of open blocks, at most [`MAX_DEPTH`] deep).

use nalgebra::Vector3;

use super::parser::{short, Parser, Word};
use super::{BvhError, BvhJoint, Channel, MAX_DEPTH, MAX_JOINTS};

/// The hierarchy as read so far.
struct Outline {
    joints: Vec<BvhJoint>,
    /// Open blocks: Some(joint) for a joint, None for an End Site.
    stack: Vec<Option<usize>>,
    next_channel: usize,
    /// A joint or End Site declared whose `{` has not been read yet.
    pending: Option<(Option<usize>, usize)>,
}

impl<'a> Parser<'a> {
    /// Reads `ROOT ... { ... }` blocks up to `MOTION` (consumed). Iterative: a stack of open
    /// joints instead of recursion, so a deep file cannot overflow the stack.
    pub(super) fn hierarchy(&mut self) -> Result<Vec<BvhJoint>, BvhError> {
        let mut h = Outline {
            joints: Vec::new(),
            stack: Vec::new(),
            next_channel: 0,
            pending: None,
        };
        loop {
            let w = self.expect_word(
                "`ROOT`, `JOINT`, `End Site`, `OFFSET`, `CHANNELS`, `}` or `MOTION`",
            )?;
            let upper = w.text.to_ascii_uppercase();
            if let Some((block, line)) = h.pending {
                self.open_block(&mut h, w, block, line)?;
                continue;
            }
            match upper.as_str() {
                "ROOT" | "JOINT" => self.joint(&mut h, w, upper == "ROOT")?,
                "END" => self.end_site(&mut h, w)?,
                "OFFSET" => self.offset(&mut h, w)?,
                "CHANNELS" => self.channels(&mut h, w)?,
                "}" => {
                    if h.stack.pop().is_none() {
                        return Err(self.error(w.line, "`}` without an open block"));
                    }
                }
                "MOTION" => {
                    if !h.stack.is_empty() {
                        return Err(self.error(w.line, format!("`MOTION` with {} block(s) still open; expected `}}`", h.stack.len())));
                    }
                    if h.joints.is_empty() {
                        return Err(self.error(w.line, "no `ROOT` joint before `MOTION`"));
                    }
                    break;
                }
                _ => {
                    return Err(self.error(
                        w.line,
                        format!("found `{}`, expected `ROOT`, `JOINT`, `End Site`, `OFFSET`, `CHANNELS`, `}}` or `MOTION`", short(w.text)),
                    ))
                }
            }
        }
        // Channels are numbered in declaration order, which is the order of the frame values.
        Ok(h.joints)
    }

    /// The `{` (word `w`) that opens `block`, declared on line `line`.
    fn open_block(
        &mut self,
        h: &mut Outline,
        w: Word<'a>,
        block: Option<usize>,
        line: usize,
    ) -> Result<(), BvhError> {
        if w.text != "{" {
            return Err(self.error(
                w.line,
                format!(
                    "found `{}`, expected `{{` to open the block declared on line {line}",
                    short(w.text)
                ),
            ));
        }
        if h.stack.len() >= MAX_DEPTH {
            return Err(self.error(
                w.line,
                format!("joints nested deeper than {MAX_DEPTH} levels; a skeleton has a few dozen"),
            ));
        }
        h.stack.push(block);
        h.pending = None;
        Ok(())
    }

    /// A `ROOT` or `JOINT` (word `w`) and its name.
    fn joint(&mut self, h: &mut Outline, w: Word<'a>, is_root: bool) -> Result<(), BvhError> {
        if is_root && !h.stack.is_empty() {
            return Err(self.error(w.line, "`ROOT` inside another joint; expected `JOINT`"));
        }
        if !is_root && h.stack.is_empty() {
            return Err(self.error(w.line, "`JOINT` outside any joint; expected `ROOT`"));
        }
        let parent = match h.stack.last() {
            Some(Some(p)) => Some(*p),
            Some(None) => {
                return Err(self.error(
                    w.line,
                    "a joint inside an `End Site`; an End Site ends its chain",
                ))
            }
            None => None,
        };
        if is_root && h.joints.iter().any(|j| j.parent.is_none()) {
            return Err(self.error(
                w.line,
                "a second `ROOT`; sgplvm reads files with one skeleton",
            ));
        }
        if h.joints.len() >= MAX_JOINTS {
            return Err(self.error(w.line, format!("more than {MAX_JOINTS} joints")));
        }
        let name_line = self.line;
        let name = self.rest_of_line(w.line)?;
        if name.is_empty() || name == "{" {
            return Err(self.error(name_line, format!("`{}` without a name", w.text)));
        }
        h.joints.push(BvhJoint {
            name,
            parent,
            offset: Vector3::zeros(),
            channels: Vec::new(),
            first_channel: h.next_channel,
            end_site: None,
            line: w.line,
        });
        h.pending = Some((Some(h.joints.len() - 1), w.line));
        Ok(())
    }

    /// An `End Site` (word `w` is the `End`).
    fn end_site(&mut self, h: &mut Outline, w: Word<'a>) -> Result<(), BvhError> {
        let site = self.expect_word("`Site`")?;
        if !site.text.eq_ignore_ascii_case("site") {
            return Err(self.error(
                site.line,
                format!("found `End {}`, expected `End Site`", short(site.text)),
            ));
        }
        match h.stack.last() {
            Some(Some(_)) => h.pending = Some((None, w.line)),
            _ => return Err(self.error(w.line, "`End Site` outside a joint")),
        }
        Ok(())
    }

    /// An `OFFSET` (word `w`): the open joint's, or its End Site's.
    fn offset(&mut self, h: &mut Outline, w: Word<'a>) -> Result<(), BvhError> {
        let v = self.vector("OFFSET")?;
        match h.stack.last() {
            Some(Some(j)) => h.joints[*j].offset = v,
            Some(None) => {
                let parent = h.stack.iter().rev().find_map(|b| *b);
                if let Some(p) = parent {
                    h.joints[p].end_site = Some(v);
                }
            }
            None => return Err(self.error(w.line, "`OFFSET` outside a joint")),
        }
        Ok(())
    }

    /// A `CHANNELS` line (word `w`) of the open joint: the count, then the channel names.
    fn channels(&mut self, h: &mut Outline, w: Word<'a>) -> Result<(), BvhError> {
        let Some(Some(j)) = h.stack.last().copied() else {
            return Err(self.error(w.line, "`CHANNELS` outside a joint (End Sites have none)"));
        };
        let count_word = self.expect_word("the channel count")?;
        let count: usize = count_word
            .text
            .parse()
            .ok()
            .filter(|&n| n <= 6)
            .ok_or_else(|| {
                self.error(
                    count_word.line,
                    format!(
                        "found `{}`, expected a channel count from 0 to 6",
                        short(count_word.text)
                    ),
                )
            })?;
        if !h.joints[j].channels.is_empty() {
            return Err(self.error(
                w.line,
                format!("a second `CHANNELS` line for joint `{}`", h.joints[j].name),
            ));
        }
        let mut channels = Vec::with_capacity(count);
        for _ in 0..count {
            let c = self.expect_word("a channel name")?;
            let channel = Channel::parse(c.text).ok_or_else(|| {
                self.error(c.line, format!(
                    "found `{}`, expected a channel name (Xposition, Yposition, Zposition, Xrotation, Yrotation or Zrotation); the line declares {count} channels",
                    short(c.text)
                ))
            })?;
            if channels.contains(&channel) {
                return Err(self.error(c.line, format!("channel `{}` listed twice", c.text)));
            }
            channels.push(channel);
        }
        h.joints[j].first_channel = h.next_channel;
        h.next_channel += count;
        h.joints[j].channels = channels;
        Ok(())
    }

    /// The rest of line `line` (a joint's name, which may contain spaces), trimmed.
    fn rest_of_line(&mut self, line: usize) -> Result<String, BvhError> {
        let bytes = self.text.as_bytes();
        let start = self.pos;
        while self.pos < bytes.len() && bytes[self.pos] != b'\n' {
            self.pos += 1;
        }
        let name = self.text[start..self.pos].trim();
        // A `{` on the same line as the name belongs to the grammar, not to the name.
        if let Some(stripped) = name.strip_suffix('{') {
            // Give the `{` back: rewind to just before it.
            let brace = start + self.text[start..self.pos].rfind('{').unwrap_or(0);
            self.pos = brace;
            return Ok(stripped.trim().to_string());
        }
        let _ = line;
        Ok(name.to_string())
    }
}
