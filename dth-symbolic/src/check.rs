//! The rules of the grammar's names, and the structural checks on a built Hamiltonian.

use crate::arena::{Arena, Func, Id, Var};
use crate::error::{Error, ErrorKind};
use crate::span::Span;

/// What a name in the source denotes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Name {
    /// A variable or parameter.
    Var(Var),
    /// `pi`.
    Pi,
    /// A function (only valid when called).
    Func(Func),
}

/// Resolves a name: `q<i>`, `p<i>` (`i >= 1`, no leading zero, at most [`crate::MAX_INDEX`]),
/// `t`, `pi`, a function name, or a declared parameter.
pub fn resolve(name: &str, params: &[String]) -> Result<Name, ErrorKind> {
    if let Some(k) = params.iter().position(|p| p == name) {
        return Ok(Name::Var(Var::Param(k as u32)));
    }
    match name {
        "t" => return Ok(Name::Var(Var::T)),
        "pi" => return Ok(Name::Pi),
        _ => {}
    }
    if let Some(f) = Func::ALL.iter().find(|f| f.name() == name) {
        return Ok(Name::Func(*f));
    }
    if name == "sqrt" {
        // `sqrt` is the power 1/2: the builder handles it; as a bare name it is a function.
        return Err(ErrorKind::FunctionWithoutCall {
            name: name.to_string(),
        });
    }
    let (head, digits) = name.split_at(1.min(name.len()));
    if (head == "q" || head == "p")
        && !digits.is_empty()
        && digits.bytes().all(|b| b.is_ascii_digit())
    {
        if digits.starts_with('0') {
            return Err(ErrorKind::BadIndex {
                name: name.to_string(),
            });
        }
        let i: u32 = match digits.parse() {
            Ok(i) if i as usize <= crate::MAX_INDEX => i,
            _ => {
                return Err(ErrorKind::IndexTooLarge {
                    name: name.to_string(),
                })
            }
        };
        return Ok(Name::Var(if head == "q" { Var::Q(i) } else { Var::P(i) }));
    }
    Err(ErrorKind::UnknownVariable {
        name: name.to_string(),
    })
}

/// Why `name` cannot be a parameter, if it cannot: it is a name of the grammar already.
pub fn reserved_name(name: &str) -> Option<&'static str> {
    match resolve(name, &[]) {
        Ok(Name::Var(_)) | Err(ErrorKind::BadIndex { .. } | ErrorKind::IndexTooLarge { .. }) => {
            Some("is a phase-space variable (q1..qN, p1..pN, t)")
        }
        Ok(Name::Pi) => Some("is the constant pi"),
        Ok(Name::Func(_)) | Err(ErrorKind::FunctionWithoutCall { .. }) => {
            Some("is a function of the grammar")
        }
        _ => None,
    }
}

/// Structural checks on `H` (before `p_t` is added): it must depend on a momentum, and so
/// on some variable at all. Parameters do not count: they are constants for the flow.
pub fn structure(arena: &Arena, h: Id, whole: Span) -> Vec<Error> {
    let vars = arena.vars(h);
    if !vars
        .iter()
        .any(|v| matches!(v, Var::Q(_) | Var::P(_) | Var::T))
    {
        return vec![Error::new(ErrorKind::ConstantHamiltonian, whole)];
    }
    if !vars.iter().any(|v| matches!(v, Var::P(_))) {
        return vec![Error::new(ErrorKind::NoMomentum, whole)];
    }
    Vec::new()
}
