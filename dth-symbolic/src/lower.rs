//! Lowering to straight-line programs: one `let` per operation, in dependency order.
//!
//! Only the nodes a program's outputs reach are emitted. On top of the arena's sharing, powers
//! of one base share their work: `x^k` is built by squaring from cached smaller powers,
//! half-integer powers use one cached `sqrt(x)`, and all negative powers of `x` share one
//! division `1/x` (`x^(-3/2) = (1/x)^2 * sqrt(x)`), which products then multiply by. Terms with a negative
//! coefficient become subtractions. Other real powers call `powf`.

use std::collections::HashMap;

use crate::arena::{Arena, Func, Id, Node, Var};
use crate::kernel::Kernel;
use crate::number::Num;

/// Index of an operation's result in a [`Program`].
pub type Slot = u32;

/// One operation; its result is the slot with its index.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Op {
    /// `z[k]` (in a two-point program, `z0[k]`).
    Input(u32),
    /// `z1[k]`, the second point of a two-point program (`z[k]` when run on one point).
    Input1(u32),
    /// The `k`-th declared parameter.
    Param(u32),
    /// A constant.
    Const(f64),
    /// `a + b`
    Add(Slot, Slot),
    /// `a - b`
    Sub(Slot, Slot),
    /// `a * b`
    Mul(Slot, Slot),
    /// `a / b`
    Div(Slot, Slot),
    /// `-a`
    Neg(Slot),
    /// `sqrt(a)`
    Sqrt(Slot),
    /// `a.powf(e)`
    Powf(Slot, f64),
    /// `f(a)`
    Call(Func, Slot),
    /// A divided-difference kernel `k(x, y)` (see [`Kernel`]), finite at `x = 0`.
    Kernel(Kernel, Slot, Slot),
}

/// What a program output is.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Output {
    /// `H(z)`.
    Value,
    /// `dH/dz_i`.
    Gradient(usize),
    /// `d^2H/dz_i dz_j`, `i <= j` (the caller mirrors it).
    Hessian(usize, usize),
    /// Psi.
    Psi,
    /// Component `i` of the discrete gradient `gbar(z0, z1)` (two-point programs).
    DiscreteGradient(usize),
    /// `H(z1) - H(z0)`, computed without cancellation (two-point programs).
    EnergyDifference,
    /// Component `i` of the defect `grad H(z0) + grad H(z1) - 2 gbar(z0, z1)`, computed without
    /// cancellation (two-point programs, see [`crate::defect`]).
    DiscreteGradientDefect(usize),
}

/// A straight-line program: operations in order, and which slots are the outputs.
#[derive(Clone, Debug, PartialEq)]
pub struct Program {
    /// The operations; operation `i` defines slot `i`.
    pub ops: Vec<Op>,
    /// The outputs and the slots holding them. Outputs not listed are zero.
    pub outputs: Vec<(Output, Slot)>,
    /// The phase-space dimension `D`.
    pub dim: usize,
    /// The number of declared parameters.
    pub params: usize,
}

/// Operation counts of a [`Program`], a proxy for emitted code size and run time.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Stats {
    /// All operations, loads included.
    pub ops: usize,
    /// Additions, subtractions and negations.
    pub adds: usize,
    /// Multiplications.
    pub muls: usize,
    /// Divisions.
    pub divs: usize,
    /// Square roots.
    pub sqrts: usize,
    /// `powf` and elementary-function calls.
    pub calls: usize,
}

impl Program {
    /// Lowers `outputs` (nodes of `arena`) with `z` laid out as `coordinates`.
    pub fn lower(arena: &Arena, coordinates: &[Var], outputs: &[(Output, Id)]) -> Program {
        cheaper(|joint| {
            let mut l = Lowerer::new(arena, coordinates);
            l.joint_denominators = joint;
            let outputs = outputs.iter().map(|&(o, id)| (o, l.value(id))).collect();
            let joinable = l.joinable;
            let program = Program {
                ops: l.ops,
                outputs,
                dim: coordinates.len(),
                params: arena.params().len(),
            };
            (program.prune(|_| true), joinable)
        })
    }

    /// Lowers `outputs` (which leave Psi out) and then Psi from the slots of the gradient and
    /// Hessian entries, `Psi = sum_ij H_ij w_i w_j`, `w = J grad`, instead of from Psi's own
    /// node: the arena flattens `2 H_ij w_i w_j` into one product of all their factors, so the
    /// symbolic Psi re-multiplies what the Hessian and gradient already computed. Entries
    /// sharing a slot (the `1/m` of a kinetic energy, the `1` of `p^2/2`) share one product:
    /// `Psi = sum_s H_s (sum_{H_ii = s} w_i^2 + 2 sum_{H_ij = s, i < j} w_i w_j)`.
    /// `nonzeros` are the Hessian's upper-triangle entries `(i, j, node)`.
    pub(crate) fn lower_assembling_psi(
        arena: &Arena,
        coordinates: &[Var],
        outputs: &[(Output, Id)],
        gradient: &[Id],
        nonzeros: &[(usize, usize, Id)],
    ) -> Program {
        cheaper(|joint| {
            Self::assembling_psi(arena, coordinates, outputs, gradient, nonzeros, joint)
        })
    }

    fn assembling_psi(
        arena: &Arena,
        coordinates: &[Var],
        outputs: &[(Output, Id)],
        gradient: &[Id],
        nonzeros: &[(usize, usize, Id)],
        joint_denominators: bool,
    ) -> (Program, bool) {
        let mut l = Lowerer::new(arena, coordinates);
        l.joint_denominators = joint_denominators;
        let mut outs: Vec<(Output, Slot)> =
            outputs.iter().map(|&(o, id)| (o, l.value(id))).collect();
        let half = coordinates.len() / 2;
        // w_i = g_{i+half} for a position, -g_{i-half} for a momentum: (negative, slot).
        let w = |l: &mut Lowerer, i: usize| {
            if i < half {
                (false, l.value(gradient[i + half]))
            } else {
                (true, l.value(gradient[i - half]))
            }
        };
        // Per distinct Hessian slot: its diagonal squares and off-diagonal products.
        let mut groups: Vec<PsiGroup> = Vec::new();
        for &(i, j, h) in nonzeros {
            let hs = l.value(h);
            let k = match groups.iter().position(|g| g.0 == hs) {
                Some(k) => k,
                None => {
                    groups.push((hs, Vec::new(), Vec::new()));
                    groups.len() - 1
                }
            };
            let (ni, wi) = w(&mut l, i);
            if i == j {
                let sq = l.powi(wi, 2);
                groups[k].1.push((false, sq));
            } else {
                let (nj, wj) = w(&mut l, j);
                let m = l.emit(Op::Mul(wi, wj));
                groups[k].2.push((ni != nj, m));
            }
        }
        let mut terms = Vec::with_capacity(groups.len());
        for (hs, diag, off) in groups {
            let mut parts = diag;
            if !off.is_empty() {
                let (neg, o) = l.signed_sum(&off);
                parts.push((neg, l.emit(Op::Add(o, o))));
            }
            let (mut neg, inner) = l.signed_sum(&parts);
            let factor = match l.ops[hs as usize] {
                Op::Const(c) => {
                    neg ^= c < 0.0;
                    (c.abs() != 1.0).then(|| l.konst(c.abs()))
                }
                _ => Some(hs),
            };
            terms.push(match factor {
                Some(f) => (neg, l.emit(Op::Mul(f, inner))),
                None => (neg, inner),
            });
        }
        let psi = match l.signed_sum(&terms) {
            (true, s) => l.emit(Op::Neg(s)),
            (false, s) => s,
        };
        outs.push((Output::Psi, psi));
        let joinable = l.joinable;
        let program = Program {
            ops: l.ops,
            outputs: outs,
            dim: coordinates.len(),
            params: arena.params().len(),
        };
        (program.prune(|_| true), joinable)
    }

    /// The program restricted to the outputs `keep` accepts, without the operations none of
    /// them reaches (dead-code elimination), slots renumbered in order.
    pub fn prune(&self, keep: impl Fn(Output) -> bool) -> Program {
        let outputs: Vec<(Output, Slot)> = self
            .outputs
            .iter()
            .copied()
            .filter(|&(o, _)| keep(o))
            .collect();
        let mut live = vec![false; self.ops.len()];
        for &(_, s) in &outputs {
            live[s as usize] = true;
        }
        // Operands come before their operation: one backward sweep marks everything reached.
        for i in (0..self.ops.len()).rev() {
            if live[i] {
                for a in operands(&self.ops[i]) {
                    live[a as usize] = true;
                }
            }
        }
        let mut new = vec![0; self.ops.len()];
        let mut ops = Vec::new();
        for (i, op) in self.ops.iter().enumerate() {
            if live[i] {
                new[i] = ops.len() as Slot;
                ops.push(renumber(op, &new));
            }
        }
        Program {
            ops,
            outputs: outputs
                .into_iter()
                .map(|(o, s)| (o, new[s as usize]))
                .collect(),
            dim: self.dim,
            params: self.params,
        }
    }

    /// Operation counts.
    pub fn stats(&self) -> Stats {
        let mut s = Stats {
            ops: self.ops.len(),
            ..Stats::default()
        };
        for op in &self.ops {
            match op {
                Op::Add(..) | Op::Sub(..) | Op::Neg(_) => s.adds += 1,
                Op::Mul(..) => s.muls += 1,
                Op::Div(..) => s.divs += 1,
                Op::Sqrt(_) => s.sqrts += 1,
                Op::Powf(..) | Op::Call(..) | Op::Kernel(..) => s.calls += 1,
                Op::Input(_) | Op::Input1(_) | Op::Param(_) | Op::Const(_) => {}
            }
        }
        s
    }
}

/// The Psi terms of one Hessian slot: the slot, the squares `w_i^2` of its diagonal entries
/// and the signed products `w_i w_j` of its off-diagonal ones.
type PsiGroup = (Slot, Vec<(bool, Slot)>, Vec<(bool, Slot)>);

/// The cheaper of `lower(false)` and `lower(true)` (a division counted as four operations,
/// roughly its throughput cost against a multiplication); `lower` also says whether joining
/// denominators could change anything, and if not the second lowering is skipped.
fn cheaper(lower: impl Fn(bool) -> (Program, bool)) -> Program {
    let cost = |p: &Program| p.ops.len() + 4 * p.stats().divs;
    let (a, joinable) = lower(false);
    if !joinable {
        return a;
    }
    let (b, _) = lower(true);
    if cost(&b) < cost(&a) {
        b
    } else {
        a
    }
}

/// The slots `op` reads.
fn operands(op: &Op) -> Vec<Slot> {
    match *op {
        Op::Input(_) | Op::Input1(_) | Op::Param(_) | Op::Const(_) => Vec::new(),
        Op::Neg(a) | Op::Sqrt(a) | Op::Powf(a, _) | Op::Call(_, a) => vec![a],
        Op::Add(a, b) | Op::Sub(a, b) | Op::Mul(a, b) | Op::Div(a, b) | Op::Kernel(_, a, b) => {
            vec![a, b]
        }
    }
}

/// `op` with its operands renamed through `new`.
fn renumber(op: &Op, new: &[Slot]) -> Op {
    let n = |a: Slot| new[a as usize];
    match *op {
        Op::Input(_) | Op::Input1(_) | Op::Param(_) | Op::Const(_) => *op,
        Op::Add(a, b) => Op::Add(n(a), n(b)),
        Op::Sub(a, b) => Op::Sub(n(a), n(b)),
        Op::Mul(a, b) => Op::Mul(n(a), n(b)),
        Op::Div(a, b) => Op::Div(n(a), n(b)),
        Op::Neg(a) => Op::Neg(n(a)),
        Op::Sqrt(a) => Op::Sqrt(n(a)),
        Op::Powf(a, e) => Op::Powf(n(a), e),
        Op::Call(f, a) => Op::Call(f, n(a)),
        Op::Kernel(k, a, b) => Op::Kernel(k, n(a), n(b)),
    }
}

/// One line per operation (`v3 = v1 * v2`), then the outputs: for reading and debugging.
impl std::fmt::Display for Program {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        for (i, op) in self.ops.iter().enumerate() {
            write!(f, "v{i} = ")?;
            match op {
                Op::Input(k) => writeln!(f, "z[{k}]")?,
                Op::Input1(k) => writeln!(f, "z1[{k}]")?,
                Op::Param(k) => writeln!(f, "param[{k}]")?,
                Op::Const(c) => writeln!(f, "{c:?}")?,
                Op::Add(a, b) => writeln!(f, "v{a} + v{b}")?,
                Op::Sub(a, b) => writeln!(f, "v{a} - v{b}")?,
                Op::Mul(a, b) => writeln!(f, "v{a} * v{b}")?,
                Op::Div(a, b) => writeln!(f, "v{a} / v{b}")?,
                Op::Neg(a) => writeln!(f, "-v{a}")?,
                Op::Sqrt(a) => writeln!(f, "sqrt(v{a})")?,
                Op::Powf(a, e) => writeln!(f, "powf(v{a}, {e:?})")?,
                Op::Call(g, a) => writeln!(f, "{}(v{a})", g.name())?,
                Op::Kernel(k, a, b) => writeln!(f, "{}(v{a}, v{b})", k.name())?,
            }
        }
        for (out, s) in &self.outputs {
            writeln!(f, "{out:?} = v{s}")?;
        }
        Ok(())
    }
}

pub(crate) struct Lowerer<'a> {
    pub(crate) arena: &'a Arena,
    pub(crate) coords: HashMap<Var, u32>,
    pub(crate) ops: Vec<Op>,
    /// Which point variables read: `false` for `z` (`z0`), `true` for `z1`.
    pub(crate) at_z1: bool,
    val: HashMap<(bool, Id), Slot>,
    mag: HashMap<(bool, Id), Slot>,
    consts: HashMap<u64, Slot>,
    powi: HashMap<(Slot, i128), Slot>,
    sqrt: HashMap<Slot, Slot>,
    recip: HashMap<Slot, Slot>,
    /// Every operation emitted, by its operands: an equal operation is emitted once (repeated
    /// partial products such as `mass*length` in several terms, `2*q2` from two derivatives).
    seen: HashMap<OpKey, Slot>,
    /// Negative powers of parameters in one product share one division (`1/(m l^2)`); off,
    /// each base has its own reciprocal, shared by every product. Which is cheaper depends on
    /// how the products overlap, so programs are lowered both ways ([`cheaper`]).
    pub(crate) joint_denominators: bool,
    /// Set when some product had two or more such powers (else joining changes nothing).
    pub(crate) joinable: bool,
}

/// An [`Op`] as a hashable key, operands of `+` and `*` in order (both commute exactly); the
/// last field names a kernel ([`Kernel::key`]).
type OpKey = (u8, u32, u32, u64, &'static str);

fn op_key(op: &Op) -> OpKey {
    let sorted = |a: Slot, b: Slot| (a.min(b), a.max(b));
    match *op {
        Op::Input(k) => (0, k, 0, 0, ""),
        Op::Input1(k) => (1, k, 0, 0, ""),
        Op::Param(k) => (2, k, 0, 0, ""),
        Op::Const(c) => (3, 0, 0, c.to_bits(), ""),
        Op::Add(a, b) => {
            let (a, b) = sorted(a, b);
            (4, a, b, 0, "")
        }
        Op::Sub(a, b) => (5, a, b, 0, ""),
        Op::Mul(a, b) => {
            let (a, b) = sorted(a, b);
            (6, a, b, 0, "")
        }
        Op::Div(a, b) => (7, a, b, 0, ""),
        Op::Neg(a) => (8, a, 0, 0, ""),
        Op::Sqrt(a) => (9, a, 0, 0, ""),
        Op::Powf(a, e) => (10, a, 0, e.to_bits(), ""),
        Op::Call(f, a) => (11, a, 0, f as u64, ""),
        Op::Kernel(k, a, b) => {
            let (name, bits) = k.key();
            (12, a, b, bits, name)
        }
    }
}

impl<'a> Lowerer<'a> {
    pub(crate) fn new(arena: &'a Arena, coordinates: &[Var]) -> Self {
        Lowerer {
            arena,
            coords: coordinates
                .iter()
                .enumerate()
                .map(|(k, v)| (*v, k as u32))
                .collect(),
            ops: Vec::new(),
            at_z1: false,
            val: HashMap::new(),
            mag: HashMap::new(),
            consts: HashMap::new(),
            powi: HashMap::new(),
            sqrt: HashMap::new(),
            recip: HashMap::new(),
            seen: HashMap::new(),
            joint_denominators: false,
            joinable: false,
        }
    }
}

impl Lowerer<'_> {
    /// Appends `op`, or returns the slot of an equal operation emitted before. The negation
    /// of a constant is the negated constant.
    pub(crate) fn emit(&mut self, op: Op) -> Slot {
        // Operations on constants fold (to the value the run time would compute), and a
        // multiplication by 1 is its other operand: `w_i = 1` in Psi costs nothing.
        let konst = |l: &Self, s: Slot| match l.ops[s as usize] {
            Op::Const(c) => Some(c),
            _ => None,
        };
        match op {
            Op::Neg(a) => {
                if let Some(c) = konst(self, a) {
                    return self.konst(-c);
                }
            }
            Op::Mul(a, b) => match (konst(self, a), konst(self, b)) {
                (Some(x), Some(y)) => return self.konst(x * y),
                (Some(1.0), None) => return b,
                (None, Some(1.0)) => return a,
                _ => {}
            },
            Op::Add(a, b) => {
                if let (Some(x), Some(y)) = (konst(self, a), konst(self, b)) {
                    return self.konst(x + y);
                }
            }
            Op::Sub(a, b) => {
                if let (Some(x), Some(y)) = (konst(self, a), konst(self, b)) {
                    return self.konst(x - y);
                }
            }
            _ => {}
        }
        let key = op_key(&op);
        if let Some(&s) = self.seen.get(&key) {
            return s;
        }
        self.ops.push(op);
        let s = (self.ops.len() - 1) as Slot;
        self.seen.insert(key, s);
        s
    }

    pub(crate) fn konst(&mut self, x: f64) -> Slot {
        if let Some(&s) = self.consts.get(&x.to_bits()) {
            return s;
        }
        let s = self.emit(Op::Const(x));
        self.consts.insert(x.to_bits(), s);
        s
    }

    /// The slot of `id` at the current point ([`Lowerer::at_z1`]).
    pub(crate) fn value(&mut self, id: Id) -> Slot {
        if let Some(&s) = self.val.get(&(self.at_z1, id)) {
            return s;
        }
        let s = match self.arena.node(id) {
            Node::Num(n) => self.konst(n.to_f64()),
            Node::Var(Var::Param(k)) => self.emit(Op::Param(*k)),
            Node::Var(v) => {
                // Every variable of H is a coordinate; `unwrap_or` only guards the invariant.
                let k = self.coords.get(v).copied().unwrap_or(0);
                self.emit(if self.at_z1 {
                    Op::Input1(k)
                } else {
                    Op::Input(k)
                })
            }
            Node::Add(ch) => {
                let ch = ch.clone();
                self.sum(&ch)
            }
            Node::Mul(_) => match self.signed(id) {
                (true, m) => self.emit(Op::Neg(m)),
                (false, m) => m,
            },
            Node::Pow(b, e) => {
                let (b, e) = (*b, *e);
                let s = self.value(b);
                self.power(s, e)
            }
            Node::Func(f, x) => {
                let (f, x) = (*f, *x);
                let s = self.value(x);
                self.emit(Op::Call(f, s))
            }
        };
        self.val.insert((self.at_z1, id), s);
        s
    }

    /// `(negative, slot of the magnitude)` for a term of a sum.
    fn signed(&mut self, id: Id) -> (bool, Slot) {
        match self.arena.node(id) {
            Node::Num(n) if n.is_negative() => (true, self.konst(-n.to_f64())),
            Node::Mul(ch) => {
                let coef = ch
                    .iter()
                    .find_map(|&c| self.arena.as_num(c))
                    .unwrap_or(Num::ONE);
                if let Some(&s) = self.mag.get(&(self.at_z1, id)) {
                    return (coef.is_negative(), s);
                }
                let mut factors: Vec<Id> = ch
                    .iter()
                    .copied()
                    .filter(|&c| self.arena.as_num(c).is_none())
                    .collect();
                // Parameters first (products of them are shared by every term that has
                // them), then the other factors from the most complex (largest id) down to
                // plain coordinates, so a term that is another term times a coordinate
                // (`q H_qt` beside `H_qt = F w sin(w t)`) reuses that term's product as prefix.
                factors.sort_by_key(|&f| {
                    let varying = !self.arena.deps(f).is_empty();
                    (varying, if varying { u32::MAX - f.0 } else { f.0 })
                });
                // Negative integer powers of parameters share one division:
                // `a^-1 b^-2 = 1/(a b^2)` (`p^2/(2 m l^2)`: one division, not two).
                let inverse = |f: Id| match self.arena.node(f) {
                    Node::Pow(b, e) if self.arena.deps(f).is_empty() => e
                        .as_rational()
                        .filter(|r| r.is_integer() && r.numer() < 0)
                        .map(|r| (*b, -r.numer())),
                    _ => None,
                };
                let denominators: Vec<(Id, i128)> =
                    factors.iter().filter_map(|&f| inverse(f)).collect();
                let mut slots = Vec::with_capacity(factors.len());
                self.joinable |= denominators.len() >= 2;
                if self.joint_denominators && denominators.len() >= 2 {
                    factors.retain(|&f| inverse(f).is_none());
                    let mut den = None;
                    for (b, k) in denominators {
                        let s = self.value(b);
                        let p = self.powi(s, k);
                        den = Some(match den {
                            None => p,
                            Some(d) => self.emit(Op::Mul(d, p)),
                        });
                    }
                    if let Some(d) = den {
                        slots.push(self.recip(d));
                    }
                }
                slots.extend(factors.iter().map(|&f| self.value(f)));
                let mut acc = slots[0];
                for &s in &slots[1..] {
                    acc = self.emit(Op::Mul(acc, s));
                }
                let c = coef.to_f64().abs();
                if c != 1.0 {
                    let k = self.konst(c);
                    acc = self.emit(Op::Mul(k, acc));
                }
                self.mag.insert((self.at_z1, id), acc);
                (coef.is_negative(), acc)
            }
            _ => (false, self.value(id)),
        }
    }

    fn sum(&mut self, terms: &[Id]) -> Slot {
        let signed: Vec<(bool, Slot)> = terms.iter().map(|&t| self.signed(t)).collect();
        let first = signed.iter().position(|&(neg, _)| !neg);
        let mut acc = match first {
            Some(k) => signed[k].1,
            None => self.emit(Op::Neg(signed[0].1)),
        };
        let skip = first.unwrap_or(0);
        for (k, &(neg, s)) in signed.iter().enumerate() {
            if k == skip {
                continue;
            }
            acc = self.emit(if neg {
                Op::Sub(acc, s)
            } else {
                Op::Add(acc, s)
            });
        }
        acc
    }

    /// `sum_k (-1)^neg_k s_k` as `(negative, slot)`: started from a positive term when there is
    /// one (then `(false, _)`), otherwise the sum of the magnitudes, negated by the caller.
    /// `items` is not empty.
    pub(crate) fn signed_sum(&mut self, items: &[(bool, Slot)]) -> (bool, Slot) {
        let start = items.iter().position(|&(neg, _)| !neg);
        let (negative, k) = match start {
            Some(k) => (false, k),
            None => (true, 0),
        };
        let mut acc = items[k].1;
        for (i, &(neg, s)) in items.iter().enumerate() {
            if i == k {
                continue;
            }
            acc = self.emit(if neg != negative {
                Op::Sub(acc, s)
            } else {
                Op::Add(acc, s)
            });
        }
        (negative, acc)
    }

    /// `s^e`. Every negative power of one base comes from one division `1/s` (and
    /// half-integer ones from one `sqrt(s)`): `s^(-k) = (1/s)^k`, `s^(-(2m+1)/2) =
    /// (1/s)^(m+1) * sqrt(s)`.
    pub(crate) fn power(&mut self, s: Slot, e: Num) -> Slot {
        match e.as_rational() {
            Some(r) if r.is_integer() => {
                let k = r.numer();
                if k > 0 {
                    self.powi(s, k)
                } else {
                    let inv = self.recip(s);
                    self.powi(inv, -k)
                }
            }
            Some(r) if r.denom() == 2 => {
                let k = r.numer();
                let sq = self.sqrt(s);
                let (base, m) = if k > 0 {
                    (s, (k - 1) / 2)
                } else {
                    (self.recip(s), (1 - k) / 2)
                };
                if m == 0 {
                    sq
                } else {
                    let p = self.powi(base, m);
                    self.emit(Op::Mul(p, sq))
                }
            }
            _ => self.emit(Op::Powf(s, e.to_f64())),
        }
    }

    /// `s^k`, `k >= 1`, by squaring through cached smaller powers.
    pub(crate) fn powi(&mut self, s: Slot, k: i128) -> Slot {
        if k == 1 {
            return s;
        }
        if let Some(&p) = self.powi.get(&(s, k)) {
            return p;
        }
        let p = if k % 2 == 0 {
            let h = self.powi(s, k / 2);
            self.emit(Op::Mul(h, h))
        } else {
            let h = self.powi(s, k - 1);
            self.emit(Op::Mul(h, s))
        };
        self.powi.insert((s, k), p);
        p
    }

    /// `sqrt(s)`, emitted once per slot.
    pub(crate) fn sqrt(&mut self, s: Slot) -> Slot {
        if let Some(&q) = self.sqrt.get(&s) {
            return q;
        }
        let q = self.emit(Op::Sqrt(s));
        self.sqrt.insert(s, q);
        q
    }

    pub(crate) fn recip(&mut self, s: Slot) -> Slot {
        if let Some(&r) = self.recip.get(&s) {
            return r;
        }
        let one = self.konst(1.0);
        let r = self.emit(Op::Div(one, s));
        self.recip.insert(s, r);
        r
    }
}
