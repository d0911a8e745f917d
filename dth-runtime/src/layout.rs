//! What each compiled program returns and where: the trait methods a run-time Hamiltonian
//! offers ([`Function`]), the engine program each is cut from, and the flat output buffer each
//! writes.

use dth_symbolic::{Method, Op, Output, Program, Slot, System};

use crate::error::RuntimeError;

/// A method of the Hamiltonian trait, computed by one program. The two-point ones are cut
/// from the engine's discrete-gradient programs exactly as `hamiltonian!` cuts them, so each
/// performs the same operations as the macro's method of the same name.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Function {
    /// `H(z)`: one value.
    Value,
    /// `grad H(z)`: `D` values.
    Gradient,
    /// `Hess H(z)`: `D x D`, row-major, both triangles.
    Hessian,
    /// `Psi(z)`: one value.
    Psi,
    /// Value, gradient, Hessian and Psi from one fused program: `1 + D + D^2 + 1` values in
    /// that order.
    Derivatives,
    /// The exact discrete gradient `gbar(z0, z1)`: `D` values.
    DiscreteGradient,
    /// `H(z1) - H(z0)` without cancellation: one value.
    EnergyDifference,
    /// `grad H(z0) + grad H(z1) - 2 gbar(z0, z1)` without cancellation: `D` values.
    DiscreteGradientDefect,
}

/// Where an output of a program goes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Placement {
    /// At this index of the output buffer, and at the second too when given (the mirrored
    /// entry of the Hessian).
    At(usize, Option<usize>),
    /// A known output this function does not return (it is pruned from the program).
    NotReturned,
    /// An output this crate does not know.
    Unknown,
}

impl Function {
    /// Every function, in the order [`crate::RuntimeHamiltonian`] compiles them.
    pub const ALL: [Function; 8] = [
        Function::Value,
        Function::Gradient,
        Function::Hessian,
        Function::Psi,
        Function::Derivatives,
        Function::DiscreteGradient,
        Function::EnergyDifference,
        Function::DiscreteGradientDefect,
    ];

    /// The method's name in the Hamiltonian trait.
    pub fn name(self) -> &'static str {
        match self {
            Function::Value => "value",
            Function::Gradient => "gradient",
            Function::Hessian => "hessian",
            Function::Psi => "psi",
            Function::Derivatives => "derivatives",
            Function::DiscreteGradient => "discrete_gradient",
            Function::EnergyDifference => "energy_difference",
            Function::DiscreteGradientDefect => "discrete_gradient_defect",
        }
    }

    /// The engine program this function is cut from.
    pub fn method(self) -> Method {
        match self {
            Function::Value => Method::Value,
            Function::Gradient => Method::Gradient,
            Function::Hessian => Method::Hessian,
            Function::Psi => Method::Psi,
            Function::Derivatives => Method::All,
            Function::DiscreteGradient | Function::EnergyDifference => Method::DiscreteGradient,
            Function::DiscreteGradientDefect => Method::DiscreteGradientDefect,
        }
    }

    /// `true` for the functions of two points `z0`, `z1`.
    pub fn two_point(self) -> bool {
        matches!(
            self,
            Function::DiscreteGradient
                | Function::EnergyDifference
                | Function::DiscreteGradientDefect
        )
    }

    /// The length of the output buffer in dimension `d`.
    pub fn len(self, d: usize) -> usize {
        match self {
            Function::Value | Function::Psi | Function::EnergyDifference => 1,
            Function::Gradient | Function::DiscreteGradient | Function::DiscreteGradientDefect => d,
            Function::Hessian => d * d,
            Function::Derivatives => 2 + d + d * d,
        }
    }

    /// Where output `o` goes in dimension `d`.
    pub fn place(self, o: Output, d: usize) -> Placement {
        use Function as F;
        use Placement::{At, NotReturned};
        // The Hessian block of the buffer starts at `start`: entry (i, j) and its mirror.
        let hessian = |start: usize, i: usize, j: usize| {
            At(start + i * d + j, (i != j).then_some(start + j * d + i))
        };
        match (self, o) {
            (F::Value | F::Derivatives, Output::Value) => At(0, None),
            (F::Gradient, Output::Gradient(i)) => At(i, None),
            (F::Derivatives, Output::Gradient(i)) => At(1 + i, None),
            (F::Hessian, Output::Hessian(i, j)) => hessian(0, i, j),
            (F::Derivatives, Output::Hessian(i, j)) => hessian(1 + d, i, j),
            (F::Psi, Output::Psi) => At(0, None),
            (F::Derivatives, Output::Psi) => At(1 + d + d * d, None),
            (F::DiscreteGradient, Output::DiscreteGradient(i)) => At(i, None),
            (F::EnergyDifference, Output::EnergyDifference) => At(0, None),
            (F::DiscreteGradientDefect, Output::DiscreteGradientDefect(i)) => At(i, None),
            (
                _,
                Output::Value
                | Output::Gradient(_)
                | Output::Hessian(..)
                | Output::Psi
                | Output::DiscreteGradient(_)
                | Output::EnergyDifference
                | Output::DiscreteGradientDefect(_),
            ) => NotReturned,
            // The engine may grow outputs (a structured Hessian, say): one this crate does
            // not know is refused by `program`, never silently dropped.
            #[allow(unreachable_patterns)]
            _ => Placement::Unknown,
        }
    }

    /// The program computing this function: the engine's program of [`Function::method`],
    /// pruned to the outputs this function returns (as `hamiltonian!` prunes the two-point
    /// program into `discrete_gradient` and `energy_difference`). An output placed nowhere
    /// is an error, and so is an output out of range: compiled code writes where
    /// [`Function::place`] says.
    pub fn program(self, system: &System) -> Result<Program, RuntimeError> {
        let program = system.program(self.method());
        let d = program.dim;
        let len = self.len(d);
        for &(o, _) in &program.outputs {
            match self.place(o, d) {
                Placement::Unknown => {
                    return Err(RuntimeError::UnsupportedOutput {
                        what: self.name(),
                        output: o,
                    })
                }
                Placement::At(a, b) if a >= len || b.is_some_and(|b| b >= len) => {
                    return Err(RuntimeError::MalformedProgram {
                        what: self.name(),
                        reason: format!("output {o:?} outside dimension {d}"),
                    })
                }
                Placement::At(..) | Placement::NotReturned => {}
            }
        }
        Ok(program.prune(|o| matches!(self.place(o, d), Placement::At(..))))
    }
}

/// Every operation of `p` reads slots defined before it, inputs and parameters in range: the
/// reason it does not, otherwise `Ok`. Compiled code trusts a program that passes.
pub fn check_ops(p: &Program) -> Result<(), String> {
    for (i, op) in p.ops.iter().enumerate() {
        let earlier = |s: Slot| (s as usize) < i;
        let ok = match *op {
            Op::Input(k) | Op::Input1(k) => (k as usize) < p.dim,
            Op::Param(k) => (k as usize) < p.params,
            Op::Const(_) => true,
            Op::Neg(a) | Op::Sqrt(a) | Op::Powf(a, _) | Op::Call(_, a) => earlier(a),
            Op::Add(a, b) | Op::Sub(a, b) | Op::Mul(a, b) | Op::Div(a, b) | Op::Kernel(_, a, b) => {
                earlier(a) && earlier(b)
            }
        };
        if !ok {
            return Err(format!("operation {i} `{op:?}` reads out of range"));
        }
    }
    match p.outputs.iter().find(|&&(_, s)| s as usize >= p.ops.len()) {
        Some(&(o, s)) => Err(format!("output {o:?} reads slot {s} of {}", p.ops.len())),
        None => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The places of one function's outputs cover its buffer exactly once (both triangles of
    /// the Hessian included), so nothing is written twice and nothing returned is left out.
    #[test]
    fn places_tile_each_buffer() {
        let d = 3;
        let mut outputs = vec![Output::Value, Output::Psi, Output::EnergyDifference];
        for i in 0..d {
            outputs.push(Output::Gradient(i));
            outputs.push(Output::DiscreteGradient(i));
            outputs.push(Output::DiscreteGradientDefect(i));
            for j in i..d {
                outputs.push(Output::Hessian(i, j));
            }
        }
        for f in Function::ALL {
            let mut hits = vec![0; f.len(d)];
            for &o in &outputs {
                if let Placement::At(a, b) = f.place(o, d) {
                    hits[a] += 1;
                    if let Some(b) = b {
                        hits[b] += 1;
                    }
                }
            }
            assert!(hits.iter().all(|&h| h == 1), "{f:?}: {hits:?}");
        }
    }
}
