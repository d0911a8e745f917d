//! Lowering to straight-line programs: one `let` per operation, in dependency order.
//!
//! Only the nodes a program's outputs reach are emitted. On top of the arena's sharing, powers
//! of one base share their work: `x^k` is built by squaring from cached smaller powers,
//! half-integer powers use one cached `sqrt(x)`, and all negative powers of `x` share one
//! division `1/x` (`x^(-3/2) = (1/x)^2 * sqrt(x)`), which products then multiply by. Terms with a negative
//! coefficient become subtractions. Other real powers call `powf`.

use std::collections::HashMap;

use crate::arena::{Arena, Func, Id, Node, Var};
use crate::divided::Kernel;
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
        let mut l = Lowerer::new(arena, coordinates);
        let outputs = outputs.iter().map(|&(o, id)| (o, l.value(id))).collect();
        Program {
            ops: l.ops,
            outputs,
            dim: coordinates.len(),
            params: arena.params().len(),
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
        }
    }
}

impl Lowerer<'_> {
    pub(crate) fn emit(&mut self, op: Op) -> Slot {
        self.ops.push(op);
        (self.ops.len() - 1) as Slot
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
                let factors: Vec<Id> = ch
                    .iter()
                    .copied()
                    .filter(|&c| self.arena.as_num(c).is_none())
                    .collect();
                let mut acc = self.value(factors[0]);
                for &f in &factors[1..] {
                    let s = self.value(f);
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
