//! `[[event]]`: a condition on the state that every method's run watches, written in the
//! Hamiltonian's grammar and compiled like it (`dth::runtime::StateFunction`), located to
//! roundoff on the step where it turns true (`dth::event`), and recorded or ending the run.
//!
//! ```toml
//! [[event]]
//! name = "close"                      # optional (default event1, event2, ...)
//! when = "q1^2 + q2^2 < 0.05^2"       # lhs < rhs or lhs > rhs, in q1..qn, p1..pn, t, params
//! action = "stop"                     # or "record" (the default): keep it and go on
//! ```
//!
//! The condition fires where it *becomes* true (one that holds at the start fires once it has
//! stopped holding and holds again); `<=` and `>=` are the same conditions (a crossing does not
//! tell them apart). Errors in either side are reported at their token in the file, as the
//! Hamiltonian's are.

use std::ops::Range;

use dth::runtime::{RuntimeError, StateFunction};
use toml::Spanned;

use super::members::Errors;
use super::raw::RawEvent;
use super::schema::EventSpec;
use super::toml_string::StringPositions;

/// What a condition's text is split into: the sides (byte ranges of the text) and whether
/// the comparison is `<` (`<=`) or `>` (`>=`).
struct Comparison {
    lhs: Range<usize>,
    rhs: Range<usize>,
    less: bool,
}

/// The one comparison in `when`, or why there is not exactly one.
fn comparison(when: &str) -> Result<Comparison, String> {
    let at: Vec<usize> = when.match_indices(['<', '>']).map(|(i, _)| i).collect();
    let [i] = at[..] else {
        return Err(format!(
            "expected one comparison, `lhs < rhs` or `lhs > rhs` (found {})",
            at.len()
        ));
    };
    let width = if when[i + 1..].starts_with('=') { 2 } else { 1 };
    Ok(Comparison {
        lhs: 0..i,
        rhs: i + width..when.len(),
        less: when.as_bytes()[i] == b'<',
    })
}

/// The function whose negative values are the condition `when` (`lhs < rhs` or `lhs > rhs`,
/// as a scene's `[[event]] when` and Python's `dth.integrate(events=...)` write it):
/// `(lhs) - (rhs)` for `lhs < rhs`, `(rhs) - (lhs)` for `lhs > rhs`; or why `when` is not one
/// comparison of two sides.
///
/// ```
/// use dth_examples::scene::condition_function;
/// assert_eq!(condition_function("q1 > 10").as_deref(), Ok("( 10) - (q1 )"));
/// assert!(condition_function("q1 <").is_err());
/// ```
pub fn condition_function(when: &str) -> Result<String, String> {
    let c = comparison(when)?;
    let (lhs, rhs) = (&when[c.lhs], &when[c.rhs]);
    if lhs.trim().is_empty() || rhs.trim().is_empty() {
        return Err("a side of the comparison is empty".into());
    }
    Ok(if c.less {
        format!("({lhs}) - ({rhs})")
    } else {
        format!("({rhs}) - ({lhs})")
    })
}

/// Validates the scene's `[[event]]`s against a system of `n` degrees of freedom (`None`:
/// not known, its own errors are reported) with the parameters `params`: their specs, or the
/// errors pushed to `errors`.
pub(super) fn check(
    text: &str,
    raw: Vec<Spanned<RawEvent>>,
    n: Option<usize>,
    time_dependent: bool,
    params: &[(&str, f64)],
    errors: &mut Errors,
) -> Vec<EventSpec> {
    let mut events: Vec<EventSpec> = Vec::new();
    for (k, e) in raw.into_iter().enumerate() {
        let e = e.into_inner();
        let name = e
            .name
            .as_ref()
            .map_or_else(|| format!("event{}", k + 1), |s| s.get_ref().clone());
        if let Some(given) = &e.name {
            if events.iter().any(|other| other.name == name) {
                errors.push((given.span(), format!("event `{name}` is named twice")));
            }
        }
        let when = e.when.get_ref();
        let sides = match comparison(when) {
            Ok(c) => vec![c.lhs, c.rhs],
            Err(why) => {
                errors.push((e.when.span(), format!("event `{name}`: {why}")));
                Vec::new()
            }
        };
        let positions = StringPositions::new(text, e.when.span(), when);
        let at = |range: Range<usize>| match &positions {
            Some(p) => p.range(range),
            None => e.when.span(),
        };
        let mut sound = !sides.is_empty();
        for side in sides {
            if when[side.clone()].trim().is_empty() {
                errors.push((
                    at(side),
                    format!("event `{name}`: a side of the comparison is empty"),
                ));
                sound = false;
                continue;
            }
            let Some(n) = n else { continue };
            match StateFunction::new(&when[side.clone()], n, time_dependent, params) {
                Ok(_) => {}
                Err(RuntimeError::Expression(es)) => {
                    for error in es.0 {
                        let range = error.span.range();
                        errors.push((
                            at(side.start + range.start..side.start + range.end),
                            error.to_string(),
                        ));
                    }
                    sound = false;
                }
                Err(other) => {
                    errors.push((e.when.span(), format!("event `{name}`: {other}")));
                    sound = false;
                }
            }
        }
        let stop = match e.action.as_ref().map(|a| a.get_ref().as_str()) {
            None | Some("record") => false,
            Some("stop") => true,
            Some(other) => {
                let span = e.action.as_ref().map_or(0..0, Spanned::span);
                errors.push((
                    span,
                    format!("unknown event action `{other}`: expected `record` or `stop`"),
                ));
                false
            }
        };
        if let (true, Ok(g)) = (sound, condition_function(when)) {
            events.push(EventSpec {
                name,
                when: when.clone(),
                g,
                stop,
            });
        }
    }
    events
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::catalogue::Catalogue;

    const KEPLER: &str = "[system]\nname = \"kepler\"\n[initial]\nq = [0.5, 0.0]\np = [0.0, 1.2]\n\
                          [[method]]\nkind = \"midpoint\"\ndt = 0.1\n[duration]\ntime = 10.0\n";

    fn errors(events: &str) -> String {
        let text = format!("{KEPLER}{events}");
        match crate::check_scene(&text, "e.toml", &Catalogue::builtin()) {
            Ok(_) => String::new(),
            Err(e) => e.to_string(),
        }
    }

    #[test]
    fn a_scene_reads_its_events() {
        let text = format!(
            "{KEPLER}[[event]]\nwhen = \"q1^2 + q2^2 > k\"\n[[event]]\nname = \"slow\"\nwhen = \"p1^2 + p2^2 < 0.1\"\naction = \"stop\"\n"
        );
        let scene = crate::check_scene(&text, "e.toml", &Catalogue::builtin()).unwrap();
        let names: Vec<(&str, bool)> = scene
            .events
            .iter()
            .map(|e| (e.name.as_str(), e.stop))
            .collect();
        assert_eq!(names, [("event1", false), ("slow", true)]);
        assert_eq!(scene.events[0].g, "( k) - (q1^2 + q2^2 )");
    }

    #[test]
    fn every_bad_event_is_reported_at_once_where_it_is() {
        let e = errors(
            "[[event]]\nwhen = \"q1^2 + q3^2 < 1\"\n\
             [[event]]\nwhen = \"q1\"\n\
             [[event]]\nwhen = \"q1 < foo\"\naction = \"halt\"\n",
        );
        let line = |n: usize| format!("e.toml:{n}:");
        // `q3` at its column inside the string, the missing comparison at the value, the
        // unknown name at the name, the action at its value.
        let want = [
            format!("{}16: `q3` is not a coordinate of this system", line(12)),
            format!("{}8: event `event2`: expected one comparison", line(14)),
            format!("{}14: unknown variable `foo`", line(16)),
            format!(
                "{}10: unknown event action `halt`: expected `record` or `stop`",
                line(17)
            ),
        ];
        let mut at = 0;
        for w in &want {
            // In file order.
            let found = e[at..].find(w.as_str()).map(|i| at + i);
            assert!(found.is_some(), "{w} in order in\n{e}");
            at = found.unwrap_or(at);
        }
    }

    #[test]
    fn an_ensemble_scene_refuses_events() {
        let e = errors(
            "[ensemble]\nkind = \"grid\"\nx = \"q1\"\nx_range = [0.4, 0.6]\nx_count = 3\n\
             [[effect]]\nkind = \"poincare\"\ncoordinate = \"q2\"\nx = \"q1\"\ny = \"p1\"\n\
             [[event]]\nwhen = \"q1 > 1\"\n",
        );
        assert!(e.contains("events are watched in single runs"), "{e}");
    }

    #[test]
    fn a_condition_is_one_comparison_turned_into_a_function_below_zero() {
        assert_eq!(
            condition_function("q1^2 + q2^2 < 0.05^2").as_deref(),
            Ok("(q1^2 + q2^2 ) - ( 0.05^2)")
        );
        assert_eq!(
            condition_function("q1 >= 10").as_deref(),
            Ok("( 10) - (q1 )")
        );
        assert!(comparison("q1").is_err());
        assert!(comparison("0 < q1 < 1").is_err());
    }
}
