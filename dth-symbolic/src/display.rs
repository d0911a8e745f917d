//! Printing expressions in the grammar's own syntax (for tests, errors and debugging).

use std::fmt;

use crate::arena::{Arena, Id, Node, Var};
use crate::number::Num;

/// An expression of an arena, printable with `{}`.
#[derive(Clone, Copy)]
pub struct Expr<'a> {
    /// The arena.
    pub arena: &'a Arena,
    /// The node.
    pub id: Id,
}

impl Arena {
    /// A printable view of `id`.
    pub fn expr(&self, id: Id) -> Expr<'_> {
        Expr { arena: self, id }
    }
}

// Precedence levels: sum 1, product 2, unary minus 3, power 4, atom 5.
fn prec(arena: &Arena, id: Id) -> u8 {
    match arena.node(id) {
        Node::Add(_) => 1,
        Node::Mul(ch) => {
            if ch
                .iter()
                .any(|&c| arena.as_num(c).is_some_and(Num::is_negative))
            {
                3
            } else {
                2
            }
        }
        Node::Num(n) if n.is_negative() => 3,
        Node::Num(Num::Rat(r)) if !r.is_integer() => 2,
        Node::Pow(..) => 4,
        _ => 5,
    }
}

fn write(arena: &Arena, id: Id, min: u8, f: &mut fmt::Formatter<'_>) -> fmt::Result {
    let p = prec(arena, id);
    if p < min {
        f.write_str("(")?;
        write(arena, id, 0, f)?;
        return f.write_str(")");
    }
    match arena.node(id) {
        Node::Num(n) => write!(f, "{n}"),
        Node::Var(Var::Q(i)) => write!(f, "q{i}"),
        Node::Var(Var::P(i)) => write!(f, "p{i}"),
        Node::Var(Var::T) => f.write_str("t"),
        Node::Var(Var::Pt) => f.write_str("p_t"),
        Node::Var(Var::Param(k)) => match arena.params().get(*k as usize) {
            Some(name) => f.write_str(name),
            None => write!(f, "param{k}"),
        },
        Node::Add(ch) => {
            for (i, &c) in ch.iter().enumerate() {
                let (neg, mag) = negated(arena, c);
                match (i, neg) {
                    (0, true) => f.write_str("-")?,
                    (0, false) => {}
                    (_, true) => f.write_str(" - ")?,
                    (_, false) => f.write_str(" + ")?,
                }
                write_term(arena, c, neg, mag, f)?;
            }
            Ok(())
        }
        Node::Mul(_) => {
            let (neg, mag) = negated(arena, id);
            if neg {
                f.write_str("-")?;
            }
            write_term(arena, id, neg, mag, f)
        }
        Node::Pow(b, e) => {
            write(arena, *b, 5, f)?;
            match e {
                Num::Rat(r) if r.is_integer() && r.numer() > 0 => write!(f, "^{r}"),
                _ => write!(f, "^({e})"),
            }
        }
        Node::Func(func, x) => {
            write!(f, "{}(", func.name())?;
            write(arena, *x, 0, f)?;
            f.write_str(")")
        }
    }
}

/// Whether a term prints with a leading minus, and its constant magnitude if it has one.
fn negated(arena: &Arena, id: Id) -> (bool, Option<Num>) {
    match arena.node(id) {
        Node::Num(n) => (
            n.is_negative(),
            Some(if n.is_negative() { -*n } else { *n }),
        ),
        Node::Mul(ch) => match ch.iter().find_map(|&c| arena.as_num(c)) {
            Some(c) if c.is_negative() => (true, Some(-c)),
            Some(c) => (false, Some(c)),
            None => (false, None),
        },
        _ => (false, None),
    }
}

/// Writes `id` without its sign (the caller wrote it).
fn write_term(
    arena: &Arena,
    id: Id,
    neg: bool,
    mag: Option<Num>,
    f: &mut fmt::Formatter<'_>,
) -> fmt::Result {
    match arena.node(id) {
        Node::Num(_) => write!(f, "{}", mag.unwrap_or(Num::ZERO)),
        Node::Mul(ch) => {
            let mut first = true;
            if let Some(m) = mag.filter(|m| !m.is_one()) {
                match m {
                    Num::Rat(r) if !r.is_integer() => write!(f, "({r})")?,
                    _ => write!(f, "{m}")?,
                }
                first = false;
            }
            for &c in ch.iter().filter(|&&c| arena.as_num(c).is_none()) {
                if !first {
                    f.write_str("*")?;
                }
                first = false;
                write(arena, c, 3, f)?;
            }
            Ok(())
        }
        _ if neg => unreachable!("only constants and products carry a sign"),
        _ => write(arena, id, 2, f),
    }
}

impl fmt::Display for Expr<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write(self.arena, self.id, 0, f)
    }
}
