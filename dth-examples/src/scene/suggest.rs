//! "Did you mean": the known name closest to a misspelled one ([`close_match`]), for the
//! messages about unknown systems, methods, effects and parameters.

/// The one name of `names` closest to `name` (case ignored; optimal string alignment distance:
/// insertions, deletions, substitutions and swaps of two adjacent characters, so `dht` is one
/// edit from `dth`), when it is close: at most a third of its
/// characters (and at least one) differ. `None` when nothing is that close, or two names are
/// equally close.
///
/// The caller words it: ``"unknown method `midpiont` (did you mean `midpoint`?)"``.
pub fn close_match<'a>(name: &str, names: impl IntoIterator<Item = &'a str>) -> Option<&'a str> {
    let lower = name.to_lowercase();
    let limit = (name.chars().count() / 3).max(1);
    let mut best: Option<(usize, &str)> = None;
    let mut tie = false;
    for candidate in names {
        let d = strsim::osa_distance(&lower, &candidate.to_lowercase());
        match best {
            Some((b, _)) if d > b => {}
            Some((b, _)) if d == b => tie = true,
            _ => {
                best = Some((d, candidate));
                tie = false;
            }
        }
    }
    match best {
        Some((d, candidate)) if d <= limit && !tie => Some(candidate),
        _ => None,
    }
}

/// `" (did you mean `x`?)"` for the [`close_match`] of `name` in `names`, or `""`.
pub fn did_you_mean<'a>(name: &str, names: impl IntoIterator<Item = &'a str>) -> String {
    close_match(name, names).map_or(String::new(), |m| format!(" (did you mean `{m}`?)"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_a_close_and_unique_name_is_suggested() {
        let methods = ["exact", "dth", "midpoint", "rk4", "trapezoidal"];
        assert_eq!(close_match("midpiont", methods), Some("midpoint"));
        assert_eq!(close_match("RK4", methods), Some("rk4"));
        assert_eq!(close_match("trapezodial", methods), Some("trapezoidal"));
        // Two adjacent letters swapped are one edit.
        assert_eq!(close_match("dht", methods), Some("dth"));
        // Far from every name.
        assert_eq!(close_match("leapfrog", methods), None);
        // Equally close to two.
        assert_eq!(close_match("ab", ["ax", "xb"]), None);
        assert_eq!(did_you_mean("rk5", methods), " (did you mean `rk4`?)");
        assert_eq!(did_you_mean("leapfrog", methods), "");
    }
}
