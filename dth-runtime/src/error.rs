//! The errors of the run-time path: the expression's (the engine's, with their spans), the
//! parameters', the JIT's, and those of an evaluation.

use dth_symbolic::{Errors, EvalError, Output};
use thiserror::Error;

/// Why the JIT could not compile a program. [`crate::Backend::Jit`] falls back to the
/// interpreter on any of these and records it ([`crate::RuntimeHamiltonian::fallback_reason`]).
#[derive(Clone, Debug, PartialEq, Eq, Error)]
#[non_exhaustive]
pub enum JitError {
    /// Cranelift has no code generator for this machine.
    #[error("no native code generator for this host: {reason}")]
    UnsupportedHost {
        /// Cranelift's reason.
        reason: String,
    },
    /// A code-generator setting was refused (a Cranelift version mismatch).
    #[error("code generator setting `{name}` refused: {reason}")]
    Setting {
        /// The setting.
        name: &'static str,
        /// Cranelift's reason.
        reason: String,
    },
    /// Cranelift failed while compiling or linking.
    #[error("Cranelift failed on the {what} program: {reason}")]
    Codegen {
        /// Which program ([`crate::Function::name`]).
        what: &'static str,
        /// Cranelift's message.
        reason: String,
    },
    /// Cranelift panicked; the panic was caught and nothing of the module is used.
    #[error("Cranelift panicked on the {what} program: {reason}")]
    Panicked {
        /// Which program.
        what: &'static str,
        /// The panic message.
        reason: String,
    },
}

/// What went wrong building or evaluating a [`crate::RuntimeHamiltonian`].
#[derive(Clone, Debug, PartialEq, Error)]
#[non_exhaustive]
pub enum RuntimeError {
    /// The expression does not compile: every independent error, each with the byte range of
    /// the offending token in the source text and the message `hamiltonian!` gives.
    #[error("{0}")]
    Expression(Errors),
    /// A parameter was given a value but the expression never names it (a typo, or a
    /// parameter of another model).
    #[error("unknown parameter `{name}`: the Hamiltonian does not use it")]
    UnknownParameter {
        /// The name given.
        name: String,
    },
    /// A parameter value is NaN or infinite.
    #[error("parameter `{name}` = {value} is not finite")]
    NonFiniteParameter {
        /// The name.
        name: String,
        /// The value given.
        value: f64,
    },
    /// The JIT failed (from [`crate::jit::compile`]; [`crate::RuntimeHamiltonian`] falls back
    /// to the interpreter instead and records it).
    #[error("{0}")]
    Jit(#[from] JitError),
    /// A program computes an output this crate does not know where to put (the engine grew a
    /// new kind of output): it is refused rather than dropped.
    #[error("the {what} program has an output this crate cannot place: {output:?}")]
    UnsupportedOutput {
        /// Which program.
        what: &'static str,
        /// The output.
        output: Output,
    },
    /// A program is not well formed (an operand after its use, an input out of range): it
    /// is refused before any code is run, since compiled code would read out of bounds.
    #[error("malformed {what} program: {reason}")]
    MalformedProgram {
        /// Which program.
        what: &'static str,
        /// What is wrong.
        reason: String,
    },
    /// The interpreter refused to run (its own check of the lengths).
    #[error("interpreter: {0}")]
    Interpreter(#[from] EvalError),
    /// A slice passed to an evaluation has the wrong length.
    #[error("`{what}` has length {found}, expected {expected}")]
    WrongLength {
        /// `"z"`, `"z0"`, `"z1"`, `"low"` or `"out"`.
        what: &'static str,
        /// The length needed.
        expected: usize,
        /// The length given.
        found: usize,
    },
    /// The text's dimension is not the `D` a [`crate::Typed`] view names.
    #[error("the Hamiltonian has dimension D = {found}, the type names D = {expected}")]
    DimensionMismatch {
        /// The type's `D`.
        expected: usize,
        /// The text's: `2n`, or `2n + 2` when it uses `t`.
        found: usize,
    },
    /// A flag a [`crate::Typed`] view declares at compile time contradicts what the engine
    /// derived from the text.
    #[error("the type declares {flag} = {declared}, but the Hamiltonian's is {derived}")]
    FlagMismatch {
        /// The view's const parameter (`TIME_DEPENDENT`, `SEPARABLE`) or the flag
        /// `PSI_IDENTICALLY_ZERO` a [`crate::Typed`] view may not have.
        flag: &'static str,
        /// The view's value.
        declared: bool,
        /// The text's.
        derived: bool,
    },
    /// An evaluation produced NaN or an infinity (outside the domain of `ln`, `sqrt`, a
    /// negative power at 0, an overflow).
    #[error("the {what} is not finite at this point: {output:?} = {value}")]
    NonFinite {
        /// Which method ([`crate::Function::name`]).
        what: &'static str,
        /// The first output found non-finite.
        output: Output,
        /// Its value.
        value: f64,
    },
    /// A physical-state operation ([`crate::RuntimeHamiltonian::physical_energy_slice`]) on a
    /// Hamiltonian that is not a regularization, whose states are already physical.
    #[error("not a regularization: its own value is the physical energy (use value_double_double_slice)")]
    NotRegularized,
}

/// `?` from the run-time path into `dth_core::Error` (the one error type of the `dth` crates):
/// [`dth_core::Error::Hamiltonian`], which displays as this error and gives it back with
/// `downcast_ref`.
///
/// ```
/// use dth_core::Error;
/// use dth_runtime::{RuntimeError, RuntimeHamiltonian};
///
/// fn build(text: &str) -> Result<RuntimeHamiltonian, Error> {
///     Ok(RuntimeHamiltonian::new(text, &[])?)
/// }
/// let err = build("p1^2 + x1").unwrap_err();
/// let Error::Hamiltonian(shared) = &err else { panic!("{err:?}") };
/// assert!(matches!(shared.downcast_ref::<RuntimeError>(), Some(RuntimeError::Expression(_))));
/// assert!(err.to_string().starts_with("unknown variable `x1`"));
/// ```
impl From<RuntimeError> for dth_core::Error {
    fn from(error: RuntimeError) -> Self {
        dth_core::Error::Hamiltonian(dth_core::error::SharedError::new(error))
    }
}

/// `?` from the JIT into `dth_core::Error`: as the [`RuntimeError::Jit`] it is.
impl From<JitError> for dth_core::Error {
    fn from(error: JitError) -> Self {
        RuntimeError::Jit(error).into()
    }
}
