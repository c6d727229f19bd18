//! The BVH (Biovision Hierarchy) reader: a skeleton of joints with offsets and channels, then
//! one line of channel values per frame.
//!
//! ```text
//! HIERARCHY
//! ROOT Hips                      one or more joints, nested in braces
//! {
//!   OFFSET 0 0 0                 from the parent joint, in the parent's frame
//!   CHANNELS 6 Xposition Yposition Zposition Zrotation Yrotation Xrotation
//!   JOINT Spine { ... }
//!   End Site { OFFSET 0 10 0 }   a segment's far end, no channels
//! }
//! MOTION
//! Frames: 2
//! Frame Time: 0.0083333
//! 0 90 0 0 0 0 ...               one line per frame, one value per declared channel
//! ```
//!
//! Any channel order is read (CMU's ZYX, Xsens's ZXY, 6-channel joints). Rotations are in
//! degrees and compose in the order the channels are listed (`Zrotation Xrotation Yrotation`
//! gives `R = Rz · Rx · Ry`, the convention of every BVH writer). Position channels, where a
//! joint has them, replace its OFFSET as the translation from its parent (Blender's reading;
//! in files that give them on every joint their values equal the offsets).
//!
//! Every problem is a [`BvhError`] naming the file, the line and what was expected. Memory is
//! bounded by the file's size: a declared frame count is checked against the bytes that follow
//! before anything is allocated for it, and the hierarchy is read without recursion, with a
//! depth limit ([`MAX_DEPTH`]).

use std::path::Path;

use nalgebra::{Rotation3, Vector3};

/// Deepest nesting of joints accepted (real skeletons have fewer than 30 levels).
pub const MAX_DEPTH: usize = 1000;

/// Longest frame time accepted, seconds (a capture samples many times a second).
pub const MAX_FRAME_TIME_S: f64 = 10.0;

/// Most joints accepted in one hierarchy.
pub const MAX_JOINTS: usize = 10_000;

/// A problem with a BVH file: the file, the line (1-based; 0 when it concerns the file as a
/// whole) and what was expected.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum BvhError {
    /// The file could not be read.
    #[error("{file}: cannot read the BVH file: {source}")]
    Io {
        /// The file.
        file: String,
        /// The operating system's reason.
        #[source]
        source: std::io::Error,
    },
    /// The text does not follow the BVH grammar, or a value is out of range.
    #[error("{file}:{line}: {message}")]
    Syntax {
        /// The file.
        file: String,
        /// 1-based line.
        line: usize,
        /// What was found and what was expected.
        message: String,
    },
}

/// One kind of channel.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Channel {
    /// Translation along x.
    Xposition,
    /// Translation along y.
    Yposition,
    /// Translation along z.
    Zposition,
    /// Rotation about x, degrees.
    Xrotation,
    /// Rotation about y, degrees.
    Yrotation,
    /// Rotation about z, degrees.
    Zrotation,
}

impl Channel {
    fn parse(word: &str) -> Option<Channel> {
        Some(match word.to_ascii_lowercase().as_str() {
            "xposition" => Channel::Xposition,
            "yposition" => Channel::Yposition,
            "zposition" => Channel::Zposition,
            "xrotation" => Channel::Xrotation,
            "yrotation" => Channel::Yrotation,
            "zrotation" => Channel::Zrotation,
            _ => return None,
        })
    }

    /// The axis index 0, 1, 2 (x, y, z).
    pub fn axis(self) -> usize {
        match self {
            Channel::Xposition | Channel::Xrotation => 0,
            Channel::Yposition | Channel::Yrotation => 1,
            Channel::Zposition | Channel::Zrotation => 2,
        }
    }

    /// Whether this is a rotation channel.
    pub fn is_rotation(self) -> bool {
        matches!(
            self,
            Channel::Xrotation | Channel::Yrotation | Channel::Zrotation
        )
    }
}

/// One joint of the hierarchy.
#[derive(Debug, Clone, PartialEq)]
pub struct BvhJoint {
    /// Name as written (e.g. `LeftForeArm`, `mixamorig:LeftArm`).
    pub name: String,
    /// Index of the parent joint; `None` for the root.
    pub parent: Option<usize>,
    /// Offset from the parent joint in the parent's frame (file units).
    pub offset: Vector3<f64>,
    /// Channels in the order of the frame values.
    pub channels: Vec<Channel>,
    /// Index of this joint's first channel within a frame.
    pub first_channel: usize,
    /// Offset of the End Site, if the joint ends a chain.
    pub end_site: Option<Vector3<f64>>,
    /// Line of the joint's declaration.
    pub line: usize,
}

impl BvhJoint {
    /// The local transform of this joint in one frame (`values` = that frame's channels):
    /// translation from the parent (offset, or the position channels where present) and
    /// rotation (the rotation channels composed in order).
    pub fn local(&self, values: &[f64]) -> (Vector3<f64>, Rotation3<f64>) {
        let mut t = self.offset;
        let mut r = Rotation3::identity();
        for (k, &c) in self.channels.iter().enumerate() {
            let v = values[self.first_channel + k];
            if c.is_rotation() {
                r *= axis_rotation(c.axis(), v.to_radians());
            } else {
                t[c.axis()] = v;
            }
        }
        (t, r)
    }

    /// Whether the joint has position channels.
    pub fn has_position(&self) -> bool {
        self.channels.iter().any(|c| !c.is_rotation())
    }
}

/// Rotation by `angle` radians about axis 0, 1 or 2.
pub(crate) fn axis_rotation(axis: usize, angle: f64) -> Rotation3<f64> {
    let (s, c) = angle.sin_cos();
    let m = match axis {
        0 => nalgebra::Matrix3::new(1.0, 0.0, 0.0, 0.0, c, -s, 0.0, s, c),
        1 => nalgebra::Matrix3::new(c, 0.0, s, 0.0, 1.0, 0.0, -s, 0.0, c),
        _ => nalgebra::Matrix3::new(c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0),
    };
    Rotation3::from_matrix_unchecked(m)
}

/// A parsed BVH file.
#[derive(Debug, Clone, PartialEq)]
pub struct Bvh {
    /// The joints, parents before children (declaration order).
    pub joints: Vec<BvhJoint>,
    /// Seconds between frames.
    pub frame_time: f64,
    /// Channels per frame.
    pub channels: usize,
    /// Frame values, row-major: frame `f` is `values[f * channels..(f + 1) * channels]`.
    pub values: Vec<f64>,
}

impl Bvh {
    /// Reads and parses a BVH file.
    pub fn read(path: impl AsRef<Path>) -> Result<Bvh, BvhError> {
        let path = path.as_ref();
        let file = path.display().to_string();
        let bytes = std::fs::read(path).map_err(|source| BvhError::Io {
            file: file.clone(),
            source,
        })?;
        let text = String::from_utf8_lossy(&bytes);
        Bvh::parse(&text, &file)
    }

    /// Parses BVH text; `file` names it in errors.
    pub fn parse(text: &str, file: &str) -> Result<Bvh, BvhError> {
        Parser::new(text, file).parse()
    }

    /// Number of frames.
    pub fn frames(&self) -> usize {
        self.values.len().checked_div(self.channels).unwrap_or(0)
    }

    /// Channel values of frame `f`.
    pub fn frame(&self, f: usize) -> &[f64] {
        &self.values[f * self.channels..(f + 1) * self.channels]
    }

    /// Frames per second.
    pub fn frame_rate(&self) -> f64 {
        1.0 / self.frame_time
    }

    /// Index of the joint called `name` (exact match).
    pub fn joint(&self, name: &str) -> Option<usize> {
        self.joints.iter().position(|j| j.name == name)
    }

    /// Children of joint `j`, in declaration order.
    pub fn children(&self, j: usize) -> impl Iterator<Item = usize> + '_ {
        self.joints
            .iter()
            .enumerate()
            .filter(move |(_, c)| c.parent == Some(j))
            .map(|(i, _)| i)
    }

    /// Joints from `ancestor` (exclusive) down to `joint` (inclusive), top first; `None` if
    /// `ancestor` is not above `joint`.
    pub fn path(&self, ancestor: usize, joint: usize) -> Option<Vec<usize>> {
        let mut path = Vec::new();
        let mut cur = joint;
        while cur != ancestor {
            path.push(cur);
            cur = self.joints[cur].parent?;
        }
        path.reverse();
        Some(path)
    }

    /// Position of `joint` in the frame of `ancestor` with every channel at zero (the file's
    /// rest pose: offsets only).
    pub fn rest_position(&self, ancestor: usize, joint: usize) -> Option<Vector3<f64>> {
        Some(
            self.path(ancestor, joint)?
                .iter()
                .map(|&j| self.joints[j].offset)
                .sum(),
        )
    }
}

/// A whitespace-separated word and its line.
#[derive(Debug, Clone, Copy)]
struct Word<'a> {
    text: &'a str,
    line: usize,
}

struct Parser<'a> {
    file: &'a str,
    text: &'a str,
    /// Byte position of the next unread character.
    pos: usize,
    /// Line of `pos`.
    line: usize,
}

impl<'a> Parser<'a> {
    fn new(text: &'a str, file: &'a str) -> Self {
        Parser {
            file,
            text,
            pos: 0,
            line: 1,
        }
    }

    fn error(&self, line: usize, message: impl Into<String>) -> BvhError {
        BvhError::Syntax {
            file: self.file.to_string(),
            line,
            message: message.into(),
        }
    }

    /// The next word, or `None` at the end of the text.
    fn next_word(&mut self) -> Option<Word<'a>> {
        let bytes = self.text.as_bytes();
        while self.pos < bytes.len() && bytes[self.pos].is_ascii_whitespace() {
            if bytes[self.pos] == b'\n' {
                self.line += 1;
            }
            self.pos += 1;
        }
        if self.pos >= bytes.len() {
            return None;
        }
        let start = self.pos;
        while self.pos < bytes.len() && !bytes[self.pos].is_ascii_whitespace() {
            self.pos += 1;
        }
        Some(Word {
            text: &self.text[start..self.pos],
            line: self.line,
        })
    }

    /// The next word, which must exist; `expected` says what was wanted.
    fn expect_word(&mut self, expected: &str) -> Result<Word<'a>, BvhError> {
        let line = self.line;
        self.next_word()
            .ok_or_else(|| self.error(line, format!("the file ends where {expected} was expected")))
    }

    /// The next word, which must be `keyword` (case-insensitive).
    fn expect_keyword(&mut self, keyword: &str) -> Result<Word<'a>, BvhError> {
        let w = self.expect_word(&format!("`{keyword}`"))?;
        if w.text.eq_ignore_ascii_case(keyword) {
            Ok(w)
        } else {
            Err(self.error(
                w.line,
                format!("found `{}`, expected `{keyword}`", short(w.text)),
            ))
        }
    }

    fn number(&mut self, what: &str) -> Result<f64, BvhError> {
        let w = self.expect_word(what)?;
        parse_finite(w.text).ok_or_else(|| {
            self.error(
                w.line,
                format!(
                    "found `{}`, expected {what} (a finite number)",
                    short(w.text)
                ),
            )
        })
    }

    fn vector(&mut self, what: &str) -> Result<Vector3<f64>, BvhError> {
        Ok(Vector3::new(
            self.number(&format!("the x of {what}"))?,
            self.number(&format!("the y of {what}"))?,
            self.number(&format!("the z of {what}"))?,
        ))
    }

    fn parse(mut self) -> Result<Bvh, BvhError> {
        let first = self
            .next_word()
            .ok_or_else(|| self.error(1, "the file is empty; expected `HIERARCHY`"))?;
        if !first
            .text
            .trim_start_matches('\u{feff}')
            .eq_ignore_ascii_case("HIERARCHY")
        {
            let found = if is_text(first.text) {
                format!("`{}`", short(first.text))
            } else {
                "binary data".to_string()
            };
            return Err(self.error(
                first.line,
                format!("found {found}, expected `HIERARCHY` (is this a BVH file?)"),
            ));
        }
        let joints = self.hierarchy()?;
        let channels = joints.iter().map(|j| j.channels.len()).sum();
        let (frame_time, values) = self.motion(channels, &joints)?;
        Ok(Bvh {
            joints,
            frame_time,
            channels,
            values,
        })
    }

    /// Reads `ROOT ... { ... }` blocks up to `MOTION` (consumed). Iterative: a stack of open
    /// joints instead of recursion, so a deep file cannot overflow the stack.
    fn hierarchy(&mut self) -> Result<Vec<BvhJoint>, BvhError> {
        let mut joints: Vec<BvhJoint> = Vec::new();
        // Open blocks: Some(joint) for a joint, None for an End Site.
        let mut stack: Vec<Option<usize>> = Vec::new();
        let mut next_channel = 0usize;
        // A joint or End Site declared whose `{` has not been read yet.
        let mut pending: Option<(Option<usize>, usize)> = None;
        loop {
            let w = self.expect_word(
                "`ROOT`, `JOINT`, `End Site`, `OFFSET`, `CHANNELS`, `}` or `MOTION`",
            )?;
            let upper = w.text.to_ascii_uppercase();
            if let Some((block, line)) = pending {
                if w.text != "{" {
                    return Err(self.error(
                        w.line,
                        format!(
                            "found `{}`, expected `{{` to open the block declared on line {line}",
                            short(w.text)
                        ),
                    ));
                }
                if stack.len() >= MAX_DEPTH {
                    return Err(self.error(
                        w.line,
                        format!("joints nested deeper than {MAX_DEPTH} levels; a skeleton has a few dozen"),
                    ));
                }
                stack.push(block);
                pending = None;
                continue;
            }
            match upper.as_str() {
                "ROOT" | "JOINT" => {
                    let is_root = upper == "ROOT";
                    if is_root && !stack.is_empty() {
                        return Err(self.error(w.line, "`ROOT` inside another joint; expected `JOINT`"));
                    }
                    if !is_root && stack.is_empty() {
                        return Err(self.error(w.line, "`JOINT` outside any joint; expected `ROOT`"));
                    }
                    let parent = match stack.last() {
                        Some(Some(p)) => Some(*p),
                        Some(None) => {
                            return Err(self.error(w.line, "a joint inside an `End Site`; an End Site ends its chain"))
                        }
                        None => None,
                    };
                    if is_root && joints.iter().any(|j| j.parent.is_none()) {
                        return Err(self.error(
                            w.line,
                            "a second `ROOT`; sgplvm reads files with one skeleton",
                        ));
                    }
                    if joints.len() >= MAX_JOINTS {
                        return Err(self.error(w.line, format!("more than {MAX_JOINTS} joints")));
                    }
                    let name_line = self.line;
                    let name = self.rest_of_line(w.line)?;
                    if name.is_empty() || name == "{" {
                        return Err(self.error(name_line, format!("`{}` without a name", w.text)));
                    }
                    joints.push(BvhJoint {
                        name,
                        parent,
                        offset: Vector3::zeros(),
                        channels: Vec::new(),
                        first_channel: next_channel,
                        end_site: None,
                        line: w.line,
                    });
                    pending = Some((Some(joints.len() - 1), w.line));
                }
                "END" => {
                    let site = self.expect_word("`Site`")?;
                    if !site.text.eq_ignore_ascii_case("site") {
                        return Err(self.error(site.line, format!("found `End {}`, expected `End Site`", short(site.text))));
                    }
                    match stack.last() {
                        Some(Some(_)) => pending = Some((None, w.line)),
                        _ => return Err(self.error(w.line, "`End Site` outside a joint")),
                    }
                }
                "OFFSET" => {
                    let v = self.vector("OFFSET")?;
                    match stack.last() {
                        Some(Some(j)) => joints[*j].offset = v,
                        Some(None) => {
                            let parent = stack.iter().rev().find_map(|b| *b);
                            if let Some(p) = parent {
                                joints[p].end_site = Some(v);
                            }
                        }
                        None => return Err(self.error(w.line, "`OFFSET` outside a joint")),
                    }
                }
                "CHANNELS" => {
                    let Some(Some(j)) = stack.last().copied() else {
                        return Err(self.error(w.line, "`CHANNELS` outside a joint (End Sites have none)"));
                    };
                    let count_word = self.expect_word("the channel count")?;
                    let count: usize = count_word.text.parse().ok().filter(|&n| n <= 6).ok_or_else(|| {
                        self.error(count_word.line, format!("found `{}`, expected a channel count from 0 to 6", short(count_word.text)))
                    })?;
                    if !joints[j].channels.is_empty() {
                        return Err(self.error(w.line, format!("a second `CHANNELS` line for joint `{}`", joints[j].name)));
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
                    joints[j].first_channel = next_channel;
                    next_channel += count;
                    joints[j].channels = channels;
                }
                "}" => {
                    if stack.pop().is_none() {
                        return Err(self.error(w.line, "`}` without an open block"));
                    }
                }
                "MOTION" => {
                    if !stack.is_empty() {
                        return Err(self.error(w.line, format!("`MOTION` with {} block(s) still open; expected `}}`", stack.len())));
                    }
                    if joints.is_empty() {
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
        Ok(joints)
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

    /// Reads `Frames: N`, `Frame Time: T` and the N frame lines.
    fn motion(
        &mut self,
        channels: usize,
        joints: &[BvhJoint],
    ) -> Result<(f64, Vec<f64>), BvhError> {
        let w = self.expect_keyword("Frames:")?;
        let count_word = self.expect_word("the frame count")?;
        let declared: usize = count_word.text.parse().map_err(|_| {
            self.error(
                count_word.line,
                format!(
                    "found `{}`, expected the number of frames (a whole number)",
                    short(count_word.text)
                ),
            )
        })?;
        let _ = w;
        let frame = self.expect_keyword("Frame")?;
        let time_word = self.expect_word("`Time:`")?;
        if !time_word.text.eq_ignore_ascii_case("time:") {
            return Err(self.error(
                frame.line,
                format!(
                    "found `Frame {}`, expected `Frame Time:`",
                    short(time_word.text)
                ),
            ));
        }
        let t_line = self.line;
        let frame_time = self.number("the frame time in seconds")?;
        if frame_time <= 0.0 || frame_time > MAX_FRAME_TIME_S {
            return Err(self.error(t_line, format!("frame time {frame_time} s; expected a positive number of seconds up to {MAX_FRAME_TIME_S} (e.g. 0.008333 for 120 frames/s)")));
        }
        // The rest of the `Frame Time:` line must be empty.
        self.skip_to_line_end(t_line)?;
        let remaining = self.text.len() - self.pos;
        // Each value takes at least two bytes (a digit and a separator): a declared count the
        // bytes cannot hold is refused before anything is allocated for it.
        let needed = declared.saturating_mul(channels.max(1)).saturating_mul(2);
        if needed > remaining + 1 {
            let lines = self.text[self.pos..]
                .lines()
                .filter(|l| !l.trim().is_empty())
                .count();
            return Err(self.error(
                count_word.line,
                format!(
                    "`Frames: {declared}` declares {declared} frames of {channels} channels, but the file has {lines} frame line(s) after `Frame Time:` (truncated MOTION block?)"
                ),
            ));
        }
        let mut values = Vec::with_capacity(declared * channels);
        let mut frames = 0usize;
        let bytes = self.text.as_bytes();
        while self.pos < bytes.len() {
            let start = self.pos;
            while self.pos < bytes.len() && bytes[self.pos] != b'\n' {
                self.pos += 1;
            }
            let line_no = self.line;
            let line = &self.text[start..self.pos];
            if self.pos < bytes.len() {
                self.pos += 1;
                self.line += 1;
            }
            if line.trim().is_empty() {
                continue;
            }
            if frames == declared {
                return Err(self.error(
                    line_no,
                    format!("more frame lines than the {declared} that `Frames:` declares (line {} declares them)", count_word.line),
                ));
            }
            let before = values.len();
            for (k, word) in line.split_ascii_whitespace().enumerate() {
                if k >= channels {
                    let found = line.split_ascii_whitespace().count();
                    return Err(self.error(line_no, format!("frame {} has {found} values, expected {channels} (the channels the hierarchy declares)", frames + 1)));
                }
                let v = parse_finite(word).ok_or_else(|| {
                    self.error(
                        line_no,
                        format!(
                            "frame {}, value {} ({}): found `{}`, expected a finite number",
                            frames + 1,
                            k + 1,
                            channel_owner(joints, k),
                            short(word)
                        ),
                    )
                })?;
                values.push(v);
            }
            let found = values.len() - before;
            if found != channels {
                return Err(self.error(line_no, format!("frame {} has {found} values, expected {channels} (the channels the hierarchy declares)", frames + 1)));
            }
            frames += 1;
        }
        if frames != declared {
            return Err(self.error(
                self.line,
                format!("the file ends after {frames} frame lines, but `Frames:` on line {} declares {declared} (truncated MOTION block?)", count_word.line),
            ));
        }
        if channels == 0 && declared > 0 {
            return Err(self.error(count_word.line, "frames declared but no joint has channels"));
        }
        Ok((frame_time, values))
    }

    /// Consumes the rest of line `line`, which must hold nothing but whitespace.
    fn skip_to_line_end(&mut self, line: usize) -> Result<(), BvhError> {
        let bytes = self.text.as_bytes();
        let start = self.pos;
        while self.pos < bytes.len() && bytes[self.pos] != b'\n' {
            self.pos += 1;
        }
        let rest = self.text[start..self.pos].trim();
        if !rest.is_empty() {
            return Err(self.error(
                line,
                format!(
                    "unexpected `{}` after the frame time; frames start on the next line",
                    short(rest)
                ),
            ));
        }
        if self.pos < bytes.len() {
            self.pos += 1;
            self.line += 1;
        }
        Ok(())
    }
}

/// `word` as a finite number.
fn parse_finite(word: &str) -> Option<f64> {
    word.parse::<f64>().ok().filter(|v| v.is_finite())
}

/// `joint`'s channel name for value `k` of a frame, for messages.
fn channel_owner(joints: &[BvhJoint], k: usize) -> String {
    joints
        .iter()
        .find(|j| k >= j.first_channel && k < j.first_channel + j.channels.len())
        .map(|j| format!("{} {:?}", j.name, j.channels[k - j.first_channel]))
        .unwrap_or_else(|| "no channel".into())
}

/// At most 40 characters of `s`, for messages.
fn short(s: &str) -> String {
    // Control characters and undecodable bytes would garble a one-line message: escaped.
    let shown: String = s
        .chars()
        .take(40)
        .flat_map(|c| {
            let escape = c.is_control() || c == char::REPLACEMENT_CHARACTER;
            let text: String = if escape {
                c.escape_unicode().collect()
            } else {
                c.to_string()
            };
            text.chars().collect::<Vec<_>>()
        })
        .collect();
    if s.chars().count() <= 40 {
        shown
    } else {
        format!("{shown}…")
    }
}

/// Whether `s` reads as text: no control characters and no undecodable bytes.
fn is_text(s: &str) -> bool {
    !s.chars()
        .any(|c| c.is_control() || c == char::REPLACEMENT_CHARACTER)
}

#[cfg(test)]
mod tests {
    use super::*;

    pub(crate) const TWO_FRAMES: &str = "HIERARCHY
ROOT Hips
{
  OFFSET 0 0 0
  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
  JOINT Spine
  {
    OFFSET 0 10 0
    CHANNELS 3 Zrotation Yrotation Xrotation
    End Site
    {
      OFFSET 0 5 0
    }
  }
}
MOTION
Frames: 2
Frame Time: 0.0083333
1 2 3 0 0 0 90 0 0
1 2 3 0 0 0 0 90 0
";

    fn err(text: &str) -> String {
        Bvh::parse(text, "t.bvh").unwrap_err().to_string()
    }

    #[test]
    fn reads_hierarchy_channels_and_frames() {
        let b = Bvh::parse(TWO_FRAMES, "t.bvh").unwrap();
        assert_eq!(b.joints.len(), 2);
        assert_eq!(b.channels, 9);
        assert_eq!(b.frames(), 2);
        assert_eq!(b.joints[1].parent, Some(0));
        assert_eq!(b.joints[1].first_channel, 6);
        assert_eq!(b.joints[1].end_site, Some(Vector3::new(0.0, 5.0, 0.0)));
        assert!((b.frame_rate() - 120.0).abs() < 1e-2);
        // Spine: Zrotation 90 then the End Site (0, 5, 0) points along -x.
        let (t, r) = b.joints[1].local(b.frame(0));
        assert_eq!(t, Vector3::new(0.0, 10.0, 0.0));
        let tip = r * Vector3::new(0.0, 5.0, 0.0);
        assert!((tip - Vector3::new(-5.0, 0.0, 0.0)).norm() < 1e-12);
        // Root: position channels replace the offset.
        let (t0, _) = b.joints[0].local(b.frame(0));
        assert_eq!(t0, Vector3::new(1.0, 2.0, 3.0));
    }

    #[test]
    fn channel_order_composes_left_to_right() {
        // Zrotation Xrotation Yrotation 30 40 50 is Rz(30) Rx(40) Ry(50).
        let j = BvhJoint {
            name: "j".into(),
            parent: None,
            offset: Vector3::zeros(),
            channels: vec![Channel::Zrotation, Channel::Xrotation, Channel::Yrotation],
            first_channel: 0,
            end_site: None,
            line: 1,
        };
        let (_, r) = j.local(&[30.0, 40.0, 50.0]);
        let expect = Rotation3::from_axis_angle(&Vector3::z_axis(), 30f64.to_radians())
            * Rotation3::from_axis_angle(&Vector3::x_axis(), 40f64.to_radians())
            * Rotation3::from_axis_angle(&Vector3::y_axis(), 50f64.to_radians());
        assert!((r.matrix() - expect.matrix()).norm() < 1e-12);
    }

    #[test]
    fn rejects_broken_files_with_the_line() {
        let wrong_count = TWO_FRAMES.replace("1 2 3 0 0 0 0 90 0", "1 2 3 0 0 0 0 90");
        assert!(
            err(&wrong_count).contains("t.bvh:20: frame 2 has 8 values, expected 9"),
            "{}",
            err(&wrong_count)
        );
        let truncated = TWO_FRAMES.replace("1 2 3 0 0 0 0 90 0\n", "");
        assert!(err(&truncated).contains("truncated"), "{}", err(&truncated));
        let nan = TWO_FRAMES.replace("0 0 0 90 0 0", "0 0 0 NaN 0 0");
        assert!(
            err(&nan).contains("t.bvh:19: frame 1, value 7 (Spine Zrotation): found `NaN`"),
            "{}",
            err(&nan)
        );
        let text = TWO_FRAMES.replace("0 0 0 90 0 0", "0 0 0 ninety 0 0");
        assert!(err(&text).contains("`ninety`"));
        let too_many = TWO_FRAMES.replace("Frames: 2", "Frames: 1");
        assert!(
            err(&too_many).contains("more frame lines than the 1"),
            "{}",
            err(&too_many)
        );
        let huge = TWO_FRAMES.replace("Frames: 2", "Frames: 100000000");
        assert!(
            err(&huge).contains("declares 100000000 frames"),
            "{}",
            err(&huge)
        );
        let zero = TWO_FRAMES.replace("0.0083333", "0");
        assert!(
            err(&zero).contains("t.bvh:18: frame time 0 s"),
            "{}",
            err(&zero)
        );
        let bad_channel = TWO_FRAMES.replace(
            "Zrotation Yrotation Xrotation",
            "Zrotation Yrotation Wrotation",
        );
        assert!(
            err(&bad_channel).contains("t.bvh:9: found `Wrotation`"),
            "{}",
            err(&bad_channel)
        );
        let short_channels = TWO_FRAMES.replace(
            "CHANNELS 3 Zrotation Yrotation Xrotation",
            "CHANNELS 3 Zrotation Yrotation",
        );
        assert!(
            err(&short_channels).contains("t.bvh:10:"),
            "{}",
            err(&short_channels)
        );
        assert!(err("").contains("empty"));
        assert!(err("hello").contains("expected `HIERARCHY`"));
        // A binary file (an MCAP given by mistake): said, not printed.
        let binary = String::from_utf8_lossy(b"\x89MCAP0\r\n\x01\xff\x00").into_owned();
        assert_eq!(
            err(&binary),
            "t.bvh:1: found binary data, expected `HIERARCHY` (is this a BVH file?)"
        );
        assert_eq!(short("a\u{1}b"), "a\\u{1}b");
        let unclosed = TWO_FRAMES.replace("  }\n}\nMOTION", "  }\nMOTION");
        assert!(err(&unclosed).contains("still open"), "{}", err(&unclosed));
    }

    #[test]
    fn deep_hierarchies_are_refused_without_recursion() {
        let mut text = String::from(
            "HIERARCHY\nROOT r\n{\nOFFSET 0 0 0\nCHANNELS 3 Zrotation Xrotation Yrotation\n",
        );
        for i in 0..10_000 {
            text.push_str(&format!("JOINT j{i}\n{{\nOFFSET 0 1 0\n"));
        }
        let e = err(&text);
        assert!(e.contains("nested deeper than 1000"), "{e}");
    }

    #[test]
    fn names_with_spaces_and_braces_on_the_same_line() {
        let text = TWO_FRAMES.replace("JOINT Spine\n  {", "JOINT Upper Spine {");
        let b = Bvh::parse(&text, "t.bvh").unwrap();
        assert_eq!(b.joints[1].name, "Upper Spine");
    }
}
