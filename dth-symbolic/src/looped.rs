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
//! What loops: a sum of single-index sums (`sum(i = a..b, f)`, no nesting, no sum over
//! pairs) whose indices are the sum's index plus a constant, with boundaries that are
//! constants (fixed ends) or a variable of the lattice (periodic), no written-out coordinate
//! and no `t`. Anything else is [`LoopError::NotLoopable`]: compile it with
//! [`crate::compile`], which builds sums site by site.
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
}

/// The summands of `ast` (a sum of sums), or why it does not loop.
fn sums(ast: &Ast) -> Result<Vec<&Ast>, LoopError> {
    match ast {
        Ast::Paren { inner, .. } => sums(inner),
        Ast::Sum { .. } => Ok(vec![ast]),
        Ast::Chain { first, rest } => {
            let mut out = sums(first)?;
            for (op, _, x) in rest {
                if *op != BinOp::Add {
                    return Err(LoopError::NotLoopable("the sums are not added"));
                }
                out.extend(sums(x)?);
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
    // The ranges first: the lattice is 1..n, n the largest upper bound.
    let mut ranges = Vec::new();
    for term in &terms {
        let Ast::Sum { range, body, span } = term else {
            continue;
        };
        let Range::Single { index, lo, hi } = &**range else {
            return Err(LoopError::NotLoopable("a sum over pairs"));
        };
        let (name, lo_value, hi_value) = (root.bindable(*index), root.int(lo), root.int(hi));
        if let (Some(name), Some(lo_value), Some(hi_value)) = (name, lo_value, hi_value) {
            let (lo_bound, hi_bound) = (
                Bound {
                    ast: lo,
                    value: lo_value,
                },
                Bound {
                    ast: hi,
                    value: hi_value,
                },
            );
            // Before anything is counted out per site: `N = 10^12` is one error, here.
            if let Some(e) = root
                .lattice
                .too_large(src, lo_bound, hi_bound, crate::MAX_SITES)
            {
                root.errors.push(e);
                continue;
            }
            let (lo, hi) = (lo_value, hi_value);
            if lo > hi {
                root.errors.push(Error::new(
                    ErrorKind::EmptySum {
                        range: format!("{name} = {lo}..{hi}"),
                    },
                    range.span(),
                ));
            }
            ranges.push((name, lo, hi, body, *span));
        }
    }
    if !root.errors.is_empty() {
        return Err(fail(root.errors));
    }
    let n = ranges.iter().map(|r| r.2).max().unwrap_or(0);
    let Ok(n_sites) = usize::try_from(n) else {
        return Err(LoopError::NotLoopable("the lattice is empty"));
    };
    // The faults of a source that loops are errors here, as the site-by-site path reports
    // them: `crate::compile` shows them for a lattice too large to write out.
    let mut errors = Vec::new();
    let mut not_loopable = None;
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
    for (name, lo, hi, body, span) in ranges {
        let mut b = Builder {
            src,
            arena: Arena::new(params),
            errors: Vec::new(),
            lattice: root.lattice.clone(),
        };
        b.lattice.local = Some(Local {
            index: name.clone(),
            ..Local::default()
        });
        b.lattice.bound.push((name, 0));
        let f = b.build(body);
        let local = b.lattice.local.take().unwrap_or_default();
        if let Some(why) = local.not_loopable {
            not_loopable = Some(why);
            continue;
        }
        // Every site the summand reaches is in the lattice or a boundary.
        errors.extend(out_of_range(
            src,
            (&local.index, lo, hi),
            n,
            &local,
            &boundaries,
        ));
        let f = match f {
            Some(f) if b.errors.is_empty() => f,
            _ => {
                errors.append(&mut b.errors);
                continue;
            }
        };
        let system = match derive(b.arena, f, span) {
            Ok(system) => system,
            Err(e) => {
                errors.push(e);
                continue;
            }
        };
        let half = system.dim() / 2;
        let slots = local
            .slots
            .iter()
            .map(|&(letter, c)| {
                let k = local
                    .slots
                    .iter()
                    .filter(|&&(l, _)| l == letter)
                    .position(|&(_, d)| d == c)
                    .unwrap_or(0);
                (letter, c, if letter == 'q' { k } else { half + k })
            })
            .collect::<Vec<_>>();
        let slot_of = |local: usize| slots.iter().position(|&(_, _, l)| l == local);
        let pattern = system
            .hessian_nonzeros()
            .iter()
            .filter_map(|&(i, j, _)| Some((slot_of(i)?, slot_of(j)?)))
            .collect();
        compiled.push(LoopSum {
            lo,
            hi,
            slots,
            pattern,
            spans: local.spans.clone(),
            local_dim: system.dim(),
            system: system.clone(),
            all: system.program(Method::All),
            pair: system.program(Method::DiscreteGradient),
            defect: system.program(Method::DiscreteGradientDefect),
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
    };
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

/// The errors of the accesses of one sum `index = lo..hi` (built in `local`) that leave the
/// lattice `1..n` where no boundary is declared: one per access, at its farthest such site,
/// as the site-by-site path reports them. The sites outside the lattice a slot `q[i + c]`
/// reaches are a few at either end of `lo + c..hi + c`; each scan stops at the first site
/// that is not a boundary, so it runs at most once more than there are boundaries.
fn out_of_range(
    src: &str,
    (index, lo, hi): (&str, i64, i64),
    n: i64,
    local: &Local,
    boundaries: &[(char, i64, Site)],
) -> Vec<Error> {
    let open = |letter: char, k: i64| !boundaries.iter().any(|&(l, s, _)| l == letter && s == k);
    let mut errors = Vec::new();
    for &(slot, span) in &local.accesses {
        let (letter, c) = local.slots[slot];
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

    /// The operations of all the summands' programs together: what a loop body holds, the
    /// same for every number of sites.
    pub fn ops(&self) -> usize {
        self.sums
            .iter()
            .map(|s| s.all.ops.len() + s.pair.ops.len() + s.defect.ops.len())
            .sum()
    }

    /// The Hessian's nonzero entries `(i, j)`, `i <= j`, in the order the loops first reach
    /// them (sum by sum, site by site, the summand's entries in order), each once: the order
    /// generated code writes them in.
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
        self.sums.iter().all(|s| {
            methods
                .iter()
                .all(|&m| s.system.program(m).ops.len() <= MAX_BODY_OPS)
        })
    }

    /// `true` when some summand reads a momentum.
    pub fn has_momentum(&self) -> bool {
        self.sums
            .iter()
            .any(|s| s.slots.iter().any(|&(letter, _, _)| letter == 'p'))
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

    /// Runs `each(sum, sites, local values)` at every site of every sum, the local
    /// coordinates read from `z` (or the boundaries).
    fn sites(&self, z: &[f64], mut each: impl FnMut(&LoopSum, &[Site], &[f64])) {
        let mut sites = Vec::new();
        let mut x = Vec::new();
        for s in &self.sums {
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
                each(s, &sites, &x);
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
            for (r, &(_, _, lr)) in s.slots.iter().enumerate() {
                if let Site::Var(a) = sites[r] {
                    gradient[a] += e.gradient[lr];
                }
            }
            for &(r, t) in &s.pattern {
                let (Site::Var(a), Site::Var(b)) = (sites[r], sites[t]) else {
                    continue;
                };
                let h = e.hessian[s.slots[r].2 * s.local_dim + s.slots[t].2];
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
            for (r, &(_, _, lr)) in s.slots.iter().enumerate() {
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
