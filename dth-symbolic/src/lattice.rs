//! The lattice of an indexed Hamiltonian: the sizes declared after `where`, the summation
//! indices in scope, the boundaries, and the integer arithmetic of indices.
//!
//! An index (`q[i + 1]`), a sum's bound (`1..N`) and a declared size (`N = 64`) are integer
//! expressions: integer literals, the indices of the enclosing sums, declared sizes, `+`, `-`,
//! `*` and parentheses. The lattice's sites are `1..n`, `n` the largest site the sums' indices
//! reach: a sum's index `i` up to `hi` reaches `a * hi`, `a` the largest coefficient of `i` in
//! the sum's accesses (`N` for `q[i]`, `q[i + 1]` and `i = 1..N`; `2N` for `p[2*i - 1]`,
//! `p[2*i]`). An indexed variable outside them must be defined by a boundary
//! (`q[0] = q[N+1] = 0`, `q[N+1] = q[1]`).

use std::collections::HashMap;

use crate::arena::Var;
use crate::check::reserved_name;
use crate::error::{Error, ErrorKind};
use crate::parser::{Ast, BinOp};
use crate::span::Span;

/// `text` without whitespace: an access or a range as the message shows it, the same for the
/// text given at run time and for the macro's tokens (which it reads spaced, `q [ i + 1 ]`).
pub(crate) fn compact(text: &str) -> String {
    text.split_whitespace().collect()
}

/// A boundary `q[site] = value` declared after `where`.
#[derive(Clone, Debug)]
pub(crate) struct Boundary {
    /// `'q'` or `'p'`.
    pub letter: char,
    /// The index it defines.
    pub site: i64,
    /// What the variable there stands for.
    pub value: Ast,
    /// The target as written.
    pub span: Span,
}

/// What the builder knows about indices while it builds (see the module docs).
#[derive(Clone, Debug, Default)]
pub(crate) struct Lattice {
    /// Declared sizes, in order.
    pub constants: Vec<(String, i64)>,
    /// The span of each declared size's value (`4096` in `N = 4096`), where an error about
    /// a bound `1..N` points.
    pub constant_spans: Vec<(String, Span)>,
    /// The indices of the enclosing sums and their current values, outermost first.
    pub bound: Vec<(String, i64)>,
    /// Per entry of `bound`: the largest coefficient of that index in an access built so far
    /// (`2` for `q[2*i - 1]`), at least 1. A sum's index `i` up to `hi` makes the lattice
    /// reach site `stride * hi`: `p[2*i-1]`, `p[2*i]` for `i = 1..N` make the sites `1..2N`.
    pub strides: Vec<i64>,
    /// The declared boundaries.
    pub boundaries: Vec<Boundary>,
    /// The largest upper bound of the sums built so far: the lattice's last site.
    pub last: Option<i64>,
    /// Per indexed access (its span): the largest index it reached, its letter, and the
    /// indices' values there (checked against [`Lattice::last`] when it is known).
    pub reached: HashMap<Span, (i64, char, String)>,
    /// Per indexed access (its span) that reached below site 1 without a boundary there: the
    /// lowest index, its letter, and the indices' values there (one error per access).
    pub below: HashMap<Span, (i64, char, String)>,
    /// Per sum (its range's span): whether any of its ranges had a site, and the range as
    /// written (a sum all of whose ranges are empty is an error).
    pub sums: HashMap<Span, (bool, String)>,
    /// Written-out positions and momenta (`q3`), with their spans.
    pub written: Vec<(Var, Span)>,
    /// `true` while a boundary's value is built (a boundary may not lead to another).
    pub in_boundary: bool,
    /// Set while one summand is built once for all its sites ([`crate::looped`]).
    pub local: Option<Local>,
}

/// A range's bound as written, for [`Lattice::too_large`].
pub(crate) struct Bound<'a> {
    /// The bound's expression.
    pub ast: &'a Ast,
    /// Its value.
    pub value: i64,
}

/// A summand built once, in local coordinates: each indexed variable `q[a i + b j + c]` is a
/// slot, the local coordinate `q<k>` (or `p<k>`) for the `k`-th distinct `q` (or `p`) slot.
#[derive(Clone, Debug, Default)]
pub(crate) struct Local {
    /// The sum's indices, outermost first: one for a sum over sites, two for a sum over pairs
    /// or a nested sum. They are the innermost entries of [`Lattice::bound`].
    pub indices: Vec<String>,
    /// The slots: letter, the coefficients `[a, b]` of the indices and the constant `c` of
    /// `q[a i + b j + c]`, in the order first met.
    pub slots: Vec<(char, [i64; 2], i64)>,
    /// The span of each slot's first access, in the order of `slots`.
    pub spans: Vec<Span>,
    /// Every access: its slot (a position in `slots`) and its span.
    pub accesses: Vec<(usize, Span)>,
    /// Why the summand cannot be built once for all sites, if it cannot.
    pub not_loopable: Option<&'static str>,
}

impl Local {
    /// The local coordinate of `letter[a i + b j + c]` (`coef = [a, b]`, `offset = c`), a new
    /// slot if not met yet.
    pub fn slot(&mut self, letter: char, coef: [i64; 2], offset: i64, span: Span) -> Var {
        let key = (letter, coef, offset);
        let slot = match self.slots.iter().position(|&s| s == key) {
            Some(slot) => slot,
            None => {
                self.slots.push(key);
                self.spans.push(span);
                self.slots.len() - 1
            }
        };
        self.accesses.push((slot, span));
        let k = self
            .slots
            .iter()
            .filter(|&&(l, ..)| l == letter)
            .position(|&s| s == key)
            .map_or(1, |k| k as u32 + 1);
        if letter == 'q' {
            Var::Q(k)
        } else {
            Var::P(k)
        }
    }
}

impl Lattice {
    /// The value of a bound index or a declared size named `name`.
    pub fn lookup(&self, name: &str) -> Option<i64> {
        self.bound
            .iter()
            .rev()
            .chain(self.constants.iter().rev())
            .find(|(n, _)| n == name)
            .map(|&(_, v)| v)
    }

    /// Where an error about the bound `ast` points: the declared size's value when the bound
    /// is a size's name (`4096` in `N = 4096` for `1..N`), else the bound as written.
    pub fn bound_span(&self, src: &str, ast: &Ast) -> Span {
        let mut inner = ast;
        while let Ast::Paren { inner: i, .. } = inner {
            inner = i;
        }
        if let Ast::Name(s) = inner {
            let name = &src[s.range()];
            let declared = self.bound.iter().all(|(n, _)| n != name);
            if let Some(&(_, span)) = self
                .constant_spans
                .iter()
                .rev()
                .find(|(n, _)| declared && n == name)
            {
                return span;
            }
        }
        ast.span()
    }

    /// The error for a range `lo..=hi` reaching beyond site `limit` (the lattice `1..hi` has
    /// `hi` sites), at the upper bound, or with more than twice `limit` terms, at the lower
    /// one. A valid range may start below site 1 (the bond sum `0..N` of a chain with fixed
    /// ends has `N + 1` terms on `N` sites; accesses below the lattice are errors of their
    /// own), so its term count may pass `limit` by the reach of its offsets but never by
    /// `limit`: twice the limit only refuses runaway work. Counted in `i128`, so no range
    /// overflows.
    pub fn too_large(
        &self,
        src: &str,
        lo: Bound<'_>,
        hi: Bound<'_>,
        limit: usize,
    ) -> Option<Error> {
        let max = i128::try_from(limit).unwrap_or(i128::MAX);
        let count = i128::from(hi.value) - i128::from(lo.value) + 1;
        let (sites, at) = if i128::from(hi.value) > max {
            (i128::from(hi.value), hi.ast)
        } else if count > max.saturating_mul(2) {
            (count, lo.ast)
        } else {
            return None;
        };
        Some(Error::new(
            ErrorKind::LatticeTooLarge { sites, limit },
            self.bound_span(src, at),
        ))
    }

    /// The bound indices and their values, `i = 3, j = 5`.
    pub fn at(&self) -> String {
        let parts: Vec<String> = self
            .bound
            .iter()
            .map(|(n, v)| format!("{n} = {v}"))
            .collect();
        parts.join(", ")
    }

    /// Why `name` cannot name an index or a size, if it cannot: a name of the grammar, a
    /// declared parameter, or one already in scope.
    pub fn bad_name(&self, name: &str, params: &[String]) -> Option<&'static str> {
        if reserved_name(name).is_some() {
            Some("is a name of the grammar: choose another (`i`, `j`, `k`, `N`, ...)")
        } else if params.iter().any(|p| p == name) {
            Some("is a declared parameter: indices and sizes need their own names")
        } else if self.lookup(name).is_some() {
            Some("is already an index or a size here")
        } else {
            None
        }
    }

    /// The integer value of `ast`, an index expression (`params`: the declared parameters,
    /// which are numbers but not integers known when compiling).
    pub fn int(&self, src: &str, ast: &Ast, params: &[String]) -> Result<i64, Error> {
        let not_an_index = |a: &Ast| {
            Error::new(
                ErrorKind::NotAnIndex {
                    text: compact(&src[a.span().range()]),
                },
                a.span(),
            )
        };
        match ast {
            Ast::Number(s) => {
                let text = &src[s.range()];
                match text.parse::<i64>() {
                    Ok(v) if text.bytes().all(|b| b.is_ascii_digit()) => Ok(v),
                    _ => Err(not_an_index(ast)),
                }
            }
            Ast::Name(s) => {
                let name = &src[s.range()];
                if let Some(v) = self.lookup(name) {
                    return Ok(v);
                }
                if reserved_name(name).is_some() || params.iter().any(|p| p == name) {
                    return Err(not_an_index(ast));
                }
                let bound: Vec<String> = self.bound.iter().map(|(n, _)| format!("`{n}`")).collect();
                Err(Error::new(
                    ErrorKind::UnboundIndex {
                        name: name.to_string(),
                        bound: bound.join(", "),
                    },
                    *s,
                ))
            }
            Ast::Paren { inner, .. } => self.int(src, inner, params),
            Ast::Unary { negate, arg, .. } => {
                let v = self.int(src, arg, params)?;
                if *negate {
                    v.checked_neg().ok_or_else(|| not_an_index(ast))
                } else {
                    Ok(v)
                }
            }
            Ast::Chain { first, rest } => {
                let mut v = self.int(src, first, params)?;
                for (op, _, x) in rest {
                    let x_value = self.int(src, x, params)?;
                    v = match op {
                        BinOp::Add => v.checked_add(x_value),
                        BinOp::Sub => v.checked_sub(x_value),
                        BinOp::Mul => v.checked_mul(x_value),
                        BinOp::Div | BinOp::Pow => return Err(not_an_index(ast)),
                    }
                    .ok_or_else(|| not_an_index(ast))?;
                }
                Ok(v)
            }
            _ => Err(not_an_index(ast)),
        }
    }

    /// The boundary defining `letter[site]`, if one does.
    pub fn boundary(&self, letter: char, site: i64) -> Option<&Boundary> {
        self.boundaries
            .iter()
            .find(|b| b.letter == letter && b.site == site)
    }

    /// The errors only the whole lattice shows, once everything is built: accesses and
    /// written-out coordinates beyond the last site, boundaries inside the lattice, sums whose
    /// every range was empty. `src` is the source, for the accesses as written.
    pub fn finish(&self, src: &str) -> Vec<Error> {
        let mut errors = Vec::new();
        for (span, (_, range)) in self.sums.iter().filter(|(_, (any, _))| !any) {
            errors.push(Error::new(
                ErrorKind::EmptySum {
                    range: range.clone(),
                },
                *span,
            ));
        }
        // Accesses below site 1 (with no boundary there), and beyond the last site.
        let beyond = self
            .reached
            .iter()
            .filter(|(_, (site, ..))| self.last.is_some_and(|last| *site > last));
        for (span, (site, letter, at)) in self.below.iter().chain(beyond) {
            errors.push(Error::new(
                ErrorKind::IndexOutOfRange {
                    access: compact(&src[span.range()]),
                    letter: *letter,
                    site: *site,
                    at: at.clone(),
                    last: self.last,
                },
                *span,
            ));
        }
        let Some(last) = self.last else {
            return errors;
        };
        for &(v, span) in &self.written {
            if let Var::Q(k) | Var::P(k) = v {
                if i64::from(k) > last {
                    errors.push(Error::new(
                        ErrorKind::MixedIndexing {
                            name: compact(&src[span.range()]),
                            last,
                        },
                        span,
                    ));
                }
            }
        }
        for b in &self.boundaries {
            if (1..=last).contains(&b.site) {
                errors.push(Error::new(
                    ErrorKind::BadBoundary {
                        name: compact(&src[b.span.range()]),
                        reason: format!(
                            "is inside the lattice 1..{last}: boundaries define sites below 1 or above {last}"
                        ),
                    },
                    b.span,
                ));
            }
        }
        errors
    }
}
