//! `[system] regularize = "levi-civita" | "ks"` and `centre`: method `dth` runs on the
//! regularized `K = |u|^2 (H + p_t)` of a Hamiltonian given as text (see
//! `crate::regularized`), with every error located in the scene file.
//!
//! ```toml
//! [system]
//! hamiltonian = "(p1^2 + p2^2)/2 - 0.99*((q1 + 0.01)^2 + q2^2)^(-1/2) - 0.01*((q1 - 0.99)^2 + q2^2)^(-1/2)"
//! regularize = "levi-civita"    # planar; "ks" (Kustaanheimo-Stiefel) in space
//! centre = [0.99, 0.0]           # optional: the point of the close approaches (default: the origin)
//! ```
//!
//! A catalogue system with a text (`kepler`; `dth list` shows which) is regularized as its
//! text is, and runs everything but method `dth` as the compiled system, its invariants and
//! exact solution included (`crate::system::Regularizable`).
//!
//! Refused, each at the key or value concerned: an unknown map; a catalogue system without a
//! text (compiled Rust only, which the engine cannot rewrite: write it as `hamiltonian`); a Hamiltonian
//! of the wrong size for the map (Levi-Civita maps `n = 2`, KS `n = 3`); a centre of the wrong
//! length or not finite, or without `regularize`; what the engine refuses (a text that uses
//! `t`); a scene without method `dth` (nothing would be regularized); and, in
//! `super::validate`, an initial `q` at the centre, where the momenta have no regularized
//! image.

use std::ops::Range;

use toml::Spanned;

use super::members::Errors;
use super::schema::{Regularization, RegularizeMap};
use dth_symbolic::lexer::{lex, TokenKind};

/// What [`check`] needs of the rest of the scene.
pub(super) struct Context<'a> {
    /// The system's name, for messages.
    pub(super) name: &'a str,
    /// `false` when the system is unknown or its text has errors (reported already).
    pub(super) known: bool,
    /// `true` when the scene has a method `dth`.
    pub(super) has_dth: bool,
    /// The initial `q` and its span in the file, when given.
    pub(super) q: Option<(&'a [f64], Range<usize>)>,
}

/// The Hamiltonian [`check`] regularizes: its text (a scene's `hamiltonian`, or a catalogue
/// system's own, `catalogue::SystemEntry::with_text`), its degrees of freedom and the names of
/// its parameters.
pub(super) struct Text<'a> {
    pub(super) source: &'a str,
    pub(super) n: usize,
    pub(super) params: &'a [&'a str],
}

/// Reads `regularize` and `centre` of a `[system]` whose Hamiltonian is `text` (`None`: a
/// catalogue system without one); `None` when there is no regularization, or with every
/// independent error pushed to `errors`.
pub(super) fn check(
    (regularize, centre): (Option<&Spanned<String>>, Option<&Spanned<Vec<f64>>>),
    text: Option<Text<'_>>,
    scene: Context<'_>,
    errors: &mut Errors,
) -> Option<Regularization> {
    let Some(regularize) = regularize else {
        if let Some(c) = centre {
            errors.push((
                c.span(),
                "`centre` is the centre of a regularization: give `regularize` (\"levi-civita\" or \"ks\") too, or remove it".to_string(),
            ));
        }
        return None;
    };
    if !scene.known {
        return None;
    }
    let (name, has_dth) = (scene.name, scene.has_dth);
    let at = regularize.span();
    let Some(map) = RegularizeMap::from_name(regularize.get_ref()) else {
        errors.push((
            at.clone(),
            format!(
                "unknown regularization `{}`: expected \"levi-civita\" (planar, n = 2) or \"ks\" (Kustaanheimo-Stiefel, in space, n = 3)",
                regularize.get_ref()
            ),
        ));
        return None;
    };
    let Some(h) = text else {
        errors.push((
            at.clone(),
            format!(
                "`regularize` rewrites a Hamiltonian's text, and `{name}` is a catalogue system compiled from Rust without one: give its H as `hamiltonian = \"...\"` instead of `name`"
            ),
        ));
        return None;
    };
    let params = h.params;
    if !has_dth {
        errors.push((
            at.clone(),
            "`regularize` applies to method `dth` (the peers run on H itself), and the scene has none: add a `dth` method or remove `regularize`".to_string(),
        ));
    }
    if h.n != map.n() {
        let other = RegularizeMap::ALL
            .into_iter()
            .find(|m| m.n() == h.n)
            .map_or(String::new(), |m| format!(": use \"{}\"", m.name()));
        errors.push((
            at.clone(),
            format!(
                "`{}` regularizes a Hamiltonian of n = {} degrees of freedom, and `{name}` has n = {}{other}",
                map.name(),
                map.n(),
                h.n
            ),
        ));
        return None;
    }
    let centre_at = centre.map_or(at.clone(), |c| c.span());
    let centre = match centre {
        None => vec![0.0; map.n()],
        Some(c) => {
            let values = c.get_ref();
            if values.len() != map.n() {
                errors.push((
                    c.span(),
                    format!(
                        "`centre` has {} value{}, but `{name}` has n = {} degrees of freedom: expected {}",
                        values.len(),
                        if values.len() == 1 { "" } else { "s" },
                        map.n(),
                        map.n()
                    ),
                ));
                return None;
            }
            if let Some(i) = values.iter().position(|x| !x.is_finite()) {
                errors.push((c.span(), format!("`centre[{i}]` is not finite")));
                return None;
            }
            values.clone()
        }
    };
    // What the engine makes of the translated text (it refuses a text that uses `t`).
    let source = match translated(h.source, &centre) {
        Ok(source) => source,
        Err(e) => {
            errors.push((centre_at, e.to_string()));
            return None;
        }
    };
    if let Err(refused) = map.symbolic()(&source, params) {
        for e in &refused.0 {
            errors.push((
                at.clone(),
                format!("`{name}` cannot be regularized by {}: {e}", map.name()),
            ));
        }
        return None;
    }
    if let Some((q, span)) = scene.q {
        if q == centre.as_slice() {
            errors.push((
                span,
                format!(
                    "initial `q` = {q:?} is the centre of the regularization, the collision, where the momenta have no regularized image: start away from it"
                ),
            ));
        }
    }
    Some(Regularization {
        map,
        centre,
        source: h.source.to_string(),
    })
}

/// A centre given with a text that indexes `q[..]` (in a sum): [`translated`] rewrites only
/// the coordinates written out.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error("a centre translates the coordinates written out (q1, q2, q3), and this text indexes `q[..]`: write them out")]
pub struct IndexedCentre;

/// The text `source` with every `q_i` written as `(q_i + c_i)` (`(q_i - |c_i|)` for a
/// negative `c_i`; unchanged where `c_i = 0`): the translation `q = c + q'` that puts the
/// centre `c` at the origin of a regularizing map (`crate::regularized`). Each `c_i`
/// is written with the fewest digits that read back as it (Rust's `{:?}`), which the engine
/// reads as an exact decimal.
///
/// # Errors
/// [`IndexedCentre`] when the text indexes `q[..]` (in a sum) while the centre is not the
/// origin: only coordinates written out (`q1`, `q2`, `q3`) are translated.
///
/// ```
/// use dth_examples::scene::translated;
/// assert_eq!(
///     translated("((q1 - 0.99)^2 + q2^2)^(-1/2)", &[0.99, 0.0]).unwrap(),
///     "(((q1 + 0.99) - 0.99)^2 + q2^2)^(-1/2)"
/// );
/// assert_eq!(translated("q1 + q2", &[-0.5, 2.0]).unwrap(), "(q1 - 0.5) + (q2 + 2.0)");
/// ```
pub fn translated(source: &str, centre: &[f64]) -> Result<String, IndexedCentre> {
    if centre.iter().all(|&c| c == 0.0) {
        return Ok(source.to_string());
    }
    let (tokens, _) = lex(source);
    let mut out = String::with_capacity(source.len() + 16 * centre.len());
    let mut at = 0;
    for (k, token) in tokens.iter().enumerate() {
        if token.kind != TokenKind::Ident {
            continue;
        }
        let range = token.span.range();
        let name = &source[range.clone()];
        let indexed = tokens
            .get(k + 1)
            .is_some_and(|next| next.kind == TokenKind::LBracket);
        if name == "q" && indexed {
            return Err(IndexedCentre);
        }
        let Some(c) = name
            .strip_prefix('q')
            .and_then(|i| i.parse::<usize>().ok())
            .filter(|&i| i >= 1)
            .and_then(|i| centre.get(i - 1))
            .filter(|c| **c != 0.0)
        else {
            continue;
        };
        let sign = if *c < 0.0 { '-' } else { '+' };
        out.push_str(&source[at..range.start]);
        out.push_str(&format!("({name} {sign} {:?})", c.abs()));
        at = range.end;
    }
    out.push_str(&source[at..]);
    Ok(out)
}
