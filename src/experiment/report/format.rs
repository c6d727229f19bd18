//! How the report writes numbers: fixed decimals with "—" for what is not finite, a true minus
//! sign, thousands separated by a space, "mean ± sd", and a point estimate with its interval.

use crate::results::Results;
use crate::stats::{self, Interval, StatsError};

use super::judged;

/// A number with `digits` decimals, "—" when not finite.
pub(super) fn num(value: f64, digits: usize) -> String {
    if value.is_finite() {
        format!("{value:.digits$}")
    } else {
        "—".into()
    }
}

/// A signed number with `digits` decimals (− as the minus sign), "—" when not finite.
pub(super) fn signed(value: f64, digits: usize) -> String {
    if value.is_finite() {
        let text = format!("{:.digits$}", value.abs());
        if value < 0.0 && text.chars().any(|c| c.is_ascii_digit() && c != '0') {
            format!("−{text}")
        } else {
            format!("+{text}")
        }
    } else {
        "—".into()
    }
}

/// An integer with a space between groups of three digits: `10 000`.
pub(super) fn thousands(n: usize) -> String {
    let digits = n.to_string();
    let mut out = String::new();
    for (i, c) in digits.chars().enumerate() {
        if i > 0 && (digits.len() - i).is_multiple_of(3) {
            out.push(' ');
        }
        out.push(c);
    }
    out
}

/// "mean ± sd" of `values` with `digits` decimals (only the mean for a single value).
pub(super) fn mean_sd(values: &[f64], digits: usize) -> String {
    let m = stats::mean(values);
    let sd = stats::sample_sd(values);
    if values.len() < 2 || !sd.is_finite() {
        num(m, digits)
    } else {
        format!("{} ± {}", num(m, digits), num(sd, digits))
    }
}

/// A point estimate with its interval, or why there is none; the estimate alone for results too
/// small to judge (an interval over so few pairs would look more certain than it is).
pub(super) fn with_interval(
    results: &Results,
    estimate: f64,
    interval: &Result<Interval, StatsError>,
    show: impl Fn(f64) -> String,
) -> String {
    if !judged(results) {
        return show(estimate);
    }
    match interval {
        Ok(ci) => format!("{} [{}, {}]", show(estimate), show(ci.low), show(ci.high)),
        Err(e) => format!("{} (no interval: {e})", show(estimate)),
    }
}
