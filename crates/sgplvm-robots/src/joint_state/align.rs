//! Alignment of topics onto a common clock: each series is interpolated linearly at the
//! instants `start + k / rate` covering the span every series has data for (from the latest
//! first timestamp to the earliest last one). At an instant equal to a sample, the sample's
//! values are returned exactly.

use std::path::{Path, PathBuf};

use super::error::{ALIGN_MIN_VALUES, ALIGN_VALUES_PER_VALUE_READ};
use super::{read_topics, JointStateError, JointStates, Result, TopicRequest};

impl JointStates {
    /// Linear interpolation of every joint at `times_ns` (which must lie within this series'
    /// time span; rows must be sorted by time). At a time equal to a sample, the sample's values
    /// are returned exactly.
    pub fn resample(&self, times_ns: &[i64]) -> Result<JointStates> {
        let d = self.dof();
        let bad = |detail: String| JointStateError::InvalidInput {
            what: "resample".into(),
            detail,
        };
        let (Some(&first), Some(&last)) = (self.times_ns.first(), self.times_ns.last()) else {
            return Err(bad("cannot resample an empty series".into()));
        };
        let mut out = Vec::with_capacity(times_ns.len() * d);
        let mut k = 0usize; // index of the left sample
        for &t in times_ns {
            if t < first || t > last {
                return Err(bad(format!(
                    "time {t} ns outside the series' span {first}..={last} ns"
                )));
            }
            if k > 0 && self.times_ns[k] > t {
                k = 0; // times not increasing: restart the search
            }
            while k + 1 < self.len() && self.times_ns[k + 1] <= t {
                k += 1;
            }
            let t0 = self.times_ns[k];
            if t == t0 || k + 1 == self.len() {
                out.extend_from_slice(self.row(k));
            } else {
                let t1 = self.times_ns[k + 1];
                let w = (t - t0) as f64 / (t1 - t0) as f64;
                let (a, b) = (self.row(k), self.row(k + 1));
                out.extend(a.iter().zip(b).map(|(x, y)| x + w * (y - x)));
            }
        }
        Ok(JointStates {
            times_ns: times_ns.to_vec(),
            names: self.names.clone(),
            positions: out,
        })
    }
}

/// Reads `requests` from `path` and aligns them onto one clock: from the latest first
/// timestamp to the earliest last one, every `1/rate_hz` s, by linear interpolation.
pub fn read_aligned(
    path: impl AsRef<Path>,
    requests: &[TopicRequest],
    rate_hz: f64,
) -> Result<Vec<JointStates>> {
    let path = path.as_ref();
    let read = read_topics(path, requests)?;
    align_onto_clock(&read.states, rate_hz).map_err(|e| e.in_file(path, None))
}

/// Aligns series onto one clock at `rate_hz` covering their common time span (see
/// [`read_aligned`]). All returned series share the same `times_ns`.
///
/// The clock is refused ([`JointStateError::TooManyFrames`]) when the aligned series would
/// hold more than [`ALIGN_VALUES_PER_VALUE_READ`] values per value read, or
/// [`ALIGN_MIN_VALUES`] if that is larger: two messages a day apart must not become millions
/// of interpolated frames.
pub fn align_onto_clock(series: &[JointStates], rate_hz: f64) -> Result<Vec<JointStates>> {
    if !(rate_hz.is_finite() && rate_hz > 0.0) {
        return Err(JointStateError::InvalidInput {
            what: "rate_hz".into(),
            detail: format!("expected a positive finite rate, got {rate_hz}"),
        });
    }
    if series.is_empty() {
        return Ok(Vec::new());
    }
    let mut start = i64::MIN;
    let mut end = i64::MAX;
    for s in series {
        let (Some(&a), Some(&b)) = (s.times_ns.first(), s.times_ns.last()) else {
            return Err(JointStateError::InvalidInput {
                what: "align".into(),
                detail: "a series is empty".into(),
            });
        };
        start = start.max(a);
        end = end.min(b);
    }
    if end < start {
        return Err(JointStateError::NoOverlap {
            path: PathBuf::new(),
            topics: format!("{} series", series.len()),
            start_ns: start,
            end_ns: end,
        });
    }
    let period = 1e9 / rate_hz;
    // In i128: the span of two i64 timestamps may exceed i64.
    let span_ns = (i128::from(end) - i128::from(start)) as f64;
    let frames = (span_ns / period).floor() + 1.0;
    let values_per_frame: usize = series.iter().map(JointStates::dof).sum();
    let values_read: u64 = series.iter().map(|s| s.positions.len() as u64).sum();
    let limit = values_read
        .saturating_mul(ALIGN_VALUES_PER_VALUE_READ)
        .max(ALIGN_MIN_VALUES);
    if frames * values_per_frame.max(1) as f64 > limit as f64 {
        return Err(JointStateError::TooManyFrames {
            path: PathBuf::new(),
            topics: format!("{} series", series.len()),
            rate_hz,
            span_s: span_ns / 1e9,
            frames: frames as u64,
            values_per_frame,
            limit,
        });
    }
    let count = frames as usize;
    let clock: Vec<i64> = (0..count)
        .map(|k| start + (k as f64 * period).round() as i64)
        .filter(|&t| t <= end)
        .collect();
    series.iter().map(|s| s.resample(&clock)).collect()
}

#[cfg(test)]
mod tests {
    use super::super::tests::{names, sample, TempDir};
    use super::super::{write_topics, MessageEncoding, TopicData, WriteSettings, DEFAULT_RATE_HZ};
    use super::*;

    #[test]
    fn alignment_interpolates_linearly_on_the_common_span() {
        // a: t = 0, 10, 20, ... 100 ms, value = t in ms; b: t = 5..=95 ms, value = 2 t.
        let ms = 1_000_000i64;
        let a = JointStates::new(
            (0..=10).map(|k| k * 10 * ms).collect(),
            names(&["a"]),
            (0..=10).map(|k| (k * 10) as f64).collect(),
        )
        .expect("a");
        let b =
            JointStates::new(vec![5 * ms, 95 * ms], names(&["b"]), vec![10.0, 190.0]).expect("b");
        let out = align_onto_clock(&[a, b], 40.0).expect("align");
        // Common span 5..95 ms at 25 ms: 5, 30, 55, 80 ms.
        let expect_t: Vec<i64> = vec![5 * ms, 30 * ms, 55 * ms, 80 * ms];
        assert_eq!(out[0].times_ns, expect_t);
        assert_eq!(out[1].times_ns, expect_t);
        for (k, t) in expect_t.iter().enumerate() {
            let t_ms = (*t / ms) as f64;
            assert!((out[0].positions[k] - t_ms).abs() < 1e-12);
            assert!((out[1].positions[k] - 2.0 * t_ms).abs() < 1e-12);
        }
        let late = JointStates::new(vec![200 * ms], names(&["c"]), vec![0.0]).expect("c");
        let err = align_onto_clock(&[out[0].clone(), late], 40.0).unwrap_err();
        assert!(matches!(err, JointStateError::NoOverlap { .. }), "{err}");
        assert!(align_onto_clock(&out, 0.0).is_err());
    }

    #[test]
    fn read_aligned_puts_topics_on_one_forty_hertz_clock() {
        let dir = TempDir::new("aligned");
        let path = dir.file("a.mcap");
        // 100 Hz and 30 Hz topics.
        let a = sample(200, &["a"], 0, 10_000_000, 0.0);
        let b = sample(60, &["b"], 3_000_000, 33_333_333, 0.5);
        write_topics(
            &path,
            &[
                TopicData {
                    topic: "/a",
                    states: &a,
                    encoding: MessageEncoding::Cdr,
                },
                TopicData {
                    topic: "/b",
                    states: &b,
                    encoding: MessageEncoding::Cdr,
                },
            ],
            &WriteSettings::default(),
        )
        .expect("write");
        let out = read_aligned(
            &path,
            &[TopicRequest::all("/a"), TopicRequest::all("/b")],
            DEFAULT_RATE_HZ,
        )
        .expect("aligned");
        let t = &out[0].times_ns;
        assert_eq!(t[0], 3_000_000);
        assert!(t.windows(2).all(|w| w[1] - w[0] == 25_000_000));
        // The common span ends at /b's last sample, 3 ms + 59 × 33.33 ms.
        assert!(*t.last().expect("non-empty") <= 3_000_000 + 59 * 33_333_333);
        assert_eq!(t.len(), 79);
        // Spot check against a hand interpolation of /a at t[1] = 28 ms: between 20 and 30 ms.
        let (v20, v30) = (a.row(2)[0], a.row(3)[0]);
        assert!((out[0].positions[1] - (v20 + 0.8 * (v30 - v20))).abs() < 1e-12);
    }

    #[test]
    fn resample_at_sample_times_is_exact() {
        let s = sample(20, &["a", "b"], 7, 13, 0.1);
        let r = s.resample(&s.times_ns).expect("resample");
        assert_eq!(r, s);
        assert!(s.resample(&[6]).is_err());
    }
}
