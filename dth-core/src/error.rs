//! The crate's one error type, [`Error`](enum@Error), and [`RunError`], a failed run with what it computed.
//!
//! Every fallible call of the `dth` crates converts into [`Error`](enum@Error) with `?`: a [`RunError`]
//! (from `integrate`, `Dth::trajectory`, `methods::run`) gives up its partial result and
//! becomes its [`RunError::error`]; the errors of other crates become [`Error::Hamiltonian`]
//! (a Hamiltonian read from text: `dth_runtime::RuntimeError`) or [`Error::Io`] (writing a
//! trajectory), kept whole.
//!
//! ```
//! use dth_core::{dth::{integrate, DthOptions}, nalgebra::Vector4, systems::Kepler, Error};
//!
//! fn orbit() -> Result<f64, Error> {
//!     let options = DthOptions::new(0.06277)?;
//!     let run = integrate(Kepler::thesis(), Vector4::new(0.5, 0.0, 0.0, 1.2), options, 100)?;
//!     Ok(run.midpoint_times()[100])
//! }
//! assert!(orbit()? > 0.0);
//! # Ok::<(), Error>(())
//! ```

use std::sync::Arc;

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
    /// `Psi = (J grad H)^T Hess H (J grad H)` is identically zero for this Hamiltonian
    /// ([`Flags::psi_identically_zero`](crate::Flags::psi_identically_zero)): the DTH energy
    /// condition does not determine `lambda` (thesis Section 3.4, paper Theorem 2).
    #[error(
        "DTH needs Psi = (J gradH)^T HessH (J gradH) != 0: with Psi identically zero the energy \
         condition does not determine lambda (thesis Section 3.4, paper Theorem 2); integrate \
         this Hamiltonian with a peer method instead"
    )]
    PsiIdenticallyZero,
    /// The DTH stepper's initial midpoint is an equilibrium: `grad H(zbar_0) = 0` exactly. The
    /// orbit stays at the point, and with `J grad H = 0` the step equation and the energy
    /// condition hold for every `lambda` (`Psi = 0` there too): nothing determines DTH's time
    /// step, and its Newton matrix is singular.
    #[error(
        "zbar_0 is an equilibrium (grad H = 0 there): the orbit stays at the point and DTH's \
         energy condition does not determine lambda; start away from it, or integrate with a \
         peer method, which keeps the point"
    )]
    Equilibrium,
    /// The phase space has an odd dimension: `z = (q, p)` needs `D = 2n`.
    #[error("phase space dimension {dim} is odd: z = (q1..qn, p1..pn) needs an even dimension")]
    OddDimension {
        /// The dimension the Hamiltonian reported.
        dim: usize,
    },
    /// A state passed to a stepper or method does not have the Hamiltonian's dimension (a
    /// `Dyn` vector of another length).
    #[error(
        "`{what}` has length {found}, but the Hamiltonian's phase space has dimension {expected}"
    )]
    WrongStateLength {
        /// Which argument: `"zbar0"` (DTH), `"z0"` (a run), `"z"` or `"z1"` (a step).
        what: &'static str,
        /// The Hamiltonian's dimension `D`.
        expected: usize,
        /// The vector's length.
        found: usize,
    },
    /// A function for the extended phase space (time-dependent `H`, `z = (q, t, p, p_t)`) was
    /// given a Hamiltonian whose [`Flags::time_dependent`](crate::Flags::time_dependent) is
    /// false: its last coordinate is a momentum `p_n`, not `p_t`.
    #[error(
        "the Hamiltonian is autonomous (flags().time_dependent is false): its z has no momentum \
         of time p_t to set; lift it with dth::Extended first"
    )]
    NotTimeDependent,
    /// An initial state component (or parameter) is NaN or infinite.
    #[error("initial state component {index} is not finite ({value})")]
    NonFiniteInitialState {
        /// Index into `z`.
        index: usize,
        /// The offending value.
        value: f64,
    },
    /// The Newton iteration of a DTH step did not converge: it hit the iteration limit, or its
    /// update stalled at roundoff level while the residual stayed above tolerance.
    #[error("newton did not converge at step {step} after {iterations} iterations (scaled residual {residual:e})")]
    NewtonDiverged {
        /// Index `k + 1` of the midpoint being computed.
        step: usize,
        /// Newton iterations spent (for the nested solver: all inner iterations, i.e. LU
        /// factorizations).
        iterations: u32,
        /// Last scaled residual (dimensionless, relative to the size of the terms).
        residual: f64,
    },
    /// Newton converged to a root with `lambda <= 0` (for example the spurious root
    /// `lambda_{k+1} = -lambda_k`, `zbar_{k+1} = zbar_k`, where time stands still).
    #[error("step {step} converged to a non-physical root with lambda = {lambda:e} (must be > 0)")]
    SpuriousRoot {
        /// Index `k + 1` of the midpoint being computed.
        step: usize,
        /// The rejected multiplier.
        lambda: f64,
    },
    /// A Newton matrix was exactly singular (zero pivot), or the Schur complement
    /// `g_lambda` of the bordered system was zero.
    #[error("singular newton matrix at step {step}")]
    SingularMatrix {
        /// Index `k + 1` of the midpoint being computed.
        step: usize,
    },
    /// A NaN or infinity appeared during a step.
    #[error("non-finite value at step {step}: {what}")]
    NonFinite {
        /// Index of the midpoint being computed (0 for the initial midpoint).
        step: usize,
        /// Which quantity.
        what: &'static str,
    },
    /// A time-dependent (extended phase space) start with `calH(zbar_0) != 0`; set `p_t` with
    /// `dth::set_momentum_of_time` first (paper Theorem 1: `calH(zbar_k) = 0` for all `k`).
    #[error("extended-phase-space start has calH(zbar_0) = {value:e}, must be 0 (set p_t = -H)")]
    ExtendedEnergyNotZero {
        /// `calH(zbar_0)`.
        value: f64,
    },
    /// The cancellation-free energy solve converged, but the plain check against the first
    /// midpoint failed: `H(zbar_{k+1}) - H(zbar_0)` exceeds the residual tolerance. It means the
    /// Hamiltonian's `discrete_gradient` / `discrete_gradient_defect` are inconsistent with its
    /// `value` (a wrong override), or `H` is too ill-conditioned there.
    #[error("energy check failed at step {step}: H(zbar) - H(zbar_0) = {deviation:e} (scaled {scaled:e})")]
    EnergyCheckFailed {
        /// Index `k + 1` of the midpoint being computed.
        step: usize,
        /// `H(zbar_{k+1}) - H(zbar_0)`.
        deviation: f64,
        /// The deviation relative to the size of the terms of `H`.
        scaled: f64,
    },
    /// DTH itself breaks down at this step: `Psi = (J grad H)^T Hess H (J grad H)` changes
    /// sign (or `lambda` predicted by the law of time `lambda Psi^(1/3) = const` blows up), so
    /// the step equations have no positive root near `lambda_k` (thesis Thm 3.11; Cartesian
    /// Kepler above e ~ 0.79, the pendulum in rotation). Detected before Newton from `Psi` at a
    /// predicted midpoint, or after it from the root's `lambda`. Use a smaller `dtau` near
    /// `Psi = 0` from one side, the robust mode (`DthOptions::with_robust`), or a peer method.
    #[error(
        "DTH breaks down at step {step} (t = {time}): Psi = {psi_previous:e} at the last midpoint, \
         {psi:e} at the predicted next one; lambda_k = {lambda}, law of time predicts \
         {lambda_predicted:e}"
    )]
    Breakdown {
        /// Index `k + 1` of the midpoint being computed.
        step: usize,
        /// Midpoint time `tbar_k` of the last accepted midpoint.
        time: f64,
        /// `Psi` at the predicted midpoint `zbar_{k+1}`.
        psi: f64,
        /// `Psi(zbar_k)`.
        psi_previous: f64,
        /// `lambda_k`.
        lambda: f64,
        /// `lambda_k (Psi_k / Psi)^(1/3)` (negative when `Psi` changes sign; after Newton,
        /// the root's `lambda`).
        lambda_predicted: f64,
    },
    /// A run that was to end at a time could not land its last step there (the robust mode's
    /// fallback steps included): nothing after the last accepted step is kept, and the run is
    /// a failure, not a shorter success.
    #[error(
        "step {step} could not end the run at t = {t_end}: the closest try ended at t = {reached}"
    )]
    EndNotReached {
        /// Index `k + 1` of the last step.
        step: usize,
        /// The time asked for.
        t_end: f64,
        /// Where the closest try of the last step ended.
        reached: f64,
    },
    /// An event's condition ([`crate::event::Event`]) is NaN at a state of the run: it cannot
    /// say whether the condition holds.
    #[error("event `{name}`: its condition is NaN at t = {t}")]
    EventNotANumber {
        /// The event's name.
        name: String,
        /// The time of the state.
        t: f64,
    },
    /// A run ([`crate::solve`](mod@crate::solve)) was to end at `t_end` but took its step limit
    /// ([`Solve::max_steps`](crate::solve::Solve::max_steps)) first: what it computed is kept,
    /// and the run is a failure, not a shorter success.
    #[error("stopped after {max_steps} steps at t = {t}, before the end t = {t_end} (raise max_steps or the step size)")]
    StepCap {
        /// The step limit.
        max_steps: usize,
        /// The time reached.
        t: f64,
        /// The time asked for.
        t_end: f64,
    },
    /// A run ([`crate::solve`](mod@crate::solve)) was interrupted through its flag
    /// ([`Solve::interrupt`](crate::solve::Solve::interrupt)) before step `step`: what it
    /// computed up to there is kept.
    #[error("interrupted before step {step}")]
    Interrupted {
        /// Index of the step not taken.
        step: usize,
    },
    /// A run ([`crate::solve`](mod@crate::solve)) was started without an end: say where it ends with
    /// [`Solve::until`](crate::solve::Solve::until) (a time), [`Solve::steps`](crate::solve::Solve::steps)
    /// or [`Solve::save_at`](crate::solve::Solve::save_at) (its last time).
    #[error("the run has no end: call .until(t_end), .steps(n) or .save_at(times) before .run()")]
    MissingEnd,
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
    /// A method for separable Hamiltonians was given one whose `separable` flag is `false`.
    #[error(
        "{method} needs a separable Hamiltonian H = T(p) + V(q) (Hamiltonian::SEPARABLE is false)"
    )]
    NotSeparable {
        /// The method's name.
        method: &'static str,
    },
    /// The Hamiltonian failed outside this crate: a Hamiltonian read from text that does not
    /// compile, names an unknown parameter or does not fit the type asked for
    /// (`dth_runtime::RuntimeError`, which converts into this variant with `?`). It displays
    /// as that error, and [`SharedError::downcast_ref`] gives it back typed.
    #[error(transparent)]
    Hamiltonian(SharedError),
    /// Writing results failed (`Trajectory::write_csv`): the [`std::io::Error`], kept whole.
    #[error(transparent)]
    Io(SharedError),
    /// The exact Kepler solution was asked for an orbit that is not elliptic.
    #[error("Kepler orbit is not elliptic: energy {energy:e}, eccentricity {eccentricity}")]
    KeplerNotElliptic {
        /// `H(q, p)`; must be negative.
        energy: f64,
        /// Eccentricity; must be below 1.
        eccentricity: f64,
    },
}

/// An error of another crate kept whole inside an [`Error`](enum@Error) ([`Error::Hamiltonian`],
/// [`Error::Io`]), so that [`Error`](enum@Error) stays `Clone` and `PartialEq`: clones share it, and it is
/// equal only to its clones (two errors built apart are not equal, whatever they say).
///
/// It displays as the error it holds, and its [`source`](std::error::Error::source) is that
/// error's source (the error itself is not repeated in a chain of causes).
///
/// ```
/// use dth_core::error::{Error, SharedError};
///
/// let io = std::io::Error::new(std::io::ErrorKind::NotFound, "no such directory");
/// let error = Error::from(io);
/// assert!(matches!(&error, Error::Io(e) if e.downcast_ref::<std::io::Error>().is_some()));
/// assert_eq!(error.to_string(), "no such directory");
/// assert_eq!(error, error.clone());
/// ```
#[derive(Clone)]
pub struct SharedError(Arc<dyn std::error::Error + Send + Sync + 'static>);

impl SharedError {
    /// Keeps `error`.
    pub fn new<E: std::error::Error + Send + Sync + 'static>(error: E) -> Self {
        SharedError(Arc::new(error))
    }

    /// The error held.
    pub fn get(&self) -> &(dyn std::error::Error + Send + Sync + 'static) {
        &*self.0
    }

    /// The error held, if it is an `E`.
    pub fn downcast_ref<E: std::error::Error + 'static>(&self) -> Option<&E> {
        self.0.downcast_ref::<E>()
    }
}

impl std::fmt::Debug for SharedError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        std::fmt::Debug::fmt(&*self.0, f)
    }
}

impl std::fmt::Display for SharedError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        std::fmt::Display::fmt(&*self.0, f)
    }
}

impl std::error::Error for SharedError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        self.0.source()
    }
}

/// The same error: one of the clones of one [`SharedError::new`].
impl PartialEq for SharedError {
    fn eq(&self, other: &Self) -> bool {
        Arc::ptr_eq(&self.0, &other.0)
    }
}

impl From<std::io::Error> for Error {
    fn from(error: std::io::Error) -> Self {
        Error::Io(SharedError::new(error))
    }
}

/// A failed run (DTH or a peer method): the error and everything computed before it.
///
/// `?` converts it into [`Error`](enum@Error) (its [`RunError::error`]; the partial result is dropped),
/// so a function returning `Result<_, dth::Error>` calls `integrate(..)?` directly; match on
/// the `RunError` first to keep [`RunError::partial`]. As a [`std::error::Error`] it says the
/// run stopped, and its [`source`](std::error::Error::source) is the typed error (a report
/// that walks the chain, as `anyhow`'s `{:#}` or its `Caused by:`, prints each once; find it
/// with `chain().find_map(|e| e.downcast_ref::<dth::Error>())`).
///
/// ```
/// use dth_core::{dth::{integrate, DthOptions}, nalgebra::Vector4, systems::Kepler, Error};
/// use std::error::Error as _;
/// // One Newton iteration is too few to solve a step to roundoff: the first step fails.
/// let options = DthOptions::thesis_kepler().with_max_iterations(1)?;
/// let err = integrate(Kepler::thesis(), Vector4::new(0.5, 0.0, 0.0, 1.2), options, 100)
///     .unwrap_err();
/// assert!(matches!(err.error, Error::NewtonDiverged { step: 1, .. }));
/// assert_eq!(err.partial.len(), 1); // zbar_0, the last accepted midpoint
/// let cause = err.source().and_then(|e| e.downcast_ref::<Error>());
/// assert_eq!(cause, Some(&err.error));
/// assert!(cause.unwrap().to_string().starts_with("newton did not converge at step 1"));
///
/// // `?` into `Error` keeps the error, not the partial run.
/// let error: Error = err.into();
/// assert!(matches!(error, Error::NewtonDiverged { step: 1, .. }));
/// # Ok::<(), Error>(())
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct RunError<T> {
    /// Why the run stopped.
    pub error: Error,
    /// What was computed up to the last accepted step.
    pub partial: T,
}

/// The message does not repeat the error's: the error is the [`source`](std::error::Error::source),
/// and a report that walks the chain prints it next.
impl<T> std::fmt::Display for RunError<T> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("the run stopped before its end (what it computed up to the last accepted step is kept)")
    }
}

impl<T: std::fmt::Debug> std::error::Error for RunError<T> {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        Some(&self.error)
    }
}

/// `?` from a failed run into [`Error`](enum@Error): the error, without the partial result.
impl<T> From<RunError<T>> for Error {
    fn from(run: RunError<T>) -> Self {
        run.error
    }
}
