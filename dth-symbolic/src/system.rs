//! A compiled Hamiltonian: `calH`, its gradient, the upper triangle of its Hessian and Psi, all
//! as nodes of one arena (so they share every common subexpression).

use crate::arena::{Arena, Id, Node, Var};
use crate::build::{coordinates, Builder};
use crate::check;
use crate::error::{Error, ErrorKind, Errors, Warning};
use crate::lexer::lex;
use crate::lower::{Output, Program};
use crate::number::{Fault, Num};
use crate::parser::parse;
use crate::span::Span;

/// Which trait method a [`Program`] computes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Method {
    /// `H(z)` (`calH` when time-dependent).
    Value,
    /// `grad H`.
    Gradient,
    /// The nonzero entries of the upper triangle of `Hess H`.
    Hessian,
    /// `Psi = (J grad H)^T Hess H (J grad H)`.
    Psi,
    /// All four, sharing every common subexpression.
    All,
    /// The exact discrete gradient `gbar(z0, z1)` and `H(z1) - H(z0)`, without cancellation: a
    /// two-point program (see [`crate::divided`], run it with [`Program::eval_pair`]).
    DiscreteGradient,
    /// The defect `grad H(z0) + grad H(z1) - 2 gbar(z0, z1)` of that discrete gradient,
    /// without cancellation: a two-point program (see [`crate::defect`]).
    DiscreteGradientDefect,
}

/// A Hamiltonian compiled to symbolic value, gradient, Hessian and Psi.
#[derive(Clone, Debug)]
pub struct System {
    arena: Arena,
    n: usize,
    time_dependent: bool,
    coordinates: Vec<Var>,
    value: Id,
    gradient: Vec<Id>,
    hessian: Vec<Id>,
    /// The nonzero entries of the upper triangle, row by row: `(i, j, node)`, `i <= j`.
    nonzeros: Vec<(usize, usize, Id)>,
    psi: Id,
    /// What is legal but easily a mistake ([`check::indices`]).
    warnings: Vec<Warning>,
    /// Psi is lowered from the gradient and Hessian slots ([`Program::lower_assembling_psi`])
    /// rather than from its own node: decided once, on the fused program, so `Psi` and `All`
    /// use the same form and `psi()` and `derivatives().psi` agree to the bit.
    psi_assembled: bool,
    /// A regularization's `K` ([`crate::regularize`]): the flow's parameter is a fictitious
    /// time, the `t` coordinate the physical one.
    pub(crate) regularized: bool,
    /// A regularization's physical `H`, the program of its value on `(q, p)`
    /// ([`System::physical_value`]).
    pub(crate) physical: Option<Program>,
}

/// [`crate::compile`] with every sum written out site by site (at most [`crate::MAX_INDEX`]
/// sites): what it runs before it looks at the loops.
pub(crate) fn written_out(src: &str, params: &[&str]) -> Result<System, Errors> {
    let (arena, h, whole) = expression(src, params)?;
    let (mut errors, warnings) = check::indices(&written(&arena));
    errors.extend(check::structure(&arena, h, whole));
    if !errors.is_empty() {
        errors.sort_by_key(|e| e.span.start);
        return Err(Errors(errors));
    }
    let mut system = derive(arena, h, whole).map_err(|e| Errors(vec![e]))?;
    system.warnings = warnings;
    Ok(system)
}

/// The variables written in the source, each with the span of its first occurrence: before
/// differentiation every variable node in the arena was named in the source (simplification
/// may drop them from `H`, not from the arena).
fn written(arena: &Arena) -> Vec<(Var, Span)> {
    (0..arena.len())
        .filter_map(|i| match arena.node(Id(i as u32)) {
            Node::Var(v) => Some((*v, arena.span(Id(i as u32)))),
            _ => None,
        })
        .collect()
}

/// Parses and simplifies `src` without the checks that make it a Hamiltonian: the arena, the
/// root, and the span of the whole expression.
///
/// ```
/// let (arena, h, _) = dth_symbolic::expression("2*q1 + q1*3 - 5*q1^1", &[]).unwrap();
/// assert_eq!(arena.expr(h).to_string(), "0");
/// ```
pub fn expression(src: &str, params: &[&str]) -> Result<(Arena, Id, Span), Errors> {
    let mut errors = Vec::new();
    for (k, p) in params.iter().enumerate() {
        if let Some(reason) = check::reserved_name(p) {
            errors.push(Error::new(
                ErrorKind::BadParameter {
                    name: p.to_string(),
                    reason,
                },
                Span::default(),
            ));
        } else if params[..k].contains(p) {
            errors.push(Error::new(
                ErrorKind::BadParameter {
                    name: p.to_string(),
                    reason: "is declared twice",
                },
                Span::default(),
            ));
        }
    }
    let (tokens, lex_errors) = lex(src);
    let had_lex_errors = !lex_errors.is_empty();
    errors.extend(lex_errors);
    let (ast, syntax) = parse(src, &tokens);
    // With bad characters dropped, a syntax error is most likely their consequence (`2*π*q1`
    // reads as `2**q1`), and so would be the tree's errors: the names are checked alone.
    let ast = match ast {
        Some(ast) if !had_lex_errors => ast,
        _ => {
            if !had_lex_errors {
                errors.extend(syntax);
            }
            // The names do not depend on the syntax: their errors are reported too.
            errors.extend(check::name_errors(src, &tokens, params));
            errors.sort_by_key(|e| e.span.start);
            return Err(Errors(errors));
        }
    };
    errors.extend(syntax);
    let mut b = Builder {
        src,
        arena: Arena::new(params),
        errors,
        lattice: Default::default(),
    };
    let h = b.build(&ast);
    let lattice_errors = b.lattice.finish(src);
    let (arena, mut errors) = (b.arena, b.errors);
    errors.extend(lattice_errors);
    // A sum's summand is built once per site: the same mistake at the same place is one error.
    let mut unique: Vec<Error> = Vec::with_capacity(errors.len());
    for e in errors {
        if !unique.contains(&e) {
            unique.push(e);
        }
    }
    let mut errors = unique;
    match h {
        Some(h) if errors.is_empty() => Ok((arena, h, ast.span())),
        _ => {
            errors.sort_by_key(|e| e.span.start);
            Err(Errors(errors))
        }
    }
}

/// Builds `calH`, the gradient, the Hessian's upper triangle and Psi from `H`.
pub(crate) fn derive(mut arena: Arena, h: Id, whole: Span) -> Result<System, Error> {
    let fault = |f: Fault, span: Span| Error::new(ErrorKind::Fault(f), span);
    // The dimension and time dependence follow the source text, not what survives
    // simplification: `p1^2 + 0*q2` is a 2-degree-of-freedom system, as written. Every
    // variable node in the arena at this point was named in the source.
    let vars: Vec<Var> = written(&arena).into_iter().map(|(v, _)| v).collect();
    let n = vars
        .iter()
        .filter_map(|v| match v {
            Var::Q(i) | Var::P(i) => Some(*i),
            _ => None,
        })
        .max()
        .unwrap_or(0);
    let time_dependent = vars.contains(&Var::T);
    let value = if time_dependent {
        arena.span = arena.span(h);
        let pt = arena.var(Var::Pt);
        arena.add(&[h, pt]).map_err(|f| fault(f, arena.span(h)))?
    } else {
        h
    };
    derive_value(arena, value, n as usize, time_dependent, whole)
}

/// The gradient, the Hessian's upper triangle and Psi of `value`, a function of the `n`
/// degrees of freedom (and of `t`, `p_t` in the extended phase space when `extended`): the
/// compiled system whose value is `value` itself (what [`derive`] and the regularizations of
/// [`crate::regularize`] build).
pub(crate) fn derive_value(
    mut arena: Arena,
    value: Id,
    n: usize,
    time_dependent: bool,
    whole: Span,
) -> Result<System, Error> {
    let h = value;
    let fault = |f: Fault, span: Span| Error::new(ErrorKind::Fault(f), span);
    // The bound on the arena, checked after each derivative: one derivative is at most
    // quadratic in its operand, so the work stops soon after the bound is crossed.
    let bounded = |arena: &Arena| {
        if arena.size() > crate::MAX_SIZE {
            Err(Error::new(
                ErrorKind::TooLarge {
                    limit: crate::MAX_SIZE,
                },
                whole,
            ))
        } else {
            Ok(())
        }
    };
    // Faults here need a constant to fold badly (`q1^(1e300)` has the second derivative
    // `1e300 * (1e300 - 1) * q1^...`, which overflows): reported on the node whose derivative
    // failed, never hidden.
    let arena = &mut arena;
    let coordinates = coordinates(n as u32, time_dependent);
    let d = coordinates.len();
    // Only coordinates a node depends on can give a nonzero derivative ([`Arena::deps`]):
    // the gradient skips absent variables, and row `i` of the Hessian visits only the `j >= i`
    // that `dH/dz_i` depends on, so the work follows the nonzeros, not `D^2`.
    let zero = arena.num(Num::ZERO);
    let mut gradient = Vec::with_capacity(d);
    for &x in &coordinates {
        gradient.push(if arena.depends_on(value, x) {
            let g = arena.diff(value, x).map_err(|f| fault(f, arena.span))?;
            bounded(arena)?;
            g
        } else {
            zero
        });
    }
    let mut hessian = vec![zero; d * (d + 1) / 2];
    let mut nonzeros = Vec::new();
    let mut k = 0;
    for (i, &g) in gradient.iter().enumerate() {
        for (j, &x) in coordinates.iter().enumerate().skip(i) {
            if arena.depends_on(g, x) {
                let h = arena.diff(g, x).map_err(|f| fault(f, arena.span))?;
                bounded(arena)?;
                if !arena.is_zero(h) {
                    hessian[k] = h;
                    nonzeros.push((i, j, h));
                }
            }
            k += 1;
        }
    }
    // Psi combines every entry: a fault there belongs to the whole Hamiltonian.
    let psi = psi(arena, &gradient, &nonzeros, d).map_err(|f| fault(f, arena.span(h)))?;
    bounded(arena)?;
    let mut system = System {
        arena: arena.clone(),
        n,
        time_dependent,
        coordinates,
        value,
        gradient,
        hessian,
        nonzeros,
        psi,
        warnings: Vec::new(),
        psi_assembled: false,
        regularized: false,
        physical: None,
    };
    if !system.psi_identically_zero() {
        let symbolic = system.program(Method::All).ops.len();
        system.psi_assembled = system.assembled(Method::All).ops.len() < symbolic;
    }
    Ok(system)
}

/// `Psi = w^T Hess w`, `w = J grad`: `sum_i H_ii w_i^2 + 2 sum_{i<j} H_ij w_i w_j` over the
/// nonzero entries.
fn psi(
    arena: &mut Arena,
    g: &[Id],
    nonzeros: &[(usize, usize, Id)],
    d: usize,
) -> Result<Id, Fault> {
    let half = d / 2;
    let mut w = Vec::with_capacity(d);
    for i in 0..d {
        w.push(if i < half {
            g[i + half]
        } else {
            arena.neg(g[i - half])?
        });
    }
    let two = arena.num(Num::int(2));
    let mut terms = Vec::with_capacity(nonzeros.len());
    for &(i, j, h) in nonzeros {
        terms.push(if i == j {
            let w2 = arena.pow(w[i], Num::int(2))?;
            arena.mul(&[h, w2])?
        } else {
            arena.mul(&[two, h, w[i], w[j]])?
        });
    }
    arena.add(&terms)
}

impl System {
    /// Degrees of freedom `n` (the largest index used).
    pub fn n(&self) -> usize {
        self.n
    }

    /// Phase-space dimension `D`: `2n`, or `2n + 2` when time-dependent.
    pub fn dim(&self) -> usize {
        self.coordinates.len()
    }

    /// `true` when `H` uses `t`: `z = (q1..qn, t, p1..pn, p_t)` and the value is `p_t + H`.
    pub fn time_dependent(&self) -> bool {
        self.time_dependent
    }

    /// The coordinates in `z` order.
    pub fn coordinates(&self) -> &[Var] {
        &self.coordinates
    }

    /// `true` for a regularization's `K` ([`crate::regularize`]): `z = (u, t, P, p_t)`, the
    /// flow's parameter a fictitious time `s` and `t` the physical time (`dt/ds = dK/dp_t`).
    pub fn regularized(&self) -> bool {
        self.regularized
    }

    /// A regularization's physical Hamiltonian `H(q, p)`, before the map: the program of its
    /// value on `z = (q1..qn, p1..pn)` (`n` the map's physical degrees of freedom: 2 for
    /// Levi-Civita, 3 for Kustaanheimo-Stiefel), with the parameters of `K`. What a run's start
    /// takes its energy from, in double-double ([`Program::value_double_double`]): `p_t = -H`
    /// sets a Kepler orbit's period. `None` for a Hamiltonian that is not a regularization.
    ///
    /// ```
    /// let k = dth_symbolic::regularize::levi_civita("p1^2 + p2^2 - (q1^2 + q2^2)^(-1/2)", &[]).unwrap();
    /// let h = k.physical_value().unwrap();
    /// let p = 1.999f64.sqrt(); // e = 0.999 at the pericentre r = 0.5
    /// assert_eq!(h.value_double_double(&[0.5, 0.0, 0.0, p], &[]).unwrap(), p.mul_add(p, -2.0));
    /// ```
    pub fn physical_value(&self) -> Option<&Program> {
        self.physical.as_ref()
    }

    /// `true` when the block of the Hessian between the first and second halves of `z`
    /// (positions and momenta) is identically zero: `H = T(p) + V(q)`.
    pub fn separable(&self) -> bool {
        let half = self.dim() / 2;
        self.nonzeros.iter().all(|&(i, j, _)| i >= half || j < half)
    }

    /// `true` when Psi simplifies to 0 (a linear `H`, a free particle). The simplifier proves
    /// zero for these cases; an identity it cannot see (`sin^2 + cos^2 - 1`) reports `false`.
    pub fn psi_identically_zero(&self) -> bool {
        self.arena.is_zero(self.psi)
    }

    /// What is legal but easily a mistake, in source order: a `q<i>` without its `p<i>`, and
    /// beside one, a `p<j>` without its `q<j>` ([`check::indices`]).
    ///
    /// ```
    /// let h = dth_symbolic::compile("p1^2/2 + p3^2/2 + q1^2 + q2^2", &[]).unwrap();
    /// let w: Vec<String> = h.warnings().iter().map(|w| w.to_string()).collect();
    /// assert_eq!(w, [
    ///     "`p3` appears without `q3` while `q2` appears without `p2`: is an index misnumbered?",
    ///     "`q2` appears without `p2`: `q2` never moves (dH/dp2 = 0) and `p2` only drifts; a constant is better declared as a parameter",
    /// ]);
    /// assert_eq!(h.warnings()[0].span.range(), 9..11);
    /// // A cyclic coordinate alone (the angle of Kepler in polar coordinates) is no warning.
    /// let polar = dth_symbolic::compile("p1^2/2 + p2^2/(2*q1^2) - 1/q1", &[]).unwrap();
    /// assert!(polar.warnings().is_empty());
    /// ```
    pub fn warnings(&self) -> &[Warning] {
        &self.warnings
    }

    /// The arena holding every expression.
    pub fn arena(&self) -> &Arena {
        &self.arena
    }

    /// The value `H` (`calH = p_t + H` when time-dependent).
    pub fn value(&self) -> Id {
        self.value
    }

    /// `grad H` in `z` order.
    pub fn gradient(&self) -> &[Id] {
        &self.gradient
    }

    /// `d^2 H / dz_i dz_j` (symmetric: any order of `i`, `j`).
    pub fn hessian_entry(&self, i: usize, j: usize) -> Id {
        let (i, j) = if i <= j { (i, j) } else { (j, i) };
        let d = self.dim();
        // Row i of the upper triangle starts after rows 0..i: i*d - i*(i-1)/2 entries.
        self.hessian[i * d - i * i.saturating_sub(1) / 2 + (j - i)]
    }

    /// The nonzero entries of the Hessian's upper triangle, row by row: `(i, j, node)`,
    /// `i <= j`.
    pub fn hessian_nonzeros(&self) -> &[(usize, usize, Id)] {
        &self.nonzeros
    }

    /// Psi.
    pub fn psi(&self) -> Id {
        self.psi
    }

    /// The declared parameter names.
    pub fn params(&self) -> &[String] {
        self.arena.params()
    }

    /// A printable view of `id`.
    pub fn expr(&self, id: Id) -> crate::display::Expr<'_> {
        self.arena.expr(id)
    }

    /// The outputs a method computes, with their nodes (zero Hessian entries left out). The
    /// discrete gradient has no nodes of its own (its program is built by
    /// [`System::program`]): empty for [`Method::DiscreteGradient`].
    pub fn outputs(&self, method: Method) -> Vec<(Output, Id)> {
        let mut out = Vec::new();
        if matches!(method, Method::Value | Method::All) {
            out.push((Output::Value, self.value));
        }
        if matches!(method, Method::Gradient | Method::All) {
            out.extend(
                self.gradient
                    .iter()
                    .enumerate()
                    .map(|(i, &g)| (Output::Gradient(i), g)),
            );
        }
        if matches!(method, Method::Hessian | Method::All) {
            out.extend(
                self.nonzeros
                    .iter()
                    .map(|&(i, j, h)| (Output::Hessian(i, j), h)),
            );
        }
        if matches!(method, Method::Psi | Method::All) {
            out.push((Output::Psi, self.psi));
        }
        out
    }

    /// The straight-line program of `method`: it computes only what that method needs.
    pub fn program(&self, method: Method) -> Program {
        if method == Method::DiscreteGradient {
            return crate::divided::lower(&self.arena, &self.coordinates, self.value);
        }
        if method == Method::DiscreteGradientDefect {
            return crate::defect::lower(&self.arena, &self.coordinates, self.value);
        }
        if self.psi_assembled && matches!(method, Method::Psi | Method::All) {
            self.assembled(method)
        } else {
            Program::lower(&self.arena, &self.coordinates, &self.outputs(method))
        }
    }

    /// The program of `method` with Psi assembled from the gradient and Hessian slots.
    fn assembled(&self, method: Method) -> Program {
        let others: Vec<(Output, Id)> = self
            .outputs(method)
            .into_iter()
            .filter(|&(o, _)| o != Output::Psi)
            .collect();
        Program::lower_assembling_psi(
            &self.arena,
            &self.coordinates,
            &others,
            &self.gradient,
            &self.nonzeros,
        )
    }

    /// Whether `id` is a constant, and which.
    pub fn constant(&self, id: Id) -> Option<Num> {
        match self.arena.node(id) {
            Node::Num(n) => Some(*n),
            _ => None,
        }
    }
}
