//! Lists of names in messages: the first few, quoted, and how many there are in all, so that an
//! error about 18 joints stays one readable line.

/// Names shown before the rest are counted, by default.
pub const SHOWN: usize = 5;

/// The first `shown` of `names`, quoted, then how many more: `"a", "b", "c" and 15 more`;
/// all of them when there are no more than `shown` (and at least one is always shown).
pub fn few<S: AsRef<str>>(names: &[S], shown: usize) -> String {
    let shown = shown.max(1);
    let quoted: Vec<String> = names
        .iter()
        .take(shown)
        .map(|n| format!("{:?}", n.as_ref()))
        .collect();
    match names.len().checked_sub(shown) {
        Some(rest) if rest > 0 => format!("{} and {rest} more", quoted.join(", ")),
        _ => quoted.join(", "),
    }
}

/// `n` and `noun`, plural unless `n` is 1 (`1 joint`, `14 joints`): counts in messages.
pub fn count(n: usize, noun: &str) -> String {
    if n == 1 {
        format!("1 {noun}")
    } else {
        format!("{n} {noun}s")
    }
}

/// How `found` differs from `expected` (both lists of `noun`s, in order), for a message: the
/// expected names that are missing and the names found that are not expected, each the first
/// few and a count (`14 of the 18 joints expected are missing: "a", "b" and 12 more; 2 joints
/// are not expected: "x", "y"`); for the same names in another order, the first position that
/// differs. Empty when the lists are equal.
pub fn difference<S: AsRef<str>, T: AsRef<str>>(expected: &[S], found: &[T], noun: &str) -> String {
    let expected: Vec<&str> = expected.iter().map(AsRef::as_ref).collect();
    let found: Vec<&str> = found.iter().map(AsRef::as_ref).collect();
    let missing: Vec<&str> = expected
        .iter()
        .copied()
        .filter(|e| !found.contains(e))
        .collect();
    let extra: Vec<&str> = found
        .iter()
        .copied()
        .filter(|f| !expected.contains(f))
        .collect();
    let mut parts = Vec::new();
    if !missing.is_empty() {
        parts.push(format!(
            "{} of the {} expected {} missing: {}",
            missing.len(),
            count(expected.len(), noun),
            if missing.len() == 1 { "is" } else { "are" },
            few(&missing, SHOWN)
        ));
    }
    if !extra.is_empty() {
        parts.push(format!(
            "{} {} not expected: {}",
            count(extra.len(), noun),
            if extra.len() == 1 { "is" } else { "are" },
            few(&extra, SHOWN)
        ));
    }
    if parts.is_empty() && expected != found {
        match expected.iter().zip(&found).position(|(e, f)| e != f) {
            Some(k) => parts.push(format!(
                "the same {} in another order: position {} has {:?} where {:?} is expected",
                count(expected.len(), noun),
                k + 1,
                found[k],
                expected[k]
            )),
            None => parts.push(format!(
                "{} where {} are expected (some twice)",
                count(found.len(), noun),
                expected.len()
            )),
        }
    }
    parts.join("; ")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn long_lists_show_the_first_few_and_a_count() {
        let names: Vec<String> = (0..18).map(|k| format!("j{k}")).collect();
        assert_eq!(few(&names, 3), "\"j0\", \"j1\", \"j2\" and 15 more");
        assert_eq!(few(&names[..3], 3), "\"j0\", \"j1\", \"j2\"");
        assert_eq!(few(&["only"], 0), "\"only\"");
        assert_eq!(few::<&str>(&[], 5), "");
        assert_eq!(
            (count(1, "joint"), count(14, "joint")),
            ("1 joint".into(), "14 joints".into())
        );
    }

    #[test]
    fn differences_name_what_is_missing_what_is_extra_or_where_the_order_differs() {
        let expected: Vec<String> = (0..18).map(|k| format!("j{k}")).collect();
        let found = ["j0", "j1", "j2", "j3", "x", "y"];
        assert_eq!(
            difference(&expected, &found, "joint"),
            "14 of the 18 joints expected are missing: \"j4\", \"j5\", \"j6\", \"j7\", \"j8\" and 9 \
             more; 2 joints are not expected: \"x\", \"y\""
        );
        assert_eq!(
            difference(&["a", "b", "c"], &["a", "c", "b"], "joint"),
            "the same 3 joints in another order: position 2 has \"c\" where \"b\" is expected"
        );
        assert_eq!(
            difference(&["a", "b"], &["a"], "column"),
            "1 of the 2 columns expected is missing: \"b\""
        );
        assert_eq!(difference(&["a"], &["a"], "joint"), "");
    }
}
