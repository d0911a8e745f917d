//! Validation of ensemble scenes: `[ensemble]` with `kind = "grid" | "random" | "list"`
//! becomes [`Members`] (the thesis's square, no `kind` or `kind = "square"`, stays
//! [`super::Ensemble`]).
//!
//! ```toml
//! [ensemble]
//! kind = "grid"                # or "random" (keys samples, seed), or "list" (key members)
//! x = "q2"                     # a coordinate (q1..qn, p1..pn) or a parameter of the system
//! x_range = [-0.4, 0.6]
//! x_count = 20
//! y = "p2"                     # optional: a one-axis grid without it
//! y_range = [-0.4, 0.4]
//! y_count = 20
//! energy = 0.125               # optional: put every member on the shell H = energy ...
//! solve = "p1"                 # ... by solving this momentum (the others as sampled)
//! chaos = "megno"              # optional: the MEGNO chaos indicator of every member
//! ```
//!
//! A list names its columns in a CSV header, one member a row:
//!
//! ```toml
//! [ensemble]
//! kind = "list"
//! members = """
//! q1, p2, k
//! 0.5, 1.2, 1.0
//! 0.6, 1.1, 2.0
//! """
//! ```

use std::ops::Range;

use toml::Spanned;

use super::raw::RawEnsemble;
use super::schema::{Axis, AxisRange, ChaosIndicator, Coord, EnergyShell, Members, Sampler};
use super::toml_string::StringPositions;

/// Validation errors: where and what.
pub(super) type Errors = Vec<(Range<usize>, String)>;

/// The keys each kind takes (besides `kind`), for "not a key of" messages.
fn keys(kind: &str) -> &'static [&'static str] {
    const SHARED: [&str; 3] = ["energy", "solve", "chaos"];
    match kind {
        "grid" => &[
            "x", "x_range", "x_count", "y", "y_range", "y_count", "energy", "solve", "chaos",
        ],
        "random" => &[
            "x", "x_range", "y", "y_range", "samples", "seed", "energy", "solve", "chaos",
        ],
        "list" => &["members", "energy", "solve", "chaos"],
        _ => &SHARED,
    }
}

/// The keys the thesis's square takes.
pub(super) const SQUARE_KEYS: [&str; 5] = ["x", "y", "half_width", "per_side", "steps"];

/// Every key given in `e`, with its span.
pub(super) fn present(e: &RawEnsemble) -> Vec<(&'static str, Range<usize>)> {
    let s = |v: Option<Range<usize>>, k: &'static str| v.map(|r| (k, r));
    [
        s(e.x.as_ref().map(Spanned::span), "x"),
        s(e.y.as_ref().map(Spanned::span), "y"),
        s(e.half_width.as_ref().map(Spanned::span), "half_width"),
        s(e.per_side.as_ref().map(Spanned::span), "per_side"),
        s(e.steps.as_ref().map(Spanned::span), "steps"),
        s(e.x_range.as_ref().map(Spanned::span), "x_range"),
        s(e.y_range.as_ref().map(Spanned::span), "y_range"),
        s(e.x_count.as_ref().map(Spanned::span), "x_count"),
        s(e.y_count.as_ref().map(Spanned::span), "y_count"),
        s(e.samples.as_ref().map(Spanned::span), "samples"),
        s(e.seed.as_ref().map(Spanned::span), "seed"),
        s(e.members.as_ref().map(Spanned::span), "members"),
        s(e.energy.as_ref().map(Spanned::span), "energy"),
        s(e.solve.as_ref().map(Spanned::span), "solve"),
        s(e.chaos.as_ref().map(Spanned::span), "chaos"),
    ]
    .into_iter()
    .flatten()
    .collect()
}

/// The kinds of `[ensemble]`, for messages.
pub(super) const KINDS: &str = "\"square\" (the default), \"grid\", \"random\" or \"list\"";

/// The axis named `s`: a coordinate `q1..qn`, `p1..pn`, or a parameter in `params`.
fn axis(s: &str, n: Option<usize>, params: &[&str]) -> Result<Axis, String> {
    match Coord::from_name(s, n) {
        Some(Coord::T) => {
            Err("an ensemble varies q or p coordinates or parameters, not the time `t`".to_string())
        }
        Some(c) => Ok(Axis::Coord(c)),
        None if params.contains(&s) => Ok(Axis::Param(s.to_string())),
        None => Err(format!(
            "unknown coordinate or parameter `{s}`: expected {}{}",
            n.map_or("q1..qn, p1..pn".to_string(), |n| format!(
                "q1..q{n}, p1..p{n}"
            )),
            if params.is_empty() {
                String::new()
            } else {
                format!(" or a parameter ({})", params.join(", "))
            }
        )),
    }
}

/// Validates `[ensemble]` of kind `kind` (`grid`, `random`, `list`) for a system with `n`
/// degrees of freedom and parameters `params`; errors go to `errors` (span, message), `at` is
/// the table's span for missing keys, `file` the scene's text.
pub(super) fn check(
    file: &str,
    e: RawEnsemble,
    kind: &Spanned<String>,
    at: Range<usize>,
    n: Option<usize>,
    params: &[&str],
    errors: &mut Errors,
) -> Option<Members> {
    let name = kind.get_ref().as_str();
    if !matches!(name, "grid" | "random" | "list") {
        errors.push((
            kind.span(),
            format!("unknown ensemble kind `{name}`: expected {KINDS}"),
        ));
        return None;
    }
    let allowed = keys(name);
    for (key, span) in present(&e) {
        if !allowed.contains(&key) {
            errors.push((
                span,
                format!(
                    "`{key}` is not a key of an ensemble of kind `{name}`: expected {}",
                    allowed.join(", ")
                ),
            ));
        }
    }
    let missing = |key: &str, what: &str, errors: &mut Errors| {
        errors.push((
            at.clone(),
            format!("an ensemble of kind `{name}` needs `{key}` ({what})"),
        ));
    };
    let range = |axis_key: &str,
                 a: &Option<Spanned<String>>,
                 r: &Option<Spanned<Vec<f64>>>,
                 errors: &mut Errors|
     -> Option<AxisRange> {
        let a = a.as_ref()?;
        let axis = axis(a.get_ref(), n, params)
            .map_err(|m| errors.push((a.span(), m)))
            .ok();
        let key = format!("{axis_key}_range");
        let Some(r) = r else {
            missing(&key, "[from, to]", errors);
            return None;
        };
        match r.get_ref().as_slice() {
            &[from, to] if from.is_finite() && to.is_finite() && from < to => Some(AxisRange {
                axis: axis?,
                from,
                to,
            }),
            v => {
                errors.push((
                    r.span(),
                    format!("`{key}` = {v:?}: expected [from, to], finite, from < to"),
                ));
                None
            }
        }
    };
    let count = |v: &Spanned<i64>, key: &str, min: i64, errors: &mut Errors| {
        if *v.get_ref() >= min {
            Some(*v.get_ref() as usize)
        } else {
            errors.push((
                v.span(),
                format!("`{key}` = {}: expected an integer >= {min}", v.get_ref()),
            ));
            None
        }
    };
    let sampler = match name {
        "grid" | "random" => {
            if e.x.is_none() {
                missing("x", "a coordinate or parameter", errors);
            }
            if e.y_range.is_some() && e.y.is_none() {
                missing("y", "the axis `y_range` is for", errors);
            }
            let x = range("x", &e.x, &e.x_range, errors);
            let y = range("y", &e.y, &e.y_range, errors);
            if let (Some(a), Some(b), Some(ys)) = (&x, &y, &e.y) {
                if a.axis == b.axis {
                    errors.push((ys.span(), "the ensemble's `x` and `y` must differ".into()));
                }
            }
            if name == "grid" {
                let xc = match &e.x_count {
                    Some(c) => count(c, "x_count", 2, errors),
                    None => {
                        missing("x_count", "points along x", errors);
                        None
                    }
                };
                let yc = match (&e.y, &e.y_count) {
                    (_, Some(c)) => count(c, "y_count", 2, errors),
                    (Some(_), None) => {
                        missing("y_count", "points along y", errors);
                        None
                    }
                    (None, None) => Some(0),
                };
                Sampler::Grid {
                    x: (x?, xc?),
                    y: match y {
                        Some(y) => Some((y, yc?)),
                        None => None,
                    },
                }
            } else {
                let samples = match &e.samples {
                    Some(c) => count(c, "samples", 1, errors),
                    None => {
                        missing("samples", "the number of members", errors);
                        None
                    }
                };
                let seed = match &e.seed {
                    None => Some(0),
                    Some(s) if *s.get_ref() >= 0 => Some(*s.get_ref() as u64),
                    Some(s) => {
                        errors.push((
                            s.span(),
                            format!("`seed` = {}: expected an integer >= 0", s.get_ref()),
                        ));
                        None
                    }
                };
                Sampler::Random {
                    x: x?,
                    y,
                    samples: samples?,
                    seed: seed?,
                }
            }
        }
        _ => {
            let Some(text) = &e.members else {
                missing(
                    "members",
                    "CSV text: a header naming the columns, one row a member",
                    errors,
                );
                return None;
            };
            // Each error at its cell or row in the file when the literal maps back to it
            // (`StringPositions`), else at the value.
            let positions = StringPositions::new(file, text.span(), text.get_ref());
            let (columns, rows) = csv(text.get_ref(), n, params)
                .map_err(|found| {
                    for (range, m) in found {
                        let span = positions.as_ref().map_or(text.span(), |p| p.range(range));
                        errors.push((span, m));
                    }
                })
                .ok()?;
            Sampler::List { columns, rows }
        }
    };
    let axes: Vec<&Axis> = match &sampler {
        Sampler::Grid { x, y } => std::iter::once(&x.0.axis)
            .chain(y.as_ref().map(|y| &y.0.axis))
            .collect(),
        Sampler::Random { x, y, .. } => std::iter::once(&x.axis)
            .chain(y.as_ref().map(|y| &y.axis))
            .collect(),
        Sampler::List { columns, .. } => columns.iter().collect(),
    };
    let shell = match (&e.energy, &e.solve) {
        (None, None) => Some(None),
        (Some(_), None) => {
            missing(
                "solve",
                "the momentum solved for the energy shell, e.g. p1",
                errors,
            );
            None
        }
        (None, Some(_)) => {
            missing("energy", "the energy E of the shell H = E", errors);
            None
        }
        (Some(en), Some(s)) => {
            let energy = if en.get_ref().is_finite() {
                Some(*en.get_ref())
            } else {
                errors.push((en.span(), "`energy` must be finite".into()));
                None
            };
            let solve = match Coord::from_name(s.get_ref(), n) {
                Some(c @ Coord::P(_)) if axes.contains(&&Axis::Coord(c)) => {
                    errors.push((
                        s.span(),
                        format!("`solve` = \"{}\" is also sampled: expected a momentum the ensemble does not vary", s.get_ref()),
                    ));
                    None
                }
                Some(c @ Coord::P(_)) => Some(c),
                _ => {
                    errors.push((
                        s.span(),
                        format!(
                            "`solve` = \"{}\": expected a momentum ({})",
                            s.get_ref(),
                            n.map_or("p1..pn".to_string(), |n| format!("p1..p{n}"))
                        ),
                    ));
                    None
                }
            };
            Some(Some(EnergyShell {
                energy: energy?,
                solve: solve?,
            }))
        }
    };
    let chaos = match &e.chaos {
        None => Some(None),
        Some(c) if c.get_ref() == "megno" => Some(Some(ChaosIndicator::Megno)),
        Some(c) => {
            errors.push((
                c.span(),
                format!(
                    "unknown chaos indicator `{}`: expected \"megno\"",
                    c.get_ref()
                ),
            ));
            None
        }
    };
    Some(Members {
        sampler,
        shell: shell?,
        chaos: chaos?,
    })
}

/// Parses a list ensemble's CSV: a header of axes, then rows of as many finite numbers.
/// Every bad row is an error of its own, at the byte range of the value (the cell, or the
/// row) within `text`.
fn csv(
    text: &str,
    n: Option<usize>,
    params: &[&str],
) -> Result<(Vec<Axis>, Vec<Vec<f64>>), Errors> {
    // (line number, byte offset of the trimmed line in `text`, the trimmed line)
    let mut start = 0;
    let mut lines = text
        .split_inclusive('\n')
        .enumerate()
        .map(|(i, raw)| {
            let at = start + (raw.len() - raw.trim_start().len());
            start += raw.len();
            (i + 1, at, raw.trim())
        })
        .filter(|(_, _, l)| !l.is_empty() && !l.starts_with('#'));
    let Some((_, header_at, header)) = lines.next() else {
        return Err(vec![(0..text.len(), "`members` is empty: expected a CSV header naming the columns (e.g. q1, p2), then one row per member".into())]);
    };
    let header_span = header_at..header_at + header.len();
    let columns = header
        .split(',')
        .map(|c| {
            axis(c.trim(), n, params)
                .map_err(|m| vec![(header_span.clone(), format!("`members` header: {m}"))])
        })
        .collect::<Result<Vec<_>, _>>()?;
    for (i, c) in columns.iter().enumerate() {
        if columns[..i].contains(c) {
            return Err(vec![(
                header_span,
                format!("`members` header names `{}` twice", c.name()),
            )]);
        }
    }
    let mut rows = Vec::new();
    let mut errors = Vec::new();
    for (line, at, l) in lines {
        let mut cell_at = at;
        let mut row = Vec::new();
        let mut bad = None;
        for cell in l.split(',') {
            let lead = cell.len() - cell.trim_start().len();
            match cell.trim().parse::<f64>().ok().filter(|x| x.is_finite()) {
                Some(x) => row.push(x),
                None if bad.is_none() => {
                    let from = cell_at + lead;
                    bad = Some((from..from + cell.trim().len(), cell.trim()));
                }
                None => {}
            }
            cell_at += cell.len() + 1;
        }
        if let Some((span, cell)) = bad {
            errors.push((
                span,
                format!(
                    "`members` row {line}: `{cell}` is not a finite number: expected {} finite numbers separated by commas",
                    columns.len()
                ),
            ));
        } else if row.len() != columns.len() {
            errors.push((
                at..at + l.len(),
                format!(
                    "`members` row {line} has {} values: expected {} (one per header column)",
                    row.len(),
                    columns.len()
                ),
            ));
        } else {
            rows.push(row);
        }
    }
    if !errors.is_empty() {
        return Err(errors);
    }
    if rows.is_empty() {
        return Err(vec![(
            header_span,
            "`members` has a header but no rows: expected at least one member".into(),
        )]);
    }
    Ok((columns, rows))
}
