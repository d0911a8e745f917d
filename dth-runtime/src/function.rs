//! A function of a system's state written in the Hamiltonian's grammar ([`StateFunction`]),
//! compiled as a Hamiltonian's value is: what an event's condition, or any other quantity a
//! run watches, is evaluated with.

use dth_symbolic::{Error, ErrorKind, Errors, Node, Output, Program, Var};

use crate::backend::{Backend, Compiled};
use crate::error::RuntimeError;
use crate::layout::Function;

/// `f(t, q, p)` from text, for a system with `n` degrees of freedom, compiled to machine code
/// (the interpreter where the JIT cannot run). It reads the state in the system's layout:
/// `z = (q1..qn, p1..pn)` and the time `t` beside it, or the extended `z = (q1..qn, t, p1..pn,
/// p_t)` of a time-dependent system, whose time is its own coordinate.
///
/// ```
/// use dth_runtime::StateFunction;
/// let r = StateFunction::new("(q1^2 + q2^2)^(1/2) - r0", 2, false, &[("r0", 0.05)])?;
/// let mut scratch = Vec::new();
/// let v = r.value_at(0.0, &[3.0, 4.0, 0.0, 0.0], &mut scratch)?;
/// assert_eq!(v, 5.0 - 0.05);
/// // A coordinate the system does not have is an error at its name.
/// let e = StateFunction::new("q3", 2, false, &[]).unwrap_err();
/// assert!(e.to_string().contains("`q3` is not a coordinate of this system"), "{e}");
/// # Ok::<(), dth_runtime::RuntimeError>(())
/// ```
#[derive(Debug)]
pub struct StateFunction {
    compiled: Compiled,
    params: Vec<f64>,
    /// The state's dimension.
    dim: usize,
    /// `t` is a coordinate of the state.
    extended: bool,
}

impl StateFunction {
    /// Compiles `src` (any expression of the grammar in `q1..qn`, `p1..pn`, `t` and the
    /// parameters `params`) for a system of `n` degrees of freedom, time-dependent (the
    /// extended layout) or not.
    ///
    /// # Errors
    /// [`RuntimeError::Expression`] with every error of the text, each at its token (a
    /// coordinate beyond `n` is `ErrorKind::NotInSystem`); [`RuntimeError::NonFiniteParameter`].
    pub fn new(
        src: &str,
        n: usize,
        time_dependent: bool,
        params: &[(&str, f64)],
    ) -> Result<Self, RuntimeError> {
        if let Some(&(name, value)) = params.iter().find(|(_, v)| !v.is_finite()) {
            return Err(RuntimeError::NonFiniteParameter {
                name: name.to_string(),
                value,
            });
        }
        let names: Vec<&str> = params.iter().map(|&(name, _)| name).collect();
        let (arena, root, _) =
            dth_symbolic::expression(src, &names).map_err(RuntimeError::Expression)?;
        let n32 = u32::try_from(n).unwrap_or(u32::MAX);
        let mut errors = Vec::new();
        for id in arena.ids() {
            let name = match arena.node(id) {
                Node::Var(Var::Q(k)) if *k > n32 => format!("q{k}"),
                Node::Var(Var::P(k)) if *k > n32 => format!("p{k}"),
                _ => continue,
            };
            errors.push(Error::new(
                ErrorKind::NotInSystem { name, n: n32 },
                arena.span(id),
            ));
        }
        if !errors.is_empty() {
            errors.sort_by_key(|e| e.span.start);
            return Err(RuntimeError::Expression(Errors(errors)));
        }
        let mut coordinates: Vec<Var> = (1..=n32).map(Var::Q).collect();
        if time_dependent {
            coordinates.push(Var::T);
        }
        coordinates.extend((1..=n32).map(Var::P));
        if time_dependent {
            coordinates.push(Var::Pt);
        } else {
            // The time beside the state, as one more input.
            coordinates.push(Var::T);
        }
        let program = Program::lower(&arena, &coordinates, &[(Output::Value, root)]);
        let (mut compiled, _) = Compiled::all(vec![(Function::Value, program)], Backend::Jit)?;
        Ok(StateFunction {
            compiled: compiled.remove(0),
            params: params.iter().map(|&(_, v)| v).collect(),
            dim: 2 * n + if time_dependent { 2 } else { 0 },
            extended: time_dependent,
        })
    }

    /// Its value at the state `z` (the system's layout) at time `t` (a time-dependent system's
    /// is `z`'s own `t` coordinate, and this `t` is not read). `scratch` holds the state and
    /// the time side by side for an autonomous system (kept by the caller, so that a run
    /// evaluating the function at every step does not allocate).
    ///
    /// # Errors
    /// [`RuntimeError::WrongLength`] for a state of another length; [`RuntimeError::NonFinite`]
    /// where the value is not finite.
    pub fn value_at(&self, t: f64, z: &[f64], scratch: &mut Vec<f64>) -> Result<f64, RuntimeError> {
        if z.len() != self.dim {
            return Err(RuntimeError::WrongLength {
                what: "z",
                expected: self.dim,
                found: z.len(),
            });
        }
        let mut out = [0.0];
        if self.extended {
            self.compiled.run(z, z, &self.params, &mut out)?;
        } else {
            scratch.clear();
            scratch.extend_from_slice(z);
            scratch.push(t);
            self.compiled
                .run(scratch, scratch, &self.params, &mut out)?;
        }
        Ok(out[0])
    }
}
