//! `[system] hamiltonian = "..."`: a Hamiltonian given as text, read by the symbolic engine
//! that `hamiltonian!` uses (one grammar, the same messages), with every error located in the
//! scene file.
//!
//! ```toml
//! [system]
//! title = "Morse oscillator"                       # optional: names it in reports
//! hamiltonian = "p1^2/(2*m) + d*(1 - exp(-a*q1))^2"
//! params = { m = 1.0, d = 1.0, a = 1.0 }          # every name the expression uses
//! ```
//!
//! - An error in the expression is reported at the offending token, inside the TOML string
//!   (escapes and multi-line strings are mapped back: [`super::toml_string`]).
//! - A name the expression uses but `params` lacks is the engine's unknown variable, at the
//!   name; a parameter given but not used, or not finite, is reported at its key or value; a
//!   parameter name the grammar reserves (`t`, `q1`, `sin`, ...) at its key.
//! - The dimension and the flags (time dependence, separability, Psi identically zero) come
//!   from the engine ([`TextHamiltonian`]); validation checks the initial state, the methods
//!   and the effects against them as for a catalogue system.

use std::collections::BTreeMap;
use std::ops::Range;

use dth::runtime::RuntimeError;
use dth_symbolic::lexer::{lex, TokenKind};
use dth_symbolic::ErrorKind;
use toml::Spanned;

use super::members::Errors;
use super::schema::TextHamiltonian;
use super::sizes::Origin;
use super::toml_string::StringPositions;

/// Reads the expression `source` (the spanned TOML string in `text`) with the parameters
/// `params` and the sizes `sizes` (`super::sizes`): the Hamiltonian and the parameter values,
/// or `None` with every independent error pushed to `errors` (file byte ranges and messages).
/// The engine's warnings go to `warnings` in the same form (the returned Hamiltonian's own
/// list is left for the caller to locate).
pub(super) fn check(
    text: &str,
    source: &Spanned<String>,
    params: &BTreeMap<Spanned<String>, Spanned<f64>>,
    sizes: &BTreeMap<Spanned<String>, Spanned<i64>>,
    errors: &mut Errors,
    warnings: &mut Errors,
) -> Option<(TextHamiltonian, BTreeMap<String, f64>)> {
    let written = source.get_ref().as_str();
    let sized = super::sizes::apply(written, sizes, errors)?;
    let expression = sized.source.as_str();
    let positions = StringPositions::new(text, source.span(), written);
    // Byte range of the expression -> file range (a size the scene set: its value there);
    // the opening quote if the literal could not be mapped (it always can for what the TOML
    // parser accepts: see `toml_string`).
    let at = |range: Range<usize>| match (sized.origin(range), &positions) {
        (Origin::Scene(value), _) => value,
        (Origin::Text(range), Some(p)) => p.range(range),
        (Origin::Text(_), None) => source.span().start..source.span().start,
    };
    // In file order, so that the engine reports parameter errors in the order written.
    let mut given: Vec<(&Spanned<String>, &Spanned<f64>)> = params.iter().collect();
    given.sort_by_key(|(k, _)| k.span().start);
    let names: Vec<&str> = given.iter().map(|(k, _)| k.get_ref().as_str()).collect();
    let key = |name: &str| {
        given
            .iter()
            .find(|(k, _)| k.get_ref() == name)
            .map_or(source.span(), |(k, _)| k.span())
    };

    // A lattice whose sums loop is read as `dth::runtime` compiles it (in loops, any size up
    // to `dth_symbolic::MAX_SITES`); everything else, errors included, site by site.
    let system = match dth_symbolic::looped::loops(expression, &names) {
        Some(lattice) => {
            for w in lattice.warnings() {
                warnings.push((at(w.span.range()), w.to_string()));
            }
            let (separable, psi_identically_zero) = lattice.flags();
            Some(Shape {
                n: lattice.n(),
                dim: lattice.dim(),
                // Looped sums do not use `t` (the loop path refuses it).
                time_dependent: false,
                separable,
                psi_identically_zero,
            })
        }
        None => match dth_symbolic::compile(expression, &names) {
            Ok(system) => {
                for w in system.warnings() {
                    warnings.push((at(w.span.range()), w.to_string()));
                }
                Some(Shape {
                    n: system.n(),
                    dim: system.dim(),
                    time_dependent: system.time_dependent(),
                    separable: system.separable(),
                    psi_identically_zero: system.psi_identically_zero(),
                })
            }
            Err(e) => {
                for e in &e.0 {
                    // A parameter's error is about a name beside the text: at its key.
                    let span = match &e.kind {
                        ErrorKind::BadParameter { name, .. } => key(name),
                        _ => at(e.span.range()),
                    };
                    errors.push((span, e.to_string()));
                }
                None
            }
        },
    };

    // Parameters the text does not name (a typo, a parameter of another model), as
    // `RuntimeHamiltonian::new` refuses them, and values that are not finite.
    let (tokens, _) = lex(expression);
    let mut values = BTreeMap::new();
    let mut bad = false;
    for (k, v) in &given {
        let name = k.get_ref().as_str();
        let named = tokens
            .iter()
            .any(|t| t.kind == TokenKind::Ident && &expression[t.span.range()] == name);
        if !named && dth_symbolic::reserved_name(name).is_none() {
            let name = name.to_string();
            errors.push((
                k.span(),
                RuntimeError::UnknownParameter { name }.to_string(),
            ));
            bad = true;
        }
        if !v.get_ref().is_finite() {
            let (name, value) = (name.to_string(), *v.get_ref());
            errors.push((
                v.span(),
                RuntimeError::NonFiniteParameter { name, value }.to_string(),
            ));
            bad = true;
        }
        values.insert(name.to_string(), *v.get_ref());
    }
    let system = system.filter(|_| !bad)?;
    Some((
        TextHamiltonian {
            source: expression.to_string(),
            n: system.n,
            dim: system.dim,
            time_dependent: system.time_dependent,
            separable: system.separable,
            psi_identically_zero: system.psi_identically_zero,
            warnings: Vec::new(),
        },
        values,
    ))
}

/// What validation needs of a compiled text, written out or in loops.
struct Shape {
    n: usize,
    dim: usize,
    time_dependent: bool,
    separable: bool,
    psi_identically_zero: bool,
}
