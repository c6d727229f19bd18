//! The `MOTION` section: `Frames: N`, `Frame Time: T`, then N lines of one value per declared
//! channel; a declared count is checked against the bytes that follow before anything is
//! allocated for it.

use super::parser::{channel_owner, parse_finite, short, Parser};
use super::{BvhError, BvhJoint, MAX_FRAME_TIME_S};

impl Parser<'_> {
    /// Reads `Frames: N`, `Frame Time: T` and the N frame lines; returns the frame time, the
    /// values and how many lines after the N were left out (not read: the count rules).
    pub(super) fn motion(
        &mut self,
        channels: usize,
        joints: &[BvhJoint],
    ) -> Result<(f64, Vec<f64>, usize), BvhError> {
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
        let mut left_out = 0usize;
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
                // More lines than declared: the count rules, as Blender reads a file; the rest
                // is counted and said (assimp reads them all).
                let rest = 1 + self.text[self.pos..]
                    .lines()
                    .filter(|l| !l.trim().is_empty())
                    .count();
                self.pos = self.text.len();
                left_out = rest;
                break;
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
        Ok((frame_time, values, left_out))
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
