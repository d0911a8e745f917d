//! [`RuntimeHamiltonian`]: a Hamiltonian read from text, its derivatives compiled when it is
//! built, evaluated into buffers the caller owns.

use dth_symbolic::double_double::Dd;
use dth_symbolic::lexer::{lex, TokenKind};
use dth_symbolic::looped::{self, Looped};
use dth_symbolic::{Method, Output, Program, System};

use crate::backend::{Backend, Compiled};
use crate::error::{JitError, RuntimeError};
use crate::layout::Function;
use crate::looped::Lattice;

/// A Hamiltonian given as text in the grammar of `hamiltonian!`, with parameter values: the
/// engine derives its gradient, Hessian, Psi and discrete gradients, and every method runs
/// as machine code compiled when it is built ([`Backend::Jit`]).
///
/// Its own evaluations take `&[f64]` points and write into `&mut [f64]` buffers the caller
/// owns, and check the lengths (`value_slice`, `gradient_slice`, ...: named apart from the
/// [`Hamiltonian`](dth_core::Hamiltonian) trait's `value`, `gradient`, ..., which take
/// nalgebra vectors, so that with the trait in scope `h.value(&z)` is the trait's). With the
/// JIT, nothing is allocated per call, and each call is one call of compiled code. The
/// layout of `z` is the macro's: `(q1..qn, p1..pn)`, or `(q1..qn, t, p1..pn, p_t)` with
/// `value = p_t + H` when `H` uses `t`.
///
/// ```
/// use dth_runtime::RuntimeHamiltonian;
///
/// let kepler = RuntimeHamiltonian::new(
///     "(p1^2 + p2^2)/(2*m) - k*(q1^2 + q2^2)^(-1/2)",
///     &[("m", 0.5), ("k", 1.0)],
/// )?;
/// assert_eq!((kepler.dimension(), kepler.separable()), (4, true));
/// let z = [0.5, 0.0, 0.0, 1.2];
/// assert!((kepler.value_slice(&z)? - (1.44 - 2.0)).abs() < 1e-15);
/// let mut g = [0.0; 4];
/// kepler.gradient_slice(&z, &mut g)?;
/// assert_eq!(g, [4.0, 0.0, 0.0, 2.4]); // (q/|q|^3, p/m)
///
/// // A parameter the expression does not use, a mistake in the text: typed errors.
/// assert!(RuntimeHamiltonian::new("p1^2/2 + q1^2/2", &[("m", 1.0)]).is_err());
/// let err = RuntimeHamiltonian::new("p1^2 + x1", &[]).unwrap_err();
/// assert_eq!(err.to_string(),
///     "unknown variable `x1`: expected q1..qN, p1..pN, t, or a declared parameter (bytes 7..9)");
/// # Ok::<(), dth_runtime::RuntimeError>(())
/// ```
#[derive(Debug)]
pub struct RuntimeHamiltonian {
    form: Form,
    names: Vec<String>,
    values: Vec<f64>,
    fallback: Option<JitError>,
    /// The engine's flags, read once: the stepper asks for them inside its Newton loop, and
    /// [`System::separable`] scans the Hessian's nonzeros.
    separable: bool,
    psi_identically_zero: bool,
    /// `Flags::structured_newton`, decided as for the macro's types.
    structured_newton: bool,
}

/// How the text was compiled: written out site by site, or a lattice in loops.
#[derive(Debug)]
enum Form {
    /// One straight-line program per function.
    Written {
        /// Boxed, as the lattice: the variants' sizes stay alike.
        system: Box<System>,
        /// One per [`Function`], in the order of [`Function::ALL`].
        functions: Vec<Compiled>,
        /// A regularization's gradient program, which
        /// [`RuntimeHamiltonian::gradient_double_double_slice`] interprets in double-double
        /// (`None` for any other system).
        gradient: Option<Program>,
    },
    /// A lattice whose sums loop, compiled as the macro compiles it (boxed: it is large).
    Looped(Box<Lattice>),
}

// One Hamiltonian serves every thread of an ensemble: compiled code is immutable and
// reentrant (checked here, at compile time).
const _: fn() = || {
    fn shareable<T: Send + Sync>() {}
    shareable::<RuntimeHamiltonian>();
};

/// The value, gradient, Hessian and Psi of one [`RuntimeHamiltonian::derivatives_slice`] call, in
/// one buffer reused from call to call.
#[derive(Clone, Debug, PartialEq)]
pub struct Derivatives {
    dim: usize,
    /// `value, gradient (D), Hessian (D x D, row-major), psi`.
    buffer: Vec<f64>,
}

impl Derivatives {
    /// A zeroed buffer for dimension `dim`.
    pub fn new(dim: usize) -> Self {
        Derivatives {
            dim,
            buffer: vec![0.0; Function::Derivatives.len(dim)],
        }
    }

    /// `H(z)`.
    pub fn value(&self) -> f64 {
        self.buffer[0]
    }

    /// `grad H(z)`, length `D`.
    pub fn gradient(&self) -> &[f64] {
        &self.buffer[1..1 + self.dim]
    }

    /// `Hess H(z)`, `D x D` row-major, both triangles.
    pub fn hessian(&self) -> &[f64] {
        &self.buffer[1 + self.dim..1 + self.dim + self.dim * self.dim]
    }

    /// `Psi(z)`.
    pub fn psi(&self) -> f64 {
        self.buffer[1 + self.dim + self.dim * self.dim]
    }
}

impl RuntimeHamiltonian {
    /// Compiles `src` with the parameters `params` (name and value) to machine code. Errors:
    /// the expression's ([`RuntimeError::Expression`], the messages and token positions of
    /// `hamiltonian!`; a parameter the text uses but `params` lacks is an unknown variable
    /// there), a parameter given but not used ([`RuntimeError::UnknownParameter`]) or not
    /// finite. If the JIT cannot run here, the interpreter is used
    /// ([`RuntimeHamiltonian::fallback_reason`] says why).
    pub fn new(src: &str, params: &[(&str, f64)]) -> Result<Self, RuntimeError> {
        Self::with_backend(src, params, Backend::Jit)
    }

    /// [`RuntimeHamiltonian::new`] with the choice of [`Backend`].
    pub fn with_backend(
        src: &str,
        params: &[(&str, f64)],
        backend: Backend,
    ) -> Result<Self, RuntimeError> {
        let names: Vec<&str> = params.iter().map(|&(n, _)| n).collect();
        // A lattice whose sums loop is compiled in loops, exactly when the macro would;
        // everything else (errors included) site by site, as before.
        let text = match looped::loops(src, &names) {
            Some(lattice) => Err(lattice),
            None => Ok(dth_symbolic::compile(src, &names).map_err(RuntimeError::Expression)?),
        };
        Self::from_text(text, src, params, backend)
    }

    /// The Levi-Civita regularization of the planar Hamiltonian `src`
    /// (`dth_symbolic::regularize`): `K = |u|^2 (H + p_t)` on `z = (u1, u2, t, P1, P2, p_t)`,
    /// compiled as [`RuntimeHamiltonian::new`] compiles `H`. Its flags say `regularized`: the
    /// DTH stepper reports the `t` coordinate as each midpoint's time. Map a physical state to
    /// its start with `dth::regularize::LeviCivita`.
    ///
    /// # Errors
    /// As [`RuntimeHamiltonian::new`], and [`RuntimeError::Expression`] with
    /// `ErrorKind::CannotRegularize` for a Hamiltonian that is not planar or uses `t`.
    pub fn levi_civita(src: &str, params: &[(&str, f64)]) -> Result<Self, RuntimeError> {
        Self::compile_regularized(src, params, dth_symbolic::regularize::levi_civita)
    }

    /// The Kustaanheimo-Stiefel regularization of the spatial Hamiltonian `src`:
    /// `K = |u|^2 (H + p_t)` on `z = (u1..u4, t, P1..P4, p_t)`, as
    /// [`RuntimeHamiltonian::levi_civita`] (states through
    /// `dth::regularize::KustaanheimoStiefel`).
    ///
    /// # Errors
    /// As [`RuntimeHamiltonian::levi_civita`], for more than three degrees of freedom.
    pub fn kustaanheimo_stiefel(src: &str, params: &[(&str, f64)]) -> Result<Self, RuntimeError> {
        Self::compile_regularized(src, params, dth_symbolic::regularize::kustaanheimo_stiefel)
    }

    /// `src` regularized by `regularize` (an engine function of `dth_symbolic::regularize`).
    fn compile_regularized(
        src: &str,
        params: &[(&str, f64)],
        regularize: fn(&str, &[&str]) -> Result<System, dth_symbolic::Errors>,
    ) -> Result<Self, RuntimeError> {
        let names: Vec<&str> = params.iter().map(|&(n, _)| n).collect();
        let system = regularize(src, &names).map_err(RuntimeError::Expression)?;
        Self::from_text(Ok(system), src, params, Backend::Jit)
    }

    /// The compiled text `src` (`Ok`: the system written out; `Err`: the lattice in loops),
    /// with the parameters `params` checked against the text.
    fn from_text(
        text: Result<System, Looped>,
        src: &str,
        params: &[(&str, f64)],
        backend: Backend,
    ) -> Result<Self, RuntimeError> {
        let names: Vec<&str> = params.iter().map(|&(n, _)| n).collect();
        let (tokens, _) = lex(src);
        for &(name, value) in params {
            let named = tokens
                .iter()
                .any(|t| t.kind == TokenKind::Ident && &src[t.span.range()] == name);
            if !named {
                return Err(RuntimeError::UnknownParameter {
                    name: name.to_string(),
                });
            }
            if !value.is_finite() {
                return Err(RuntimeError::NonFiniteParameter {
                    name: name.to_string(),
                    value,
                });
            }
        }
        let names = names.iter().map(|n| n.to_string()).collect();
        let values = params.iter().map(|&(_, v)| v).collect();
        // `Ok`: the system written out; `Err`: the lattice in loops.
        let system = match text {
            Ok(system) => system,
            Err(lattice) => return Self::from_lattice(lattice, names, values, backend),
        };
        let programs = Function::ALL
            .iter()
            .map(|&f| Ok((f, f.program(&system)?)))
            .collect::<Result<Vec<_>, RuntimeError>>()?;
        let (functions, fallback) = Compiled::all(programs, backend)?;
        let gradient = system
            .physical_value()
            .map(|_| system.program(Method::Gradient));
        Ok(RuntimeHamiltonian {
            separable: system.separable(),
            psi_identically_zero: system.psi_identically_zero(),
            structured_newton: false,
            form: Form::Written {
                system: Box::new(system),
                functions,
                gradient,
            },
            names,
            values,
            fallback,
        })
    }

    /// A lattice in loops: its flags as the macro's looped type sets them.
    fn from_lattice(
        lattice: Looped,
        names: Vec<String>,
        values: Vec<f64>,
        backend: Backend,
    ) -> Result<Self, RuntimeError> {
        let (separable, psi_identically_zero) = lattice.flags();
        let (lattice, fallback) = Lattice::new(lattice, values.len(), backend)?;
        let structured_newton = dth_symbolic::solver::structured_newton(
            lattice.looped().dim(),
            lattice.pattern().len(),
            lattice.diagonal(),
            separable,
        );
        Ok(RuntimeHamiltonian {
            form: Form::Looped(Box::new(lattice)),
            names,
            values,
            fallback,
            separable,
            psi_identically_zero,
            structured_newton,
        })
    }

    /// Runs `f` at `z0`, `z1` (the same point for a one-point function) into `out`.
    pub(crate) fn run(
        &self,
        f: Function,
        z0: &[f64],
        z1: &[f64],
        out: &mut [f64],
    ) -> Result<(), RuntimeError> {
        match &self.form {
            // `functions` follows `Function::ALL`, whose order is the enum's.
            Form::Written { functions, .. } => functions[f as usize].run(z0, z1, &self.values, out),
            Form::Looped(lattice) => lattice.run(f, z0, z1, &self.values, out),
        }
    }

    /// The phase-space dimension `D`: `2n`, or `2n + 2` when time-dependent. (Named apart from
    /// the [`Hamiltonian`](dth_core::Hamiltonian) trait's `dim()`, which is `Dyn` of it, so
    /// that `h.dim()` means one thing whatever the receiver.)
    pub fn dimension(&self) -> usize {
        match &self.form {
            Form::Written { system, .. } => system.dim(),
            Form::Looped(lattice) => lattice.looped().dim(),
        }
    }

    /// The degrees of freedom `n` (the largest index in the text).
    pub fn degrees_of_freedom(&self) -> usize {
        match &self.form {
            Form::Written { system, .. } => system.n(),
            Form::Looped(lattice) => lattice.looped().n(),
        }
    }

    /// `true` when `H = T(p) + V(q)`.
    pub fn separable(&self) -> bool {
        self.separable
    }

    /// `true` when `H` uses `t`: `z` is extended with `t` and `p_t`.
    pub fn time_dependent(&self) -> bool {
        match &self.form {
            Form::Written { system, .. } => system.time_dependent(),
            // A lattice that loops does not read `t` (`dth_symbolic::looped`).
            Form::Looped(_) => false,
        }
    }

    /// `true` for a regularization's `K` ([`RuntimeHamiltonian::levi_civita`]).
    pub fn regularized(&self) -> bool {
        match &self.form {
            Form::Written { system, .. } => system.regularized(),
            // A lattice is never a regularization.
            Form::Looped(_) => false,
        }
    }

    /// `true` when Psi simplifies to 0 (DTH's energy condition then does not determine the
    /// step).
    pub fn psi_identically_zero(&self) -> bool {
        self.psi_identically_zero
    }

    /// The backend running the programs: [`Backend::Jit`] unless the interpreter was asked
    /// for or the JIT failed.
    pub fn backend(&self) -> Backend {
        let jit = match &self.form {
            Form::Written { functions, .. } => functions.iter().all(Compiled::is_jit),
            Form::Looped(lattice) => lattice.is_jit(),
        };
        if jit {
            Backend::Jit
        } else {
            Backend::Interpreter
        }
    }

    /// The bytes of machine code the JIT compiled for this Hamiltonian (every function);
    /// `None` when the interpreter runs. A lattice whose sums loop compiles the same code at
    /// every size (but for the width of the constants that hold its sizes).
    ///
    /// ```
    /// use dth_runtime::RuntimeHamiltonian;
    /// let chain = |n: usize| {
    ///     RuntimeHamiltonian::new(
    ///         &format!("sum(i = 1..N, p[i]^2/2 + (q[i+1] - q[i])^4/4) where N = {n}, q[N+1] = 0"),
    ///         &[],
    ///     )
    /// };
    /// let small = chain(64)?.code_bytes().unwrap_or(0);
    /// let large = chain(4096)?.code_bytes().unwrap_or(0);
    /// // The same code: only the sites' counts in its instructions are wider.
    /// assert!(small > 0 && large.abs_diff(small) * 100 <= small);
    /// # Ok::<(), dth_runtime::RuntimeError>(())
    /// ```
    pub fn code_bytes(&self) -> Option<usize> {
        if self.backend() != Backend::Jit {
            return None;
        }
        Some(match &self.form {
            Form::Written { functions, .. } => {
                crate::jit::code_bytes(functions.iter().filter_map(Compiled::jit))
            }
            Form::Looped(lattice) => crate::jit::code_bytes(lattice.jit()),
        })
    }

    /// Why the JIT was asked for but the interpreter runs.
    pub fn fallback_reason(&self) -> Option<&JitError> {
        self.fallback.as_ref()
    }

    /// What looks like a mistake in the text without being an error (a position without its
    /// momentum, a misnumbered index): the warnings `hamiltonian!` gives, with their spans.
    pub fn warnings(&self) -> &[dth_symbolic::Warning] {
        match &self.form {
            Form::Written { system, .. } => system.warnings(),
            Form::Looped(lattice) => lattice.looped().warnings(),
        }
    }

    /// The compiled symbolic system (expressions of the derivatives, programs) of a text
    /// written out site by site; `None` for a lattice compiled in loops
    /// ([`RuntimeHamiltonian::looped`]), which has one system per summand.
    pub fn system(&self) -> Option<&System> {
        match &self.form {
            Form::Written { system, .. } => Some(system.as_ref()),
            Form::Looped(_) => None,
        }
    }

    /// The lattice, when the text is a lattice whose sums loop: compiled as
    /// `hamiltonian!` compiles it (one program per summand and a loop over the sites, code
    /// that does not grow with the number of sites), with the macro's bits, its Hessian
    /// pattern and the structured Newton solver. `None` for a text written out site by site.
    ///
    /// ```
    /// use dth_runtime::RuntimeHamiltonian;
    /// let chain = RuntimeHamiltonian::new(
    ///     "sum(i = 1..N, p[i]^2/2) + sum(i = 0..N, (q[i+1] - q[i])^2/2 + b*(q[i+1] - q[i])^4/4) \
    ///      where N = 4096, q[0] = q[N+1] = 0",
    ///     &[("b", 1.0)],
    /// )?;
    /// assert_eq!(chain.looped().map(|l| l.n()), Some(4096));
    /// assert_eq!(chain.hessian_pattern().map(<[_]>::len), Some(3 * 4096 - 1));
    /// assert!(chain.structured_newton());
    /// # Ok::<(), dth_runtime::RuntimeError>(())
    /// ```
    pub fn looped(&self) -> Option<&Looped> {
        match &self.form {
            Form::Written { .. } => None,
            Form::Looped(lattice) => Some(lattice.looped()),
        }
    }

    /// The Hessian's nonzero entries `(i, j)`, `i <= j`, in the order
    /// [`RuntimeHamiltonian::hessian_nonzeros_slice`] writes them (the macro's looped type's
    /// pattern); `None` for a text written out site by site.
    pub fn hessian_pattern(&self) -> Option<&[(usize, usize)]> {
        match &self.form {
            Form::Written { .. } => None,
            Form::Looped(lattice) => Some(lattice.pattern()),
        }
    }

    /// The Hessian's entries at [`RuntimeHamiltonian::hessian_pattern`] into `values` (as long
    /// as the pattern). A text without a pattern (written out site by site) writes nothing.
    pub fn hessian_nonzeros_slice(
        &self,
        z: &[f64],
        values: &mut [f64],
    ) -> Result<(), RuntimeError> {
        match &self.form {
            Form::Written { .. } => Ok(()),
            Form::Looped(lattice) => lattice.nonzeros(z, &self.values, values),
        }
    }

    /// Whether the implicit methods should solve their Newton systems with the structured
    /// solver on the Hessian's pattern (`dth_core::Flags::structured_newton`): decided as for
    /// the macro's types, `false` without a pattern.
    pub fn structured_newton(&self) -> bool {
        self.structured_newton
    }

    /// The parameters, by name, in the order given.
    pub fn parameters(&self) -> impl Iterator<Item = (&str, f64)> {
        self.names
            .iter()
            .map(String::as_str)
            .zip(self.values.iter().copied())
    }

    /// Sets the value of parameter `name` (no recompilation: values are read at each call).
    pub fn set_parameter(&mut self, name: &str, value: f64) -> Result<(), RuntimeError> {
        let k = self.names.iter().position(|n| n == name).ok_or_else(|| {
            RuntimeError::UnknownParameter {
                name: name.to_string(),
            }
        })?;
        if !value.is_finite() {
            return Err(RuntimeError::NonFiniteParameter {
                name: name.to_string(),
                value,
            });
        }
        self.values[k] = value;
        Ok(())
    }

    /// `H(z)` (`p_t + H` when time-dependent).
    pub fn value_slice(&self, z: &[f64]) -> Result<f64, RuntimeError> {
        let mut out = [0.0];
        self.run(Function::Value, z, z, &mut out)?;
        Ok(out[0])
    }

    /// `H(z)` in double-double arithmetic, rounded once: the start's energy of a regularized
    /// run, whose period follows it (see `dth_core::regularize`). Where `H(z)` is a small
    /// difference of large terms (Kepler near the pericentre of an eccentric orbit) this keeps
    /// the digits [`RuntimeHamiltonian::value_slice`] loses (three of `E` at e = 0.999); see
    /// [`dth_symbolic::Program::value_double_double`] for what is carried (functions stay in
    /// doubles). A lattice in loops is evaluated as `value_slice` does.
    ///
    /// ```
    /// use dth_runtime::RuntimeHamiltonian;
    /// let kepler = RuntimeHamiltonian::new("p1^2 + p2^2 - (q1^2 + q2^2)^(-1/2)", &[])?;
    /// let p = 1.999f64.sqrt(); // e = 0.999 at the pericentre r = 0.5
    /// let energy = kepler.value_double_double_slice(&[0.5, 0.0, 0.0, p])?;
    /// assert_eq!(energy, p.mul_add(p, -2.0)); // E = p^2 - 2 rounded once
    /// # Ok::<(), dth_runtime::RuntimeError>(())
    /// ```
    ///
    /// # Errors
    /// [`RuntimeError::Interpreter`] for a `z` of the wrong length (and for a lattice, as
    /// `value_slice`). The value's program is lowered again for it (a run start's one
    /// evaluation; a `RuntimeHamiltonian` keeps only the compiled functions).
    pub fn value_double_double_slice(&self, z: &[f64]) -> Result<f64, RuntimeError> {
        match &self.form {
            Form::Written { system, .. } => Ok(system
                .program(Method::Value)
                .value_double_double(z, &self.values)?),
            Form::Looped(_) => self.value_slice(z),
        }
    }

    /// For a regularization's `K` ([`RuntimeHamiltonian::levi_civita`],
    /// [`RuntimeHamiltonian::kustaanheimo_stiefel`]), the physical Hamiltonian `H(q, p)` of the
    /// text at `z = (q, p)` (length 4 in the plane, 6 in space) in double-double, rounded once
    /// ([`dth_symbolic::Program::value_double_double`]): the energy a regularized run starts
    /// from (`p_t = -H`, which sets a Kepler orbit's period; see `dth_core::regularize`).
    ///
    /// ```
    /// use dth_runtime::RuntimeHamiltonian;
    /// let k = RuntimeHamiltonian::levi_civita("p1^2 + p2^2 - (q1^2 + q2^2)^(-1/2)", &[])?;
    /// let p = 1.999f64.sqrt(); // e = 0.999 at the pericentre r = 0.5
    /// assert_eq!(k.physical_energy_slice(&[0.5, 0.0, 0.0, p])?, p.mul_add(p, -2.0));
    /// # Ok::<(), dth_runtime::RuntimeError>(())
    /// ```
    ///
    /// # Errors
    /// [`RuntimeError::NotRegularized`] for a Hamiltonian that is not a regularization;
    /// [`RuntimeError::Interpreter`] for a `z` of the wrong length.
    pub fn physical_energy_slice(&self, z: &[f64]) -> Result<f64, RuntimeError> {
        let (hi, lo) = self.physical_energy_double_double_slice(z)?;
        Ok(hi + lo)
    }

    /// [`RuntimeHamiltonian::physical_energy_slice`] before its rounding: `(hi, lo)`, the
    /// energy `hi + lo` in double-double (the start of a run solved in double-double,
    /// `dth_core::regularize::LeviCivita::start_double_double`).
    ///
    /// # Errors
    /// As [`RuntimeHamiltonian::physical_energy_slice`].
    pub fn physical_energy_double_double_slice(
        &self,
        z: &[f64],
    ) -> Result<(f64, f64), RuntimeError> {
        let physical = match &self.form {
            Form::Written { system, .. } => system.physical_value(),
            Form::Looped(_) => None,
        };
        let physical = physical.ok_or(RuntimeError::NotRegularized)?;
        let energy = physical.value_in_double_double(z, &self.values)?;
        Ok((energy.hi, energy.lo))
    }

    /// A regularization's `grad K` at `hi + lo` in double-double, into `out_hi + out_lo` (all
    /// of length `D`): the interpreter's double-double run of `K`'s gradient program (what
    /// is carried: [`dth_symbolic::Program::value_double_double`]), the operations of the
    /// `hamiltonian!` type's `gradient_double_double_into` in the same order, so the same
    /// bits. A DTH run started in double-double solves its steps with it
    /// (`dth_core::dth::Dth::with_low`). Its scratch is one buffer per thread, kept: nothing
    /// is allocated per call after a thread's first.
    ///
    /// # Errors
    /// [`RuntimeError::NotRegularized`] when the text is not a regularization;
    /// [`RuntimeError::WrongLength`] for a slice of another length.
    pub fn gradient_double_double_slice(
        &self,
        (hi, lo): (&[f64], &[f64]),
        (out_hi, out_lo): (&mut [f64], &mut [f64]),
    ) -> Result<(), RuntimeError> {
        let Form::Written {
            gradient: Some(program),
            ..
        } = &self.form
        else {
            return Err(RuntimeError::NotRegularized);
        };
        let d = program.dim;
        let lengths = [
            ("z", hi.len()),
            ("low", lo.len()),
            ("out", out_hi.len()),
            ("out", out_lo.len()),
        ];
        if let Some(&(what, found)) = lengths.iter().find(|&&(_, n)| n != d) {
            return Err(RuntimeError::WrongLength {
                what,
                expected: d,
                found,
            });
        }
        thread_local! {
            static SLOTS: std::cell::RefCell<Vec<Dd>> = const { std::cell::RefCell::new(Vec::new()) };
        }
        SLOTS.with_borrow_mut(|v| {
            let point = |k: usize| Dd {
                hi: hi[k],
                lo: lo[k],
            };
            program.run_double_double_into((point, point), &self.values, v);
            out_hi.fill(0.0);
            out_lo.fill(0.0);
            for &(output, s) in &program.outputs {
                if let Output::Gradient(i) = output {
                    (out_hi[i], out_lo[i]) = (v[s as usize].hi, v[s as usize].lo);
                }
            }
        });
        Ok(())
    }

    /// `grad H(z)` into `out` (length `D`).
    pub fn gradient_slice(&self, z: &[f64], out: &mut [f64]) -> Result<(), RuntimeError> {
        self.run(Function::Gradient, z, z, out)
    }

    /// `Hess H(z)` into `out` (`D x D`, row-major, both triangles).
    pub fn hessian_slice(&self, z: &[f64], out: &mut [f64]) -> Result<(), RuntimeError> {
        self.run(Function::Hessian, z, z, out)
    }

    /// `Psi(z) = (J grad H)^T Hess H (J grad H)`.
    pub fn psi_slice(&self, z: &[f64]) -> Result<f64, RuntimeError> {
        let mut out = [0.0];
        self.run(Function::Psi, z, z, &mut out)?;
        Ok(out[0])
    }

    /// A buffer for [`RuntimeHamiltonian::derivatives_slice`].
    pub fn derivatives_buffer(&self) -> Derivatives {
        Derivatives::new(self.dimension())
    }

    /// Value, gradient, Hessian and Psi from one fused program (every common subexpression
    /// computed once) into `out`, a buffer of this dimension.
    pub fn derivatives_slice(&self, z: &[f64], out: &mut Derivatives) -> Result<(), RuntimeError> {
        self.run(Function::Derivatives, z, z, &mut out.buffer)
    }

    /// The exact discrete gradient `gbar(z0, z1)` into `out` (length `D`): divided
    /// differences without cancellation, `gbar . (z1 - z0) = H(z1) - H(z0)`.
    pub fn discrete_gradient_slice(
        &self,
        z0: &[f64],
        z1: &[f64],
        out: &mut [f64],
    ) -> Result<(), RuntimeError> {
        self.run(Function::DiscreteGradient, z0, z1, out)
    }

    /// `H(z1) - H(z0)`, computed without cancellation.
    pub fn energy_difference_slice(&self, z0: &[f64], z1: &[f64]) -> Result<f64, RuntimeError> {
        let mut out = [0.0];
        self.run(Function::EnergyDifference, z0, z1, &mut out)?;
        Ok(out[0])
    }

    /// The defect `grad H(z0) + grad H(z1) - 2 gbar(z0, z1)` into `out` (length `D`),
    /// computed without cancellation.
    pub fn discrete_gradient_defect_slice(
        &self,
        z0: &[f64],
        z1: &[f64],
        out: &mut [f64],
    ) -> Result<(), RuntimeError> {
        self.run(Function::DiscreteGradientDefect, z0, z1, out)
    }
}
