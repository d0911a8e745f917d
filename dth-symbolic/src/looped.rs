//! Lattices compiled once for all sites: each summand of `sum(i = a..b, f)` is built and
//! differentiated once, in local coordinates (one per distinct `q[i + c]`, `p[i + c]`), and
//! evaluated in a loop over the sites, its gradient and Hessian scattered onto the lattice.
//!
//! The index-shift rule: with `x_r(i) = z[i + c_r]`, `d/dz_k sum_i f(x(i)) = sum_r
//! (df/dx_r)(x(k - c_r))`, and the Hessian entry `(i + c_r, i + c_s)` receives
//! `d^2 f / dx_r dx_s` at site `i`. The discrete gradient and its defect are linear in `H`, so
//! the summand's two-point programs scatter the same way. The work and the programs depend on
//! the summand, not on the number of sites: [`Looped::ops`] is the same for `N = 64` and
//! `N = 4096`.
//!
//! A lattice has at most [`crate::MAX_SITES`] sites: beyond, [`compile`] is one error
//! ([`ErrorKind::LatticeTooLarge`], at `N`'s value), checked before anything is counted out
//! per site; every index and size is computed with checked (or saturating) arithmetic. The
//! flags (`flags`: on the whole lattice's derivatives, one class of sites at a time) and the
//! written-out path's warnings (`reach`) are decided on the summands and the ranges, never
//! site by site.
//!
//! What loops: sums, added or subtracted, each times constant factors (`- g^2 * sum(..)`), of
//! two kinds, with no written-out coordinate and no `t`:
//!
//! - sums over sites, `sum(i = a..b, f)` whose indices are the sum's index plus a constant,
//!   with boundaries that are constants (fixed ends) or a variable of the lattice (periodic);
//! - sums over pairs `sum(lo <= i < j <= hi, f)`, nested sums `sum(i = a..b, sum(j = c..d, f))`
//!   (`c`, `d` a constant or the outer index plus one) and strided sums (`q[3*i - 2]`), whose
//!   indices are affine in the sum's indices and stay inside the lattice ([`nested`]).
//!
//! The lattice's sites are `1..n`, `n` the largest site the sums' indices reach (`2N` for
//! `p[2*i]` and `i = 1..N`, as [`crate::compile`] counts them). Anything else is
//! [`LoopError::NotLoopable`]: compile it with [`crate::compile`], which builds sums site by
//! site.
//!
//! ```
//! use dth_symbolic::looped;
//! let src = "sum(i = 1..N, p[i]^2/2) + sum(i = 0..N, (q[i+1] - q[i])^2/2) \
//!            where N = 4096, q[0] = q[N+1] = 0";
//! let chain = looped::compile(src, &[]).unwrap();
//! assert_eq!(chain.dim(), 8192);
//! let mut z = vec![0.0; 8192];
//! z[0] = 0.5;
//! let (value, gradient) = chain.value_gradient(&z, &[]).unwrap();
//! assert_eq!((value, gradient[0], gradient[1]), (0.25, 1.0, -0.5));
//! ```

pub mod diagonals;
mod flags;
pub mod nested;
mod reach;
mod runs;

use crate::arena::Arena;
use crate::build::Builder;
use crate::error::{Error, ErrorKind, Errors, EvalError, Warning};
use crate::lattice::{compact, Bound, Lattice, Local};
use crate::lexer::lex;
use crate::lower::Program;
use crate::number::Num;
use crate::parser::{parse, Ast, BinOp, Decl, Range};
use crate::span::Span;
use crate::system::{derive, Method};
use diagonals::Layout;
use nested::{NestedSlot, NestedSum, Tuples};

/// Why a Hamiltonian is not compiled by [`compile`].
#[derive(Clone, Debug, PartialEq)]
pub enum LoopError {
    /// The source has errors.
    Errors(Errors),
    /// The source is valid but not of the form that loops (see the module docs).
    NotLoopable(&'static str),
}

impl std::fmt::Display for LoopError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            LoopError::Errors(e) => write!(f, "{e}"),
            LoopError::NotLoopable(why) => write!(f, "not compiled in loops: {why}"),
        }
    }
}

impl std::error::Error for LoopError {}

/// Where a slot reads its value at one site ([`Looped::site`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Site {
    /// `z[k]`.
    Var(usize),
    /// A fixed boundary's value.
    Const(f64),
}

/// One sum, compiled once.
#[derive(Clone, Debug)]
pub struct LoopSum {
    pub(crate) lo: i64,
    pub(crate) hi: i64,
    /// Per slot: letter, offset, and its index in the local coordinates.
    pub(crate) slots: Vec<(char, i64, usize)>,
    pub(crate) local_dim: usize,
    /// The summand's Hessian nonzeros, upper triangle, as pairs of slots.
    pub(crate) pattern: Vec<(usize, usize)>,
    /// Each slot's first access, in the order of `slots`.
    spans: Vec<Span>,
    /// The summand in local coordinates.
    system: crate::System,
    all: Program,
    pair: Program,
    defect: Program,
}

impl LoopSum {
    /// The summand as a system in local coordinates: `q<k>` (`p<k>`) is the `k`-th distinct
    /// `q[i + c]` (`p[i + c]`) of the summand, in the order written.
    pub fn summand(&self) -> &crate::System {
        &self.system
    }

    /// The summand's Hessian nonzeros, upper triangle, as pairs of indices into
    /// [`LoopSum::slots`], in the order the generated code writes them.
    pub fn pattern(&self) -> &[(usize, usize)] {
        &self.pattern
    }

    /// The sum's range `lo..=hi`.
    pub fn range(&self) -> (i64, i64) {
        (self.lo, self.hi)
    }

    /// The slots: per distinct `q[i + c]` or `p[i + c]` of the summand, its letter, its
    /// offset `c`, and its position in the summand's local coordinates
    /// ([`LoopSum::summand`]'s `z`).
    pub fn slots(&self) -> &[(char, i64, usize)] {
        &self.slots
    }
}

/// A lattice Hamiltonian compiled once per summand (see the module docs).
#[derive(Clone, Debug)]
pub struct Looped {
    pub(crate) n: usize,
    pub(crate) sums: Vec<LoopSum>,
    /// Boundaries: letter, index, and what the variable there is.
    pub(crate) boundaries: Vec<(char, i64, Site)>,
    /// Each boundary's value as written, in the order of `boundaries`.
    boundary_spans: Vec<Span>,
    params: usize,
    /// The written-out path's warnings, decided on the ranges (`reach`).
    warnings: Vec<Warning>,
    /// The sums over pairs, nested and strided sums, in the order written.
    pub(crate) nested: Vec<NestedSum>,
    /// The Hessian's layout ([`diagonals::layout`]).
    pub(crate) layout: Layout,
}

/// One term of the Hamiltonian: a sum, times constant factors, negated or not
/// (`- g^2 * sum(..)`).
struct Term<'a> {
    factors: Vec<&'a Ast>,
    negate: bool,
    sum: &'a Ast,
}

/// `true` when `ast` holds a sum.
fn has_sum(ast: &Ast) -> bool {
    match ast {
        Ast::Sum { .. } => true,
        Ast::Paren { inner, .. } => has_sum(inner),
        Ast::Unary { arg, .. } | Ast::Call { arg, .. } => has_sum(arg),
        Ast::Chain { first, rest } => has_sum(first) || rest.iter().any(|(_, _, x)| has_sum(x)),
        Ast::Binary { lhs, rhs, .. } => has_sum(lhs) || has_sum(rhs),
        _ => false,
    }
}

/// The terms of `ast` (sums, added or subtracted, each times factors without a sum), or why
/// it does not loop.
fn sums(ast: &Ast) -> Result<Vec<Term<'_>>, LoopError> {
    match ast {
        Ast::Paren { inner, .. } => sums(inner),
        Ast::Sum { .. } => Ok(vec![Term {
            factors: Vec::new(),
            negate: false,
            sum: ast,
        }]),
        Ast::Unary { negate, arg, .. } => {
            let mut terms = sums(arg)?;
            for t in &mut terms {
                t.negate ^= negate;
            }
            Ok(terms)
        }
        Ast::Chain { first, rest } if matches!(rest.first(), Some((BinOp::Mul, _, _))) => {
            // `g^2 * sum(..)`: one factor holds the sums, the others are constants.
            let operands: Vec<&Ast> = std::iter::once(&**first)
                .chain(rest.iter().map(|(_, _, x)| x))
                .collect();
            if rest.iter().any(|(op, _, _)| *op != BinOp::Mul) {
                return Err(LoopError::NotLoopable("a sum is divided"));
            }
            let with: Vec<usize> = (0..operands.len())
                .filter(|&k| has_sum(operands[k]))
                .collect();
            let [at] = with[..] else {
                return Err(LoopError::NotLoopable("a product of sums"));
            };
            let mut terms = sums(operands[at])?;
            for t in &mut terms {
                let others = operands.iter().enumerate().filter(|&(k, _)| k != at);
                t.factors.extend(others.map(|(_, &x)| x));
            }
            Ok(terms)
        }
        Ast::Chain { first, rest } => {
            let mut out = sums(first)?;
            for (op, _, x) in rest {
                let mut terms = sums(x)?;
                if *op == BinOp::Sub {
                    for t in &mut terms {
                        t.negate = !t.negate;
                    }
                }
                out.extend(terms);
            }
            Ok(out)
        }
        _ => Err(LoopError::NotLoopable("a term outside a sum")),
    }
}

/// The most operations of one summand program that a loop body holds: a lattice with a longer
/// summand program is compiled site by site ([`crate::compile`]) by the macro and the JIT alike
/// (the macro's limit on one function's body, `emit`'s `CHUNK_OPS`).
pub const MAX_BODY_OPS: usize = 1000;

/// The lattice compiled in loops exactly when `hamiltonian!` compiles `src` in loops: a source
/// with a sum that [`compile`] accepts and whose summand programs each fit one loop body
/// ([`Looped::fits_one_body`]). `None` for every other source, errors included: the caller
/// compiles it site by site ([`crate::compile`]), which reports them. The macro and
/// `dth-runtime` both decide here.
///
/// ```
/// use dth_symbolic::looped;
/// let chain = "sum(i = 1..N, p[i]^2/2) + sum(i = 0..N, (q[i+1] - q[i])^2/2) \
///              where N = 64, q[0] = q[N+1] = 0";
/// assert_eq!(looped::loops(chain, &[]).map(|l| l.n()), Some(64));
/// assert!(looped::loops("p1^2/2 + q1^2/2", &[]).is_none());
/// ```
pub fn loops(src: &str, params: &[&str]) -> Option<Looped> {
    if !src.contains("sum") {
        return None;
    }
    compile(src, params).ok().filter(Looped::fits_one_body)
}

/// Compiles `src` in loops (see the module docs).
pub fn compile(src: &str, params: &[&str]) -> Result<Looped, LoopError> {
    let fail = |errors: Vec<Error>| LoopError::Errors(Errors(errors));
    let (tokens, lex_errors) = lex(src);
    if !lex_errors.is_empty() {
        return Err(fail(lex_errors));
    }
    let (ast, syntax) = parse(src, &tokens);
    let ast = match ast {
        Some(ast) if syntax.is_empty() => ast,
        _ => return Err(fail(syntax)),
    };
    let (body, decls): (&Ast, &[Decl]) = match &ast {
        Ast::Where { body, decls } => (body, decls),
        other => (other, &[]),
    };
    let terms = sums(body)?;
    let mut root = Builder {
        src,
        arena: Arena::new(params),
        errors: Vec::new(),
        lattice: Lattice::default(),
    };
    root.declare(decls);
    // The ranges first: `N = 10^12` is one error, before anything is counted out per site.
    let mut shapes = Vec::new();
    for term in &terms {
        let Ast::Sum { range, body, span } = term.sum else {
            continue;
        };
        if let Some(shape) = shape(&mut root, range, body)? {
            shapes.push((term, shape, *span));
        }
    }
    if !root.errors.is_empty() {
        return Err(fail(root.errors));
    }
    // Each summand built once, in local coordinates.
    let mut errors = Vec::new();
    let mut not_loopable = None;
    let mut pending = Vec::new();
    for (term, shape, span) in shapes {
        let mut b = Builder {
            src,
            arena: Arena::new(params),
            errors: Vec::new(),
            lattice: root.lattice.clone(),
        };
        b.lattice.local = Some(Local {
            indices: shape.names.clone(),
            ..Local::default()
        });
        for name in &shape.names {
            b.lattice.bound.push((name.clone(), 0));
        }
        let f = b.build(shape.body);
        let factors: Vec<Option<crate::arena::Id>> =
            term.factors.iter().map(|x| b.build(x)).collect();
        let local = b.lattice.local.take().unwrap_or_default();
        if let Some(why) = local.not_loopable {
            not_loopable = Some(why);
            continue;
        }
        let factors: Option<Vec<_>> = factors.into_iter().collect();
        let f = match (f, factors) {
            (Some(f), Some(mut factors)) if b.errors.is_empty() => {
                b.arena.span = span;
                factors.push(f);
                let f = if factors.len() > 1 {
                    b.arena.mul(&factors)
                } else {
                    Ok(f)
                };
                match f.and_then(|f| if term.negate { b.arena.neg(f) } else { Ok(f) }) {
                    Ok(f) => Some(f),
                    Err(fault) => {
                        errors.push(Error::new(ErrorKind::Fault(fault), span));
                        None
                    }
                }
            }
            _ => {
                errors.append(&mut b.errors);
                None
            }
        };
        let system = match f.map(|f| derive(b.arena, f, span)) {
            Some(Ok(system)) => Some(system),
            Some(Err(e)) => {
                errors.push(e);
                None
            }
            None => None,
        };
        pending.push((shape.names.len(), shape.tuples, local, system));
    }
    // The lattice is `1..n`: each index reaches its largest value times its largest
    // coefficient, as the site-by-site path counts (`Lattice::strides`).
    let mut n: i64 = 0;
    for (indices, tuples, local, _) in &pending {
        let Some(extent) = tuples.extent() else {
            continue;
        };
        for (k, &(_, largest)) in extent.iter().enumerate().take(*indices) {
            let stride = local.slots.iter().map(|s| s.1[k]).max().unwrap_or(1).max(1);
            n = n.max(stride.saturating_mul(largest));
        }
    }
    let Ok(n_sites) = usize::try_from(n) else {
        return Err(LoopError::NotLoopable("the lattice is empty"));
    };
    // The faults of a source that loops are errors here, as the site-by-site path reports
    // them: `crate::compile` shows them for a lattice too large to write out.
    let mut boundaries = Vec::new();
    let mut boundary_spans = Vec::new();
    for b in &root.lattice.boundaries {
        if (1..=n).contains(&b.site) {
            errors.push(Error::new(
                ErrorKind::BadBoundary {
                    name: compact(&src[b.span.range()]),
                    reason: format!(
                        "is inside the lattice 1..{n}: boundaries define sites below 1 or above {n}"
                    ),
                },
                b.span,
            ));
            continue;
        }
        let site = match &b.value {
            Ast::Index { name, index, span } => {
                let letter = src[name.range()].chars().next().unwrap_or('q');
                match root.lattice.int(src, index, root.arena.params()) {
                    Ok(k) if (1..=n).contains(&k) => Site::Var(index_of(letter, k, n_sites)),
                    // Still a boundary: the accesses that reach it are not out of range.
                    Ok(k) => {
                        errors.push(boundary_outside(src, &root.lattice, letter, k, n, *span));
                        Site::Const(0.0)
                    }
                    Err(e) => {
                        errors.push(e);
                        Site::Const(0.0)
                    }
                }
            }
            value => {
                let mut scratch = Builder {
                    src,
                    arena: Arena::new(params),
                    errors: Vec::new(),
                    lattice: root.lattice.clone(),
                };
                match scratch.build(value).and_then(|id| scratch.arena.as_num(id)) {
                    Some(c) => Site::Const(Num::to_f64(c)),
                    None => {
                        not_loopable = Some("a boundary is neither a constant nor a site");
                        continue;
                    }
                }
            }
        };
        boundaries.push((b.letter, b.site, site));
        boundary_spans.push(b.value.span());
    }
    let mut compiled = Vec::new();
    let mut nested = Vec::new();
    for (indices, tuples, local, system) in pending {
        let band = indices == 1 && local.slots.iter().all(|s| s.1 == [1, 0]);
        if band {
            // Every site the summand reaches is in the lattice or a boundary.
            let slots: Vec<(char, i64)> = local.slots.iter().map(|&(l, _, c)| (l, c)).collect();
            let index = local.indices.first().cloned().unwrap_or_default();
            let (lo, hi) = tuples.outer;
            errors.extend(out_of_range(
                src,
                (&index, lo, hi),
                n,
                &slots,
                &local.accesses,
                &boundaries,
            ));
        }
        let Some(system) = system else { continue };
        let letters: Vec<char> = local.slots.iter().map(|s| s.0).collect();
        let locals = locals(&letters, system.dim() / 2);
        let slot_of = |l: usize| locals.iter().position(|&x| x == l);
        let pattern: Vec<(usize, usize)> = system
            .hessian_nonzeros()
            .iter()
            .filter_map(|&(i, j, _)| Some((slot_of(i)?, slot_of(j)?)))
            .collect();
        let (all, pair, defect) = (
            system.program(Method::All),
            system.program(Method::DiscreteGradient),
            system.program(Method::DiscreteGradientDefect),
        );
        if band {
            compiled.push(LoopSum {
                lo: tuples.outer.0,
                hi: tuples.outer.1,
                slots: local
                    .slots
                    .iter()
                    .zip(&locals)
                    .map(|(&(letter, _, c), &l)| (letter, c, l))
                    .collect(),
                pattern,
                spans: local.spans.clone(),
                local_dim: system.dim(),
                system,
                all,
                pair,
                defect,
            });
            continue;
        }
        let slots: Vec<NestedSlot> = local
            .slots
            .iter()
            .zip(&locals)
            .map(|(&(letter, coef, offset), &local)| NestedSlot {
                letter,
                coef,
                offset,
                local,
            })
            .collect();
        if let Some(why) = nested_reach(&tuples, &slots, indices, n) {
            not_loopable = Some(why);
            continue;
        }
        nested.push(NestedSum {
            tuples,
            slots,
            local_dim: system.dim(),
            pattern,
            spans: local.spans.clone(),
            system,
            all,
            pair,
            defect,
        });
    }
    if let Some(why) = not_loopable {
        return Err(LoopError::NotLoopable(why));
    }
    if !errors.is_empty() {
        errors.sort_by_key(|e| e.span.start);
        errors.dedup();
        return Err(fail(errors));
    }
    let mut looped = Looped {
        n: n_sites,
        sums: compiled,
        boundaries,
        boundary_spans,
        params: params.len(),
        warnings: Vec::new(),
        nested,
        layout: Layout::default(),
    };
    looped.layout = diagonals::try_layout(&looped).map_err(LoopError::NotLoopable)?;
    let faults = looped.boundary_faults();
    if !faults.is_empty() {
        return Err(fail(faults));
    }
    let Some((errors, warnings)) = looped.numbering() else {
        return Err(LoopError::NotLoopable("no variable reaches the last site"));
    };
    if !errors.is_empty() {
        return Err(fail(errors));
    }
    // Without a momentum the flow does not move: the site-by-site path's error.
    if !looped.has_momentum() {
        return Err(fail(vec![Error::new(ErrorKind::NoMomentum, ast.span())]));
    }
    looped.warnings = warnings;
    Ok(looped)
}

/// The errors of the accesses of one sum `index = lo..hi` (its `slots` `letter[i + c]`, and
/// each access's slot and span) that leave the
/// lattice `1..n` where no boundary is declared: one per access, at its farthest such site,
/// as the site-by-site path reports them. The sites outside the lattice a slot `q[i + c]`
/// reaches are a few at either end of `lo + c..hi + c`; each scan stops at the first site
/// that is not a boundary, so it runs at most once more than there are boundaries.
fn out_of_range(
    src: &str,
    (index, lo, hi): (&str, i64, i64),
    n: i64,
    slots: &[(char, i64)],
    accesses: &[(usize, Span)],
    boundaries: &[(char, i64, Site)],
) -> Vec<Error> {
    let open = |letter: char, k: i64| !boundaries.iter().any(|&(l, s, _)| l == letter && s == k);
    let mut errors = Vec::new();
    for &(slot, span) in accesses {
        let (letter, c) = slots[slot];
        let (from, to) = (lo.saturating_add(c), hi.saturating_add(c));
        let lowest = (from..=to.min(0)).find(|&k| open(letter, k));
        let highest = (from.max(n.saturating_add(1))..=to)
            .rev()
            .find(|&k| open(letter, k));
        for site in lowest.into_iter().chain(highest) {
            errors.push(Error::new(
                ErrorKind::IndexOutOfRange {
                    access: compact(&src[span.range()]),
                    letter,
                    site,
                    at: format!("{index} = {}", site.saturating_sub(c)),
                    last: Some(n),
                },
                span,
            ));
        }
    }
    errors
}

/// A term's indices, their tuples, and the summand inside the sums.
struct Shape<'a> {
    names: Vec<String>,
    tuples: Tuples,
    body: &'a Ast,
}

/// The indices and tuples of `sum(range, body)`: one index (`i = lo..hi`), or two (`lo <= i <
/// j <= hi`, or `sum(i = a..b, sum(j = c..d, f))` with `c`, `d` affine in `i`). `Ok(None)`
/// with the errors in `root.errors` (a range too large, ...); `NotLoopable` for what the
/// site-by-site path builds or reports (an empty sum over pairs, a bound not affine).
fn shape<'a>(
    root: &mut Builder<'_>,
    range: &Range,
    body: &'a Ast,
) -> Result<Option<Shape<'a>>, LoopError> {
    let src = root.src;
    let fits = |root: &mut Builder<'_>, lo: &Ast, lo_v: i64, hi: &Ast, hi_v: i64| {
        let (lo, hi) = (
            Bound {
                ast: lo,
                value: lo_v,
            },
            Bound {
                ast: hi,
                value: hi_v,
            },
        );
        match root.lattice.too_large(src, lo, hi, crate::MAX_SITES) {
            Some(e) => {
                root.errors.push(e);
                false
            }
            None => true,
        }
    };
    match range {
        Range::Single { index, lo, hi } => {
            let (name, lo_v, hi_v) = (root.bindable(*index), root.int(lo), root.int(hi));
            let (Some(name), Some(lo_v), Some(hi_v)) = (name, lo_v, hi_v) else {
                return Ok(None);
            };
            if !fits(root, lo, lo_v, hi, hi_v) {
                return Ok(None);
            }
            if lo_v > hi_v {
                root.errors.push(Error::new(
                    ErrorKind::EmptySum {
                        range: format!("{name} = {lo_v}..{hi_v}"),
                    },
                    range.span(),
                ));
                return Ok(None);
            }
            let mut inside = body;
            while let Ast::Paren { inner, .. } = inside {
                inside = inner;
            }
            let Ast::Sum {
                range: inner,
                body: inner_body,
                ..
            } = inside
            else {
                return Ok(Some(Shape {
                    names: vec![name],
                    tuples: Tuples {
                        outer: (lo_v, hi_v),
                        inner: None,
                    },
                    body,
                }));
            };
            let Range::Single {
                index: j,
                lo: jlo,
                hi: jhi,
            } = &**inner
            else {
                return Err(LoopError::NotLoopable("a sum over pairs inside a sum"));
            };
            // The inner bounds at `i = 0, 1, 2`: `a i + b` with `a` 0 or 1.
            root.lattice.bound.push((name.clone(), 0));
            let jname = root.bindable(*j);
            let params = root.arena.params().to_vec();
            let mut values = Vec::new();
            for i in 0..3 {
                if let Some(last) = root.lattice.bound.last_mut() {
                    last.1 = i;
                }
                let bound = |ast: &Ast| root.lattice.int(src, ast, &params);
                values.push((bound(jlo), bound(jhi)));
            }
            root.lattice.bound.pop();
            let mut ends = [[0i64; 3]; 2];
            for (i, (l, h)) in values.into_iter().enumerate() {
                match (l, h) {
                    (Ok(l), Ok(h)) => (ends[0][i], ends[1][i]) = (l, h),
                    (Err(e), _) | (_, Err(e)) => {
                        root.errors.push(e);
                        return Ok(None);
                    }
                }
            }
            let Some(jname) = jname else { return Ok(None) };
            let affine = |v: [i64; 3]| {
                let a = v[1].checked_sub(v[0])?;
                ((a == 0 || a == 1) && v[2].checked_sub(v[1]) == Some(a)).then_some((a, v[0]))
            };
            let (Some(l), Some(h)) = (affine(ends[0]), affine(ends[1])) else {
                return Err(LoopError::NotLoopable(
                    "an inner sum's bound is not the outer index plus a constant, or a constant",
                ));
            };
            for i in [lo_v, hi_v] {
                let (a, b) = (l.0 * i, h.0 * i);
                if !fits(root, jlo, a.saturating_add(l.1), jhi, b.saturating_add(h.1)) {
                    return Ok(None);
                }
            }
            let tuples = Tuples {
                outer: (lo_v, hi_v),
                inner: Some([l, h]),
            };
            if tuples.extent().is_none() {
                return Err(LoopError::NotLoopable("an empty sum"));
            }
            Ok(Some(Shape {
                names: vec![name, jname],
                tuples,
                body: inner_body,
            }))
        }
        Range::Pairs {
            lo,
            lo_strict,
            i,
            j,
            hi_strict,
            hi,
        } => {
            let (a, b) = (root.bindable(*i), root.bindable(*j));
            let (lo_v, hi_v) = (root.int(lo), root.int(hi));
            let (Some(a), Some(b), Some(lo_v), Some(hi_v)) = (a, b, lo_v, hi_v) else {
                return Ok(None);
            };
            if a == b {
                return Err(LoopError::NotLoopable(
                    "a sum over pairs names one index twice",
                ));
            }
            if !fits(root, lo, lo_v, hi, hi_v) {
                return Ok(None);
            }
            let (first, last) = (
                lo_v.saturating_add(i64::from(*lo_strict)),
                hi_v.saturating_sub(i64::from(*hi_strict)),
            );
            if first >= last {
                return Err(LoopError::NotLoopable("an empty sum"));
            }
            Ok(Some(Shape {
                names: vec![a, b],
                tuples: Tuples {
                    outer: (first, last),
                    inner: Some([(1, 1), (0, last)]),
                },
                body,
            }))
        }
    }
}

/// Why a nested sum's accesses do not loop, if they do not: an access of a pair depends on
/// both indices, or some access reaches outside the lattice `1..n` (a boundary: the sum is
/// then written out, which reads it).
fn nested_reach(
    tuples: &Tuples,
    slots: &[NestedSlot],
    indices: usize,
    n: i64,
) -> Option<&'static str> {
    let extent = tuples.extent()?;
    for s in slots {
        let Some(k) = s.depends_on().filter(|&k| k < indices) else {
            return Some("an access depends on both indices of a pair");
        };
        let (vmin, vmax) = extent[k];
        let at = |v: i64| s.coef[k].checked_mul(v)?.checked_add(s.offset);
        match (at(vmin), at(vmax)) {
            (Some(a), Some(b)) if 1 <= a && b <= n => {}
            _ => return Some("a sum over pairs, nested or strided, reaches outside the lattice"),
        }
    }
    None
}

/// The local coordinate of each slot (`letters`, in the order met): the `k`-th distinct `q` is
/// `k`, the `k`-th `p` is `half + k`.
fn locals(letters: &[char], half: usize) -> Vec<usize> {
    let mut counts = [0usize; 2];
    letters
        .iter()
        .map(|&letter| {
            let h = self::half(letter);
            let k = counts[h];
            counts[h] += 1;
            if h == 0 {
                k
            } else {
                half + k
            }
        })
        .collect()
}

/// The error of a boundary whose value `letter[k]` is not a site of the lattice `1..n`, as
/// the site-by-site path reports it: another boundary, or out of range.
fn boundary_outside(
    src: &str,
    lattice: &Lattice,
    letter: char,
    k: i64,
    n: i64,
    span: Span,
) -> Error {
    let kind = if lattice.boundary(letter, k).is_some() {
        ErrorKind::BadBoundary {
            name: compact(&src[span.range()]),
            reason: "is defined by a boundary: a boundary's value uses sites of the lattice"
                .to_string(),
        }
    } else {
        ErrorKind::IndexOutOfRange {
            access: compact(&src[span.range()]),
            letter,
            site: k,
            at: String::new(),
            last: Some(n),
        }
    };
    Error::new(kind, span)
}

/// `q` is 0, `p` is 1: the half of `z` a letter's variables fill.
fn half(letter: char) -> usize {
    usize::from(letter != 'q')
}

/// The position in `z` of `letter[k]`, `1 <= k <= n`.
fn index_of(letter: char, k: i64, n: usize) -> usize {
    let k = (k - 1) as usize;
    if letter == 'q' {
        k
    } else {
        n + k
    }
}

/// What [`Looped::eval`] runs at one site of a sum: the summand's programs, the local
/// coordinate of each slot, the summand's Hessian pattern as pairs of slots.
#[derive(Clone, Copy)]
struct Summand<'a> {
    all: &'a Program,
    pair: &'a Program,
    defect: &'a Program,
    locals: &'a [usize],
    pattern: &'a [(usize, usize)],
    local_dim: usize,
}

/// The outputs of [`Looped::eval`].
#[derive(Clone, Debug, PartialEq)]
pub struct LoopedEvaluation {
    /// `H(z)`.
    pub value: f64,
    /// `grad H`.
    pub gradient: Vec<f64>,
    /// The Hessian's nonzero entries `(i, j, value)`, `i <= j`, each once, sorted.
    pub hessian: Vec<(usize, usize, f64)>,
    /// Psi.
    pub psi: f64,
}

impl Looped {
    /// Degrees of freedom `n`.
    pub fn n(&self) -> usize {
        self.n
    }

    /// `D = 2n`.
    pub fn dim(&self) -> usize {
        2 * self.n
    }

    /// The sums, each compiled once, in the order written.
    pub fn sums(&self) -> &[LoopSum] {
        &self.sums
    }

    /// The sums over pairs, nested and strided sums, each compiled once, in the order
    /// written (they are computed after [`Looped::sums`]).
    pub fn nested(&self) -> &[NestedSum] {
        &self.nested
    }

    /// The operations of all the summands' programs together: what a loop body holds, the
    /// same for every number of sites.
    pub fn ops(&self) -> usize {
        let sums = self.sums.iter().map(|s| [&s.all, &s.pair, &s.defect]);
        let nested = self.nested.iter().map(|s| [&s.all, &s.pair, &s.defect]);
        sums.chain(nested).flatten().map(|p| p.ops.len()).sum()
    }

    /// Every summand system, the sums over sites first.
    fn summands(&self) -> impl Iterator<Item = &crate::System> {
        let nested = self.nested.iter().map(|s| &s.system);
        self.sums.iter().map(|s| &s.system).chain(nested)
    }

    /// The Hessian's nonzero entries `(i, j)`, `i <= j`, in the order the loops first reach
    /// them (sum by sum, site by site, the summand's entries in order), each once, every
    /// entry of every tuple visited: a reference for tests, quadratic in `N` for a sum over
    /// pairs (the generated code uses [`diagonals::layout`]).
    pub fn hessian_pattern(&self) -> Vec<(usize, usize)> {
        let mut seen = std::collections::HashSet::new();
        let mut out = Vec::new();
        for s in &self.sums {
            for i in s.lo..=s.hi {
                for &(r, t) in &s.pattern {
                    let (lr, cr, _) = s.slots[r];
                    let (lt, ct, _) = s.slots[t];
                    if let (Site::Var(a), Site::Var(b)) =
                        (self.site(lr, i + cr), self.site(lt, i + ct))
                    {
                        let e = (a.min(b), a.max(b));
                        if seen.insert(e) {
                            out.push(e);
                        }
                    }
                }
            }
        }
        for s in &self.nested {
            for at in s.tuples.iter() {
                for &(r, t) in &s.pattern {
                    let (a, b) = (
                        s.slots[r].position(at, self.n),
                        s.slots[t].position(at, self.n),
                    );
                    let e = (a.min(b), a.max(b));
                    if seen.insert(e) {
                        out.push(e);
                    }
                }
            }
        }
        out
    }

    /// `true` when every summand's programs (value, gradient, Hessian, and the two-point
    /// discrete gradient and defect) hold at most [`MAX_BODY_OPS`] operations each.
    pub fn fits_one_body(&self) -> bool {
        let methods = [
            Method::Value,
            Method::Gradient,
            Method::Hessian,
            Method::DiscreteGradient,
            Method::DiscreteGradientDefect,
        ];
        self.summands().all(|system| {
            methods
                .iter()
                .all(|&m| system.program(m).ops.len() <= MAX_BODY_OPS)
        })
    }

    /// `true` when some summand reads a momentum.
    pub fn has_momentum(&self) -> bool {
        self.sums
            .iter()
            .any(|s| s.slots.iter().any(|&(letter, _, _)| letter == 'p'))
            || self
                .nested
                .iter()
                .any(|s| s.slots.iter().any(|slot| slot.letter == 'p'))
    }

    /// What is legal but easily a mistake, as the written-out path reports it (a `q` without
    /// its `p`, ...): one warning per run of sites, decided on the ranges.
    ///
    /// ```
    /// use dth_symbolic::looped;
    /// let src = "sum(i = 1..4, p[i]^2/2) + sum(i = 1..N, q[i]^2/2) where N = 4096";
    /// let h = looped::compile(src, &[]).unwrap();
    /// let w: Vec<String> = h.warnings().iter().map(|w| w.to_string()).collect();
    /// assert_eq!(w, ["`q5`..`q4096` appear without `p5`..`p4096`: they never move \
    ///     (dH/dp = 0) and their momenta only drift; constants are better declared as parameters"]);
    /// assert_eq!(&src[h.warnings()[0].span.range()], "q[i]");
    /// ```
    pub fn warnings(&self) -> &[Warning] {
        &self.warnings
    }

    /// Where `letter[k]` (`letter` is `'q'` or `'p'`) is read from: a variable of the
    /// lattice or a periodic boundary's site, or a fixed boundary's value (`0` outside both).
    pub fn site(&self, letter: char, k: i64) -> Site {
        if (1..=self.n as i64).contains(&k) {
            return Site::Var(index_of(letter, k, self.n));
        }
        self.boundaries
            .iter()
            .find(|&&(l, s, _)| l == letter && s == k)
            .map_or(Site::Const(0.0), |&(_, _, site)| site)
    }

    fn check(&self, z: &[f64], params: &[f64]) -> Result<(), EvalError> {
        if z.len() != self.dim() {
            return Err(EvalError::WrongLength {
                what: "z",
                expected: self.dim(),
                found: z.len(),
            });
        }
        if params.len() != self.params {
            return Err(EvalError::WrongLength {
                what: "params",
                expected: self.params,
                found: params.len(),
            });
        }
        Ok(())
    }

    /// Runs `each(summand, sites, local values)` at every site of every sum over sites, then
    /// at every tuple of every nested sum, the local coordinates read from `z` (or the
    /// boundaries).
    fn sites(&self, z: &[f64], mut each: impl FnMut(Summand<'_>, &[Site], &[f64])) {
        let mut sites = Vec::new();
        let mut x = Vec::new();
        for s in &self.sums {
            let locals: Vec<usize> = s.slots.iter().map(|slot| slot.2).collect();
            let summand = Summand {
                all: &s.all,
                pair: &s.pair,
                defect: &s.defect,
                locals: &locals,
                pattern: &s.pattern,
                local_dim: s.local_dim,
            };
            for i in s.lo..=s.hi {
                sites.clear();
                x.clear();
                x.resize(s.local_dim, 0.0);
                for &(letter, c, local) in &s.slots {
                    let site = self.site(letter, i + c);
                    x[local] = match site {
                        Site::Var(k) => z[k],
                        Site::Const(v) => v,
                    };
                    sites.push(site);
                }
                each(summand, &sites, &x);
            }
        }
        for s in &self.nested {
            let locals: Vec<usize> = s.slots.iter().map(|slot| slot.local).collect();
            let summand = Summand {
                all: &s.all,
                pair: &s.pair,
                defect: &s.defect,
                locals: &locals,
                pattern: &s.pattern,
                local_dim: s.local_dim,
            };
            for at in s.tuples.iter() {
                sites.clear();
                x.clear();
                x.resize(s.local_dim, 0.0);
                for slot in &s.slots {
                    let k = slot.position(at, self.n);
                    x[slot.local] = z[k];
                    sites.push(Site::Var(k));
                }
                each(summand, &sites, &x);
            }
        }
    }

    /// Value and gradient, in one loop over the sites.
    pub fn value_gradient(&self, z: &[f64], params: &[f64]) -> Result<(f64, Vec<f64>), EvalError> {
        let e = self.eval(z, params)?;
        Ok((e.value, e.gradient))
    }

    /// Value, gradient, the Hessian's nonzeros and Psi: one loop over the sites for the
    /// first three, one more for Psi (which needs the whole gradient).
    pub fn eval(&self, z: &[f64], params: &[f64]) -> Result<LoopedEvaluation, EvalError> {
        self.check(z, params)?;
        let d = self.dim();
        let mut value = 0.0;
        let mut gradient = vec![0.0; d];
        let mut entries: Vec<(usize, usize, f64)> = Vec::new();
        let mut failed = None;
        self.sites(z, |s, sites, x| {
            let e = match s.all.eval(x, params) {
                Ok(e) => e,
                Err(err) => {
                    failed = Some(err);
                    return;
                }
            };
            value += e.value;
            for (r, &lr) in s.locals.iter().enumerate() {
                if let Site::Var(a) = sites[r] {
                    gradient[a] += e.gradient[lr];
                }
            }
            for &(r, t) in s.pattern {
                let (Site::Var(a), Site::Var(b)) = (sites[r], sites[t]) else {
                    continue;
                };
                let h = e.hessian[s.locals[r] * s.local_dim + s.locals[t]];
                // Two slots on one particle (a ring of two): d^2/dz_a^2 of f(z_a, z_a) has
                // the mixed entry twice.
                let h = if r != t && a == b { 2.0 * h } else { h };
                entries.push((a.min(b), a.max(b), h));
            }
        });
        if let Some(err) = failed {
            return Err(err);
        }
        // Entries from several sites and sums on one (a, b) add up.
        entries.sort_by_key(|&(a, b, _)| (a, b));
        let mut hessian: Vec<(usize, usize, f64)> = Vec::with_capacity(entries.len());
        for (a, b, v) in entries {
            match hessian.last_mut() {
                Some(last) if (last.0, last.1) == (a, b) => last.2 += v,
                _ => hessian.push((a, b, v)),
            }
        }
        // Psi = w^T Hess w, w = J grad, over the nonzeros (each off-diagonal entry twice).
        let n = self.n;
        let w = |i: usize| {
            if i < n {
                gradient[i + n]
            } else {
                -gradient[i - n]
            }
        };
        let psi = hessian
            .iter()
            .map(|&(a, b, v)| {
                if a == b {
                    v * w(a) * w(a)
                } else {
                    2.0 * v * w(a) * w(b)
                }
            })
            .sum();
        Ok(LoopedEvaluation {
            value,
            gradient,
            hessian,
            psi,
        })
    }

    /// The discrete gradient `gbar(z0, z1)`, `H(z1) - H(z0)` without cancellation, and the
    /// defect `grad H(z0) + grad H(z1) - 2 gbar`: each summand's two-point programs, scattered.
    pub fn eval_pair(
        &self,
        z0: &[f64],
        z1: &[f64],
        params: &[f64],
    ) -> Result<(Vec<f64>, f64, Vec<f64>), EvalError> {
        self.check(z0, params)?;
        self.check(z1, params)?;
        let d = self.dim();
        let (mut gbar, mut delta, mut defect) = (vec![0.0; d], 0.0, vec![0.0; d]);
        let mut failed = None;
        // The sites of z0 and z1 are the same slots; collect the local z1 alongside.
        let mut x1s: Vec<Vec<f64>> = Vec::new();
        self.sites(z1, |_, _, x| x1s.push(x.to_vec()));
        let mut k = 0;
        self.sites(z0, |s, sites, x0| {
            let x1 = &x1s[k];
            k += 1;
            let (e, t) = match (
                s.pair.eval_pair(x0, x1, params),
                s.defect.eval_pair(x0, x1, params),
            ) {
                (Ok(e), Ok(t)) => (e, t),
                (Err(err), _) | (_, Err(err)) => {
                    failed = Some(err);
                    return;
                }
            };
            delta += e.energy_difference;
            for (r, &lr) in s.locals.iter().enumerate() {
                if let Site::Var(a) = sites[r] {
                    gbar[a] += e.discrete_gradient[lr];
                    defect[a] += t.discrete_gradient_defect[lr];
                }
            }
        });
        match failed {
            Some(err) => Err(err),
            None => Ok((gbar, delta, defect)),
        }
    }
}
