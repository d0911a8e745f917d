//! The rules of the grammar's names, and the structural checks on a built Hamiltonian.

use crate::arena::{Arena, Func, Id, Var};
use crate::error::{Error, ErrorKind, Warning, WarningKind};
use crate::lexer::{Token, TokenKind};
use crate::span::Span;

/// What a name in the source denotes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Name {
    /// A variable or parameter.
    Var(Var),
    /// `pi`.
    Pi,
    /// A function (only valid when called).
    Func(Func),
}

/// Resolves a name: `q<i>`, `p<i>` (`i >= 1`, no leading zero, at most [`crate::MAX_INDEX`]),
/// `t`, `pi`, a function name, or a declared parameter.
pub fn resolve(name: &str, params: &[String]) -> Result<Name, ErrorKind> {
    if let Some(k) = params.iter().position(|p| p == name) {
        return Ok(Name::Var(Var::Param(k as u32)));
    }
    match name {
        "t" => return Ok(Name::Var(Var::T)),
        "pi" => return Ok(Name::Pi),
        "e" => return Err(ErrorKind::EulerNumber { exponent: None }),
        _ => {}
    }
    if let Some(f) = Func::ALL.iter().find(|f| f.name() == name) {
        return Ok(Name::Func(*f));
    }
    if name == "sqrt" || name == "sum" {
        // `sqrt` is the power 1/2: the builder handles it; as a bare name it is a function.
        return Err(ErrorKind::FunctionWithoutCall {
            name: name.to_string(),
        });
    }
    let (head, digits) = name.split_at(1.min(name.len()));
    if (head == "q" || head == "p")
        && !digits.is_empty()
        && digits.bytes().all(|b| b.is_ascii_digit())
    {
        if digits.starts_with('0') {
            return Err(ErrorKind::BadIndex {
                name: name.to_string(),
            });
        }
        let i: u32 = match digits.parse() {
            Ok(i) if i as usize <= crate::MAX_INDEX => i,
            _ => {
                return Err(ErrorKind::IndexTooLarge {
                    name: name.to_string(),
                })
            }
        };
        return Ok(Name::Var(if head == "q" { Var::Q(i) } else { Var::P(i) }));
    }
    Err(ErrorKind::UnknownVariable {
        name: name.to_string(),
    })
}

/// Why `name` cannot be a parameter, if it cannot: it is a name of the grammar already.
pub fn reserved_name(name: &str) -> Option<&'static str> {
    match resolve(name, &[]) {
        Ok(Name::Var(_)) | Err(ErrorKind::BadIndex { .. } | ErrorKind::IndexTooLarge { .. }) => {
            Some("is a phase-space variable (q1..qN, p1..pN, t)")
        }
        Ok(Name::Pi) => Some("is the constant pi"),
        Ok(Name::Func(_)) | Err(ErrorKind::FunctionWithoutCall { .. }) => {
            Some("is a function of the grammar")
        }
        _ if name == "where" => Some("is a word of the grammar"),
        _ => None,
    }
}

/// Structural checks on `H` (before `p_t` is added): it must depend on a momentum, and so
/// on some variable at all. Parameters do not count: they are constants for the flow.
pub fn structure(arena: &Arena, h: Id, whole: Span) -> Vec<Error> {
    let vars = arena.vars(h);
    if !vars
        .iter()
        .any(|v| matches!(v, Var::Q(_) | Var::P(_) | Var::T))
    {
        return vec![Error::new(ErrorKind::ConstantHamiltonian, whole)];
    }
    if !vars.iter().any(|v| matches!(v, Var::P(_))) {
        return vec![Error::new(ErrorKind::NoMomentum, whole)];
    }
    Vec::new()
}

/// The numbering of the coordinates, from the variables written in the source (`written`:
/// each variable with the span of its first occurrence). `n` is the largest index: an index
/// below it with neither `q<i>` nor `p<i>` is an error at the variable that sets `n` (a gap
/// is a misnumbering: the pair would only sit still). A `q<i>` without `p<i>` is legal but a
/// warning (it never moves). A `p<i>` without `q<i>` is a cyclic coordinate (an angle, a free
/// particle) and fine, unless some position lacks its momentum too: then it is a warning, as
/// the pair of mistakes looks like a misnumbering. Consecutive indices with the same verdict
/// and the same first occurrence (one access of a sum, `q[i]`, over a run of sites) make one
/// error or warning for the run, not one per site.
pub fn indices(written: &[(Var, Span)]) -> (Vec<Error>, Vec<Warning>) {
    let find = |v: Var| written.iter().find(|(w, _)| *w == v).map(|&(_, s)| s);
    let largest = written
        .iter()
        .filter_map(|&(v, s)| match v {
            Var::Q(i) | Var::P(i) => Some((i, v, s)),
            _ => None,
        })
        .max_by_key(|&(i, _, s)| (i, std::cmp::Reverse(s.start)));
    let Some((n, top, top_span)) = largest else {
        return (Vec::new(), Vec::new());
    };
    let largest = if matches!(top, Var::Q(_)) { 'q' } else { 'p' };
    // Runs `(first, last, span)` of the indices missing both, a `q` only, a `p` only.
    let (mut skipped, mut frozen, mut cyclic) = (Vec::new(), Vec::new(), Vec::new());
    for i in 1..=n {
        let (run, span) = match (find(Var::Q(i)), find(Var::P(i))) {
            (None, None) => (&mut skipped, top_span),
            (None, Some(span)) => (&mut cyclic, span),
            (Some(span), None) => (&mut frozen, span),
            (Some(_), Some(_)) => continue,
        };
        extend_run(run, i, span);
    }
    let errors = skipped
        .iter()
        .map(|&(first, last, span)| {
            let kind = if first == last {
                ErrorKind::SkippedIndex {
                    missing: first,
                    largest,
                    n,
                }
            } else {
                ErrorKind::SkippedIndices {
                    first,
                    last,
                    largest,
                    n,
                }
            };
            Error::new(kind, span)
        })
        .collect();
    let mut warnings: Vec<Warning> = frozen
        .iter()
        .map(|&(first, last, span)| Warning {
            kind: if first == last {
                WarningKind::FrozenCoordinate { index: first }
            } else {
                WarningKind::FrozenCoordinates { first, last }
            },
            span,
        })
        .collect();
    if let Some(&(position, _, _)) = frozen.first() {
        warnings.extend(cyclic.iter().map(|&(first, last, span)| Warning {
            kind: if first == last {
                WarningKind::Misnumbered {
                    momentum: first,
                    position,
                }
            } else {
                WarningKind::MisnumberedMomenta {
                    first,
                    last,
                    position,
                }
            },
            span,
        }));
    }
    warnings.sort_by_key(|w| w.span.start);
    (errors, warnings)
}

/// Adds index `i` to `runs`: to the last run when it ends at `i - 1` with the same span.
fn extend_run(runs: &mut Vec<(u32, u32, Span)>, i: u32, span: Span) {
    match runs.last_mut() {
        Some(last) if last.1 + 1 == i && last.2 == span => last.1 = i,
        _ => runs.push((i, i, span)),
    }
}

/// The errors of the names in `tokens`, read without a syntax tree (after a syntax error, so
/// they are reported with it): names that denote nothing, calls of unknown functions and of
/// variables. Bare function names are left out: the syntax error is usually about them.
pub fn name_errors(src: &str, tokens: &[Token], params: &[&str]) -> Vec<Error> {
    let params: Vec<String> = params.iter().map(|p| p.to_string()).collect();
    let kind_at = |k: usize| tokens.get(k).map(|t| t.kind);
    // Indices and sizes are names the grammar binds: `i = ..`, `N = ..`, `i < j`.
    let binds = |k: usize| {
        matches!(
            kind_at(k + 1),
            Some(TokenKind::Eq | TokenKind::Lt | TokenKind::Le)
        ) || k > 0 && matches!(kind_at(k - 1), Some(TokenKind::Lt | TokenKind::Le))
    };
    // ... and so are the first argument of `sum(` and the names inside an index `[...]`.
    let sum_argument = |k: usize| {
        k >= 2
            && kind_at(k - 1) == Some(TokenKind::LParen)
            && &src[tokens[k - 2].span.range()] == "sum"
    };
    let mut depth = 0usize;
    let mut bound: Vec<&str> = Vec::new();
    for (k, t) in tokens.iter().enumerate() {
        match t.kind {
            TokenKind::LBracket => depth += 1,
            TokenKind::RBracket => depth = depth.saturating_sub(1),
            TokenKind::Ident if binds(k) || sum_argument(k) || depth > 0 => {
                bound.push(&src[t.span.range()])
            }
            _ => {}
        }
    }
    let mut errors = Vec::new();
    for (k, t) in tokens.iter().enumerate() {
        if t.kind != TokenKind::Ident {
            continue;
        }
        let name = &src[t.span.range()];
        // `where`, an indexed variable's letter, and names bound somewhere are no variables.
        if name == "where" || kind_at(k + 1) == Some(TokenKind::LBracket) || bound.contains(&name) {
            continue;
        }
        let called = kind_at(k + 1) == Some(TokenKind::LParen);
        let kind = match (resolve(name, &params), called) {
            (Ok(Name::Func(_)), _) | (Err(ErrorKind::FunctionWithoutCall { .. }), _) => continue,
            (Ok(_), false) => continue,
            (Ok(_) | Err(ErrorKind::BadIndex { .. } | ErrorKind::IndexTooLarge { .. }), true) => {
                ErrorKind::NotAFunction {
                    name: name.to_string(),
                }
            }
            (Err(_), true) => ErrorKind::UnknownFunction {
                name: name.to_string(),
            },
            (Err(ErrorKind::EulerNumber { .. }), false) => {
                // `e^x`: suggest `exp(x)` for a one-token exponent, `exp(...)` for another
                // (without a tree, its extent is unknown).
                let exponent = match (kind_at(k + 1), tokens.get(k + 2)) {
                    (Some(TokenKind::Caret), Some(x))
                        if matches!(x.kind, TokenKind::Ident | TokenKind::Number) =>
                    {
                        Some(src[x.span.range()].to_string())
                    }
                    (Some(TokenKind::Caret), _) => Some("...".to_string()),
                    _ => None,
                };
                ErrorKind::EulerNumber { exponent }
            }
            (Err(kind), false) => kind,
        };
        errors.push(Error::new(kind, t.span));
    }
    errors
}
