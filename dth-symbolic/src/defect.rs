//! The trapezoid defect `t(z0, z1) = grad H(z0) + grad H(z1) - 2 gbar(z0, z1)` of the exact
//! discrete gradient of [`crate::divided`], computed without cancellation.
//!
//! `t` is `O(|d|^2)`, `d = z1 - z0`, and the DTH stepper needs it to an absolute error of a few
//! `eps |grad H| |d| / |z|`; the plain difference of `O(1)` gradients carries `eps |grad H|`,
//! whatever `d`. It is built by the same structural recursion as `gbar`, and is consistent
//! with the `gbar` that [`crate::divided`] emits (the same product rule, folded in the same
//! order; exact divided differences `DD_f` at compositions). Every node `a` carries its values
//! `a0`, `a1`, `delta_a = gbar_a . d`, its discrete gradient `gbar_a`, its gradients `g_a0`,
//! `g_a1` at both points (forward mode), `Dg_a = g_a1 - g_a0` and its defect `t_a`. `Dg_a` and
//! `f'(a1) - f'(a0)` are not plain differences (those would be accurate only to `eps |g|`,
//! enough for the stepper since they multiply `O(|d|)` factors, but `eps / |d|` relative to
//! `t`): they are built by exact rules too (see `Defect::dgrad` and the `df` of each `T_f`),
//! so `t` keeps a few `eps` of relative accuracy however small `d` is.
//!
//! | node | `t` |
//! |---|---|
//! | `z_i`, constant, parameter | `0` |
//! | `a + b` | `t_a + t_b` |
//! | `a * b` (symmetric `gbar`) | `mean(a) t_b + mean(b) t_a + (delta_a Dg_b + delta_b Dg_a)/2` |
//! | `f(a)` | `mean(f') t_a + T_f(a0, a1) gbar_a + ((f'(a1) - f'(a0))/2) Dg_a` |
//!
//! with `T_f(a0, a1) = f'(a0) + f'(a1) - 2 DD_f(a0, a1) = O(delta^2)`. (Product: write
//! `a0 = abar - delta_a/2`, `g_b0 = gm_b - Dg_b/2` etc. in `a0 g_b0 + a1 g_b1 + b0 g_a0 + b1 g_a1`
//! and subtract `2 (gbar_a bbar + abar gbar_b)`. Composition: the same with `f'(a_i)` for `a_i`
//! and `DD_f` for the mean.) `T_f` is computed from terms that are themselves `O(delta^2)`
//! with relative accuracy, with `m = mean(a)`, `x = delta/2`:
//!
//! | `f` | `T_f` |
//! |---|---|
//! | `a^k`, integer `k >= 2` | `2 sum_{i = 2, 4, .. <= k-1} i C(k, i+1) m^(k-1-i) x^i` (all terms one sign) |
//! | `1/a` | `-(delta / (a0 a1))^2` |
//! | `sqrt a` | `delta^2 / (2 s0 s1 (s0 + s1)^3)`, `s = sqrt a` |
//! | `a^-k`, `a^(k/2)` | chains of the above: `T_(g o h) = mean(g') T_h + T_g DD_h + Dg' Dh' / 2` |
//! | `a^r`, other `r` | `2 (a0 a1)^((r-1)/2) N(y) / sinh y`, `y = ln(a1/a0)/2`, [`Kernel::PowDefect`] |
//! | `exp` | `2 e^m (cosh x - sinh(x)/x)` ([`Kernel::ExpDefect`]) |
//! | `sin`, `cos` | `2 (cos m, -sin m) (cos x - sin(x)/x)` |
//! | `sinh`, `cosh` | `2 (cosh m, sinh m) (cosh x - sinh(x)/x)` |
//! | `tan` | `(2 sin m sin x / (c0 c1))^2 - 2 (sinc(delta) - 1)/(c0 c1)`, `c = cos a` |
//! | `tanh` | `(2 sinh m sinh x / (C0 C1))^2 - 2 (sinhc(delta) - 1)/(C0 C1)`, `C = cosh a` |
//! | `atan` | `(delta (a0 + a1) / ((s0 + s1) s0 s1))^2 + 2 (sinc(theta) - 1) theta/delta`, `s = sqrt(1 + a^2)`, `theta = atan2(delta, 1 + a0 a1)` |
//! | `ln` | `2 (sinhc(l) - 1) l / delta`, `l = ln(a1/a0)` |
//!
//! (`ln`: with `a1 = a0 e^l`, `1/a0 + 1/a1 = 2 sinh(l)/delta`. `atan`: with `a = tan theta`,
//! `f'(a) = cos^2 theta` and `sin(theta1 - theta0) = delta cos theta0 cos theta1`.
//! `a^r`: with `a = e^u`, `T = 2 e^((r-1) um) (r cosh((r-1) y) - sinh(r y)/sinh y)` and
//! `N(y) = ((r-2)/2) sinh(r y) - (r/2) sinh((r-2) y)`.)
//!
//! The kernels `cos x - sin(x)/x`, `cosh x - sinh(x)/x`, `sin(x)/x - 1`, `sinh(x)/x - 1`,
//! [`Kernel::PowDefect`] and the others, their series and why they keep their accuracy, are in
//! [`crate::kernel`].
//!
//! # References
//! O. Gonzalez, Time integration and discrete Hamiltonian systems, J. Nonlinear Sci. 6 (1996);
//! the cancellation-free energy residual it serves: `dth_core::dth::EnergyResidual`.

use std::collections::HashMap;

use crate::arena::{Arena, Func, Id, Node, Var};
use crate::divided::{Diff, Divided};
use crate::kernel::{Kernel, Midpoint};
use crate::lower::{Op, Output, Program, Slot};
use crate::number::Num;

/// A scalar map `b -> f(b)` between the two points: `f'` at both ends, the divided difference
/// `DD_f` (only for chains) and `T_f` (`None`: identically zero), and the image values.
#[derive(Clone, Copy, Debug)]
struct Piece {
    d0: Slot,
    d1: Slot,
    dd: Slot,
    /// `f'(b1) - f'(b0)`, without cancellation.
    df: Slot,
    t: Option<Slot>,
    /// `f(b0)`, `f(b1)`, `f(b1) - f(b0)`.
    out: (Slot, Slot, Slot),
}

/// Lowers the defect of `root` to a two-point program with outputs
/// [`Output::DiscreteGradientDefect`].
pub(crate) fn lower(arena: &Arena, coordinates: &[Var], root: Id) -> Program {
    let mut s = Defect {
        d: Divided::new(arena, coordinates),
        grad: HashMap::new(),
        deriv: HashMap::new(),
        dgrad: HashMap::new(),
        t: HashMap::new(),
    };
    let t = s.defect(root);
    let outputs = t
        .grad
        .iter()
        .map(|&(k, slot)| (Output::DiscreteGradientDefect(k as usize), slot))
        .collect();
    Program {
        ops: s.d.l.ops,
        outputs,
        dim: coordinates.len(),
        params: arena.params().len(),
    }
}

struct Defect<'a> {
    d: Divided<'a>,
    /// `grad a` at `z0` (`false`) or `z1` (`true`), as a vector (`delta` unused).
    grad: HashMap<(bool, Id), Diff>,
    /// `f'(child)` of a power or function node at either point.
    deriv: HashMap<(bool, Id), Slot>,
    /// `g_a1 - g_a0`.
    dgrad: HashMap<Id, Diff>,
    t: HashMap<Id, Diff>,
}

/// The largest integer power whose `T` is the polynomial series of [`Defect::powi_series`]
/// (`k/2` terms); larger ones are built by squaring, in `O(log k)` operations.
const SERIES_MAX: i128 = 64;

fn vector(d: &Diff) -> Diff {
    Diff {
        delta: None,
        grad: d.grad.clone(),
    }
}

impl Defect<'_> {
    fn arena(&self) -> &Arena {
        self.d.arena()
    }

    fn at(&mut self, id: Id, z1: bool) -> Slot {
        if z1 {
            self.d.val1(id)
        } else {
            self.d.val0(id)
        }
    }

    fn konst(&mut self, c: f64) -> Slot {
        self.d.l.konst(c)
    }

    fn emit(&mut self, op: Op) -> Slot {
        self.d.l.emit(op)
    }

    fn sub(&mut self, a: Slot, b: Slot) -> Slot {
        self.emit(Op::Sub(a, b))
    }

    fn div(&mut self, a: Slot, b: Slot) -> Slot {
        self.emit(Op::Div(a, b))
    }

    fn half(&mut self, a: Slot) -> Slot {
        let h = self.konst(0.5);
        self.d.mul(h, a)
    }

    /// A vector scaled by a constant coefficient (`1`: unchanged).
    fn coefficient(&mut self, v: Diff, c: f64) -> Diff {
        if c == 1.0 || v.is_zero() {
            return v;
        }
        let k = self.konst(c);
        self.d.scaled(&v, k)
    }

    /// The constant coefficient and the other factors of a product.
    fn factors(&self, factors: &[Id]) -> (f64, Vec<Id>) {
        let (coef, rest) = self.d.coefficient_and_factors(factors);
        (coef.to_f64(), rest)
    }

    /// `grad a` at one point, forward mode.
    fn gradient(&mut self, id: Id, z1: bool) -> Diff {
        if let Some(g) = self.grad.get(&(z1, id)) {
            return g.clone();
        }
        let g = match self.arena().node(id).clone() {
            Node::Num(_) | Node::Var(Var::Param(_)) => Diff::default(),
            Node::Var(v) => {
                let k = self.d.l.coords.get(&v).copied().unwrap_or(0);
                Diff {
                    delta: None,
                    grad: vec![(k, self.d.one)],
                }
            }
            Node::Add(terms) => {
                let parts: Vec<Diff> = terms.iter().map(|&t| self.gradient(t, z1)).collect();
                self.d.sum(&parts)
            }
            Node::Mul(factors) => {
                let (c, rest) = self.factors(&factors);
                let mut g = self.gradient(rest[0], z1);
                let mut p = self.at(rest[0], z1);
                for &f in &rest[1..] {
                    let (gf, fv) = (self.gradient(f, z1), self.at(f, z1));
                    let a = self.d.scaled(&g, fv);
                    let b = self.d.scaled(&gf, p);
                    g = self.d.sum(&[a, b]);
                    p = self.d.mul(p, fv);
                }
                self.coefficient(g, c)
            }
            Node::Pow(b, _) | Node::Func(_, b) => {
                let gb = self.gradient(b, z1);
                if gb.is_zero() {
                    gb
                } else {
                    let f = self.derivative(id, z1);
                    self.d.scaled(&gb, f)
                }
            }
        };
        self.grad.insert((z1, id), g.clone());
        g
    }

    /// `f'(b)` of the node `id = f(b)` (a power or a function) at one point.
    fn derivative(&mut self, id: Id, z1: bool) -> Slot {
        if let Some(&s) = self.deriv.get(&(z1, id)) {
            return s;
        }
        let s = match self.arena().node(id).clone() {
            Node::Pow(b, e) => {
                let bv = self.at(b, z1);
                self.power_derivative(bv, e)
            }
            Node::Func(f, u) => {
                let uv = self.at(u, z1);
                // The value f(u), for the derivatives written through it (read lazily: the
                // others need no call of f).
                let value = |this: &mut Self| this.at(id, z1);
                let one = self.d.one;
                // sin, cos, sinh, cosh: f' = sign partner.
                let mid = |this: &mut Self, rule: Midpoint| {
                    let s = this.emit(Op::Call(rule.partner, uv));
                    if rule.sign < 0.0 {
                        this.emit(Op::Neg(s))
                    } else {
                        s
                    }
                };
                match f {
                    Func::Sin => mid(self, Midpoint::SIN),
                    Func::Cos => mid(self, Midpoint::COS),
                    Func::Tan => {
                        let v = value(self);
                        let vv = self.d.mul(v, v);
                        self.d.add(one, vv)
                    }
                    Func::Exp => value(self),
                    Func::Ln => self.d.l.recip(uv),
                    Func::Sinh => mid(self, Midpoint::SINH),
                    Func::Cosh => mid(self, Midpoint::COSH),
                    Func::Tanh => {
                        let v = value(self);
                        let vv = self.d.mul(v, v);
                        self.sub(one, vv)
                    }
                    Func::Atan => {
                        let uu = self.d.mul(uv, uv);
                        let w = self.d.add(one, uu);
                        self.d.l.recip(w)
                    }
                }
            }
            _ => self.d.one,
        };
        self.deriv.insert((z1, id), s);
        s
    }

    /// `e b^(e - 1)`.
    fn power_derivative(&mut self, b: Slot, e: Num) -> Slot {
        let p = match e.try_add(Num::int(-1)) {
            Ok(e1) if e1.is_one() => b,
            Ok(e1) => self.d.l.power(b, e1),
            Err(_) => self.emit(Op::Powf(b, e.to_f64() - 1.0)),
        };
        let k = self.konst(e.to_f64());
        self.d.mul(k, p)
    }

    /// `Dg_a = g_a1 - g_a0`, without cancellation: `0` for leaves, summed over sums, and for
    /// products and compositions by the exact rules `Dg_(ab) = abar Dg_b + delta_a gm_b +
    /// bbar Dg_a + delta_b gm_a` and `Dg_(f(a)) = mean(f') Dg_a + (f'(a1) - f'(a0)) gm_a`
    /// (`gm = (g0 + g1)/2`; from `x1 y1 - x0 y0 = xbar (y1 - y0) + (x1 - x0) ybar`), computed
    /// with [`Defect::defect`].
    fn dgrad(&mut self, id: Id) -> Diff {
        if let Some(g) = self.dgrad.get(&id) {
            return g.clone();
        }
        let v = match self.arena().node(id).clone() {
            Node::Num(_) | Node::Var(_) => Diff::default(),
            Node::Add(terms) => {
                let parts: Vec<Diff> = terms.iter().map(|&t| self.dgrad(t)).collect();
                self.d.sum(&parts)
            }
            Node::Mul(_) | Node::Pow(..) | Node::Func(..) => {
                self.defect(id);
                self.dgrad.get(&id).cloned().unwrap_or_default()
            }
        };
        self.dgrad.insert(id, v.clone());
        v
    }

    /// `(g0 + g1)/2` component by component.
    fn mean_vec(&mut self, g0: &Diff, g1: &Diff) -> Diff {
        let mut map: std::collections::BTreeMap<u32, (Option<Slot>, Option<Slot>)> =
            Default::default();
        for &(k, s) in &g0.grad {
            map.entry(k).or_default().0 = Some(s);
        }
        for &(k, s) in &g1.grad {
            map.entry(k).or_default().1 = Some(s);
        }
        let mut grad = Vec::new();
        for (k, pair) in map {
            let s = match pair {
                (Some(a), Some(b)) => self.d.mean(a, b),
                (Some(a), None) | (None, Some(a)) => self.half(a),
                (None, None) => continue,
            };
            grad.push((k, s));
        }
        Diff { delta: None, grad }
    }

    /// `t_a`.
    fn defect(&mut self, id: Id) -> Diff {
        if let Some(t) = self.t.get(&id) {
            return t.clone();
        }
        let t = match self.arena().node(id).clone() {
            Node::Num(_) | Node::Var(_) => Diff::default(),
            Node::Add(terms) => {
                let parts: Vec<Diff> = terms.iter().map(|&t| self.defect(t)).collect();
                self.d.sum(&parts)
            }
            Node::Mul(factors) => self.product(id, &factors),
            Node::Pow(b, _) | Node::Func(_, b) => self.composition(id, b),
        };
        self.t.insert(id, t.clone());
        t
    }

    /// The product rule, folded left to right as [`crate::divided`] folds `gbar`.
    fn product(&mut self, id: Id, factors: &[Id]) -> Diff {
        let (c, rest) = self.factors(factors);
        let mut t = self.defect(rest[0]);
        let mut dg = self.dgrad(rest[0]);
        // The partial product: its gbar (as divided.rs builds it), values and gradients.
        let mut acc = self.d.diff(rest[0]);
        let (mut p0, mut p1) = (self.d.val0(rest[0]), self.d.val1(rest[0]));
        let (mut g0, mut g1) = (self.gradient(rest[0], false), self.gradient(rest[0], true));
        for &f in &rest[1..] {
            let df = self.d.diff(f);
            let tf = self.defect(f);
            let (f0, f1) = (self.d.val0(f), self.d.val1(f));
            let (gf0, gf1) = (self.gradient(f, false), self.gradient(f, true));
            let (mp, mf) = (self.d.mean(p0, p1), self.d.mean(f0, f1));
            let dgf = self.dgrad(f);
            let mut parts = vec![self.d.scaled(&tf, mp), self.d.scaled(&t, mf)];
            let mut dparts = vec![self.d.scaled(&dgf, mp), self.d.scaled(&dg, mf)];
            if let Some(dp) = acc.delta {
                let h = self.half(dp);
                parts.push(self.d.scaled(&dgf, h));
                let gmf = self.mean_vec(&gf0, &gf1);
                dparts.push(self.d.scaled(&gmf, dp));
            }
            if let Some(dfd) = df.delta {
                let h = self.half(dfd);
                parts.push(self.d.scaled(&dg, h));
                let gmp = self.mean_vec(&g0, &g1);
                dparts.push(self.d.scaled(&gmp, dfd));
            }
            t = self.d.sum(&parts);
            dg = self.d.sum(&dparts);
            // Next partial product, by divided.rs's rule.
            acc = self.d.product_rule(&acc, (p0, p1), &df, (f0, f1));
            let (a0, b0) = (self.d.scaled(&g0, f0), self.d.scaled(&gf0, p0));
            g0 = self.d.sum(&[a0, b0]);
            let (a1, b1) = (self.d.scaled(&g1, f1), self.d.scaled(&gf1, p1));
            g1 = self.d.sum(&[a1, b1]);
            p0 = self.d.mul(p0, f0);
            p1 = self.d.mul(p1, f1);
        }
        let dg = self.coefficient(dg, c);
        self.dgrad.insert(id, dg);
        self.coefficient(t, c)
    }

    /// `f(b)`: `mean(f') t_b + T_f gbar_b + ((f'(b1) - f'(b0))/2) Dg_b`.
    fn composition(&mut self, id: Id, b: Id) -> Diff {
        let db = self.d.diff(b);
        let Some(delta) = db.delta else {
            self.dgrad.insert(id, Diff::default());
            return Diff::default();
        };
        let (d0, d1) = (self.derivative(id, false), self.derivative(id, true));
        let (b0, b1) = (self.d.val0(b), self.d.val1(b));
        let (tf, df) = match self.arena().node(id).clone() {
            Node::Pow(_, e) => self.power_defect(id, e, (b0, b1, delta)),
            Node::Func(f, _) => self.function_defect(id, f, (b0, b1, delta)),
            _ => (None, self.d.one),
        };
        let tb = self.defect(b);
        let md = self.d.mean(d0, d1);
        let mut parts = vec![self.d.scaled(&tb, md)];
        if let Some(tf) = tf {
            parts.push(self.d.scaled(&vector(&db), tf));
        }
        let dg = self.dgrad(b);
        if !dg.is_zero() {
            let h = self.half(df);
            parts.push(self.d.scaled(&dg, h));
        }
        let (g0, g1) = (self.gradient(b, false), self.gradient(b, true));
        let gm = self.mean_vec(&g0, &g1);
        let dparts = [self.d.scaled(&dg, md), self.d.scaled(&gm, df)];
        let dgf = self.d.sum(&dparts);
        self.dgrad.insert(id, dgf);
        self.d.sum(&parts)
    }

    /// `T_f` and `f'(b1) - f'(b0)` of `b^e`, by the chain of pieces divided.rs differences it
    /// through.
    fn power_defect(&mut self, id: Id, e: Num, b: (Slot, Slot, Slot)) -> (Option<Slot>, Slot) {
        let chain = match e.as_rational() {
            Some(r) if r.is_integer() && r.numer() > 0 => self.powi(b, r.numer()),
            Some(r) if r.is_integer() => {
                let u = self.recip(b);
                self.then_powi(u, -r.numer())
            }
            Some(r) if r.denom() == 2 => {
                let s = self.sqrt(b);
                let k = r.numer();
                if k > 0 {
                    self.then_powi(s, k)
                } else {
                    let u = self.recip(s.out);
                    let su = self.compose(s, u);
                    self.then_powi(su, -k)
                }
            }
            _ => {
                // T = b0^(r-1) K; f'(b1) - f'(b0) = r (b1^(r-1) - b0^(r-1))
                // = f'(b0) delta pow_ratio_(r-1)(delta, b0).
                let r = e.to_f64();
                let (b0, _, delta) = b;
                let k = self.emit(Op::Kernel(Kernel::PowDefect(r), delta, b0));
                let v0 = self.d.val0(id);
                let q = self.div(v0, b0);
                let t = self.d.mul(q, k);
                let ratio = self.emit(Op::Kernel(Kernel::PowRatio(r - 1.0), delta, b0));
                let d0 = self.derivative(id, false);
                let rd = self.d.mul(ratio, delta);
                return (Some(t), self.d.mul(d0, rd));
            }
        };
        (chain.t, chain.df)
    }

    /// `h` followed by `u^k` (`k >= 1`).
    fn then_powi(&mut self, h: Piece, k: i128) -> Piece {
        if k == 1 {
            return h;
        }
        let g = self.powi(h.out, k);
        self.compose(h, g)
    }

    /// `g o h`: `f' = g'(h) h'`, `DD = DD_g DD_h`, `T = mean(g') T_h + T_g DD_h + Dg' Dh'/2`.
    fn compose(&mut self, h: Piece, g: Piece) -> Piece {
        let d0 = self.d.mul(g.d0, h.d0);
        let d1 = self.d.mul(g.d1, h.d1);
        let dd = self.d.mul(g.dd, h.dd);
        // g'(u1) h'(a1) - g'(u0) h'(a0) = mean(g') Dh' + Dg' mean(h').
        let (mg, mh) = (self.d.mean(g.d0, g.d1), self.d.mean(h.d0, h.d1));
        let (x, y) = (self.d.mul(mg, h.df), self.d.mul(g.df, mh));
        let df = self.d.add(x, y);
        let mut terms = Vec::new();
        if let Some(th) = h.t {
            let m = self.d.mean(g.d0, g.d1);
            terms.push(self.d.mul(m, th));
        }
        if let Some(tg) = g.t {
            terms.push(self.d.mul(tg, h.dd));
        }
        let p = self.d.mul(g.df, h.df);
        terms.push(self.half(p));
        let t = terms
            .split_first()
            .map(|(&first, rest)| rest.iter().fold(first, |acc, &s| self.d.add(acc, s)));
        Piece {
            d0,
            d1,
            dd,
            df,
            t,
            out: g.out,
        }
    }

    /// `a -> a^k`, `k >= 2`. Up to [`SERIES_MAX`], the series below; beyond, by squaring
    /// (`a^2m = (a^m)^2`, [`Defect::compose`]) and peeling one factor (`a^k = a a^(k-1)`,
    /// [`Defect::times_base`]), so the work grows with `log k`: the series has `k/2` terms and
    /// binomial coefficients that overflow `f64` from `k = 1020`.
    fn powi(&mut self, a: (Slot, Slot, Slot), k: i128) -> Piece {
        if k <= SERIES_MAX {
            return self.powi_series(a, k);
        }
        if k % 2 == 0 {
            let h = self.powi(a, k / 2);
            let g = self.powi_series(h.out, 2);
            self.compose(h, g)
        } else {
            let h = self.powi(a, k - 1);
            self.times_base(a, h)
        }
    }

    /// `b -> b h(b)` for the piece `h` of `b = a`: the product rule of the module table with
    /// `f = b` (`f' = 1`, `T_f = 0`, `f'(b1) - f'(b0) = 0`): `T = mean(a) T_h + delta Dh'/2`.
    fn times_base(&mut self, (a0, a1, delta): (Slot, Slot, Slot), h: Piece) -> Piece {
        let (h0, h1, dh) = h.out;
        let (ma, mh) = (self.d.mean(a0, a1), self.d.mean(h0, h1));
        // (b h)' = h' b + h at both ends.
        let x0 = self.d.mul(h.d0, a0);
        let x1 = self.d.mul(h.d1, a1);
        let (d0, d1) = (self.d.add(x0, h0), self.d.add(x1, h1));
        // DD = mean(b) DD_h + mean(h) DD_b, DD_b = 1.
        let x = self.d.mul(ma, h.dd);
        let dd = self.d.add(x, mh);
        // (h'1 a1 - h'0 a0) + (h1 - h0) = mean(h') delta + Dh' mean(a) + Delta h.
        let mdh = self.d.mean(h.d0, h.d1);
        let (x, y) = (self.d.mul(mdh, delta), self.d.mul(h.df, ma));
        let xy = self.d.add(x, y);
        let df = self.d.add(xy, dh);
        let p = self.d.mul(delta, h.df);
        let hp = self.half(p);
        let t = match h.t {
            Some(th) => {
                let x = self.d.mul(ma, th);
                self.d.add(x, hp)
            }
            None => hp,
        };
        // Values: a_i h_i, and Delta(b h) = mean(a) Delta h + delta mean(h).
        let (y0, y1) = (self.d.mul(a0, h0), self.d.mul(a1, h1));
        let (x, y) = (self.d.mul(ma, dh), self.d.mul(delta, mh));
        let dy = self.d.add(x, y);
        Piece {
            d0,
            d1,
            dd,
            df,
            t: Some(t),
            out: (y0, y1, dy),
        }
    }

    /// `a -> a^k`, `2 <= k <= SERIES_MAX`: `T = 2 X m^(k-1-2J) sum_(j=1..J) c_j M^(J-j) X^(j-1)`,
    /// `c_j = 2j C(k, 2j+1)`, `M = m^2`, `X = x^2`, `J = floor((k-1)/2)` (zero for `k = 2`).
    fn powi_series(&mut self, (a0, a1, delta): (Slot, Slot, Slot), k: i128) -> Piece {
        let kf = self.konst(k as f64);
        let (p0, p1) = (self.d.l.powi(a0, k - 1), self.d.l.powi(a1, k - 1));
        let (d0, d1) = (self.d.mul(kf, p0), self.d.mul(kf, p1));
        let dd = self.d.power_sum(a0, a1, k);
        // k (a1^(k-1) - a0^(k-1)) = k F_(k-1)(a0, a1) delta.
        let f = self.d.power_sum(a0, a1, k - 1);
        let kf_f = self.d.mul(kf, f);
        let df = self.d.mul(kf_f, delta);
        let j_max = (k - 1) / 2;
        let t = (j_max >= 1).then(|| {
            let binom =
                |n: i128, r: i128| (0..r).fold(1.0, |c, i| c * (n - i) as f64 / (i + 1) as f64);
            let coef = |j: i128| 2.0 * j as f64 * binom(k, 2 * j + 1);
            let m = self.d.mean(a0, a1);
            let x = self.half(delta);
            let (mm, xx) = (self.d.mul(m, m), self.d.mul(x, x));
            let mut acc = self.konst(coef(j_max));
            let mut mp: Option<Slot> = None;
            for j in (1..j_max).rev() {
                let next = match mp {
                    None => mm,
                    Some(p) => self.d.mul(p, mm),
                };
                mp = Some(next);
                let c = self.konst(coef(j));
                let cm = self.d.mul(c, next);
                let xa = self.d.mul(xx, acc);
                acc = self.d.add(cm, xa);
            }
            let two = self.konst(2.0);
            let tx = self.d.mul(two, xx);
            let mut t = self.d.mul(tx, acc);
            if k % 2 == 0 {
                t = self.d.mul(t, m);
            }
            t
        });
        let y0 = self.d.l.powi(a0, k);
        let y1 = self.d.l.powi(a1, k);
        let dy = self.d.mul(dd, delta);
        Piece {
            d0,
            d1,
            dd,
            df,
            t,
            out: (y0, y1, dy),
        }
    }

    /// `a -> 1/a`: `f' = -1/a^2`, `DD = -u0 u1`, `T = -(delta u0 u1)^2`.
    fn recip(&mut self, (a0, a1, delta): (Slot, Slot, Slot)) -> Piece {
        let (u0, u1) = (self.d.l.recip(a0), self.d.l.recip(a1));
        let (q0, q1) = (self.d.mul(u0, u0), self.d.mul(u1, u1));
        let d0 = self.emit(Op::Neg(q0));
        let d1 = self.emit(Op::Neg(q1));
        let uu = self.d.mul(u0, u1);
        let dd = self.emit(Op::Neg(uu));
        let w = self.d.mul(delta, uu);
        let ww = self.d.mul(w, w);
        let t = self.emit(Op::Neg(ww));
        let dy = self.d.mul(dd, delta);
        // -(u1^2 - u0^2) = -(u1 - u0)(u0 + u1).
        let su = self.d.add(u0, u1);
        let p = self.d.mul(dy, su);
        let df = self.emit(Op::Neg(p));
        Piece {
            d0,
            d1,
            dd,
            df,
            t: Some(t),
            out: (u0, u1, dy),
        }
    }

    /// `a -> sqrt a`: `f' = 1/(2s)`, `DD = 1/(s0 + s1)`,
    /// `T = delta^2 / (2 s0 s1 (s0 + s1)^3)`.
    fn sqrt(&mut self, (a0, a1, delta): (Slot, Slot, Slot)) -> Piece {
        let (s0, s1) = (self.d.l.sqrt(a0), self.d.l.sqrt(a1));
        let (r0, r1) = (self.d.l.recip(s0), self.d.l.recip(s1));
        let (d0, d1) = (self.half(r0), self.half(r1));
        let ss = self.d.add(s0, s1);
        let dd = self.d.l.recip(ss);
        let dd2 = self.d.mul(delta, delta);
        let prod = self.d.mul(s0, s1);
        let ss3 = self.d.l.powi(ss, 3);
        let two = self.konst(2.0);
        let den = self.d.mul(prod, ss3);
        let den = self.d.mul(two, den);
        let t = self.div(dd2, den);
        let dy = self.d.mul(dd, delta);
        // (1/s1 - 1/s0)/2 = -(s1 - s0)/(2 s0 s1).
        let q = self.d.mul(two, prod);
        let r = self.div(dy, q);
        let df = self.emit(Op::Neg(r));
        Piece {
            d0,
            d1,
            dd,
            df,
            t: Some(t),
            out: (s0, s1, dy),
        }
    }

    /// `T_f` and `f'(u1) - f'(u0)` of the elementary function node `id = f(u)`.
    fn function_defect(
        &mut self,
        id: Id,
        f: Func,
        (u0, u1, delta): (Slot, Slot, Slot),
    ) -> (Option<Slot>, Slot) {
        let one = self.d.one;
        let two = self.konst(2.0);
        let kernel = |this: &mut Self, k: Kernel, x: Slot, y: Slot| this.emit(Op::Kernel(k, x, y));
        // The divided difference DD_f(u0, u1) = (f(u1) - f(u0))/delta, as divided.rs forms it.
        let ratio = |this: &mut Self| this.d.func_factor(f, (u0, u1, delta));
        // sin, cos, sinh, cosh: T = 2 f'(m) defect(x), Df' = 2 f''(m) odd(x), x = delta/2,
        // with f' = sign partner, f'' = curvature f.
        let mid = |this: &mut Self, rule: Midpoint| {
            let m = this.d.mean(u0, u1);
            let x = this.half(delta);
            let gm = this.emit(Op::Call(rule.partner, m));
            let kx = kernel(this, rule.defect, x, x);
            let c = this.konst(2.0 * rule.sign);
            let p = this.d.mul(gm, kx);
            let t = this.d.mul(c, p);
            let hm = this.emit(Op::Call(f, m));
            let sx = this.emit(Op::Call(rule.odd, x));
            let c = this.konst(2.0 * rule.curvature);
            let p = this.d.mul(hm, sx);
            (Some(t), this.d.mul(c, p))
        };
        match f {
            Func::Sin => mid(self, Midpoint::SIN),
            Func::Cos => mid(self, Midpoint::COS),
            Func::Sinh => mid(self, Midpoint::SINH),
            Func::Cosh => mid(self, Midpoint::COSH),
            Func::Exp => {
                let t = kernel(self, Kernel::ExpDefect, delta, u0);
                // e^u1 - e^u0 = delta exp_ratio(delta, u0).
                let r = ratio(self);
                (Some(t), self.d.mul(r, delta))
            }
            Func::Tanh => {
                let t = kernel(self, Kernel::TanhDefect, delta, u0);
                // f' = 1 - tanh^2: Df' = -(tanh u1 - tanh u0)(tanh u0 + tanh u1).
                let r = ratio(self);
                let dv = self.d.mul(r, delta);
                let (v0, v1) = (self.d.val0(id), self.d.val1(id));
                let sv = self.d.add(v0, v1);
                let p = self.d.mul(dv, sv);
                (Some(t), self.emit(Op::Neg(p)))
            }
            Func::Tan => {
                let c0 = self.emit(Op::Call(Func::Cos, u0));
                let c1 = self.emit(Op::Call(Func::Cos, u1));
                let cc = self.d.mul(c0, c1);
                let m = self.d.mean(u0, u1);
                let x = self.half(delta);
                let sm = self.emit(Op::Call(Func::Sin, m));
                let sx = self.emit(Op::Call(Func::Sin, x));
                let ss = self.d.mul(sm, sx);
                let num = self.d.mul(two, ss);
                let q = self.div(num, cc);
                let qq = self.d.mul(q, q);
                let k = kernel(self, Kernel::SincMinusOne, delta, delta);
                let k2 = self.d.mul(two, k);
                let r = self.div(k2, cc);
                let t = self.sub(qq, r);
                // f' = 1 + tan^2: Df' = (tan u1 - tan u0)(tan u0 + tan u1), and
                // tan u1 - tan u0 = sin(delta)/(cos u0 cos u1).
                let sd = self.emit(Op::Call(Func::Sin, delta));
                let dv = self.div(sd, cc);
                let (v0, v1) = (self.d.val0(id), self.d.val1(id));
                let sv = self.d.add(v0, v1);
                (Some(t), self.d.mul(dv, sv))
            }
            Func::Atan => {
                let (q0, q1) = (self.d.mul(u0, u0), self.d.mul(u1, u1));
                let (w0, w1) = (self.d.add(one, q0), self.d.add(one, q1));
                let (s0, s1) = (self.d.l.sqrt(w0), self.d.l.sqrt(w1));
                let su = self.d.add(u0, u1);
                let num = self.d.mul(delta, su);
                let ss = self.d.add(s0, s1);
                let sp = self.d.mul(s0, s1);
                let den = self.d.mul(ss, sp);
                let r = self.div(num, den);
                let rr = self.d.mul(r, r);
                let a = ratio(self);
                let theta = self.d.mul(a, delta);
                let k = kernel(self, Kernel::SincMinusOne, theta, theta);
                let ka = self.d.mul(k, a);
                let ka2 = self.d.mul(two, ka);
                let t = self.d.add(rr, ka2);
                // 1/(1 + u1^2) - 1/(1 + u0^2) = -f'(u0) f'(u1) delta (u0 + u1).
                let (d0, d1) = (self.derivative(id, false), self.derivative(id, true));
                let dd = self.d.mul(d0, d1);
                let ddn = self.d.mul(dd, num);
                (Some(t), self.emit(Op::Neg(ddn)))
            }
            Func::Ln => {
                let l = ratio(self);
                let ell = self.d.mul(l, delta);
                let k = kernel(self, Kernel::SinhcMinusOne, ell, ell);
                let kl = self.d.mul(k, l);
                let t = self.d.mul(two, kl);
                // 1/u1 - 1/u0 = -delta/(u0 u1).
                let (r0, r1) = (self.d.l.recip(u0), self.d.l.recip(u1));
                let rr = self.d.mul(r0, r1);
                let p = self.d.mul(rr, delta);
                (Some(t), self.emit(Op::Neg(p)))
            }
        }
    }
}

#[cfg(test)]
mod tests {
    //! Per rule: at a step of 0.2 the defect equals the plain `g0 + g1 - 2 gbar` (which loses
    //! only `eps |g|` there, against `t ~ 1e-2`), and `t / s^2` does not depend on the step
    //! size `s` from 1e-2 down to 1e-7 (no cancellation: a plain difference would have
    //! relative error `eps / s^2 ~ 2e-2` at 1e-7).

    use crate::{compile, Method};

    const EPS: f64 = f64::EPSILON;

    struct Case {
        pair: crate::Program,
        defect: crate::Program,
        all: crate::Program,
    }

    impl Case {
        fn new(src: &str) -> Case {
            let h = compile(src, &[]).unwrap_or_else(|e| panic!("{src}: {e}"));
            Case {
                pair: h.program(Method::DiscreteGradient),
                defect: h.program(Method::DiscreteGradientDefect),
                all: h.program(Method::All),
            }
        }

        /// `(t, plain g0 + g1 - 2 gbar, max |g|)`.
        fn at(&self, z0: &[f64], z1: &[f64]) -> (Vec<f64>, Vec<f64>, f64) {
            let t = self
                .defect
                .eval_pair(z0, z1, &[])
                .unwrap()
                .discrete_gradient_defect;
            let gbar = self.pair.eval_pair(z0, z1, &[]).unwrap().discrete_gradient;
            let g0 = self.all.eval(z0, &[]).unwrap().gradient;
            let g1 = self.all.eval(z1, &[]).unwrap().gradient;
            let plain = (0..z0.len())
                .map(|i| g0[i] + g1[i] - 2.0 * gbar[i])
                .collect();
            let g = g0.iter().chain(&g1).fold(0.0f64, |m, x| m.max(x.abs()));
            (t, plain, g)
        }
    }

    fn check(src: &str, z0: &[f64], dir: &[f64]) {
        check_with(src, z0, dir, 64.0);
    }

    /// [`check`], with the plain form's error at the large step allowed to be `rounding` eps
    /// of `|g|` (64 in `check`; `a^k` has condition number `k`, so its evaluation carries up to
    /// about `k` eps whatever the formula).
    fn check_with(src: &str, z0: &[f64], dir: &[f64], rounding: f64) {
        let case = Case::new(src);
        let step = |s: f64| -> Vec<f64> { z0.iter().zip(dir).map(|(z, d)| z + s * d).collect() };
        let z1 = step(0.2);
        let (t, plain, g) = case.at(z0, &z1);
        for i in 0..t.len() {
            // The plain form's error: a few roundings of |g| in each of g0, g1, gbar.
            assert!(
                (t[i] - plain[i]).abs() <= rounding * EPS * g.max(1.0),
                "{src}: t_{i} = {} vs plain {}",
                t[i],
                plain[i]
            );
        }
        let scaled = |s: f64| -> Vec<f64> {
            let (t, _, _) = case.at(z0, &step(s));
            t.iter().map(|x| x / (s * s)).collect()
        };
        let reference = scaled(1e-4);
        let size = reference.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        if size == 0.0 {
            // Quadratic H: the symmetric discrete gradient is the midpoint gradient, t = 0.
            for s in [1e-2, 1e-7] {
                assert!(scaled(s).iter().all(|&x| x == 0.0), "{src}");
            }
            return;
        }
        assert!(size > 1e-3, "{src}: t/s^2 = {reference:?}");
        // At the smallest steps, against the step doubled: t/s^2 changes by O(s) only, and
        // t carries a few eps relative plus the rounding of z1 = z0 + s dir, a relative change
        // of eps |z| / s in d (2e-9 at 1e-7): a kernel or rule that cancelled would be off by
        // eps / s^2 relative (2e-2).
        for s in [1e-6, 1e-7] {
            let (v, w) = (scaled(s), scaled(2.0 * s));
            for i in 0..v.len() {
                // O(s) Taylor term: its coefficient relative to t/s^2 reaches ~50 here
                // (atan(3 q1 p1): 4.5e-5 relative at 1e-6, measured).
                let tol = 64.0 * s * size.max(1.0) + 64.0 * EPS / s * size;
                assert!(
                    (v[i] - w[i]).abs() <= tol,
                    "{src}: t_{i}/s^2 = {} at {s}, {} at {}",
                    v[i],
                    w[i],
                    2.0 * s
                );
            }
        }
        for s in [1e-2, 1e-3, 1e-5, 1e-6, 1e-7] {
            let v = scaled(s);
            for i in 0..v.len() {
                // t/s^2 = c + O(s): the next order of the expansion, whose coefficient is
                // the largest frequency in H (5, in cos(5 q1)) times |dir| times c (6% at
                // s = 1e-2 measured there); plus the rounding of t: eps |g| per plain
                // difference Dg times O(s), i.e. eps / s relative to s^2.
                let tol = 16.0 * (s.max(1e-4)) * size.max(1.0) + 64.0 * EPS / s * size.max(1.0);
                assert!(
                    (v[i] - reference[i]).abs() <= tol,
                    "{src} at s = {s}: t_{i}/s^2 = {} vs {} at 1e-4",
                    v[i],
                    reference[i]
                );
            }
        }
    }

    /// At steps where every kernel takes its closed-form branch (`|x| >= 1`) the plain
    /// difference is accurate relative to `t = O(1)`.
    fn check_large(src: &str, z0: &[f64], dir: &[f64], s: f64) {
        let case = Case::new(src);
        let z1: Vec<f64> = z0.iter().zip(dir).map(|(z, d)| z + s * d).collect();
        let (t, plain, g) = case.at(z0, &z1);
        for i in 0..t.len() {
            assert!(
                (t[i] - plain[i]).abs() <= 64.0 * EPS * g.max(1.0),
                "{src} at step {s}: t_{i} = {} vs plain {}",
                t[i],
                plain[i]
            );
        }
    }

    #[test]
    fn closed_form_branches() {
        for f in [
            "exp(q1)",
            "ln(2 + q1)",
            "sin(q1)",
            "cos(q1)",
            "sinh(q1)",
            "cosh(q1)",
            "tanh(q1)",
            "atan(q1)",
            "(2 + q1)^(1/3)",
            "(2 + q1)^(-2/3)",
            "(2 + q1)^pi",
            "exp(-q1^2)",
        ] {
            check_large(&format!("p1^2/2 + {f}"), &Z, &DIR, 3.0);
            check_large(&format!("p1^2/2 + {f}"), &Z, &DIR, -1.2);
        }
        check_large("p1^2/2 + tan(q1)", &Z, &DIR, -2.0);
    }

    /// Far-apart points where the values over- or underflow: the defect stays finite and equals
    /// the plain difference (accurate there: `t` is as large as the gradients).
    #[test]
    fn extreme_arguments() {
        // exp(-q1^2) underflows at q1 = 30; the jump in its argument (875) overflows expm1
        // and cosh(x/2).
        check_large("p1^2/2 + exp(-q1^2)", &[30.0, 0.0], &[-25.0, 0.0], 1.0);
        // tanh whose argument jumps by 800 (sinh(800) overflows): the plain branch.
        let z1 = (800.0f64 - 0.125).cbrt();
        check_large("p1^2/2 + tanh(q1^3)", &[-0.5, 0.0], &[z1 + 0.5, 0.0], 1.0);
        // Both ends of tanh beyond 350: every term below 1e-300, finite.
        let case = Case::new("p1^2/2 + tanh(q1)");
        let (t, _, _) = case.at(&[400.0, 0.0], &[400.5, 0.0]);
        assert!(t.iter().all(|x| x.is_finite() && x.abs() < 1e-300), "{t:?}");
        // sinh, cosh across a large step (closed form of cosh x - sinh(x)/x).
        check_large(
            "p1^2/2 + sinh(q1) + cosh(q1)",
            &[-3.0, 0.0],
            &[8.0, 0.0],
            1.0,
        );
    }

    #[test]
    fn time_dependent() {
        // z = (q1, t, p1, p_t).
        check(
            "p1^2/2 + q1^2/2 - q1*cos(2*t)",
            &[0.3, 1.0, -0.2, 0.1],
            &[0.5, 0.9, 0.4, -0.3],
        );
    }

    const Z: [f64; 2] = [0.7, -0.4];
    const DIR: [f64; 2] = [0.9, 0.5];

    #[test]
    fn sums_and_products() {
        check("p1^2/2 + q1*p1 - 3*q1*p1^2*sin(p1) + q1^2*p1^3", &Z, &DIR);
    }

    #[test]
    fn integer_powers() {
        for k in [2i32, 3, 4, 5, 7, 12, -1, -2, -3, -6] {
            check(&format!("p1^2 + (2 + q1)^({k}) + q1^{}", k.abs()), &Z, &DIR);
        }
        // A base crossing zero: the polynomial form has no sign assumption.
        check("p1^2 + q1^5 + q1^4", &[-0.05, 0.3], &[1.0, 0.5]);
    }

    /// Beyond the series (`k > 64`), powers are built by squaring: the same accuracy, work
    /// in `log k`, and no binomial coefficient overflowing `f64` (`q1^1024` had an infinite
    /// constant). The base stays near 1 so `q1^k` stays finite along the step, and the step
    /// in the base scales as `1/k`, keeping the O(s) term of `t/s^2` (relative size about
    /// `k s |dir|`) within what `check` allows.
    #[test]
    fn large_integer_powers() {
        for k in [63i32, 64, 65, 66, 100, 127, 1023, 1024, -1024] {
            let dir = 2.0 / f64::from(k.abs());
            let rounding = 64.0 + 4.0 * f64::from(k.abs());
            let q = if k > 0 { 1.02 } else { 0.98 };
            check_with(
                &format!("p1^2 + q1^({k})"),
                &[q, 0.3],
                &[dir, 0.5],
                rounding,
            );
            let src = format!("p1^2 + (q1 + p1)^({k})");
            check_with(&src, &[0.7, 0.3], &[dir, -dir / 2.0], rounding);
        }
        for k in [1024i64, 1_000_000, 1_000_000_007] {
            let h = compile(&format!("p1^2 + (q1 + p1)^{k}"), &[]).unwrap();
            let p = h.program(Method::DiscreteGradientDefect);
            assert!(p.ops.len() < 2000, "{k}: {} operations", p.ops.len());
            assert!(
                p.ops.iter().all(|op| match op {
                    crate::Op::Const(c) | crate::Op::Powf(_, c) => c.is_finite(),
                    _ => true,
                }),
                "{k}: a constant overflows"
            );
        }
    }

    #[test]
    fn half_integer_and_real_powers() {
        for r in [
            "1/2", "3/2", "5/2", "-1/2", "-3/2", "-5/2", "1/3", "-2/3", "pi", "7/5",
        ] {
            check(&format!("p1^2 + (2 + q1)^({r})"), &Z, &DIR);
        }
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
            "sin(q1)*cos(p1)",
        ] {
            check(&format!("p1^2/2 + {f}"), &Z, &DIR);
        }
    }

    #[test]
    fn kepler_and_variable_exponent() {
        check(
            "p1^2 + p2^2 - (q1^2 + q2^2)^(-1/2)",
            &[0.5, 0.1, -0.3, 1.2],
            &[0.7, -0.4, 0.2, 0.9],
        );
        check("p1^2 + (2 + q1)^p1", &Z, &DIR);
    }
}
