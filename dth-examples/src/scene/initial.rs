//! `[initial]` of any size: `q` and `p` as lists of numbers, as formulas of the site index, or
//! read from a CSV file of states.
//!
//! ```toml
//! [initial]
//! q = "0.5*sin(i*pi/(N+1))"     # q_i for i = 1..n
//! p = "0.01*(2*random - 1)"     # seeded, uniform in [-0.01, 0.01)
//! seed = 7                      # optional (default 0), read by `random`
//! ```
//!
//! or `file = "start.csv"` (in place of `q` and `p`).
//!
//! # Formulas
//! A formula is an expression in the grammar of `hamiltonian!` (read by the symbolic engine,
//! the same messages, located in the scene file inside the string), evaluated once per
//! degree of freedom: `i` runs over `1..n`, the indices of `q` and of `p`. For a lattice with
//! several coordinates per site (`q[2*i-1]`, `q[2*i]` of bodies in the plane) `i` is still the
//! coordinate's index, `1..n`, not the body's. A formula may use:
//! - `i`, the index;
//! - `n`, the number of degrees of freedom;
//! - the sizes the Hamiltonian given as text declares after `where` (`N`), after `sizes`
//!   overrode them;
//! - the system's parameters (the scene's `params`, with a catalogue system's defaults);
//! - `pi`, the grammar's functions, and `random`: uniform in `[0, 1)`, independent for every
//!   entry. The value at `q_i` is the `2i - 1`-th draw and at `p_i` the `2i`-th of the
//!   SplitMix64 stream seeded by `seed`, so one seed gives the same state on every machine
//!   and whatever else the scene says.
//!
//! A name is taken in that order (a size or parameter named `i`, `n` or `random` is hidden by
//! the built-in one). A formula may not use `q1`, `p1` or `t` (the state it defines), and
//! every value must be finite.
//!
//! # CSV
//! `file = "start.csv"`, a path relative to the scene file: a header naming the columns, then
//! rows of numbers; the columns `q1..qn` and `p1..pn` (any order, other columns ignored, so
//! the `trajectory` CSV of a run is such a file) of the **last** row are the state, and its
//! column `t`, if any, the initial time unless `[initial] t` is given.

use std::collections::HashMap;
use std::fmt;
use std::ops::Range;
use std::path::Path;

use dth_symbolic::lower::{Output, Program};
use dth_symbolic::{Node, Var};
use serde::de::{self, Deserializer, SeqAccess, Visitor};
use serde::Deserialize;
use toml::Spanned;

use super::members::Errors;
use super::toml_string::StringPositions;
use crate::ensemble::sample::SplitMix64;

/// `q` or `p` of `[initial]` as written: numbers, or a formula of the index (a string).
#[derive(Debug, Clone, PartialEq)]
pub(super) enum RawValues {
    /// `[0.1, 0.2, ...]`.
    Numbers(Vec<f64>),
    /// `"0.5*sin(i*pi/(N+1))"`.
    Formula(String),
}

impl<'de> Deserialize<'de> for RawValues {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct Values;
        impl<'de> Visitor<'de> for Values {
            type Value = RawValues;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("an array of numbers, or a formula of the index `i` (a string)")
            }
            fn visit_str<E: de::Error>(self, s: &str) -> Result<RawValues, E> {
                Ok(RawValues::Formula(s.to_string()))
            }
            fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<RawValues, A::Error> {
                let mut v = Vec::new();
                while let Some(x) = seq.next_element::<f64>()? {
                    v.push(x);
                }
                Ok(RawValues::Numbers(v))
            }
        }
        d.deserialize_any(Values)
    }
}

/// Which half of the state a formula fills.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Half {
    /// Positions.
    Q,
    /// Momenta.
    P,
}

impl Half {
    fn name(self) -> &'static str {
        match self {
            Half::Q => "q",
            Half::P => "p",
        }
    }
}

/// What a formula may name besides `i`, `n` and `random` (see the module docs).
pub(super) struct Names {
    /// The number of degrees of freedom: `i` runs over `1..=n`.
    pub n: usize,
    /// Sizes and parameters with their values, in the order they are looked up.
    pub values: Vec<(String, f64)>,
    /// The seed of `random`.
    pub seed: u64,
}

/// `random` for `half` at index `i` (1-based): draw `2i - 1` (q) or `2i` (p) of the
/// SplitMix64 stream seeded by `seed`. The `k`-th output of SplitMix64 is its mixing function
/// at `seed + k * gamma`: computed directly, without drawing the ones before.
fn draw(seed: u64, half: Half, i: usize) -> f64 {
    const GAMMA: u64 = 0x9e37_79b9_7f4a_7c15;
    let before = 2 * (i as u64 - 1) + u64::from(half == Half::P);
    SplitMix64::new(seed.wrapping_add(before.wrapping_mul(GAMMA))).unit()
}

/// The values of the formula `source` (the spanned TOML string in `text`) for `half` at
/// `i = 1..=names.n`, or `None` with every error pushed to `errors` at its place in the file.
pub(super) fn formula(
    text: &str,
    source: &Spanned<RawValues>,
    formula: &str,
    half: Half,
    names: &Names,
    errors: &mut Errors,
) -> Option<Vec<f64>> {
    let positions = StringPositions::new(text, source.span(), formula);
    let at = |range: Range<usize>| match &positions {
        Some(p) => p.range(range),
        None => source.span(),
    };
    let (arena, root, values) = match parse(formula, names) {
        Ok(parsed) => parsed,
        Err(e) => {
            for e in e.0 {
                errors.push((at(e.span.range()), e.to_string()));
            }
            return None;
        }
    };
    // Only the index, the sizes and the parameters: not the state being defined.
    let mut ok = true;
    let (mut stack, mut seen) = (vec![root], std::collections::HashSet::new());
    while let Some(id) = stack.pop() {
        if !seen.insert(id) {
            continue;
        }
        stack.extend(arena.children(id));
        if let Node::Var(Var::Q(_) | Var::P(_) | Var::T | Var::Pt) = arena.node(id) {
            errors.push((
                at(arena.span(id).range()),
                format!(
                    "initial `{}` is a formula of the index `i`, `n`, the sizes, the parameters and `random`: `{}` is the state it defines",
                    half.name(),
                    &formula[arena.span(id).range()]
                ),
            ));
            ok = false;
        }
    }
    if !ok {
        return None;
    }
    let program = Program::lower(&arena, &[], &[(Output::Value, root)]);
    let mut params = values;
    let mut out = Vec::with_capacity(names.n);
    for i in 1..=names.n {
        params[0] = i as f64;
        params[2] = draw(names.seed, half, i);
        let value = program
            .eval(&[], &params)
            .map(|e| e.value)
            .unwrap_or(f64::NAN);
        if !value.is_finite() {
            errors.push((
                source.span(),
                format!(
                    "initial `{}` is not finite at i = {i}: the formula gives {value}",
                    half.name()
                ),
            ));
            return None;
        }
        out.push(value);
    }
    Some(out)
}

/// `[initial]`'s `q` and `p` as numbers, whichever way the scene gives them, with the time a
/// CSV file gives: what validation then checks as if the scene had listed the numbers.
pub(super) struct Resolved {
    /// The positions, spanned by what gave them (a list, a formula, the `file` value).
    pub q: Option<Spanned<Vec<f64>>>,
    /// The momenta.
    pub p: Option<Spanned<Vec<f64>>>,
    /// The column `t` of a CSV file.
    pub t: Option<f64>,
}

/// Turns `raw`'s `q`, `p`, `seed` and `file` into numbers for a system of `n` degrees of
/// freedom (`None` when the system is not known: formulas and files are then not read, and
/// give empty lists that no length check looks at), with the sizes and parameters `values`
/// formulas may name. Errors go to `errors` at their place in the scene file `scene_file`
/// (whose text is `text`).
pub(super) fn resolve(
    text: &str,
    scene_file: &str,
    raw: &mut super::raw::RawInitial,
    n: Option<usize>,
    values: Vec<(String, f64)>,
    errors: &mut Errors,
) -> Resolved {
    let seed = match &raw.seed {
        Some(s) if *s.get_ref() < 0 => {
            errors.push((
                s.span(),
                format!("`seed` = {}: expected 0 or more", s.get_ref()),
            ));
            0
        }
        Some(s) => *s.get_ref() as u64,
        None => 0,
    };
    if let Some(file) = &raw.file {
        if let Some(given) = raw.q.as_ref().or(raw.p.as_ref()) {
            errors.push((
                given.span(),
                "`[initial] file` gives the whole state: remove `q` and `p`, or `file`".into(),
            ));
            return Resolved {
                q: None,
                p: None,
                t: None,
            };
        }
        let span = file.span();
        let Some(n) = n else {
            let none = || Some(Spanned::new(span.clone(), Vec::new()));
            return Resolved {
                q: none(),
                p: none(),
                t: None,
            };
        };
        return match csv(scene_file, file.get_ref(), span.clone(), n, errors) {
            Some((q, p, t)) => Resolved {
                q: Some(Spanned::new(span.clone(), q)),
                p: Some(Spanned::new(span, p)),
                t,
            },
            // Its error is reported; zeros keep the length checks quiet.
            None => {
                let zeros = || Some(Spanned::new(span.clone(), vec![0.0; n]));
                Resolved {
                    q: zeros(),
                    p: zeros(),
                    t: None,
                }
            }
        };
    }
    let names = Names {
        n: n.unwrap_or(0),
        values,
        seed,
    };
    let mut one = |v: Option<Spanned<RawValues>>, half: Half| {
        let v = v?;
        let span = v.span();
        Some(match v.get_ref() {
            RawValues::Numbers(x) => Spanned::new(span, x.clone()),
            RawValues::Formula(f) if n.is_some() => {
                let x = formula(text, &v, f, half, &names, errors);
                // Failed: its errors are reported; zeros keep the length checks quiet.
                Spanned::new(span, x.unwrap_or_else(|| vec![0.0; names.n]))
            }
            RawValues::Formula(_) => Spanned::new(span, Vec::new()),
        })
    };
    let q = one(raw.q.take(), Half::Q);
    let p = one(raw.p.take(), Half::P);
    Resolved { q, p, t: None }
}

/// Parses `formula` with the names a formula may use: the arena, its root, and the values of
/// the names in the arena's parameter order (`i` and `random` first, updated per index).
fn parse(
    formula: &str,
    names: &Names,
) -> Result<(dth_symbolic::Arena, dth_symbolic::Id, Vec<f64>), dth_symbolic::Errors> {
    let mut all: Vec<(&str, f64)> = vec![("i", 0.0), ("n", names.n as f64), ("random", 0.0)];
    for (name, value) in &names.values {
        if !all.iter().any(|(n, _)| n == name) {
            all.push((name, *value));
        }
    }
    let list: Vec<&str> = all.iter().map(|(n, _)| *n).collect();
    let (arena, root, _) = dth_symbolic::expression(formula, &list)?;
    Ok((arena, root, all.iter().map(|(_, v)| *v).collect()))
}

/// The sizes declared after `where` in the Hamiltonian `source` (`N = 64`, `M = 2*N`), in
/// order, with their values; none when the text declares none or does not parse (its own
/// errors are reported where it is read).
pub(super) fn declared_sizes(source: &str) -> Vec<(String, f64)> {
    let (tokens, _) = dth_symbolic::lexer::lex(source);
    let (ast, _) = dth_symbolic::parser::parse(source, &tokens);
    let Some(dth_symbolic::parser::Ast::Where { decls, .. }) = ast else {
        return Vec::new();
    };
    let mut sizes: Vec<(String, f64)> = Vec::new();
    for d in decls {
        if let dth_symbolic::parser::Decl::Constant { name, value } = d {
            let names = Names {
                n: 0,
                values: sizes.clone(),
                seed: 0,
            };
            let value = &source[value.span().range()];
            if let Ok((arena, root, params)) = parse(value, &names) {
                let program = Program::lower(&arena, &[], &[(Output::Value, root)]);
                if let Ok(e) = program.eval(&[], &params) {
                    sizes.push((source[name.range()].to_string(), e.value));
                }
            }
        }
    }
    sizes
}

/// A state read from a CSV file: `q`, `p` and the time, if the file has a `t` column.
type CsvState = (Vec<f64>, Vec<f64>, Option<f64>);

/// The state in the CSV file `file` (relative to the scene file `scene_file`): `q`, `p` and
/// the column `t` of its last row, or `None` with the error pushed to `errors` at `span` (the
/// `file` value).
pub(super) fn csv(
    scene_file: &str,
    file: &str,
    span: Range<usize>,
    n: usize,
    errors: &mut Errors,
) -> Option<CsvState> {
    let path = Path::new(scene_file)
        .parent()
        .unwrap_or(Path::new(""))
        .join(file);
    let read = std::fs::read_to_string(&path).map_err(|e| e.to_string());
    match read.and_then(|text| csv_state(&text, n)) {
        Ok(state) => Some(state),
        Err(why) => {
            errors.push((
                span,
                format!("initial state file `{}`: {why}", path.display()),
            ));
            None
        }
    }
}

/// The state of `n` degrees of freedom in the last row of the CSV `text` (see the module
/// docs), or why there is none.
fn csv_state(text: &str, n: usize) -> Result<CsvState, String> {
    let mut lines = text.lines().filter(|l| !l.trim().is_empty());
    let header: Vec<&str> = lines
        .next()
        .ok_or("it is empty: expected a header row naming the columns q1..qn, p1..pn")?
        .split(',')
        .map(str::trim)
        .collect();
    let column: HashMap<&str, usize> = header.iter().enumerate().map(|(k, &h)| (h, k)).collect();
    let find = |name: &str| {
        column
            .get(name)
            .copied()
            .ok_or_else(|| format!("no column `{name}` (the system has n = {n} degrees of freedom: expected q1..q{n}, p1..p{n})"))
    };
    let q_cols = (1..=n)
        .map(|i| find(&format!("q{i}")))
        .collect::<Result<Vec<_>, _>>()?;
    let p_cols = (1..=n)
        .map(|i| find(&format!("p{i}")))
        .collect::<Result<Vec<_>, _>>()?;
    let (rows, last) = lines
        .enumerate()
        .last()
        .ok_or("it has a header but no row of values")?;
    let line = rows + 2;
    let cells: Vec<&str> = last.split(',').map(str::trim).collect();
    let cell = |k: usize| -> Result<f64, String> {
        let raw = cells.get(k).ok_or_else(|| {
            format!(
                "line {line} has {} values, the header {} columns",
                cells.len(),
                header.len()
            )
        })?;
        match raw.parse::<f64>() {
            Ok(x) if x.is_finite() => Ok(x),
            _ => Err(format!(
                "line {line}, column `{}`: `{raw}` is not a finite number",
                header[k]
            )),
        }
    };
    let q = q_cols.iter().map(|&k| cell(k)).collect::<Result<_, _>>()?;
    let p = p_cols.iter().map(|&k| cell(k)).collect::<Result<_, _>>()?;
    let t = match column.get("t") {
        Some(&k) => Some(cell(k)?),
        None => None,
    };
    Ok((q, p, t))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn names(n: usize) -> Names {
        Names {
            n,
            values: vec![("N".into(), n as f64), ("alpha".into(), 0.25)],
            seed: 3,
        }
    }

    fn eval(formula: &str, half: Half, n: usize) -> Result<Vec<f64>, Errors> {
        let text = format!("q = \"{formula}\"");
        #[derive(Deserialize)]
        struct T {
            q: Spanned<RawValues>,
        }
        let t: T = toml::from_str(&text).unwrap();
        let mut errors = Vec::new();
        formula_of(&text, &t.q, half, &names(n), &mut errors).ok_or(errors)
    }

    fn formula_of(
        text: &str,
        v: &Spanned<RawValues>,
        half: Half,
        names: &Names,
        errors: &mut Errors,
    ) -> Option<Vec<f64>> {
        match v.get_ref() {
            RawValues::Formula(f) => formula(text, v, f, half, names, errors),
            RawValues::Numbers(_) => None,
        }
    }

    #[test]
    fn a_sine_of_the_index() {
        let q = eval("0.5*sin(i*pi/(N+1))", Half::Q, 8).unwrap();
        for (k, &x) in q.iter().enumerate() {
            let want = 0.5 * ((k + 1) as f64 * std::f64::consts::PI / 9.0).sin();
            assert!((x - want).abs() <= 2.0 * f64::EPSILON, "{x} {want}");
        }
    }

    #[test]
    fn random_is_seeded_in_the_unit_interval_and_differs_between_q_and_p() {
        let q = eval("random", Half::Q, 64).unwrap();
        let p = eval("random", Half::P, 64).unwrap();
        assert!(q.iter().chain(&p).all(|&x| (0.0..1.0).contains(&x)));
        assert_ne!(q, p);
        // Draw 2i - 1 and 2i of the stream, as the docs say.
        let mut rng = SplitMix64::new(3);
        for i in 0..64 {
            assert_eq!(q[i], rng.unit());
            assert_eq!(p[i], rng.unit());
        }
    }

    #[test]
    fn an_unknown_name_is_reported_inside_the_string() {
        let errors = eval("0.5*sin(j*pi)", Half::Q, 4).unwrap_err();
        assert_eq!(errors.len(), 1, "{errors:?}");
        // `q = "0.5*sin(` is 13 bytes: `j` is at byte 13 of the file.
        assert_eq!(errors[0].0, 13..14, "{errors:?}");
        assert!(errors[0].1.contains("unknown variable `j`"), "{errors:?}");
    }

    #[test]
    fn the_state_itself_is_refused_at_its_name() {
        let errors = eval("i + q2", Half::P, 4).unwrap_err();
        assert_eq!(errors[0].0, 9..11, "{errors:?}");
        assert!(errors[0].1.contains("`q2` is the state it defines"));
    }

    #[test]
    fn a_value_that_is_not_finite_names_the_index() {
        let errors = eval("1/(i - 3)", Half::Q, 4).unwrap_err();
        assert!(errors[0].1.contains("not finite at i = 3"), "{errors:?}");
    }

    #[test]
    fn sizes_are_read_after_where() {
        let sizes = declared_sizes("sum(i = 1..N, p[i]^2) where N = 4, M = 2*N + 1, q[0] = 0");
        assert_eq!(sizes, vec![("N".into(), 4.0), ("M".into(), 9.0)]);
        assert!(declared_sizes("p1^2").is_empty());
    }

    #[test]
    fn csv_takes_the_last_row_by_column_name() {
        let text = "step,t,q1,q2,p1,p2\n0,0,1,2,3,4\n10,0.5,5,6,7,8\n";
        let (q, p, t) = csv_state(text, 2).unwrap();
        assert_eq!((q, p, t), (vec![5.0, 6.0], vec![7.0, 8.0], Some(0.5)));
        assert!(csv_state(text, 3).unwrap_err().contains("no column `q3`"));
        let bad = "q1,p1\n1,x\n";
        assert!(csv_state(bad, 1)
            .unwrap_err()
            .contains("line 2, column `p1`: `x`"));
        assert!(csv_state("q1,p1\n", 1).unwrap_err().contains("no row"));
    }
}
