//! Joint frames as CSV: a header of joint names, then one frame per line. An optional first
//! column named `time` (seconds) or `time_ns` is carried through. Lines starting with `#` are
//! comments, skipped wherever they are: `sgplvm predict` no longer writes any (its CSV starts
//! with the header, for readers without options; what the commands are goes in the sidecar
//! `OUT.json`), but files from earlier versions began with one and still read.

use std::io::BufRead;

/// A CSV file of joint frames that could not be read.
#[derive(Debug, thiserror::Error)]
pub enum CsvError {
    /// The header line is missing.
    #[error("{source_name}: empty input, expected a header line of joint names")]
    MissingHeader {
        /// File name (or `stdin`).
        source_name: String,
    },
    /// A line has a value that is not a finite number, or the wrong number of values.
    #[error("{source_name}: line {line}: {message}")]
    BadLine {
        /// File name (or `stdin`).
        source_name: String,
        /// 1-based line number.
        line: usize,
        /// What was wrong.
        message: String,
    },
    /// The header is followed by no data line.
    #[error("{source_name}: a header but no frames, expected at least one line of values")]
    NoFrames {
        /// File name (or `stdin`).
        source_name: String,
    },
    /// Reading failed.
    #[error("{source_name}: {source}")]
    Io {
        /// File name (or `stdin`).
        source_name: String,
        /// The I/O error.
        #[source]
        source: std::io::Error,
    },
}

/// The parsed header: joint names, and whether the first column is a time column.
#[derive(Debug, Clone, PartialEq)]
pub struct CsvHeader {
    /// Name of a leading time column (`time` or `time_ns`), if any.
    pub time_column: Option<String>,
    /// Joint names, in column order.
    pub joints: Vec<String>,
}

impl CsvHeader {
    /// Parses a header line (a UTF-8 byte-order mark before it is ignored).
    pub fn parse(line: &str) -> CsvHeader {
        let mut names: Vec<String> = line
            .trim_start_matches('\u{feff}')
            .trim()
            .split(',')
            .map(|s| s.trim().to_string())
            .collect();
        let time_column = match names.first().map(String::as_str) {
            Some("time") | Some("time_ns") | Some("t") => Some(names.remove(0)),
            _ => None,
        };
        CsvHeader {
            time_column,
            joints: names,
        }
    }

    /// Parses one data line (1-based `line_number` for messages) into an optional time and the
    /// joint values.
    pub fn parse_line(
        &self,
        text: &str,
        line_number: usize,
        source_name: &str,
    ) -> Result<(Option<f64>, Vec<f64>), CsvError> {
        let bad = |message: String| CsvError::BadLine {
            source_name: source_name.to_string(),
            line: line_number,
            message,
        };
        let mut values = Vec::with_capacity(self.joints.len() + 1);
        for (i, field) in text.trim().split(',').enumerate() {
            let v: f64 = field.trim().parse().map_err(|_| {
                bad(format!(
                    "column {} is {:?}, expected a number",
                    i + 1,
                    field.trim()
                ))
            })?;
            if !v.is_finite() {
                return Err(bad(format!(
                    "column {} is {v}, expected a finite number",
                    i + 1
                )));
            }
            values.push(v);
        }
        let expected = self.joints.len() + usize::from(self.time_column.is_some());
        if values.len() != expected {
            return Err(bad(format!(
                "{} values, expected {expected} (one per header column)",
                values.len()
            )));
        }
        let time = self.time_column.as_ref().map(|_| values.remove(0));
        if let (Some(t), Some(column)) = (time, self.time_column.as_deref()) {
            // Times become i64 nanoseconds (MCAP log time): refuse what would saturate.
            let ns = if column == "time_ns" { t } else { t * 1e9 };
            if ns.abs() >= i64::MAX as f64 {
                return Err(bad(format!(
                    "{column} is {t:e}, beyond what nanosecond timestamps hold (±9.2e18 ns)"
                )));
            }
        }
        Ok((time, values))
    }
}

/// A whole CSV table of frames.
#[derive(Debug, Clone, PartialEq)]
pub struct CsvFrames {
    /// The header.
    pub header: CsvHeader,
    /// Times of the frames, when the file has a time column.
    pub times: Option<Vec<f64>>,
    /// Row-major values, `rows × header.joints.len()`.
    pub values: Vec<f64>,
    /// Number of frames.
    pub rows: usize,
}

impl CsvFrames {
    /// Frame times in nanoseconds: a `time_ns` column as it is, any other time column read as
    /// seconds, and without a time column frames 25 ms apart (40 Hz) from 0.
    pub fn times_ns(&self) -> Vec<i64> {
        match (&self.times, self.header.time_column.as_deref()) {
            (Some(t), Some("time_ns")) => t.iter().map(|&v| v as i64).collect(),
            (Some(t), _) => t.iter().map(|&v| (v * 1e9).round() as i64).collect(),
            (None, _) => (0..self.rows as i64).map(|i| i * 25_000_000).collect(),
        }
    }

    /// Frame times in seconds, by the rules of [`times_ns`](Self::times_ns).
    pub fn times_seconds(&self) -> Vec<f64> {
        match (&self.times, self.header.time_column.as_deref()) {
            (Some(t), Some("time_ns")) => t.iter().map(|v| v * 1e-9).collect(),
            (Some(t), _) => t.clone(),
            (None, _) => (0..self.rows).map(|i| i as f64 / 40.0).collect(),
        }
    }

    /// These frames without the `<joint>_std` columns that `sgplvm predict --std` writes beside
    /// each `<joint>` (a column named `x_std` with no column `x` is kept: it may be a joint).
    pub fn without_std_columns(self) -> CsvFrames {
        let joints = &self.header.joints;
        let keep: Vec<bool> = joints
            .iter()
            .map(|j| {
                j.strip_suffix(STD_SUFFIX)
                    .is_none_or(|base| !joints.iter().any(|other| other == base))
            })
            .collect();
        if keep.iter().all(|&k| k) {
            return self;
        }
        let d = joints.len();
        let values = self
            .values
            .chunks(d.max(1))
            .flat_map(|row| row.iter().zip(&keep).filter(|(_, &k)| k).map(|(&v, _)| v))
            .collect();
        let kept = joints
            .iter()
            .zip(&keep)
            .filter(|(_, &k)| k)
            .map(|(j, _)| j.clone())
            .collect();
        CsvFrames {
            header: CsvHeader {
                joints: kept,
                ..self.header
            },
            values,
            ..self
        }
    }
}

/// The suffix of the standard-deviation columns `sgplvm predict --std` writes.
pub const STD_SUFFIX: &str = "_std";

/// Reads lines up to the first one neither blank nor a `#` comment and parses it as the header; returns it with its
/// 1-based line number (data lines are numbered on from it in messages).
pub fn read_header(
    lines: &mut impl Iterator<Item = std::io::Result<String>>,
    source_name: &str,
) -> Result<(CsvHeader, usize), CsvError> {
    for (i, line) in lines.enumerate() {
        let line = line.map_err(|source| CsvError::Io {
            source_name: source_name.to_string(),
            source,
        })?;
        if !line.trim().is_empty() && !line.starts_with('#') {
            return Ok((CsvHeader::parse(&line), i + 1));
        }
    }
    Err(CsvError::MissingHeader {
        source_name: source_name.to_string(),
    })
}

/// Reads a whole CSV table of frames from `reader`.
pub fn read_frames(reader: impl BufRead, source_name: &str) -> Result<CsvFrames, CsvError> {
    let io = |source| CsvError::Io {
        source_name: source_name.to_string(),
        source,
    };
    let mut lines = reader.lines();
    let (header, header_line) = read_header(&mut lines, source_name)?;
    let mut times = header.time_column.as_ref().map(|_| Vec::new());
    let mut values = Vec::new();
    let mut rows = 0;
    for (i, line) in lines.enumerate() {
        let line = line.map_err(io)?;
        if line.trim().is_empty() || line.starts_with('#') {
            continue;
        }
        let (time, row) = header.parse_line(&line, header_line + i + 1, source_name)?;
        if let (Some(times), Some(t)) = (times.as_mut(), time) {
            times.push(t);
        }
        values.extend(row);
        rows += 1;
    }
    if rows == 0 {
        return Err(CsvError::NoFrames {
            source_name: source_name.to_string(),
        });
    }
    Ok(CsvFrames {
        header,
        times,
        values,
        rows,
    })
}

/// Formats one output line: optional time, then the values, full precision.
pub fn format_line(time: Option<f64>, values: &[f64]) -> String {
    let mut out = String::with_capacity(values.len() * 12);
    if let Some(t) = time {
        out.push_str(&format!("{t}"));
    }
    for (i, v) in values.iter().enumerate() {
        if i > 0 || time.is_some() {
            out.push(',');
        }
        out.push_str(&format!("{v}"));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn std_columns_beside_their_joint_are_dropped() {
        let text = "time,a,b,a_std,b_std,c_std\n0.0,1,2,0.1,0.2,3\n0.1,4,5,0.4,0.5,6\n";
        let frames = read_frames(text.as_bytes(), "x.csv")
            .unwrap()
            .without_std_columns();
        // c_std has no column c: it is a joint of its own.
        assert_eq!(frames.header.joints, vec!["a", "b", "c_std"]);
        assert_eq!(frames.values, vec![1.0, 2.0, 3.0, 4.0, 5.0, 6.0]);
        assert_eq!(frames.rows, 2);
        assert_eq!(frames.times, Some(vec![0.0, 0.1]));
        let plain = read_frames("a,b\n1,2\n".as_bytes(), "y.csv").unwrap();
        assert_eq!(plain.without_std_columns().header.joints, vec!["a", "b"]);
    }

    #[test]
    fn reads_header_time_and_values() {
        let text = "time,a,b\n0.0,1.5,-2\n\n0.025,1e-3,4\n";
        let frames = read_frames(text.as_bytes(), "x.csv").unwrap();
        assert_eq!(frames.header.joints, vec!["a", "b"]);
        assert_eq!(frames.times, Some(vec![0.0, 0.025]));
        assert_eq!(frames.values, vec![1.5, -2.0, 1e-3, 4.0]);
        assert_eq!(frames.rows, 2);
    }

    #[test]
    fn files_with_the_comment_line_earlier_predicts_wrote_still_read() {
        let old = "# coman commands: raw model output\ntime,a\n0,1\n# later\n0.025,2\n";
        let new = "time,a\n0,1\n0.025,2\n";
        let (old, new) = (
            read_frames(old.as_bytes(), "old.csv").unwrap(),
            read_frames(new.as_bytes(), "new.csv").unwrap(),
        );
        assert_eq!(old, new);
        assert_eq!(old.values, vec![1.0, 2.0]);
    }

    /// Hostile but plausible files (issue 13): a byte-order mark, blank lines before the
    /// header, a time that would saturate, a header without frames.
    #[test]
    fn bom_blank_lines_huge_times_and_empty_tables() {
        let t = read_frames("\u{feff}time,a\n0.5,1\n".as_bytes(), "bom.csv").expect("bom");
        assert_eq!(t.header.time_column.as_deref(), Some("time"));
        assert_eq!(t.times_ns(), vec![500_000_000]);
        let e = read_frames("\n\ntime,a\n\n0,1\nx,2\n".as_bytes(), "f.csv").expect_err("bad");
        assert_eq!(
            e.to_string(),
            "f.csv: line 6: column 1 is \"x\", expected a number"
        );
        let e = read_frames("time,a\n1e308,1\n".as_bytes(), "f.csv").expect_err("huge");
        assert!(
            e.to_string()
                .starts_with("f.csv: line 2: time is 1e308, beyond"),
            "{e}"
        );
        let e = read_frames("time_ns,a\n1e19,1\n".as_bytes(), "f.csv").expect_err("huge");
        assert!(e.to_string().contains("time_ns is 1e19"), "{e}");
        assert!(read_frames("time_ns,a\n9e18,1\n".as_bytes(), "f.csv").is_ok());
        let e = read_frames("a,b\n\n".as_bytes(), "h.csv").expect_err("no frames");
        assert!(matches!(e, CsvError::NoFrames { .. }), "{e}");
    }

    #[test]
    fn bad_lines_name_the_line_and_column() {
        let err = read_frames("a,b\n1,2\n1,x\n".as_bytes(), "in.csv").unwrap_err();
        assert_eq!(
            err.to_string(),
            "in.csv: line 3: column 2 is \"x\", expected a number"
        );
        let err = read_frames("a,b\n1,2,3\n".as_bytes(), "in.csv").unwrap_err();
        assert!(err.to_string().contains("3 values, expected 2"));
        let err = read_frames("a,b\n1,NaN\n".as_bytes(), "in.csv").unwrap_err();
        assert!(err.to_string().contains("finite"));
        assert!(matches!(
            read_frames("".as_bytes(), "e.csv"),
            Err(CsvError::MissingHeader { .. })
        ));
    }

    #[test]
    fn times_follow_the_time_column() {
        let seconds = read_frames("time,a\n0.5,1\n0.75,2\n".as_bytes(), "s.csv").unwrap();
        assert_eq!(seconds.times_ns(), vec![500_000_000, 750_000_000]);
        assert_eq!(seconds.times_seconds(), vec![0.5, 0.75]);
        let ns = read_frames("time_ns,a\n1000,1\n".as_bytes(), "n.csv").unwrap();
        assert_eq!(ns.times_ns(), vec![1000]);
        assert_eq!(ns.times_seconds(), vec![1000.0 * 1e-9]);
        let none = read_frames("a\n1\n2\n".as_bytes(), "x.csv").unwrap();
        assert_eq!(none.times_ns(), vec![0, 25_000_000]);
        assert_eq!(none.times_seconds(), vec![0.0, 0.025]);
    }

    #[test]
    fn lines_round_trip() {
        let header = CsvHeader::parse("a,b");
        let line = format_line(None, &[0.1, -1.0 / 3.0]);
        let (_, back) = header.parse_line(&line, 1, "x").unwrap();
        assert_eq!(back, vec![0.1, -1.0 / 3.0]);
    }
}
