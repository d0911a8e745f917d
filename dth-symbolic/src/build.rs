//! Builds the arena from the syntax tree, resolving names and folding constants. Every
//! independent error is collected; a subtree with an error is skipped, so its parents add none.
//!
//! Sums are built site by site: `sum(i = 1..N, f(i))` becomes the sum of `f(1)..f(N)`, each
//! indexed variable `q[i + 1]` the written-out `q<i+1>` (or its boundary's value), so the
//! arena, the derivatives and the programs are those of the written-out Hamiltonian.

use crate::arena::{Arena, Id, Var};
use crate::check::{resolve, Name};
use crate::error::{Error, ErrorKind};
use crate::lattice::{compact, Bound, Boundary, Lattice};
use crate::number::{parse_literal, Fault, LiteralError, Num};
use crate::parser::{operand_text, Ast, BinOp, Decl, Range};
use crate::span::Span;

pub(crate) struct Builder<'a> {
    pub src: &'a str,
    pub arena: Arena,
    pub errors: Vec<Error>,
    pub lattice: Lattice,
}

impl Builder<'_> {
    /// The node for `ast`, or `None` when it (or a part of it) is in error.
    pub fn build(&mut self, ast: &Ast) -> Option<Id> {
        let span = ast.span();
        let result = match ast {
            Ast::Number(s) => {
                let text = &self.src[s.range()];
                match parse_literal(text) {
                    Ok(n) => Ok(self.arena.num(n)),
                    Err(e) => {
                        let text = text.to_string();
                        let kind = match e {
                            LiteralError::Invalid => ErrorKind::InvalidNumber { text },
                            LiteralError::Overflow => ErrorKind::LiteralOverflow { text },
                            LiteralError::Underflow => ErrorKind::LiteralUnderflow { text },
                        };
                        self.errors.push(Error::new(kind, *s));
                        return None;
                    }
                }
            }
            Ast::Name(s)
                if self
                    .lattice
                    .local
                    .as_ref()
                    .is_some_and(|l| l.indices.iter().any(|i| *i == self.src[s.range()])) =>
            {
                if let Some(local) = self.lattice.local.as_mut() {
                    local.not_loopable = Some("the sum's index is used as a number");
                }
                return None;
            }
            Ast::Name(s) if self.lattice.lookup(&self.src[s.range()]).is_some() => {
                // An index or a size as a number (`sum(i = 1..N, i*q[i]^2)`).
                let v = self.lattice.lookup(&self.src[s.range()]).unwrap_or(0);
                self.arena.span = *s;
                Ok(self.arena.num(Num::int(i128::from(v))))
            }
            Ast::Index { name, index, span } => return self.indexed(*name, index, *span),
            Ast::Sum { .. } if self.lattice.local.is_some() => {
                if let Some(local) = self.lattice.local.as_mut() {
                    local.not_loopable = Some("sums are nested");
                }
                return None;
            }
            Ast::Sum { range, body, .. } => return self.sum(range, body),
            Ast::Where { body, decls } => return self.declared(body, decls),
            Ast::Name(s) => {
                let params = self.arena.params().to_vec();
                match resolve(&self.src[s.range()], &params) {
                    Ok(Name::Var(v)) => {
                        if let (Some(local), Var::Q(_) | Var::P(_) | Var::T) =
                            (self.lattice.local.as_mut(), v)
                        {
                            local.not_loopable =
                                Some("a summand uses a written-out coordinate or `t`");
                            return None;
                        }
                        if matches!(v, Var::Q(_) | Var::P(_)) {
                            self.lattice.written.push((v, *s));
                        }
                        self.arena.span = *s;
                        Ok(self.arena.var(v))
                    }
                    Ok(Name::Pi) => Ok(self.arena.num(Num::Float(std::f64::consts::PI))),
                    Ok(Name::Func(f)) => {
                        self.errors.push(Error::new(
                            ErrorKind::FunctionWithoutCall {
                                name: f.name().to_string(),
                            },
                            *s,
                        ));
                        return None;
                    }
                    Err(kind) => {
                        self.errors.push(Error::new(kind, *s));
                        return None;
                    }
                }
            }
            Ast::Call {
                name, arg, extra, ..
            } if !extra.is_empty() => {
                let text = &self.src[name.range()];
                let params = self.arena.params().to_vec();
                let kind = match resolve(text, &params) {
                    _ if text == "pow" && extra.len() == 1 => ErrorKind::PowFunction {
                        power: format!(
                            "{}^{}",
                            operand_text(self.src, arg),
                            operand_text(self.src, &extra[0])
                        ),
                    },
                    Ok(Name::Func(_)) | Err(ErrorKind::FunctionWithoutCall { .. }) => {
                        ErrorKind::TooManyArguments {
                            name: text.to_string(),
                            found: 1 + extra.len(),
                        }
                    }
                    Ok(_) | Err(ErrorKind::BadIndex { .. } | ErrorKind::IndexTooLarge { .. }) => {
                        ErrorKind::NotAFunction {
                            name: text.to_string(),
                        }
                    }
                    Err(_) => ErrorKind::UnknownFunction {
                        name: text.to_string(),
                    },
                };
                // The extra arguments are the offending piece of a known function's call.
                let at = match &kind {
                    ErrorKind::TooManyArguments { .. } => {
                        extra[0].span().to(extra[extra.len() - 1].span())
                    }
                    _ => *name,
                };
                self.errors.push(Error::new(kind, at));
                self.build(arg);
                for x in extra {
                    self.build(x);
                }
                return None;
            }
            Ast::Call { name, arg, .. } => {
                let text = &self.src[name.range()];
                let params = self.arena.params().to_vec();
                let f = match resolve(text, &params) {
                    Ok(Name::Func(f)) => Some(f),
                    _ if text == "sqrt" => None,
                    Ok(_) | Err(ErrorKind::BadIndex { .. } | ErrorKind::IndexTooLarge { .. }) => {
                        self.errors.push(Error::new(
                            ErrorKind::NotAFunction {
                                name: text.to_string(),
                            },
                            *name,
                        ));
                        self.build(arg);
                        return None;
                    }
                    Err(_) => {
                        self.errors.push(Error::new(
                            ErrorKind::UnknownFunction {
                                name: text.to_string(),
                            },
                            *name,
                        ));
                        self.build(arg);
                        return None;
                    }
                };
                let x = self.build(arg)?;
                self.arena.span = span;
                match f {
                    Some(f) => self.arena.func(f, x),
                    None => self
                        .arena
                        .pow(x, Num::Rat(crate::number::Rational::new(1, 2)?)),
                }
            }
            Ast::Paren { inner, .. } => return self.build(inner),
            Ast::Unary { negate, arg, .. } => {
                let x = self.build(arg)?;
                if !negate {
                    return Some(x);
                }
                self.arena.span = span;
                self.arena.neg(x)
            }
            Ast::Chain { first, rest } => return self.chain(first, rest, span),
            Ast::Binary { lhs, rhs, .. } => {
                if let Ast::Name(e) = &**lhs {
                    let params = self.arena.params().to_vec();
                    if let Err(ErrorKind::EulerNumber { .. }) =
                        resolve(&self.src[e.range()], &params)
                    {
                        // `e^x` is `exp(x)`.
                        let x = match &**rhs {
                            Ast::Paren { inner, .. } => inner.span(),
                            x => x.span(),
                        };
                        let exponent = Some(self.src[x.range()].to_string());
                        self.errors
                            .push(Error::new(ErrorKind::EulerNumber { exponent }, *e));
                        self.build(rhs);
                        return None;
                    }
                }
                let (a, b) = (self.build(lhs), self.build(rhs));
                let (a, b) = (a?, b?);
                self.arena.span = span;
                self.arena.pow_general(a, b)
            }
        };
        match result {
            Ok(id) => Some(id),
            Err(fault) => {
                self.errors.push(Error::new(ErrorKind::Fault(fault), span));
                None
            }
        }
    }
}

impl Builder<'_> {
    /// A sum or product chain, built with one n-ary constructor call.
    fn chain(&mut self, first: &Ast, rest: &[(BinOp, Span, Ast)], span: Span) -> Option<Id> {
        let a = self.build(first);
        let operands: Vec<Option<Id>> = rest.iter().map(|(_, _, x)| self.build(x)).collect();
        let mut parts = vec![a?];
        for ((op, _, x), id) in rest.iter().zip(operands) {
            let id = id?;
            self.arena.span = x.span();
            let part = match op {
                BinOp::Sub => self.arena.neg(id),
                // A division by zero is the divisor's fault.
                BinOp::Div if self.arena.is_zero(id) => Err(Fault::DivisionByZero),
                BinOp::Div => self.arena.pow(id, Num::int(-1)),
                _ => Ok(id),
            };
            match part {
                Ok(p) => parts.push(p),
                Err(fault) => {
                    self.errors
                        .push(Error::new(ErrorKind::Fault(fault), x.span()));
                    return None;
                }
            }
        }
        self.arena.span = span;
        let sum = matches!(rest.first(), Some((BinOp::Add | BinOp::Sub, _, _)));
        let r = if sum {
            self.arena.add(&parts)
        } else {
            self.arena.mul(&parts)
        };
        match r {
            Ok(id) => Some(id),
            Err(fault) => {
                self.errors.push(Error::new(ErrorKind::Fault(fault), span));
                None
            }
        }
    }
}

impl Builder<'_> {
    /// `q[index]` or `p[index]`: the variable at that site, or its boundary's value.
    fn indexed(&mut self, name: Span, index: &Ast, span: Span) -> Option<Id> {
        let letter = match &self.src[name.range()] {
            "q" => 'q',
            "p" => 'p',
            other => {
                self.errors.push(Error::new(
                    ErrorKind::IndexedName {
                        name: other.to_string(),
                    },
                    name,
                ));
                return None;
            }
        };
        if self.lattice.local.is_some() {
            return self.slot(letter, index, span);
        }
        let site = match self.lattice.int(self.src, index, self.arena.params()) {
            Ok(site) => site,
            Err(e) => {
                self.errors.push(e);
                return None;
            }
        };
        if let Some(b) = self.lattice.boundary(letter, site).cloned() {
            if self.lattice.in_boundary {
                self.errors.push(Error::new(
                    ErrorKind::BadBoundary {
                        name: compact(&self.src[span.range()]),
                        reason:
                            "is defined by a boundary: a boundary's value uses sites of the lattice"
                                .to_string(),
                    },
                    span,
                ));
                return None;
            }
            // The value is built where it was declared, with no summation index in scope.
            let bound = std::mem::take(&mut self.lattice.bound);
            self.lattice.in_boundary = true;
            let id = self.build(&b.value);
            self.lattice.in_boundary = false;
            self.lattice.bound = bound;
            return id;
        }
        if self.lattice.in_boundary && (site < 1 || self.lattice.last.is_some_and(|n| site > n)) {
            self.errors.push(Error::new(
                ErrorKind::IndexOutOfRange {
                    access: compact(&self.src[span.range()]),
                    letter,
                    site,
                    at: self.lattice.at(),
                    last: self.lattice.last,
                },
                span,
            ));
            return None;
        }
        // Out of range at some sites of a sum: one error per access, at its farthest site
        // ([`Lattice::finish`] reports them), not one per site.
        if site < 1 {
            self.record(true, span, site, letter);
            return None;
        }
        let k = match u32::try_from(site) {
            Ok(k) if k as usize <= crate::MAX_INDEX => k,
            // Beyond the largest index: in a sum also beyond its lattice (whose bounds are at
            // most that index), so out of range.
            _ if !self.lattice.bound.is_empty() => {
                self.record(false, span, site, letter);
                return None;
            }
            _ => {
                self.errors.push(Error::new(
                    ErrorKind::IndexTooLarge {
                        name: format!("{letter}[{site}]"),
                    },
                    span,
                ));
                return None;
            }
        };
        self.record(false, span, site, letter);
        self.strides(index, site);
        self.arena.span = span;
        Some(
            self.arena
                .var(if letter == 'q' { Var::Q(k) } else { Var::P(k) }),
        )
    }

    /// Records that the access at `span` reached `letter[site]`, if it is the lowest (`below`)
    /// or highest such site of that access so far, with the indices' values there.
    fn record(&mut self, below: bool, span: Span, site: i64, letter: char) {
        let map = if below {
            &mut self.lattice.below
        } else {
            &mut self.lattice.reached
        };
        let farther = map.get(&span).is_none_or(|&(farthest, ..)| {
            if below {
                site < farthest
            } else {
                site > farthest
            }
        });
        if farther {
            let at = self.lattice.at();
            let map = if below {
                &mut self.lattice.below
            } else {
                &mut self.lattice.reached
            };
            map.insert(span, (site, letter, at));
        }
    }

    /// Raises the strides ([`Lattice::strides`]) of the bound indices to their coefficients in
    /// `index`, which is `site` at the indices' current values.
    fn strides(&mut self, index: &Ast, site: i64) {
        let params = self.arena.params().to_vec();
        if self.lattice.strides.len() < self.lattice.bound.len() {
            self.lattice.strides.resize(self.lattice.bound.len(), 1);
        }
        for k in 0..self.lattice.bound.len() {
            let v = self.lattice.bound[k].1;
            self.lattice.bound[k].1 = v.saturating_add(1);
            let next = self.lattice.int(self.src, index, &params);
            self.lattice.bound[k].1 = v;
            if let Ok(next) = next {
                let stride = &mut self.lattice.strides[k];
                *stride = (*stride).max(next.saturating_sub(site));
            }
        }
    }

    /// `letter[index]` in a summand built once ([`crate::looped`]): the index must be affine
    /// in the sum's indices, `a i + b j + c`; the variable is the slot of that access.
    fn slot(&mut self, letter: char, index: &Ast, span: Span) -> Option<Id> {
        let params = self.arena.params().to_vec();
        let k = self.lattice.local.as_ref()?.indices.len();
        let base = self.lattice.bound.len().checked_sub(k)?;
        let at = |b: &mut Self, values: [i64; 2]| {
            for (m, &v) in values.iter().enumerate().take(k) {
                b.lattice.bound[base + m].1 = v;
            }
            b.lattice.int(b.src, index, &params)
        };
        let c = match at(self, [0, 0]) {
            Ok(c) => c,
            Err(e) => {
                self.errors.push(e);
                return None;
            }
        };
        // The coefficients, from the values at `e_m`, checked at `2 e_m` and `e_0 + e_1`
        // (which tell `2*i` from `i*i` and `i + j` from `i*j`).
        let probes: &[[i64; 2]] = if k == 2 {
            &[[1, 0], [0, 1], [2, 0], [0, 2], [1, 1]]
        } else {
            &[[1, 0], [2, 0]]
        };
        let values: Vec<Option<i64>> = probes.iter().map(|&p| at(self, p).ok()).collect();
        at(self, [0, 0]).ok();
        // In `i128`: near the ends of `i64` nothing overflows.
        let wide = |v: Option<i64>| v.map_or(0, |v| i128::from(v) - i128::from(c));
        let coef = [wide(values[0]), if k == 2 { wide(values[1]) } else { 0 }];
        let affine = probes.iter().zip(&values).all(|(p, v)| {
            let expected = i128::from(c) + i128::from(p[0]) * coef[0] + i128::from(p[1]) * coef[1];
            v.map(i128::from) == Some(expected)
        });
        let coef = coef.map(|a| i64::try_from(a).unwrap_or(-1));
        let local = self.lattice.local.as_mut()?;
        if !affine || coef.iter().any(|&a| a < 0) || coef == [0, 0] {
            local.not_loopable =
                Some("an index is not a sum's index times a positive integer plus a constant");
            return None;
        }
        let v = local.slot(letter, coef, c, span);
        self.arena.span = span;
        Some(self.arena.var(v))
    }

    /// Declares the sizes and boundaries of `decls`.
    pub fn declare(&mut self, decls: &[Decl]) {
        for decl in decls {
            match decl {
                Decl::Constant { name, value } => {
                    let (name, number) = (self.bindable(*name), self.int(value));
                    if let (Some(name), Some(number)) = (name, number) {
                        self.lattice
                            .constant_spans
                            .push((name.clone(), value.span()));
                        self.lattice.constants.push((name, number));
                    }
                }
                Decl::Boundary { targets, value } => {
                    for target in targets {
                        self.boundary(target, value);
                    }
                }
            }
        }
    }

    /// An integer of the lattice (an index's bound), or `None` with its error recorded.
    pub fn int(&mut self, ast: &Ast) -> Option<i64> {
        match self.lattice.int(self.src, ast, self.arena.params()) {
            Ok(v) => Some(v),
            Err(e) => {
                self.errors.push(e);
                None
            }
        }
    }

    /// Binds `name` (an index), or records why it cannot be one.
    pub fn bindable(&mut self, name: Span) -> Option<String> {
        let text = self.src[name.range()].to_string();
        match self.lattice.bad_name(&text, self.arena.params()) {
            None => Some(text),
            Some(reason) => {
                self.errors.push(Error::new(
                    ErrorKind::BadIndexName { name: text, reason },
                    name,
                ));
                None
            }
        }
    }

    /// `sum(range, body)`: the sum of the body at every site (pair of sites) of the range.
    fn sum(&mut self, range: &Range, body: &Ast) -> Option<Id> {
        let range_span = range.span();
        let sites: Vec<Vec<i64>> = match range {
            Range::Single { index, lo, hi } => {
                let (name, lo_value, hi_value) =
                    (self.bindable(*index), self.int(lo), self.int(hi));
                let (_, lo_value, hi_value) = (name?, lo_value?, hi_value?);
                self.fits(lo, lo_value, hi, hi_value)?;
                self.extend_lattice(hi_value);
                (lo_value..=hi_value).map(|i| vec![i]).collect()
            }
            Range::Pairs {
                lo,
                lo_strict,
                i,
                j,
                hi_strict,
                hi,
            } => {
                let (a, b) = (self.bindable(*i), self.bindable(*j));
                let (lo_value, hi_value) = (self.int(lo), self.int(hi));
                let (a, b, lo_value, hi_value) = (a?, b?, lo_value?, hi_value?);
                self.fits(lo, lo_value, hi, hi_value)?;
                if a == b {
                    self.errors.push(Error::new(
                        ErrorKind::BadIndexName {
                            name: b,
                            reason: "is declared twice",
                        },
                        *j,
                    ));
                    return None;
                }
                // Saturating: an empty range may sit at the ends of `i64`.
                let (lo, hi) = (
                    lo_value.saturating_add(i64::from(*lo_strict)),
                    hi_value.saturating_sub(i64::from(*hi_strict)),
                );
                self.extend_lattice(hi);
                (lo..=hi)
                    .flat_map(|i| (i + 1..=hi).map(move |j| vec![i, j]))
                    .collect()
            }
        };
        let names: Vec<String> = match range {
            Range::Single { index, .. } => vec![self.src[index.range()].to_string()],
            Range::Pairs { i, j, .. } => [i, j]
                .iter()
                .map(|s| self.src[s.range()].to_string())
                .collect(),
        };
        let text = match range {
            Range::Single { index, lo, hi } => format!(
                "{} = {}..{}",
                &self.src[index.range()],
                compact(&self.src[lo.span().range()]),
                compact(&self.src[hi.span().range()])
            ),
            Range::Pairs {
                lo,
                lo_strict,
                i,
                j,
                hi_strict,
                hi,
            } => format!(
                "{} {} {} < {} {} {}",
                compact(&self.src[lo.span().range()]),
                if *lo_strict { "<" } else { "<=" },
                &self.src[i.range()],
                &self.src[j.range()],
                if *hi_strict { "<" } else { "<=" },
                compact(&self.src[hi.span().range()])
            ),
        };
        let seen = self.lattice.sums.entry(range_span).or_insert((false, text));
        seen.0 |= !sites.is_empty();
        if sites.is_empty() {
            // An empty sum is zero; one whose every range is empty is an error (`finish`).
            return Some(self.arena.num(Num::ZERO));
        }
        let depth = self.lattice.bound.len();
        if self.lattice.strides.len() < depth + names.len() {
            self.lattice.strides.resize(depth + names.len(), 1);
        }
        for stride in &mut self.lattice.strides[depth..depth + names.len()] {
            *stride = 1;
        }
        // The largest value each index takes: the lattice reaches `stride * value`.
        let largest: Vec<i64> = (0..names.len())
            .map(|m| sites.iter().map(|v| v[m]).max().unwrap_or(0))
            .collect();
        let mut terms = Vec::with_capacity(sites.len());
        let mut failed = false;
        for values in sites {
            for (n, v) in names.iter().zip(values) {
                self.lattice.bound.push((n.clone(), v));
            }
            let term = self.build(body);
            for _ in &names {
                self.lattice.bound.pop();
            }
            match term {
                Some(t) => terms.push(t),
                None => failed = true,
            }
        }
        let reach = largest
            .iter()
            .zip(&self.lattice.strides[depth..depth + names.len()])
            .map(|(&v, &stride)| v.saturating_mul(stride))
            .max();
        if let Some(reach) = reach {
            self.extend_lattice(reach);
        }
        if failed {
            return None;
        }
        self.arena.span = range_span;
        match self.arena.add(&terms) {
            Ok(id) => Some(id),
            Err(fault) => {
                self.errors
                    .push(Error::new(ErrorKind::Fault(fault), range_span));
                None
            }
        }
    }

    /// Checks that the range `lo..=hi` has at most [`crate::MAX_INDEX`] sites and reaches no
    /// further, before its sites are counted out: `None`, with the error, when it does not.
    /// Beyond [`crate::MAX_SITES`] the error is the loops' (as [`crate::looped::compile`]
    /// reports it), so both paths give one error, the same, for `N = 10^12`.
    fn fits(&mut self, lo: &Ast, lo_value: i64, hi: &Ast, hi_value: i64) -> Option<()> {
        let error = [crate::MAX_SITES, crate::MAX_INDEX]
            .iter()
            .find_map(|&limit| {
                let lo = Bound {
                    ast: lo,
                    value: lo_value,
                };
                let hi = Bound {
                    ast: hi,
                    value: hi_value,
                };
                self.lattice.too_large(self.src, lo, hi, limit)
            });
        match error {
            Some(e) => {
                // The lattice reaches `hi` still: the other sums' accesses are checked
                // against it, not reported out of range because this sum was not built.
                self.extend_lattice(hi_value);
                self.errors.push(e);
                None
            }
            None => Some(()),
        }
    }

    fn extend_lattice(&mut self, hi: i64) {
        self.lattice.last = Some(self.lattice.last.map_or(hi, |n| n.max(hi)));
    }

    /// `body where decls`: the sizes and boundaries, then the body.
    fn declared(&mut self, body: &Ast, decls: &[Decl]) -> Option<Id> {
        self.declare(decls);
        self.build(body)
    }

    /// Declares `target = value`, a boundary.
    fn boundary(&mut self, target: &Ast, value: &Ast) {
        let span = target.span();
        let Ast::Index { name, index, .. } = target else {
            self.errors.push(Error::new(ErrorKind::Declaration, span));
            return;
        };
        let letter = match &self.src[name.range()] {
            "q" => 'q',
            "p" => 'p',
            other => {
                self.errors.push(Error::new(
                    ErrorKind::IndexedName {
                        name: other.to_string(),
                    },
                    *name,
                ));
                return;
            }
        };
        let Some(site) = self.int(index) else { return };
        if self.lattice.boundary(letter, site).is_some() {
            self.errors.push(Error::new(
                ErrorKind::BadBoundary {
                    name: compact(&self.src[span.range()]),
                    reason: "is declared twice".to_string(),
                },
                span,
            ));
            return;
        }
        self.lattice.boundaries.push(Boundary {
            letter,
            site,
            value: value.clone(),
            span,
        });
    }
}

/// `Var`s of the phase space in `z` order.
pub(crate) fn coordinates(n: u32, time_dependent: bool) -> Vec<Var> {
    let mut z: Vec<Var> = (1..=n).map(Var::Q).collect();
    if time_dependent {
        z.push(Var::T);
    }
    z.extend((1..=n).map(Var::P));
    if time_dependent {
        z.push(Var::Pt);
    }
    z
}
