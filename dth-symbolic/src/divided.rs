//! Exact, cancellation-free discrete gradients by symbolic divided differences.
//!
//! For `H` and two points `z0`, `z1` with step `d = z1 - z0`, the discrete gradient
//! `gbar(z0, z1)` satisfies `gbar . d = H(z1) - H(z0)` exactly (in exact arithmetic) and
//! `gbar(z, z) = grad H(z)`. It is built by structural recursion over the expression: every
//! node `a` gets a vector `Delta[a]` with `Delta[a] . d = a(z1) - a(z0)` and, computed by the
//! same rules, the scalar `delta[a] = a(z1) - a(z0)` itself. With `a0 = a(z0)`, `a1 = a(z1)`,
//! `mean(a) = (a0 + a1)/2`:
//!
//! | node | `Delta` |
//! |---|---|
//! | `z_i` | `e_i` (and `delta = d_i = z1_i - z0_i`, the only subtraction of inputs) |
//! | constant, parameter | `0` |
//! | `a + b` | `Delta[a] + Delta[b]` |
//! | `a * b` | `Delta[a] mean(b) + mean(a) Delta[b]` (n-ary: folded left to right) |
//! | `a^k`, `k >= 1` | `Delta[a] sum_j a1^j a0^(k-1-j)` (by halving `k`) |
//! | `a^-k` | `u = 1/a`: `Delta[u] = -Delta[a] u0 u1`, then `u^k` |
//! | `a^(k/2)` | `s = sqrt a`: `Delta[s] = Delta[a] / (s0 + s1)`, then `s^k` |
//! | `a^r`, other `r` | `Delta[a] a0^r expm1(r ln1p(delta/a0)) / delta` |
//! | `exp a` | `Delta[a] exp(a0) expm1(delta)/delta` (from the larger end, see [`Kernel`]) |
//! | `ln a` | `Delta[a] ln1p(delta/a0)/delta` |
//! | `sin a`, `cos a` | `Delta[a] (cos, -sin)(mean a) sinc(delta/2)` |
//! | `sinh a`, `cosh a` | `Delta[a] (cosh, sinh)(mean a) sinhc(delta/2)` |
//! | `tan a` | `Delta[a] sinc(delta) / (cos(a0) cos(a1))` |
//! | `tanh a` | `Delta[a] sinhc(delta) / (cosh(a0) cosh(a0 + delta))` |
//! | `atan a` | `Delta[a] atan2(delta, 1 + a0 a1)/delta` |
//!
//! where `delta = delta[a]` and each `g(x)/x` is a [`Kernel`] with its limit at `x = 0`
//! (their formulas are in [`crate::kernel`]).
//!
//! **Why no cancellation.** The inputs are subtracted once, `d_i = z1_i - z0_i` (exact when
//! `z1_i` and `z0_i` are within a factor 2 of each other, Sterbenz). Every other sum in the
//! rules is either a sum the expression itself contains (which the gradient has too) or a sum
//! of two values of one subexpression at `z0` and at `z1` (`a0 + a1`, `s0 + s1`,
//! `a0^j + a1^j`, `1 + a0 a1` for `atan`), and those have one sign when `z1` is near `z0`. So
//! each component of `gbar` is as accurate as the gradient itself, and `gbar . d` (or `delta`
//! at the root) carries relative accuracy a few `eps` of `sum_i |gbar_i d_i|`, however small
//! `d` is; the plain `H(z1) - H(z0)` carries an absolute error of `eps |H|`, which relative to
//! the difference is `eps |H| / (|grad H| |d|)`.
//!
//! **Why the symmetric product rule.** `Delta[a b] = Delta[a] b1 + a0 Delta[b]` is exact too
//! and one operation cheaper, but not symmetric: it makes `gbar(z0, z1) - grad H(zbar)` of first
//! order in `d`, where the symmetric rule (every rule above is symmetric in `z0`, `z1`) gives
//! `gbar(z0, z1) = gbar(z1, z0) = grad H(zbar) + O(|d|^2)`, `zbar` the midpoint, as for the
//! midpoint discrete gradient of Gonzalez (1996). A symmetric discrete gradient keeps a scheme
//! built on it symmetric (time-reversible).
//!
//! # References
//! O. Gonzalez, Time integration and discrete Hamiltonian systems, J. Nonlinear Sci. 6 (1996)
//! (discrete gradients); R. I. McLachlan, G. R. W. Quispel, N. Robidoux, Geometric integration
//! using discrete gradients, Phil. Trans. R. Soc. A 357 (1999) (divided differences, symmetric
//! discrete gradients).

use std::collections::{BTreeMap, HashMap};

use crate::arena::{Arena, Func, Id, Node, Var};
use crate::kernel::{Kernel, Midpoint};
use crate::lower::{Lowerer, Op, Output, Program, Slot};
use crate::number::Num;

/// `Delta[a]` of one node: `delta = a(z1) - a(z0)` (`None`: identically 0) and the nonzero
/// components of the vector, by coordinate.
#[derive(Clone, Debug, Default)]
pub(crate) struct Diff {
    pub(crate) delta: Option<Slot>,
    pub(crate) grad: Vec<(u32, Slot)>,
}

impl Diff {
    pub(crate) fn is_zero(&self) -> bool {
        self.delta.is_none() && self.grad.is_empty()
    }
}

/// Lowers the discrete gradient of `root` to a two-point program (inputs `z0` through
/// [`Op::Input`], `z1` through [`Op::Input1`]) with outputs [`Output::DiscreteGradient`] and
/// [`Output::EnergyDifference`].
pub(crate) fn lower(arena: &Arena, coordinates: &[Var], root: Id) -> Program {
    let mut dd = Divided::new(arena, coordinates);
    let r = dd.diff(root);
    let mut outputs: Vec<(Output, Slot)> = r
        .grad
        .iter()
        .map(|&(k, s)| (Output::DiscreteGradient(k as usize), s))
        .collect();
    let delta = match r.delta {
        Some(s) => s,
        None => dd.l.konst(0.0),
    };
    outputs.push((Output::EnergyDifference, delta));
    Program {
        ops: dd.l.ops,
        outputs,
        dim: coordinates.len(),
        params: arena.params().len(),
    }
    .prune(|_| true)
}

/// The lowering state of a divided-difference program (shared with [`crate::defect`], which
/// builds on the same slots).
pub(crate) struct Divided<'a> {
    pub(crate) l: Lowerer<'a>,
    pub(crate) one: Slot,
    memo: HashMap<Id, Diff>,
    ops: HashMap<(bool, Slot, Slot), Slot>,
    factor: HashMap<(Slot, Slot, i128), Slot>,
}

impl<'a> Divided<'a> {
    pub(crate) fn new(arena: &'a Arena, coordinates: &[Var]) -> Self {
        let mut l = Lowerer::new(arena, coordinates);
        let one = l.konst(1.0);
        Divided {
            l,
            one,
            memo: HashMap::new(),
            ops: HashMap::new(),
            factor: HashMap::new(),
        }
    }
}

impl Divided<'_> {
    pub(crate) fn arena(&self) -> &Arena {
        self.l.arena
    }

    /// `a(z0)`.
    pub(crate) fn val0(&mut self, id: Id) -> Slot {
        self.l.at_z1 = false;
        self.l.value(id)
    }

    /// `a(z1)`; the same slot as `a(z0)` when `a` does not depend on `z`.
    pub(crate) fn val1(&mut self, id: Id) -> Slot {
        if self.diff(id).is_zero() {
            return self.val0(id);
        }
        self.l.at_z1 = true;
        let s = self.l.value(id);
        self.l.at_z1 = false;
        s
    }

    pub(crate) fn mul(&mut self, a: Slot, b: Slot) -> Slot {
        if a == self.one {
            b
        } else if b == self.one {
            a
        } else {
            self.shared(true, a, b)
        }
    }

    pub(crate) fn add(&mut self, a: Slot, b: Slot) -> Slot {
        self.shared(false, a, b)
    }

    /// `a * b` or `a + b`, emitted once per pair of operands (either order: both commute
    /// exactly in floating point).
    pub(crate) fn shared(&mut self, mul: bool, a: Slot, b: Slot) -> Slot {
        let key = (mul, a.min(b), a.max(b));
        if let Some(&s) = self.ops.get(&key) {
            return s;
        }
        let s = self.l.emit(if mul { Op::Mul(a, b) } else { Op::Add(a, b) });
        self.ops.insert(key, s);
        s
    }

    /// `(a + b)/2` (halving is exact).
    pub(crate) fn mean(&mut self, a: Slot, b: Slot) -> Slot {
        if a == b {
            return a;
        }
        let s = self.add(a, b);
        let half = self.l.konst(0.5);
        self.mul(half, s)
    }

    /// `Delta` scaled by the slot `f`.
    pub(crate) fn scaled(&mut self, d: &Diff, f: Slot) -> Diff {
        Diff {
            delta: d.delta.map(|s| self.mul(f, s)),
            grad: d.grad.iter().map(|&(k, s)| (k, self.mul(f, s))).collect(),
        }
    }

    /// The sum of several `Delta`s, component by component.
    pub(crate) fn sum(&mut self, parts: &[Diff]) -> Diff {
        let mut deltas = Vec::new();
        let mut grad: BTreeMap<u32, Vec<Slot>> = BTreeMap::new();
        for p in parts {
            deltas.extend(p.delta);
            for &(k, s) in &p.grad {
                grad.entry(k).or_default().push(s);
            }
        }
        let fold =
            |this: &mut Self, v: &[Slot]| v[1..].iter().fold(v[0], |acc, &s| this.add(acc, s));
        Diff {
            delta: (!deltas.is_empty()).then(|| fold(self, &deltas)),
            grad: grad.into_iter().map(|(k, v)| (k, fold(self, &v))).collect(),
        }
    }

    pub(crate) fn diff(&mut self, id: Id) -> Diff {
        if let Some(d) = self.memo.get(&id) {
            return d.clone();
        }
        let d = self.rule(id);
        self.memo.insert(id, d.clone());
        d
    }

    fn rule(&mut self, id: Id) -> Diff {
        match self.arena().node(id).clone() {
            Node::Num(_) | Node::Var(Var::Param(_)) => Diff::default(),
            Node::Var(v) => {
                let k = self.l.coords.get(&v).copied().unwrap_or(0);
                let (z0, z1) = (self.val0(id), {
                    self.l.at_z1 = true;
                    let s = self.l.value(id);
                    self.l.at_z1 = false;
                    s
                });
                let step = self.l.emit(Op::Sub(z1, z0));
                Diff {
                    delta: Some(step),
                    grad: vec![(k, self.one)],
                }
            }
            Node::Add(terms) => {
                let parts: Vec<Diff> = terms.iter().map(|&t| self.diff(t)).collect();
                self.sum(&parts)
            }
            Node::Mul(factors) => self.product(&factors),
            Node::Pow(b, e) => {
                let db = self.diff(b);
                if db.is_zero() {
                    return db;
                }
                let f = self.power_factor(id, b, e, &db);
                self.scaled(&db, f)
            }
            Node::Func(f, u) => {
                let du = self.diff(u);
                if du.is_zero() {
                    return du;
                }
                let delta = du.delta.unwrap_or(self.one);
                let (u0, u1) = (self.val0(u), self.val1(u));
                let f = self.func_factor(f, (u0, u1, delta));
                self.scaled(&du, f)
            }
        }
    }

    /// `Delta` of a product: a constant coefficient scales; the other factors fold with the
    /// symmetric product rule `Delta[P F] = Delta[P] mean(F) + mean(P) Delta[F]`.
    fn product(&mut self, factors: &[Id]) -> Diff {
        let (coef, rest) = self.coefficient_and_factors(factors);
        let mut acc = self.diff(rest[0]);
        // Values of the partial product at z0 and z1, emitted only when a factor follows.
        let mut partial: Option<(Slot, Slot)> = None;
        for (i, &f) in rest.iter().enumerate().skip(1) {
            let (p0, p1) = match partial {
                Some(p) => p,
                None => (self.val0(rest[0]), self.val1(rest[0])),
            };
            let df = self.diff(f);
            let (f0, f1) = (self.val0(f), self.val1(f));
            acc = self.product_rule(&acc, (p0, p1), &df, (f0, f1));
            if i + 1 < rest.len() {
                let same = p0 == p1 && f0 == f1;
                let q0 = self.mul(p0, f0);
                partial = Some((q0, if same { q0 } else { self.mul(p1, f1) }));
            }
        }
        let c = coef.to_f64();
        if c == 1.0 {
            return acc;
        }
        let neg = |this: &mut Self, s: Slot| {
            if c == -1.0 {
                this.l.emit(Op::Neg(s))
            } else {
                let k = this.l.konst(c);
                this.l.emit(Op::Mul(k, s))
            }
        };
        Diff {
            delta: acc.delta.map(|s| neg(self, s)),
            grad: acc.grad.iter().map(|&(k, s)| (k, neg(self, s))).collect(),
        }
    }

    /// The constant coefficient of a product (1 if none) and its other factors.
    pub(crate) fn coefficient_and_factors(&self, factors: &[Id]) -> (Num, Vec<Id>) {
        let coef = factors
            .iter()
            .find_map(|&f| self.arena().as_num(f))
            .unwrap_or(Num::ONE);
        let rest = factors
            .iter()
            .copied()
            .filter(|&f| self.arena().as_num(f).is_none())
            .collect();
        (coef, rest)
    }

    /// The symmetric product rule `Delta[P F] = Delta[P] mean(F) + mean(P) Delta[F]`, from
    /// `Delta[P]`, `Delta[F]` and the values of `P` and `F` at `z0` and `z1`.
    pub(crate) fn product_rule(
        &mut self,
        dp: &Diff,
        (p0, p1): (Slot, Slot),
        df: &Diff,
        (f0, f1): (Slot, Slot),
    ) -> Diff {
        let mut parts = Vec::new();
        if !dp.is_zero() {
            let mf = self.mean(f0, f1);
            parts.push(self.scaled(dp, mf));
        }
        if !df.is_zero() {
            let mp = self.mean(p0, p1);
            parts.push(self.scaled(df, mp));
        }
        self.sum(&parts)
    }

    /// `sum_{j=0}^{k-1} a1^j a0^(k-1-j) = (a1^k - a0^k)/(a1 - a0)`, `k >= 1`: halving `k`
    /// (`F_2m = F_m (a0^m + a1^m)`), or peeling one factor (`F_k = F_(k-1) a1 + a0^(k-1)`).
    /// Every term has the sign of `a0^(k-1)` when `a1` is near `a0`.
    pub(crate) fn power_sum(&mut self, a0: Slot, a1: Slot, k: i128) -> Slot {
        if k == 1 {
            return self.one;
        }
        if let Some(&s) = self.factor.get(&(a0, a1, k)) {
            return s;
        }
        let s = if k % 2 == 0 {
            let h = self.power_sum(a0, a1, k / 2);
            let (x0, x1) = (self.l.powi(a0, k / 2), self.l.powi(a1, k / 2));
            let s = self.add(x0, x1);
            self.mul(h, s)
        } else {
            let h = self.power_sum(a0, a1, k - 1);
            let t = self.mul(h, a1);
            let x0 = self.l.powi(a0, k - 1);
            self.add(t, x0)
        };
        self.factor.insert((a0, a1, k), s);
        s
    }

    /// `(u1^k - u0^k)/(a1 - a0)` for `u = 1/a`, `k >= 1`: `-u0 u1 F_k(u0, u1)`.
    fn recip_power_sum(&mut self, u0: Slot, u1: Slot, k: i128) -> Slot {
        let f = self.power_sum(u0, u1, k);
        let uu = self.mul(u0, u1);
        let g = self.mul(f, uu);
        self.l.emit(Op::Neg(g))
    }

    /// `(b1^e - b0^e)/(b1 - b0)` for the node `id = b^e`.
    fn power_factor(&mut self, id: Id, b: Id, e: Num, db: &Diff) -> Slot {
        let (b0, b1) = (self.val0(b), self.val1(b));
        match e.as_rational() {
            Some(r) if r.is_integer() && r.numer() > 0 => self.power_sum(b0, b1, r.numer()),
            Some(r) if r.is_integer() => {
                let (u0, u1) = (self.l.recip(b0), self.l.recip(b1));
                self.recip_power_sum(u0, u1, -r.numer())
            }
            Some(r) if r.denom() == 2 => {
                // s = sqrt(b): (s1^k - s0^k)/(s1 - s0) times (s1 - s0)/(b1 - b0) = 1/(s0 + s1).
                let (s0, s1) = (self.l.sqrt(b0), self.l.sqrt(b1));
                let k = r.numer();
                let f = if k > 0 {
                    self.power_sum(s0, s1, k)
                } else {
                    // 1/s = (1/b) s, sharing the division 1/b with the value.
                    let (r0, r1) = (self.l.recip(b0), self.l.recip(b1));
                    let (t0, t1) = (self.mul(r0, s0), self.mul(r1, s1));
                    self.recip_power_sum(t0, t1, -k)
                };
                let ss = self.add(s0, s1);
                let one = self.one;
                let g = self.l.emit(Op::Div(one, ss));
                self.mul(f, g)
            }
            _ => {
                let delta = db.delta.unwrap_or(self.one);
                let k = self
                    .l
                    .emit(Op::Kernel(Kernel::PowRatio(e.to_f64()), delta, b0));
                let v0 = self.val0(id);
                self.mul(v0, k)
            }
        }
    }

    /// `DD_f(u0, u1) = (f(u1) - f(u0))/(u1 - u0)` for the elementary function `f`, from `u0`,
    /// `u1` and `delta = u1 - u0` (shared with [`crate::defect`], which needs it for `f'`).
    pub(crate) fn func_factor(&mut self, f: Func, (u0, u1, delta): (Slot, Slot, Slot)) -> Slot {
        let half_delta = |this: &mut Self| {
            let h = this.l.konst(0.5);
            this.l.emit(Op::Mul(h, delta))
        };
        // f'(mean u) * ratio(delta/2): sin, cos, sinh, cosh.
        let mid = |this: &mut Self, rule: Midpoint| {
            let m = this.mean(u0, u1);
            let gm = this.l.emit(Op::Call(rule.partner, m));
            let gm = if rule.sign < 0.0 {
                this.l.emit(Op::Neg(gm))
            } else {
                gm
            };
            let hd = half_delta(this);
            let kk = this.l.emit(Op::Kernel(rule.ratio, hd, hd));
            this.mul(gm, kk)
        };
        // sinc(delta) / (cos(u0) cos(u1)): tan.
        let quotient = |this: &mut Self| {
            let kk = this.l.emit(Op::Kernel(Kernel::Sinc, delta, delta));
            let g0 = this.l.emit(Op::Call(Func::Cos, u0));
            let g1 = this.l.emit(Op::Call(Func::Cos, u1));
            let gg = this.mul(g0, g1);
            this.l.emit(Op::Div(kk, gg))
        };
        match f {
            Func::Exp => self.l.emit(Op::Kernel(Kernel::ExpRatio, delta, u0)),
            Func::Ln => self.l.emit(Op::Kernel(Kernel::LnRatio, delta, u0)),
            Func::Sin => mid(self, Midpoint::SIN),
            Func::Cos => mid(self, Midpoint::COS),
            Func::Sinh => mid(self, Midpoint::SINH),
            Func::Cosh => mid(self, Midpoint::COSH),
            Func::Tan => quotient(self),
            Func::Tanh => self.l.emit(Op::Kernel(Kernel::TanhRatio, delta, u0)),
            Func::Atan => {
                let uu = self.mul(u0, u1);
                let one = self.one;
                let c = self.add(one, uu);
                self.l.emit(Op::Kernel(Kernel::AtanRatio, delta, c))
            }
        }
    }
}

#[cfg(test)]
mod tests {
    //! One test per rule: the identity `gbar . d = H(z1) - H(z0)` at a large step (against the
    //! plain difference, accurate there), at a step of 1e-9 (against Gauss-Legendre quadrature
    //! of the exact gradient along the segment), `gbar(z, z) = grad H(z)`, and symmetry.

    use crate::{compile, Method, Op};

    const EPS: f64 = f64::EPSILON;

    fn dot(a: &[f64], b: &[f64]) -> f64 {
        a.iter().zip(b).map(|(x, y)| x * y).sum()
    }

    /// `sum_i |a_i b_i|`: the size of the terms of `a . b`.
    fn dot_abs(a: &[f64], b: &[f64]) -> f64 {
        a.iter().zip(b).map(|(x, y)| (x * y).abs()).sum()
    }

    /// Checks every property for `src` (plus a kinetic term) at `z0` along `dir`.
    fn check(src: &str, z0: &[f64], dir: &[f64], params: &[f64]) {
        let names: Vec<&str> = ["a", "b"][..params.len()].to_vec();
        let h = compile(src, &names).unwrap_or_else(|e| panic!("{src}: {e}"));
        let (pair, all) = (h.program(Method::DiscreteGradient), h.program(Method::All));
        let at = |z: &[f64]| all.eval(z, params).unwrap();
        let dg = |z0: &[f64], z1: &[f64]| pair.eval_pair(z0, z1, params).unwrap();
        let step = |s: f64| -> Vec<f64> { z0.iter().zip(dir).map(|(z, d)| z + s * d).collect() };
        let diff = |z1: &[f64]| -> Vec<f64> { z1.iter().zip(z0).map(|(a, b)| a - b).collect() };

        // A large step: the plain difference has error ~ eps (|H0| + |H1|), the divided
        // difference a few eps of its terms; a few dozen roundings of each are allowed.
        let z1 = step(0.3);
        let d = diff(&z1);
        let e = dg(z0, &z1);
        let (h0, h1) = (at(z0).value, at(&z1).value);
        let terms = dot_abs(&e.discrete_gradient, &d);
        let tol = 64.0 * EPS * (h0.abs() + h1.abs() + terms);
        assert!(
            (e.energy_difference - (h1 - h0)).abs() <= tol,
            "{src}: delta {} vs H1 - H0 = {}",
            e.energy_difference,
            h1 - h0
        );
        assert!(
            (dot(&e.discrete_gradient, &d) - e.energy_difference).abs() <= 64.0 * EPS * terms,
            "{src}: gbar . d {} vs delta {}",
            dot(&e.discrete_gradient, &d),
            e.energy_difference
        );
        // Symmetry: gbar(z0, z1) = gbar(z1, z0) up to rounding of the same terms.
        let back = dg(&z1, z0);
        let scale = e
            .discrete_gradient
            .iter()
            .fold(1.0f64, |m, g| m.max(g.abs()));
        for (a, b) in e.discrete_gradient.iter().zip(&back.discrete_gradient) {
            assert!(
                (a - b).abs() <= 64.0 * EPS * scale,
                "{src}: not symmetric: {a} vs {b}"
            );
        }

        // A tiny step: three-point Gauss-Legendre quadrature of grad H . d along the segment
        // has truncation error O(|d|^7), far below rounding; both sides then carry a few eps
        // of sum |g_i d_i|. The plain difference is reported for contrast.
        let z1 = step(1e-9);
        let d = diff(&z1);
        let e = dg(z0, &z1);
        let nodes = [
            (0.5, 4.0 / 9.0),
            (0.5 - 0.6f64.sqrt() / 2.0, 5.0 / 18.0),
            (0.5 + 0.6f64.sqrt() / 2.0, 5.0 / 18.0),
        ];
        let reference: f64 = nodes
            .iter()
            .map(|&(s, w)| {
                let zs: Vec<f64> = z0.iter().zip(&d).map(|(z, d)| z + s * d).collect();
                w * dot(&at(&zs).gradient, &d)
            })
            .sum();
        let terms = dot_abs(&at(z0).gradient, &d);
        let err = (e.energy_difference - reference).abs();
        assert!(
            err <= 32.0 * EPS * terms,
            "{src}: delta {} vs quadrature {reference}: error {:.1} eps of the terms",
            e.energy_difference,
            err / (EPS * terms)
        );
        assert!((dot(&e.discrete_gradient, &d) - reference).abs() <= 32.0 * EPS * terms);

        // gbar(z, z) = grad H(z): the rules reduce to the chain rule, up to rounding.
        let e = dg(z0, z0);
        let g = at(z0).gradient;
        let scale = g.iter().fold(1.0f64, |m, g| m.max(g.abs()));
        for (i, (a, b)) in e.discrete_gradient.iter().zip(&g).enumerate() {
            assert!(
                (a - b).abs() <= 16.0 * EPS * scale,
                "{src}: gbar(z, z)_{i} = {a} vs grad {b}"
            );
        }
        assert_eq!(e.energy_difference, 0.0, "{src}: H(z) - H(z)");
    }

    const Z: [f64; 2] = [0.7, -0.4];
    const DIR: [f64; 2] = [0.9, 0.5];

    #[test]
    fn variables_and_sums() {
        check("p1 + q1 - 2*q1 + 3", &Z, &DIR, &[]);
    }

    #[test]
    fn products_are_symmetric() {
        check("q1*p1 - 3*q1*p1^2*sin(p1)", &Z, &DIR, &[]);
    }

    #[test]
    fn parameters_are_constants() {
        check("a*q1^2 + b*p1^2", &Z, &DIR, &[1.5, 0.25]);
    }

    #[test]
    fn positive_integer_powers() {
        for k in [2, 3, 4, 5, 7, 12] {
            check(&format!("p1^2 + q1^{k}"), &Z, &DIR, &[]);
        }
    }

    #[test]
    fn negative_integer_powers() {
        for k in [1, 2, 3, 6] {
            check(&format!("p1^2 + (2 + q1)^(-{k})"), &Z, &DIR, &[]);
        }
    }

    #[test]
    fn half_integer_powers() {
        for r in ["1/2", "3/2", "5/2", "-1/2", "-3/2", "-5/2"] {
            check(&format!("p1^2 + (2 + q1)^({r})"), &Z, &DIR, &[]);
        }
    }

    #[test]
    fn real_powers() {
        for r in ["1/3", "-2/3", "pi", "7/5"] {
            check(&format!("p1^2 + (2 + q1)^({r})"), &Z, &DIR, &[]);
        }
    }

    #[test]
    fn variable_exponent() {
        check("p1^2 + (2 + q1)^p1", &Z, &DIR, &[]);
    }

    #[test]
    fn functions() {
        for f in [
            "exp(q1)",
            "ln(2 + q1)",
            "sin(q1)",
            "cos(q1)",
            "tan(q1)",
            "sinh(q1)",
            "cosh(q1)",
            "tanh(q1)",
            "atan(q1)",
            "atan(3*q1*p1)",
            "cos(5*q1)",
            "exp(-q1^2)",
        ] {
            check(&format!("p1^2/2 + {f}"), &Z, &DIR, &[]);
        }
    }

    #[test]
    fn kepler_and_time_dependence() {
        check(
            "p1^2 + p2^2 - (q1^2 + q2^2)^(-1/2)",
            &[0.5, 0.0, 0.0, 1.2],
            &[0.1, 0.9, -0.8, 0.2],
            &[],
        );
        // z = (q1, t, p1, p_t).
        check(
            "p1^2/2 + q1^2/2 - a*q1*cos(2*t)",
            &[0.3, 1.0, -0.2, 0.1],
            &[0.5, 0.9, 0.4, -0.3],
            &[0.7],
        );
    }

    /// A Gaussian well left from far away: `exp(-q1^2)` underflows at `z0`, and the step in
    /// its argument (875) overflows `expm1`; the divided difference is still finite and exact.
    #[test]
    fn exponential_from_underflow() {
        let h = compile("p1^2/2 + exp(-q1^2)", &[]).unwrap();
        let (z0, z1) = ([30.0, 0.0], [5.0, 0.0]);
        let e = h
            .program(Method::DiscreteGradient)
            .eval_pair(&z0, &z1, &[])
            .unwrap();
        let exact = (-25f64).exp();
        assert!((e.energy_difference - exact).abs() <= 4.0 * EPS * exact);
        assert!((e.discrete_gradient[0] * -25.0 - exact).abs() <= 4.0 * EPS * exact);
    }

    /// `tanh` whose argument jumps by 800: `sinh(800)` overflows, the kernel falls back to
    /// the plain quotient (no cancellation between values that far apart).
    #[test]
    fn hyperbolic_tangent_across_a_large_jump() {
        let h = compile("p1^2/2 + tanh(q1^3)", &[]).unwrap();
        let (z0, z1) = ([-0.5, 0.0], [(800.0f64 - 0.125).cbrt(), 0.0]);
        let e = h
            .program(Method::DiscreteGradient)
            .eval_pair(&z0, &z1, &[])
            .unwrap();
        let exact = 1.0 - (-0.125f64).tanh();
        assert!(
            (e.energy_difference - exact).abs() <= 8.0 * EPS * exact,
            "{e:?}"
        );
    }

    /// The symmetric rules make `gbar(z0, z1) = grad H(zbar) + O(|d|^2)` at the midpoint
    /// `zbar`: halving the step divides the defect by 4 (the asymmetric product rule would
    /// leave an O(|d|) defect, divided by 2).
    #[test]
    fn second_order_at_the_midpoint() {
        let h = compile("p1^2 + p2^2 - (q1^2 + q2^2)^(-1/2) + q1*p2*sin(q2)", &[]).unwrap();
        let (pair, all) = (h.program(Method::DiscreteGradient), h.program(Method::All));
        let z0 = [0.5, 0.1, 0.3, 1.2];
        let dir = [0.3, -0.2, 0.5, 0.4];
        let defect = |s: f64| {
            let z1: Vec<f64> = z0.iter().zip(&dir).map(|(z, d)| z + s * d).collect();
            let mid: Vec<f64> = z0.iter().zip(&z1).map(|(a, b)| (a + b) / 2.0).collect();
            let g = pair.eval_pair(&z0, &z1, &[]).unwrap().discrete_gradient;
            let m = all.eval(&mid, &[]).unwrap().gradient;
            g.iter()
                .zip(&m)
                .map(|(a, b)| (a - b).abs())
                .fold(0.0, f64::max)
        };
        // Steps 2e-3 and 1e-3: defects ~1e-7, far above rounding (~1e-15); the next term of
        // the expansion shifts the ratio by O(|d|) relative (0.07 at 1e-2, measured).
        let ratio = defect(2e-3) / defect(1e-3);
        assert!((ratio - 4.0).abs() < 0.05, "ratio {ratio}");
    }

    /// The program of `p1^2`, in full: the only subtraction is the step `d`, and nothing
    /// unused (the constant `1` the lowering starts with is dropped).
    #[test]
    fn square_lowers_to_sum_times_step() {
        let h = compile("p1^2", &[]).unwrap();
        assert_eq!(
            h.program(Method::DiscreteGradient).to_string(),
            "v0 = z[1]\nv1 = z1[1]\nv2 = v1 - v0\nv3 = v0 + v1\nv4 = v3 * v2\n\
             DiscreteGradient(1) = v3\nEnergyDifference = v4\n"
        );
    }

    /// `1/x`: `Delta = -Delta[x]/(x0 x1)`, sharing `1/x0`, `1/x1` with the values.
    #[test]
    fn reciprocal_form() {
        let h = compile("p1^2 + 1/q1", &[]).unwrap();
        let e = h
            .program(Method::DiscreteGradient)
            .eval_pair(&[2.0, 1.0], &[4.0, 3.0], &[])
            .unwrap();
        // (1/4 - 1/2)/(4 - 2) = -1/8; (9 - 1)/(3 - 1) = 4; H1 - H0 = -1/4 + 8.
        assert_eq!(e.discrete_gradient, vec![-0.125, 4.0]);
        assert_eq!(e.energy_difference, 7.75);
    }

    /// `sqrt(x)`: `Delta = Delta[x]/(sqrt x0 + sqrt x1)`.
    #[test]
    fn square_root_form() {
        let h = compile("p1^2 + sqrt(q1)", &[]).unwrap();
        let e = h
            .program(Method::DiscreteGradient)
            .eval_pair(&[4.0, 0.0], &[16.0, 0.0], &[])
            .unwrap();
        assert_eq!(e.discrete_gradient[0], 1.0 / 6.0);
        assert_eq!(e.energy_difference, 2.0);
    }

    /// A polynomial with positive coefficients subtracts nothing but the steps `d_i`.
    #[test]
    fn no_subtraction_but_the_steps() {
        let h = compile("p1^2 + p2^2 + (q1^2 + q2^2)^3 + q1*q2*p1", &[]).unwrap();
        let p = h.program(Method::DiscreteGradient);
        let subs: Vec<_> = p
            .ops
            .iter()
            .filter(|op| matches!(op, Op::Sub(..) | Op::Neg(_)))
            .collect();
        assert_eq!(subs.len(), 4, "{p}");
        for op in subs {
            let Op::Sub(a, b) = *op else { panic!("{op:?}") };
            assert!(
                matches!(p.ops[a as usize], Op::Input1(_))
                    && matches!(p.ops[b as usize], Op::Input(_))
            );
        }
    }
}
