//! A looped lattice's flags, decided on the whole lattice's derivatives as the written-out
//! path decides them, one class of sites at a time, never site by site.
//!
//! The gradient of the whole lattice at site `a` adds, over every sum and every slot
//! `q[i + c]` of its letter, the summand's derivative at `i = a - c`. Between the cuts where
//! a sum's range starts or ends under some slot, and away from the ends of the lattice (where
//! a term reads a boundary), that sum of terms is the same expression at every site, moved
//! along: so one site per class of sites ([`Looped::classes`]) is built, in one arena, where
//! the simplifier sees terms of different sums or sites that cancel (`sum(i = 1..N, q[i]) +
//! sum(i = 1..N, -q[i])`, or the telescoping `sum(i = 1..N, q[i+1] - q[i])` of a ring). Its
//! derivatives by the sites it reads are the Hessian's row there. The sites within reach of
//! an end are classes of one site each.
//!
//! - [`Looped::psi_identically_zero`]: the written-out path proves `Psi = w^T Hess w = 0`
//!   (`w = J grad H`) when every term `Hess_ab w_a w_b` has a factor the simplifier makes 0;
//!   here the same, on the rows and gradients of the classes. Like the written-out rule read
//!   term by term, two nonzero terms `Hess_ab w_a w_b` of different entries that cancel each
//!   other are not seen (the written-out simplifier, which adds all terms into one node,
//!   could see some).
//! - [`Looped::separable`]: no nonzero entry between a position and a momentum.
//!
//! A nested sum ([`super::nested`]) counts by its summand: the lattice is separable when
//! every summand is and the sums over sites are, and Psi is not claimed identically zero
//! (the cautious answer) once there is one.
//!
//! A fixed boundary's value enters as the number the generated code reads (`0` exactly, other
//! values as `f64`); should building a class fault (a constant that overflows), the answer is
//! the cautious one (`false` for both flags).

use std::collections::HashMap;

use super::runs::Runs;
use super::{half, LoopSum, Looped, Site};
use crate::arena::{Arena, Id, Node, Var};
use crate::error::{Error, ErrorKind};
use crate::number::{Fault, Num};

/// A Hessian entry of the whole lattice that is not identically zero: at every site `a` of
/// `sites`, the entry between `(letter, a)` and `(other, a + offset)`, letters as [`half`].
struct Entry {
    sites: (i64, i64),
    letter: usize,
    other: usize,
    offset: i64,
}

/// The whole lattice's derivatives, as far as the flags need them.
struct Derivatives {
    /// Per letter, the sites where the gradient is not identically zero.
    gradient: [Runs; 2],
    entries: Vec<Entry>,
}

/// `id` of `from`, rebuilt in `to` through its simplifying constructors, each variable
/// replaced by what `var` makes of it.
fn import(
    from: &Arena,
    id: Id,
    to: &mut Arena,
    var: &mut impl FnMut(Var, &mut Arena) -> Result<Id, Fault>,
    memo: &mut HashMap<Id, Id>,
) -> Result<Id, Fault> {
    if let Some(&done) = memo.get(&id) {
        return Ok(done);
    }
    // A fault (a divisor that is 0 once a boundary's value is in) points at its node.
    to.span = from.span(id);
    let out = match from.node(id) {
        Node::Num(x) => to.num(*x),
        Node::Var(v) => var(*v, to)?,
        Node::Add(terms) | Node::Mul(terms) => {
            let mut parts = Vec::with_capacity(terms.len());
            for &t in terms.iter() {
                parts.push(import(from, t, to, var, memo)?);
            }
            to.span = from.span(id);
            match from.node(id) {
                Node::Add(_) => to.add(&parts)?,
                _ => to.mul(&parts)?,
            }
        }
        &Node::Pow(base, e) => {
            let base = import(from, base, to, var, memo)?;
            to.span = from.span(id);
            to.pow(base, e)?
        }
        &Node::Func(f, x) => {
            let x = import(from, x, to, var, memo)?;
            to.span = from.span(id);
            to.func(f, x)?
        }
    };
    memo.insert(id, out);
    Ok(out)
}

impl Looped {
    /// The classes of sites, as runs `(first, last)` covering `1..n`: on each, which terms
    /// reach a site (sum, slot) does not change, and no term reaching it reads a boundary,
    /// or the class is one site (see the module docs).
    fn classes(&self) -> Vec<(i64, i64)> {
        let n = self.n as i64;
        let mut cuts = vec![1, n + 1];
        let mut reach = 0i64;
        for s in &self.sums {
            for &(_, cr, _) in &s.slots {
                cuts.push(s.lo.saturating_add(cr));
                cuts.push(s.hi.saturating_add(cr).saturating_add(1));
                for &(_, ct, _) in &s.slots {
                    reach = reach.max(cr.saturating_sub(ct).saturating_abs());
                }
            }
        }
        // A term at site `a` through slot `r` reads slot `t` at `a - c_r + c_t`: outside the
        // lattice only for `a <= c_r - c_t` or `a > n - (c_t - c_r)`.
        for k in 0..=reach.min(n) {
            cuts.extend([1 + k, n + 1 - k]);
        }
        // A site a boundary stands for (`q[N+1] = q[1]`) is reached through it too.
        for &(_, _, site) in &self.boundaries {
            if let Site::Var(position) = site {
                let (_, k) = self.letter_site(position);
                cuts.extend([k, k + 1]);
            }
        }
        cuts.retain(|c| (1..=n + 1).contains(c));
        cuts.sort_unstable();
        cuts.dedup();
        cuts.windows(2).map(|w| (w[0], w[1] - 1)).collect()
    }

    /// The whole lattice's gradient with respect to `(letter, a)`, in `arena`, whose
    /// variables stand for the positions of `z` listed in `positions`.
    fn gradient_at(
        &self,
        (letter, a): (char, i64),
        arena: &mut Arena,
        positions: &mut Vec<usize>,
    ) -> Result<Id, Fault> {
        let position = match self.site(letter, a) {
            Site::Var(position) => position,
            Site::Const(_) => return Ok(arena.num(Num::ZERO)),
        };
        // The sites outside the lattice that stand for this one (a periodic boundary).
        let through: Vec<(char, i64)> = self
            .boundaries
            .iter()
            .filter(|&&(_, _, site)| site == Site::Var(position))
            .map(|&(l, k, _)| (l, k))
            .collect();
        let mut terms = Vec::new();
        for s in &self.sums {
            for &(l, c, local) in &s.slots {
                let reached = std::iter::once((letter, a)).chain(through.iter().copied());
                for i in reached
                    .filter(|&(bl, _)| bl == l)
                    .map(|(_, k)| k.saturating_sub(c))
                {
                    if !(s.lo..=s.hi).contains(&i) {
                        continue;
                    }
                    let system = s.summand();
                    let mut var = |v: Var, to: &mut Arena| self.at_site(s, i, v, to, positions);
                    let g = import(
                        system.arena(),
                        system.gradient()[local],
                        arena,
                        &mut var,
                        &mut HashMap::new(),
                    )?;
                    terms.push(g);
                }
            }
        }
        arena.add(&terms)
    }

    /// The summand's local variable `v` at site `i` of sum `s`: the variable of `arena` for
    /// the position of `z` it reads (listed in `positions`), or a fixed boundary's value.
    fn at_site(
        &self,
        s: &LoopSum,
        i: i64,
        v: Var,
        arena: &mut Arena,
        positions: &mut Vec<usize>,
    ) -> Result<Id, Fault> {
        let half = s.local_dim / 2;
        let local = match v {
            Var::Q(k) => k as usize - 1,
            Var::P(k) => half + k as usize - 1,
            other => return Ok(arena.var(other)),
        };
        let Some(&(letter, c, _)) = s.slots.iter().find(|slot| slot.2 == local) else {
            return Ok(arena.var(v));
        };
        match self.site(letter, i + c) {
            Site::Const(value) => Ok(arena.num(Num::float(value)?)),
            Site::Var(position) => {
                let k = match positions.iter().position(|&p| p == position) {
                    Some(k) => k,
                    None => {
                        positions.push(position);
                        positions.len() - 1
                    }
                };
                // Fewer than `MAX_INDEX`: a class reads a few sites per slot of each sum.
                let k = u32::try_from(k + 1).map_err(|_| Fault::NonFinite)?;
                if k as usize > crate::MAX_INDEX {
                    return Err(Fault::NonFinite);
                }
                Ok(arena.var(Var::Q(k)))
            }
        }
    }

    /// The parameter names of the summands (every sum's arena has the same), for a new
    /// arena of the whole lattice.
    fn params(&self) -> Vec<&str> {
        self.sums
            .first()
            .map(|s| {
                s.summand()
                    .arena()
                    .params()
                    .iter()
                    .map(String::as_str)
                    .collect()
            })
            .unwrap_or_default()
    }

    /// The faults of the summands at the sites where a slot reads a fixed boundary (`1/q[i-1]^2`
    /// at `i = 1` with `q[0] = 0`: a divisor that is 0 there), as the site-by-site path finds
    /// them when it builds those terms: one error per fault and place. The summand is built
    /// again there with the boundary's value in; the sites are a few at each end of a sum.
    pub(crate) fn boundary_faults(&self) -> Vec<Error> {
        let n = self.n as i64;
        let params = self.params();
        let mut errors: Vec<Error> = Vec::new();
        for s in &self.sums {
            let low = s.slots.iter().map(|slot| slot.1).min().unwrap_or(0);
            let high = s.slots.iter().map(|slot| slot.1).max().unwrap_or(0);
            // Below `1 - low` some slot reads below the lattice, above `n - high` beyond it.
            let below = s.lo..=s.hi.min(0i64.saturating_sub(low));
            let above = s.lo.max(n.saturating_sub(high).saturating_add(1))..=s.hi;
            for i in below.chain(above) {
                let mut arena = Arena::new(&params);
                let mut positions = Vec::new();
                let system = s.summand();
                let mut var = |v: Var, to: &mut Arena| self.at_site(s, i, v, to, &mut positions);
                let built = import(
                    system.arena(),
                    system.value(),
                    &mut arena,
                    &mut var,
                    &mut HashMap::new(),
                );
                if let Err(fault) = built {
                    let e = Error::new(ErrorKind::Fault(fault), arena.span);
                    if !errors.contains(&e) {
                        errors.push(e);
                    }
                }
            }
        }
        errors
    }

    /// The gradient and the nonzero Hessian entries of the whole lattice, class by class;
    /// `None` when building a class faults.
    fn derivatives(&self) -> Option<Derivatives> {
        let params = self.params();
        let mut gradient: [Runs; 2] = Default::default();
        let mut entries = Vec::new();
        for (first, last) in self.classes() {
            for letter in ['q', 'p'] {
                let mut arena = Arena::new(&params);
                let mut positions = Vec::new();
                let g = self
                    .gradient_at((letter, first), &mut arena, &mut positions)
                    .ok()?;
                if arena.is_zero(g) {
                    continue;
                }
                gradient[half(letter)].insert(first, last);
                for (k, &position) in positions.iter().enumerate() {
                    let x = Var::Q(u32::try_from(k + 1).ok()?);
                    let h = arena.diff(g, x).ok()?;
                    if !arena.is_zero(h) {
                        let (other, b) = self.letter_site(position);
                        entries.push(Entry {
                            sites: (first, last),
                            letter: half(letter),
                            other: half(other),
                            offset: b - first,
                        });
                    }
                }
            }
        }
        Some(Derivatives { gradient, entries })
    }

    /// `true` when Psi is identically zero by the written-out path's rule (see the module
    /// docs): no nonzero Hessian entry `(a, b)` where `w_a` and `w_b` (`w = J grad H`: at
    /// `q[k]` the gradient by `p[k]`, at `p[k]` by `q[k]`) are both nonzero.
    ///
    /// ```
    /// use dth_symbolic::looped;
    /// // A free chain pushed by a constant force: Psi = sum_i (dH/dq[i])^2 = N, not zero.
    /// let free = looped::compile("sum(i = 1..N, p[i]^2/2 + q[i]) where N = 8", &[]).unwrap();
    /// assert!(!free.psi_identically_zero());
    /// let drift = looped::compile("sum(i = 1..N, p[i]^2/2 + p[i]) where N = 8", &[]).unwrap();
    /// assert!(drift.psi_identically_zero());
    /// // The force of the second sum cancels the first's: the chain is free, Psi = 0.
    /// let cancelled = "sum(i = 1..N, p[i]^2/2 + q[i]) + sum(i = 1..N, -q[i]) where N = 8";
    /// assert!(looped::compile(cancelled, &[]).unwrap().psi_identically_zero());
    /// ```
    pub fn psi_identically_zero(&self) -> bool {
        self.flags().1
    }

    /// `true` when no Hessian entry of the whole lattice between a position and a momentum is
    /// nonzero: `H = T(p) + V(q)`.
    ///
    /// ```
    /// use dth_symbolic::looped;
    /// let src = "sum(i = 1..N, p[i]^2/2 + q[i]*p[i]) + sum(i = 1..N, q[i]^2/2 - q[i]*p[i]) \
    ///            where N = 8";
    /// assert!(looped::compile(src, &[]).unwrap().separable());
    /// ```
    pub fn separable(&self) -> bool {
        self.flags().0
    }

    /// `(separable, psi_identically_zero)` from one build of the lattice's derivatives (what
    /// the emitter asks for together); `(false, false)` when building them faults.
    pub fn flags(&self) -> (bool, bool) {
        let Some(d) = self.derivatives() else {
            return (false, false);
        };
        // A nested sum: separable when its summand is; Psi is then not proven zero (the
        // cautious answer: the stepper computes it).
        let nested_separable = self.nested.iter().all(|s| {
            s.pattern
                .iter()
                .all(|&(r, t)| s.slots[r].letter == s.slots[t].letter)
        });
        if !self.nested.is_empty() {
            let separable = nested_separable && d.entries.iter().all(|e| e.letter == e.other);
            return (separable, false);
        }
        let separable = d.entries.iter().all(|e| e.letter == e.other);
        // `w` at letter `l` is the gradient by the other letter.
        let w = |l: usize| &d.gradient[1 - l];
        let psi_identically_zero = !d.entries.iter().any(|e| {
            !w(e.letter)
                .intersect(&w(e.other).minus(e.offset))
                .intersect(&Runs::run(e.sites.0, e.sites.1))
                .is_empty()
        });
        (separable, psi_identically_zero)
    }
}
