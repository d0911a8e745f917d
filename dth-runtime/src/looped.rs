//! A lattice Hamiltonian compiled in loops ([`dth_symbolic::looped`]) behind the same calls as
//! a written-out one: each [`Function`] of [`crate::RuntimeHamiltonian`] from the lattice's
//! looped functions ([`LoopFunction`]), assembled as the macro's looped types assemble them
//! (`dth_symbolic::emit::lattice`): the dense Hessian is the nonzeros set at the pattern and
//! its mirror, Psi is `w^T Hess w` (`w = J grad H`) summed over the nonzeros in the pattern's
//! order, and the fused derivatives are the four computed one after the other. So every
//! output has the bits of the macro's looped type for the same text.

use std::cell::RefCell;

use dth_symbolic::looped::Looped;
use dth_symbolic::Output;

use crate::backend::Backend;
use crate::error::{JitError, RuntimeError};
use crate::jit::{self, JitFunction};
use crate::lattice::{self, LatticePlan, LoopFunction};
use crate::layout::Function;

/// A lattice's looped functions, ready to run.
#[derive(Debug)]
pub(crate) struct Lattice {
    looped: Looped,
    plan: LatticePlan,
    /// One per [`LoopFunction::ALL`] with the JIT; `None` for the interpreter.
    code: Option<Vec<JitFunction>>,
}

thread_local! {
    /// The gradient and the nonzeros Psi and the dense Hessian are assembled from, grown to
    /// the largest lattice seen on the thread (no allocation per call after the first).
    static SCRATCH: RefCell<(Vec<f64>, Vec<f64>)> = const { RefCell::new((Vec::new(), Vec::new())) };
}

impl Lattice {
    /// Plans `looped` (with `params` parameters) and compiles its functions with `backend`;
    /// with [`Backend::Jit`], a failure of the JIT is returned beside the interpreter.
    pub(crate) fn new(
        looped: Looped,
        params: usize,
        backend: Backend,
    ) -> Result<(Lattice, Option<JitError>), RuntimeError> {
        let plan = LatticePlan::new(&looped, params)?;
        let (code, fallback) = match backend {
            Backend::Interpreter => (None, None),
            Backend::Jit => {
                let codes: Vec<_> = plan.functions.iter().collect();
                match jit::compile_loops(&codes) {
                    Ok(code) => (Some(code), None),
                    Err(RuntimeError::Jit(e)) => (None, Some(e)),
                    Err(e) => return Err(e),
                }
            }
        };
        Ok((Lattice { looped, plan, code }, fallback))
    }

    /// The lattice.
    pub(crate) fn looped(&self) -> &Looped {
        &self.looped
    }

    /// The Hessian's nonzeros, upper triangle, in the order the nonzeros are written.
    pub(crate) fn pattern(&self) -> &[(usize, usize)] {
        &self.plan.pattern
    }

    /// How many of the nonzeros are on the diagonal.
    pub(crate) fn diagonal(&self) -> usize {
        self.plan.layout.diagonal
    }

    /// `true` when the functions run compiled code.
    pub(crate) fn is_jit(&self) -> bool {
        self.code.is_some()
    }

    /// The compiled code of the functions (empty for the interpreter).
    pub(crate) fn jit(&self) -> &[JitFunction] {
        self.code.as_deref().unwrap_or(&[])
    }

    /// Runs `f` into `out` (zeroed first), no length checks (the caller's).
    fn raw(
        &self,
        f: LoopFunction,
        z0: &[f64],
        z1: &[f64],
        params: &[f64],
        out: &mut [f64],
    ) -> Result<(), RuntimeError> {
        let k = f as usize;
        match &self.code {
            Some(code) => {
                out.fill(0.0);
                // SAFETY: the caller checked `z0`, `z1` against the lattice's dimension,
                // `params` against its parameters and `out` against the function's length,
                // the bounds `lattice::LatticePlan::new` checked every address against.
                unsafe { code[k].call(z0, z1, params, out) };
                Ok(())
            }
            None => lattice::interpret(&self.plan.functions[k], z0, z1, params, out),
        }
    }

    /// The Hessian's nonzeros at `z` into `values` (as long as the pattern).
    pub(crate) fn nonzeros(
        &self,
        z: &[f64],
        params: &[f64],
        values: &mut [f64],
    ) -> Result<(), RuntimeError> {
        self.lengths(("z", "z"), z, z, params, values.len(), self.pattern().len())?;
        self.raw(LoopFunction::HessianNonzeros, z, z, params, values)?;
        self.finite("hessian", values, |k| {
            let (i, j) = self.plan.pattern[k];
            Output::Hessian(i, j)
        })
    }

    /// Runs `f` at `z0`, `z1` into `out`, as [`crate::backend`] runs a written-out program:
    /// the lengths checked, the outputs checked finite.
    pub(crate) fn run(
        &self,
        f: Function,
        z0: &[f64],
        z1: &[f64],
        params: &[f64],
        out: &mut [f64],
    ) -> Result<(), RuntimeError> {
        let d = self.looped.dim();
        let names = if f.two_point() {
            ("z0", "z1")
        } else {
            ("z", "z")
        };
        self.lengths(names, z0, z1, params, out.len(), f.len(d))?;
        let looped = |lf: LoopFunction, out: &mut [f64]| self.raw(lf, z0, z1, params, out);
        match f {
            Function::Value => looped(LoopFunction::Value, out)?,
            Function::Gradient => looped(LoopFunction::Gradient, out)?,
            Function::DiscreteGradient => looped(LoopFunction::DiscreteGradient, out)?,
            Function::EnergyDifference => looped(LoopFunction::EnergyDifference, out)?,
            Function::DiscreteGradientDefect => looped(LoopFunction::DiscreteGradientDefect, out)?,
            Function::Hessian => self.hessian(z0, params, out)?,
            Function::Psi => out[0] = self.psi(z0, params)?,
            Function::Derivatives => {
                let (value, rest) = out.split_at_mut(1);
                let (gradient, rest) = rest.split_at_mut(d);
                let (hessian, psi) = rest.split_at_mut(d * d);
                looped(LoopFunction::Value, value)?;
                looped(LoopFunction::Gradient, gradient)?;
                self.hessian(z0, params, hessian)?;
                psi[0] = self.psi(z0, params)?;
            }
        }
        let name = f.name();
        self.finite(name, out, |k| output_at(f, d, k))
    }

    /// The dense Hessian, row-major, both triangles: the nonzeros at the pattern and its
    /// mirror, zero elsewhere.
    fn hessian(&self, z: &[f64], params: &[f64], out: &mut [f64]) -> Result<(), RuntimeError> {
        let d = self.looped.dim();
        SCRATCH.with_borrow_mut(|(_, values)| {
            values.resize(self.pattern().len(), 0.0);
            self.raw(LoopFunction::HessianNonzeros, z, z, params, values)?;
            out.fill(0.0);
            for (&(a, b), &v) in self.pattern().iter().zip(values.iter()) {
                out[a * d + b] = v;
                out[b * d + a] = v;
            }
            Ok(())
        })
    }

    /// `Psi = w^T Hess w`, `w = J grad H`, over the nonzeros in the pattern's order (each
    /// off-diagonal entry twice), as the macro's looped types compute it.
    fn psi(&self, z: &[f64], params: &[f64]) -> Result<f64, RuntimeError> {
        let n = self.looped.n();
        SCRATCH.with_borrow_mut(|(g, values)| {
            g.resize(self.looped.dim(), 0.0);
            values.resize(self.pattern().len(), 0.0);
            self.raw(LoopFunction::Gradient, z, z, params, g)?;
            self.raw(LoopFunction::HessianNonzeros, z, z, params, values)?;
            let w = |i: usize| if i < n { g[i + n] } else { -g[i - n] };
            let mut psi = 0.0f64;
            for (&(a, b), &v) in self.pattern().iter().zip(values.iter()) {
                psi += if a == b {
                    v * w(a) * w(a)
                } else {
                    2.0 * v * w(a) * w(b)
                };
            }
            Ok(psi)
        })
    }

    fn lengths(
        &self,
        names: (&'static str, &'static str),
        z0: &[f64],
        z1: &[f64],
        params: &[f64],
        out: usize,
        expected: usize,
    ) -> Result<(), RuntimeError> {
        let (d, p) = (self.looped.dim(), self.plan.functions[0].params);
        for (what, expected, found) in [
            (names.0, d, z0.len()),
            (names.1, d, z1.len()),
            ("params", p, params.len()),
            ("out", expected, out),
        ] {
            if found != expected {
                return Err(RuntimeError::WrongLength {
                    what,
                    expected,
                    found,
                });
            }
        }
        Ok(())
    }

    /// `Ok` when every entry of `out` is finite, else the first that is not, as the output
    /// `output(k)` of function `what`.
    fn finite(
        &self,
        what: &'static str,
        out: &[f64],
        output: impl Fn(usize) -> Output,
    ) -> Result<(), RuntimeError> {
        if out.iter().all(|x| x.is_finite()) {
            return Ok(());
        }
        match out.iter().position(|x| !x.is_finite()) {
            Some(k) => Err(RuntimeError::NonFinite {
                what,
                output: output(k),
                value: out[k],
            }),
            None => Ok(()),
        }
    }
}

/// The output at index `k` of `f`'s buffer in dimension `d` (the inverse of
/// [`Function::place`]).
fn output_at(f: Function, d: usize, k: usize) -> Output {
    let hessian = |k: usize| Output::Hessian((k / d).min(k % d), (k / d).max(k % d));
    match f {
        Function::Value => Output::Value,
        Function::Psi => Output::Psi,
        Function::EnergyDifference => Output::EnergyDifference,
        Function::Gradient => Output::Gradient(k),
        Function::DiscreteGradient => Output::DiscreteGradient(k),
        Function::DiscreteGradientDefect => Output::DiscreteGradientDefect(k),
        Function::Hessian => hessian(k),
        Function::Derivatives => match k {
            0 => Output::Value,
            k if k <= d => Output::Gradient(k - 1),
            k if k <= d + d * d => hessian(k - 1 - d),
            _ => Output::Psi,
        },
    }
}
