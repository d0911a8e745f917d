//! Simplifying constructors: the only way nodes enter the [`Arena`].
//!
//! Rules, applied as each node is built (so every node is canonical and hash-consing finds
//! equal subexpressions):
//! - constants fold exactly as rationals (`1/3 + 1/6 = 1/2`), irrational ones as `f64`;
//! - sums and products flatten, drop neutral elements (`x + 0`, `1*x`), and a zero factor
//!   absorbs the product (`0*x = 0`);
//! - like terms collect (`2*x + 3*x = 5*x`, `x - x = 0`);
//! - powers of one base merge (`x^2 * x^(-1/2) = x^(3/2)`, `x * x = x^2`);
//! - integer powers distribute over products and compose (`(x*y)^2 = x^2*y^2`,
//!   `(x^(1/2))^2 = x`); non-integer powers of powers are kept (`(x^2)^(1/2)` is `|x|`, not `x`);
//! - `ln(exp(x)) = x`, `exp(ln(x)) = x` (where `ln x` is defined), and functions of constants
//!   fold (`cos(0) = 1`; `ln(0)` is an error).
//!
//! Merging powers extends the domain (`x * x^-1` becomes `1`, defined at `x = 0` too), as in
//! every computer algebra system; it never changes a value where the original is defined.

use std::collections::HashMap;

use crate::arena::{Arena, Func, Id, Node, Var};
use crate::number::{Fault, Num};

impl Arena {
    /// The constant `n`.
    pub fn num(&mut self, n: Num) -> Id {
        self.intern(Node::Num(n))
    }

    /// The variable `v`.
    pub fn var(&mut self, v: Var) -> Id {
        self.intern(Node::Var(v))
    }

    /// `sum(terms)`, simplified.
    pub fn add(&mut self, terms: &[Id]) -> Result<Id, Fault> {
        let mut constant = Num::ZERO;
        let mut order: Vec<Id> = Vec::new();
        let mut coef: HashMap<Id, Num> = HashMap::new();
        let mut stack: Vec<Id> = terms.iter().rev().copied().collect();
        while let Some(t) = stack.pop() {
            match self.node(t) {
                Node::Add(ch) => stack.extend(ch.iter().rev()),
                Node::Num(c) => constant = constant.try_add(*c)?,
                _ => {
                    let (c, base) = self.split_term(t);
                    match coef.get_mut(&base) {
                        Some(acc) => *acc = acc.try_add(c)?,
                        None => {
                            order.push(base);
                            coef.insert(base, c);
                        }
                    }
                }
            }
        }
        let mut parts = Vec::new();
        if !constant.is_zero() {
            parts.push(self.num(constant));
        }
        for base in order {
            let c = coef[&base];
            if !c.is_zero() {
                parts.push(self.scale(c, base));
            }
        }
        Ok(match parts.len() {
            0 => self.num(Num::ZERO),
            1 => parts[0],
            _ => {
                parts.sort();
                self.intern(Node::Add(parts.into()))
            }
        })
    }

    /// `(c, base)` with `t = c * base`, `base` free of a constant factor.
    fn split_term(&mut self, t: Id) -> (Num, Id) {
        if let Node::Mul(ch) = self.node(t) {
            let ch = ch.clone();
            if let Some(k) = ch.iter().position(|&f| self.as_num(f).is_some()) {
                let c = self.as_num(ch[k]).unwrap_or(Num::ONE);
                let rest: Vec<Id> = ch
                    .iter()
                    .enumerate()
                    .filter(|(i, _)| *i != k)
                    .map(|(_, &f)| f)
                    .collect();
                // A sub-product of a canonical product is canonical.
                let base = if rest.len() == 1 {
                    rest[0]
                } else {
                    self.intern(Node::Mul(rest.into()))
                };
                return (c, base);
            }
        }
        (Num::ONE, t)
    }

    /// `c * base` for a `base` free of a constant factor, `c != 0`.
    fn scale(&mut self, c: Num, base: Id) -> Id {
        if c.is_one() {
            return base;
        }
        let k = self.num(c);
        let mut parts = match self.node(base) {
            Node::Mul(ch) => ch.to_vec(),
            _ => vec![base],
        };
        parts.push(k);
        parts.sort();
        self.intern(Node::Mul(parts.into()))
    }

    /// `product(factors)`, simplified.
    pub fn mul(&mut self, factors: &[Id]) -> Result<Id, Fault> {
        let mut coef = Num::ONE;
        let mut order: Vec<Id> = Vec::new();
        let mut expo: HashMap<Id, Num> = HashMap::new();
        let mut stack: Vec<Id> = factors.iter().rev().copied().collect();
        while let Some(f) = stack.pop() {
            let (base, e) = match self.node(f) {
                Node::Mul(ch) => {
                    stack.extend(ch.iter().rev());
                    continue;
                }
                Node::Num(c) => {
                    coef = coef.try_mul(*c)?;
                    continue;
                }
                Node::Pow(b, e) => (*b, *e),
                _ => (f, Num::ONE),
            };
            match expo.get_mut(&base) {
                Some(acc) => *acc = acc.try_add(e)?,
                None => {
                    order.push(base);
                    expo.insert(base, e);
                }
            }
        }
        if coef.is_zero() {
            return Ok(self.num(Num::ZERO));
        }
        let mut parts = Vec::new();
        let mut again = false;
        for base in order {
            let p = self.pow(base, expo[&base])?;
            match self.node(p) {
                Node::Num(c) => coef = coef.try_mul(*c)?,
                // A merged exponent became an integer and distributed: flatten once more.
                Node::Mul(_) => {
                    again = true;
                    parts.push(p);
                }
                _ => parts.push(p),
            }
        }
        if again {
            let c = self.num(coef);
            parts.push(c);
            return self.mul(&parts);
        }
        if parts.is_empty() {
            return Ok(self.num(coef));
        }
        if parts.len() == 1 && coef.is_one() {
            return Ok(parts[0]);
        }
        if !coef.is_one() {
            parts.push(self.num(coef));
        }
        parts.sort();
        Ok(self.intern(Node::Mul(parts.into())))
    }

    /// `base ^ e` for a constant exponent, simplified.
    pub fn pow(&mut self, base: Id, e: Num) -> Result<Id, Fault> {
        if e.is_zero() {
            return Ok(self.num(Num::ONE));
        }
        if e.is_one() {
            return Ok(base);
        }
        let integer = e.as_rational().is_some_and(|r| r.is_integer());
        match self.node(base).clone() {
            Node::Num(c) => Ok(self.num(c.pow(e)?)),
            Node::Pow(b, e0) if integer => {
                let e1 = e0.try_mul(e)?;
                self.pow(b, e1)
            }
            Node::Mul(ch) if integer => {
                let parts = ch
                    .iter()
                    .map(|&f| self.pow(f, e))
                    .collect::<Result<Vec<_>, _>>()?;
                self.mul(&parts)
            }
            _ => Ok(self.intern(Node::Pow(base, e))),
        }
    }

    /// `base ^ exponent` for any exponent: a constant one goes to [`Arena::pow`]; a variable
    /// one is `exp(exponent * ln(base))`, defined for `base > 0`.
    pub fn pow_general(&mut self, base: Id, exponent: Id) -> Result<Id, Fault> {
        if let Some(e) = self.as_num(exponent) {
            return self.pow(base, e);
        }
        let l = self.func(Func::Ln, base)?;
        let m = self.mul(&[exponent, l])?;
        self.func(Func::Exp, m)
    }

    /// `f(x)`, simplified.
    pub fn func(&mut self, f: Func, x: Id) -> Result<Id, Fault> {
        match (f, self.node(x).clone()) {
            (_, Node::Num(c)) => {
                let v = c.to_f64();
                if f == Func::Ln && v <= 0.0 {
                    return Err(Fault::Undefined(
                        "the logarithm of a non-positive constant is undefined",
                    ));
                }
                let folded = match (f, c.is_zero()) {
                    (Func::Cos | Func::Cosh | Func::Exp, true) => Num::ONE,
                    (Func::Ln, _) if c.is_one() => Num::ZERO,
                    (Func::Sin | Func::Tan | Func::Sinh | Func::Tanh | Func::Atan, true) => {
                        Num::ZERO
                    }
                    _ => Num::float(f.apply(v))?,
                };
                Ok(self.num(folded))
            }
            (Func::Ln, Node::Func(Func::Exp, y)) | (Func::Exp, Node::Func(Func::Ln, y)) => Ok(y),
            _ => Ok(self.intern(Node::Func(f, x))),
        }
    }

    /// `-x`.
    pub fn neg(&mut self, x: Id) -> Result<Id, Fault> {
        let m = self.num(Num::int(-1));
        self.mul(&[m, x])
    }

    /// `a - b`.
    pub fn sub(&mut self, a: Id, b: Id) -> Result<Id, Fault> {
        let nb = self.neg(b)?;
        self.add(&[a, nb])
    }

    /// `a / b` (an error when `b` simplifies to 0).
    pub fn div(&mut self, a: Id, b: Id) -> Result<Id, Fault> {
        if self.is_zero(b) {
            return Err(Fault::DivisionByZero);
        }
        let r = self.pow(b, Num::int(-1))?;
        self.mul(&[a, r])
    }
}
