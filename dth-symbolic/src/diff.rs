//! Symbolic differentiation. Each derivative node inherits the span of the node it came from.
//!
//! Rules (`u' = du/dx`):
//! - constants and other variables: `0`; `x`: `1`; parameters are constants;
//! - sum: `(a + b)' = a' + b'`;
//! - product (n-ary Leibniz): `(a b c)' = a' b c + a b' c + a b c'`;
//! - constant power: `(u^c)' = c u^(c-1) u'` (a variable exponent was already rewritten as
//!   `exp(b ln a)`, so the chain rule covers it);
//! - `sin' = cos`, `cos' = -sin`, `tan' = 1 + tan^2`, `exp' = exp`, `ln' = u^-1`,
//!   `sinh' = cosh`, `cosh' = sinh`, `tanh' = 1 - tanh^2`, `atan' = (1 + u^2)^-1`
//!   (`tan` and `tanh` are written through themselves so the derivative shares their value).

use std::collections::HashMap;

use crate::arena::{Arena, Func, Id, Node, Var};
use crate::number::{Fault, Num};

impl Arena {
    /// `d node / d x`, simplified. On a fault (a constant that overflows, say),
    /// `self.span` is the span of the innermost node whose derivative failed.
    pub fn diff(&mut self, node: Id, x: Var) -> Result<Id, Fault> {
        let mut memo = HashMap::new();
        self.diff_memo(node, x, &mut memo)
    }

    fn diff_memo(&mut self, node: Id, x: Var, memo: &mut HashMap<Id, Id>) -> Result<Id, Fault> {
        // A subtree free of `x` differentiates to 0 without being walked.
        if !self.depends_on(node, x) {
            return Ok(self.num(Num::ZERO));
        }
        if let Some(&d) = memo.get(&node) {
            return Ok(d);
        }
        self.diff_work += 1;
        let saved = self.span;
        self.span = self.span(node);
        // On a fault the span is left on the innermost node that failed: the caller reports it
        // there (`arena.span` after the error).
        let d = self.diff_rule(node, x, memo)?;
        self.span = saved;
        memo.insert(node, d);
        Ok(d)
    }

    fn diff_rule(&mut self, node: Id, x: Var, memo: &mut HashMap<Id, Id>) -> Result<Id, Fault> {
        let zero = |a: &mut Arena| a.num(Num::ZERO);
        match self.node(node).clone() {
            Node::Num(_) => Ok(zero(self)),
            Node::Var(v) => Ok(self.num(if v == x { Num::ONE } else { Num::ZERO })),
            Node::Add(ch) => {
                let mut ds = Vec::new();
                for &c in ch.iter() {
                    if self.depends_on(c, x) {
                        ds.push(self.diff_memo(c, x, memo)?);
                    }
                }
                self.add(&ds)
            }
            Node::Mul(ch) => {
                let mut terms = Vec::new();
                for (i, &c) in ch.iter().enumerate() {
                    if !self.depends_on(c, x) {
                        continue;
                    }
                    let dc = self.diff_memo(c, x, memo)?;
                    if self.is_zero(dc) {
                        continue;
                    }
                    let mut factors: Vec<Id> = ch.to_vec();
                    factors[i] = dc;
                    terms.push(self.mul(&factors)?);
                }
                self.add(&terms)
            }
            Node::Pow(b, e) => {
                let db = self.diff_memo(b, x, memo)?;
                if self.is_zero(db) {
                    return Ok(zero(self));
                }
                let p = self.pow(b, e.try_add(Num::int(-1))?)?;
                let c = self.num(e);
                self.mul(&[c, p, db])
            }
            Node::Func(f, u) => {
                let du = self.diff_memo(u, x, memo)?;
                if self.is_zero(du) {
                    return Ok(zero(self));
                }
                let outer = match f {
                    Func::Sin => self.func(Func::Cos, u)?,
                    Func::Cos => {
                        let s = self.func(Func::Sin, u)?;
                        self.neg(s)?
                    }
                    Func::Tan => {
                        let sq = self.pow(node, Num::int(2))?;
                        let one = self.num(Num::ONE);
                        self.add(&[one, sq])?
                    }
                    Func::Exp => node,
                    Func::Ln => self.pow(u, Num::int(-1))?,
                    Func::Sinh => self.func(Func::Cosh, u)?,
                    Func::Cosh => self.func(Func::Sinh, u)?,
                    Func::Tanh => {
                        let sq = self.pow(node, Num::int(2))?;
                        let one = self.num(Num::ONE);
                        self.sub(one, sq)?
                    }
                    Func::Atan => {
                        let sq = self.pow(u, Num::int(2))?;
                        let one = self.num(Num::ONE);
                        let s = self.add(&[one, sq])?;
                        self.pow(s, Num::int(-1))?
                    }
                };
                self.mul(&[outer, du])
            }
        }
    }
}
