//! The crate's one error type.

use thiserror::Error;

/// Everything that can go wrong in `dth-core`. Variants carry the data needed to act on them;
/// match on variants (`matches!`), never on the message text.
#[derive(Debug, Clone, PartialEq, Error)]
#[non_exhaustive]
pub enum Error {
    /// An option is outside its valid range.
    #[error("invalid option `{name}` = {value}: {reason}")]
    InvalidOption {
        /// Option name, as in the options struct.
        name: &'static str,
        /// The rejected value.
        value: f64,
        /// The rule it breaks.
        reason: &'static str,
    },
    /// An initial state component (or parameter) is NaN or infinite.
    #[error("initial state component {index} is not finite ({value})")]
    NonFiniteInitialState {
        /// Index into `z`.
        index: usize,
        /// The offending value.
        value: f64,
    },
    /// A peer method's Newton iteration did not reach roundoff within the iteration limit (or
    /// diverged); `residual` is the infinity norm of the nonlinear residual at the last iterate.
    #[error("{method}: Newton did not converge at step {step} after {iterations} iterations (residual {residual:e})")]
    MethodNotConverged {
        /// The method's name ([`crate::methods::OneStepMethod::NAME`]).
        method: &'static str,
        /// Index of the failing step in a run (0 for a direct call to `step`).
        step: usize,
        /// Newton iterations performed.
        iterations: usize,
        /// Infinity norm of the residual at the last iterate.
        residual: f64,
    },
    /// A peer method's Newton matrix was singular.
    #[error("{method}: singular Newton matrix at step {step}, iteration {iteration} (residual {residual:e})")]
    MethodSingularMatrix {
        /// The method's name.
        method: &'static str,
        /// Index of the failing step in a run (0 for a direct call to `step`).
        step: usize,
        /// Newton iteration at which the solve failed (1-based).
        iteration: usize,
        /// Infinity norm of the residual at that iterate.
        residual: f64,
    },
    /// A peer method produced a NaN or infinite value.
    #[error("{method}: non-finite {what} at step {step}")]
    MethodNonFinite {
        /// The method's name.
        method: &'static str,
        /// Index of the failing step in a run (0 for a direct call to `step`).
        step: usize,
        /// What became non-finite (e.g. "state", "Newton residual").
        what: &'static str,
    },
    /// A method for separable Hamiltonians was given one whose `SEPARABLE` is `false`.
    #[error(
        "{method} needs a separable Hamiltonian H = T(p) + V(q) (Hamiltonian::SEPARABLE is false)"
    )]
    NotSeparable {
        /// The method's name.
        method: &'static str,
    },
    /// The exact Kepler solution was asked for an orbit that is not elliptic.
    #[error("Kepler orbit is not elliptic: energy {energy:e}, eccentricity {eccentricity}")]
    KeplerNotElliptic {
        /// `H(q, p)`; must be negative.
        energy: f64,
        /// Eccentricity; must be below 1.
        eccentricity: f64,
    },
}
