//! Builds the arena from the syntax tree, resolving names and folding constants. Every
//! independent error is collected; a subtree with an error is skipped, so its parents add none.

use crate::arena::{Arena, Id, Var};
use crate::check::{resolve, Name};
use crate::error::{Error, ErrorKind};
use crate::number::{parse_literal, Fault, LiteralError, Num};
use crate::parser::{operand_text, Ast, BinOp};
use crate::span::Span;

pub(crate) struct Builder<'a> {
    pub src: &'a str,
    pub arena: Arena,
    pub errors: Vec<Error>,
}

impl Builder<'_> {
    /// The node for `ast`, or `None` when it (or a part of it) is in error.
    pub fn build(&mut self, ast: &Ast) -> Option<Id> {
        let span = ast.span();
        let result = match ast {
            Ast::Number(s) => {
                let text = &self.src[s.range()];
                match parse_literal(text) {
                    Ok(n) => Ok(self.arena.num(n)),
                    Err(e) => {
                        let text = text.to_string();
                        let kind = match e {
                            LiteralError::Invalid => ErrorKind::InvalidNumber { text },
                            LiteralError::Overflow => ErrorKind::LiteralOverflow { text },
                            LiteralError::Underflow => ErrorKind::LiteralUnderflow { text },
                        };
                        self.errors.push(Error::new(kind, *s));
                        return None;
                    }
                }
            }
            Ast::Name(s) => {
                let params = self.arena.params().to_vec();
                match resolve(&self.src[s.range()], &params) {
                    Ok(Name::Var(v)) => {
                        self.arena.span = *s;
                        Ok(self.arena.var(v))
                    }
                    Ok(Name::Pi) => Ok(self.arena.num(Num::Float(std::f64::consts::PI))),
                    Ok(Name::Func(f)) => {
                        self.errors.push(Error::new(
                            ErrorKind::FunctionWithoutCall {
                                name: f.name().to_string(),
                            },
                            *s,
                        ));
                        return None;
                    }
                    Err(kind) => {
                        self.errors.push(Error::new(kind, *s));
                        return None;
                    }
                }
            }
            Ast::Call {
                name, arg, extra, ..
            } if !extra.is_empty() => {
                let text = &self.src[name.range()];
                let params = self.arena.params().to_vec();
                let kind = match resolve(text, &params) {
                    _ if text == "pow" && extra.len() == 1 => ErrorKind::PowFunction {
                        power: format!(
                            "{}^{}",
                            operand_text(self.src, arg),
                            operand_text(self.src, &extra[0])
                        ),
                    },
                    Ok(Name::Func(_)) | Err(ErrorKind::FunctionWithoutCall { .. }) => {
                        ErrorKind::TooManyArguments {
                            name: text.to_string(),
                            found: 1 + extra.len(),
                        }
                    }
                    Ok(_) | Err(ErrorKind::BadIndex { .. } | ErrorKind::IndexTooLarge { .. }) => {
                        ErrorKind::NotAFunction {
                            name: text.to_string(),
                        }
                    }
                    Err(_) => ErrorKind::UnknownFunction {
                        name: text.to_string(),
                    },
                };
                // The extra arguments are the offending piece of a known function's call.
                let at = match &kind {
                    ErrorKind::TooManyArguments { .. } => {
                        extra[0].span().to(extra[extra.len() - 1].span())
                    }
                    _ => *name,
                };
                self.errors.push(Error::new(kind, at));
                self.build(arg);
                for x in extra {
                    self.build(x);
                }
                return None;
            }
            Ast::Call { name, arg, .. } => {
                let text = &self.src[name.range()];
                let params = self.arena.params().to_vec();
                let f = match resolve(text, &params) {
                    Ok(Name::Func(f)) => Some(f),
                    _ if text == "sqrt" => None,
                    Ok(_) | Err(ErrorKind::BadIndex { .. } | ErrorKind::IndexTooLarge { .. }) => {
                        self.errors.push(Error::new(
                            ErrorKind::NotAFunction {
                                name: text.to_string(),
                            },
                            *name,
                        ));
                        self.build(arg);
                        return None;
                    }
                    Err(_) => {
                        self.errors.push(Error::new(
                            ErrorKind::UnknownFunction {
                                name: text.to_string(),
                            },
                            *name,
                        ));
                        self.build(arg);
                        return None;
                    }
                };
                let x = self.build(arg)?;
                self.arena.span = span;
                match f {
                    Some(f) => self.arena.func(f, x),
                    None => self
                        .arena
                        .pow(x, Num::Rat(crate::number::Rational::new(1, 2)?)),
                }
            }
            Ast::Paren { inner, .. } => return self.build(inner),
            Ast::Unary { negate, arg, .. } => {
                let x = self.build(arg)?;
                if !negate {
                    return Some(x);
                }
                self.arena.span = span;
                self.arena.neg(x)
            }
            Ast::Chain { first, rest } => return self.chain(first, rest, span),
            Ast::Binary { lhs, rhs, .. } => {
                if let Ast::Name(e) = &**lhs {
                    let params = self.arena.params().to_vec();
                    if let Err(ErrorKind::EulerNumber { .. }) =
                        resolve(&self.src[e.range()], &params)
                    {
                        // `e^x` is `exp(x)`.
                        let x = match &**rhs {
                            Ast::Paren { inner, .. } => inner.span(),
                            x => x.span(),
                        };
                        let exponent = Some(self.src[x.range()].to_string());
                        self.errors
                            .push(Error::new(ErrorKind::EulerNumber { exponent }, *e));
                        self.build(rhs);
                        return None;
                    }
                }
                let (a, b) = (self.build(lhs), self.build(rhs));
                let (a, b) = (a?, b?);
                self.arena.span = span;
                self.arena.pow_general(a, b)
            }
        };
        match result {
            Ok(id) => Some(id),
            Err(fault) => {
                self.errors.push(Error::new(ErrorKind::Fault(fault), span));
                None
            }
        }
    }
}

impl Builder<'_> {
    /// A sum or product chain, built with one n-ary constructor call.
    fn chain(&mut self, first: &Ast, rest: &[(BinOp, Span, Ast)], span: Span) -> Option<Id> {
        let a = self.build(first);
        let operands: Vec<Option<Id>> = rest.iter().map(|(_, _, x)| self.build(x)).collect();
        let mut parts = vec![a?];
        for ((op, _, x), id) in rest.iter().zip(operands) {
            let id = id?;
            self.arena.span = x.span();
            let part = match op {
                BinOp::Sub => self.arena.neg(id),
                // A division by zero is the divisor's fault.
                BinOp::Div if self.arena.is_zero(id) => Err(Fault::DivisionByZero),
                BinOp::Div => self.arena.pow(id, Num::int(-1)),
                _ => Ok(id),
            };
            match part {
                Ok(p) => parts.push(p),
                Err(fault) => {
                    self.errors
                        .push(Error::new(ErrorKind::Fault(fault), x.span()));
                    return None;
                }
            }
        }
        self.arena.span = span;
        let sum = matches!(rest.first(), Some((BinOp::Add | BinOp::Sub, _, _)));
        let r = if sum {
            self.arena.add(&parts)
        } else {
            self.arena.mul(&parts)
        };
        match r {
            Ok(id) => Some(id),
            Err(fault) => {
                self.errors.push(Error::new(ErrorKind::Fault(fault), span));
                None
            }
        }
    }
}

/// `Var`s of the phase space in `z` order.
pub(crate) fn coordinates(n: u32, time_dependent: bool) -> Vec<Var> {
    let mut z: Vec<Var> = (1..=n).map(Var::Q).collect();
    if time_dependent {
        z.push(Var::T);
    }
    z.extend((1..=n).map(Var::P));
    if time_dependent {
        z.push(Var::Pt);
    }
    z
}
