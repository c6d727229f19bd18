//! The reader's lexer and outline: whitespace-separated words with their lines, numbers and
//! vectors, keywords, errors that name the line, and the file's two sections in order
//! (`HIERARCHY`, then `MOTION`).

use nalgebra::Vector3;

use super::{Bvh, BvhError, BvhJoint};

/// A whitespace-separated word and its line.
#[derive(Debug, Clone, Copy)]
pub(super) struct Word<'a> {
    pub(super) text: &'a str,
    pub(super) line: usize,
}

/// The reader's position in the text.
pub(super) struct Parser<'a> {
    file: &'a str,
    pub(super) text: &'a str,
    /// Byte position of the next unread character.
    pub(super) pos: usize,
    /// Line of `pos`.
    pub(super) line: usize,
}

impl<'a> Parser<'a> {
    pub(super) fn new(text: &'a str, file: &'a str) -> Self {
        Parser {
            file,
            text,
            pos: 0,
            line: 1,
        }
    }

    pub(super) fn error(&self, line: usize, message: impl Into<String>) -> BvhError {
        BvhError::Syntax {
            file: self.file.to_string(),
            line,
            message: message.into(),
        }
    }

    /// The next word, or `None` at the end of the text.
    pub(super) fn next_word(&mut self) -> Option<Word<'a>> {
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
    pub(super) fn expect_word(&mut self, expected: &str) -> Result<Word<'a>, BvhError> {
        let line = self.line;
        self.next_word()
            .ok_or_else(|| self.error(line, format!("the file ends where {expected} was expected")))
    }

    /// The next word, which must be `keyword` (case-insensitive).
    pub(super) fn expect_keyword(&mut self, keyword: &str) -> Result<Word<'a>, BvhError> {
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

    pub(super) fn number(&mut self, what: &str) -> Result<f64, BvhError> {
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

    pub(super) fn vector(&mut self, what: &str) -> Result<Vector3<f64>, BvhError> {
        Ok(Vector3::new(
            self.number(&format!("the x of {what}"))?,
            self.number(&format!("the y of {what}"))?,
            self.number(&format!("the z of {what}"))?,
        ))
    }

    pub(super) fn parse(mut self) -> Result<Bvh, BvhError> {
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
        let (frame_time, values, frame_lines_left_out) = self.motion(channels, &joints)?;
        Ok(Bvh {
            joints,
            frame_time,
            channels,
            values,
            frame_lines_left_out,
        })
    }
}

/// `word` as a finite number.
pub(super) fn parse_finite(word: &str) -> Option<f64> {
    word.parse::<f64>().ok().filter(|v| v.is_finite())
}

/// `joint`'s channel name for value `k` of a frame, for messages.
pub(super) fn channel_owner(joints: &[BvhJoint], k: usize) -> String {
    joints
        .iter()
        .find(|j| k >= j.first_channel && k < j.first_channel + j.channels.len())
        .map(|j| format!("{} {:?}", j.name, j.channels[k - j.first_channel]))
        .unwrap_or_else(|| "no channel".into())
}

/// At most 40 characters of `s`, for messages.
pub(super) fn short(s: &str) -> String {
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
pub(super) fn is_text(s: &str) -> bool {
    !s.chars()
        .any(|c| c.is_control() || c == char::REPLACEMENT_CHARACTER)
}
