//! How a function is run: compiled code ([`Backend::Jit`]) or the engine's interpreter
//! ([`Backend::Interpreter`]), behind one call that checks lengths and the
//! finiteness of what it returns.

use dth_symbolic::{Evaluation, Output, PairEvaluation, Program};

use crate::error::RuntimeError;
use crate::jit::{self, JitFunction};
use crate::layout::{Function, Placement};

/// What runs the programs.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Backend {
    /// Machine code compiled with Cranelift when the Hamiltonian is built (the default).
    /// Where the JIT cannot run (a host without a code generator), the interpreter is used
    /// instead and the reason recorded.
    #[default]
    Jit,
    /// [`Program::eval`], the engine's interpreter: the reference the JIT is tested against.
    /// It allocates its result on every call.
    Interpreter,
}

/// One [`Function`] ready to run.
#[derive(Debug)]
pub(crate) struct Compiled {
    function: Function,
    runner: Runner,
    dim: usize,
    params: usize,
    /// Where each output is written (its first place), to check finiteness.
    written: Vec<(usize, Output)>,
    /// `true` when the program writes every entry of its buffer; otherwise the buffer is
    /// zeroed first (entries a program does not compute are zero).
    dense: bool,
}

#[derive(Debug)]
enum Runner {
    Jit(JitFunction),
    Interpreter(Program),
}

impl Compiled {
    /// Compiles `programs` (checked with [`jit::check`]) with `backend`. With
    /// [`Backend::Jit`], a failure of the JIT is returned beside interpreted functions.
    pub(crate) fn all(
        programs: Vec<(Function, Program)>,
        backend: Backend,
    ) -> Result<(Vec<Compiled>, Option<crate::JitError>), RuntimeError> {
        for (f, p) in &programs {
            jit::check(*f, p)?;
        }
        let (runners, fallback) = match backend {
            Backend::Interpreter => (None, None),
            Backend::Jit => {
                let refs: Vec<(Function, &Program)> =
                    programs.iter().map(|(f, p)| (*f, p)).collect();
                match jit::compile(&refs) {
                    Ok(code) => (Some(code), None),
                    Err(RuntimeError::Jit(e)) => (None, Some(e)),
                    Err(e) => return Err(e),
                }
            }
        };
        let mut code = runners.map(Vec::into_iter);
        let compiled = programs
            .into_iter()
            .map(|(function, program)| {
                let runner = match code.as_mut().and_then(Iterator::next) {
                    Some(f) => Runner::Jit(f),
                    None => Runner::Interpreter(program.clone()),
                };
                Compiled::new(function, &program, runner)
            })
            .collect();
        Ok((compiled, fallback))
    }

    fn new(function: Function, program: &Program, runner: Runner) -> Compiled {
        let d = program.dim;
        let mut written = Vec::with_capacity(program.outputs.len());
        let mut covered = 0;
        for &(o, _) in &program.outputs {
            if let Placement::At(a, b) = function.place(o, d) {
                written.push((a, o));
                covered += 1 + usize::from(b.is_some());
            }
        }
        Compiled {
            function,
            runner,
            dim: d,
            params: program.params,
            written,
            dense: covered == function.len(d),
        }
    }

    /// `true` when this function runs compiled code.
    pub(crate) fn is_jit(&self) -> bool {
        matches!(self.runner, Runner::Jit(_))
    }

    /// The compiled code this function runs, if it runs compiled code.
    pub(crate) fn jit(&self) -> Option<&JitFunction> {
        match &self.runner {
            Runner::Jit(f) => Some(f),
            Runner::Interpreter(_) => None,
        }
    }

    /// Runs at `z0`, `z1` (the same point for a one-point function) into `out`.
    pub(crate) fn run(
        &self,
        z0: &[f64],
        z1: &[f64],
        params: &[f64],
        out: &mut [f64],
    ) -> Result<(), RuntimeError> {
        let f = self.function;
        let names: (&str, &str) = if f.two_point() {
            ("z0", "z1")
        } else {
            ("z", "z")
        };
        for (what, expected, found) in [
            (names.0, self.dim, z0.len()),
            (names.1, self.dim, z1.len()),
            ("params", self.params, params.len()),
            ("out", f.len(self.dim), out.len()),
        ] {
            if found != expected {
                return Err(RuntimeError::WrongLength {
                    what,
                    expected,
                    found,
                });
            }
        }
        if !self.dense {
            out.fill(0.0);
        }
        match &self.runner {
            // SAFETY: the lengths were checked above against the program's, which `check`
            // verified the program respects.
            Runner::Jit(code) => unsafe { code.call(z0, z1, params, out) },
            Runner::Interpreter(p) => self.interpret(p, z0, z1, params, out)?,
        }
        // Every entry of `out` is an output or a zero written above: one pass over the
        // contiguous buffer (vectorised) decides, and only a failure looks for its output.
        if out.iter().all(|x| x.is_finite()) {
            return Ok(());
        }
        for &(at, output) in &self.written {
            if !out[at].is_finite() {
                return Err(RuntimeError::NonFinite {
                    what: f.name(),
                    output,
                    value: out[at],
                });
            }
        }
        Ok(())
    }

    /// [`Program::eval`] or [`Program::eval_pair`], its results placed as compiled code
    /// places them.
    fn interpret(
        &self,
        p: &Program,
        z0: &[f64],
        z1: &[f64],
        params: &[f64],
        out: &mut [f64],
    ) -> Result<(), RuntimeError> {
        let d = self.dim;
        let (one, two) = if self.function.two_point() {
            (None, Some(p.eval_pair(z0, z1, params)?))
        } else {
            (Some(p.eval(z0, params)?), None)
        };
        for &(o, _) in &p.outputs {
            let x = match (&one, &two) {
                (Some(e), _) => output(e, o, d),
                (_, Some(e)) => pair_output(e, o),
                (None, None) => 0.0,
            };
            if let Placement::At(a, b) = self.function.place(o, d) {
                out[a] = x;
                if let Some(b) = b {
                    out[b] = x;
                }
            }
        }
        Ok(())
    }
}

/// Output `o` of a one-point evaluation (0 for outputs it does not hold).
fn output(e: &Evaluation, o: Output, d: usize) -> f64 {
    match o {
        Output::Value => e.value,
        Output::Gradient(i) => e.gradient[i],
        Output::Hessian(i, j) => e.hessian[i * d + j],
        Output::Psi => e.psi,
        _ => 0.0,
    }
}

/// Output `o` of a two-point evaluation (0 for outputs it does not hold).
fn pair_output(e: &PairEvaluation, o: Output) -> f64 {
    match o {
        Output::DiscreteGradient(i) => e.discrete_gradient[i],
        Output::EnergyDifference => e.energy_difference,
        Output::DiscreteGradientDefect(i) => e.discrete_gradient_defect[i],
        _ => 0.0,
    }
}
