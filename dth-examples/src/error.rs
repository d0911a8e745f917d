//! The crate's error type and the exit code each kind maps to, and how a method run fails
//! ([`MethodFailure`]). The bottom layer: it imports nothing from the crate.

use std::path::PathBuf;

use thiserror::Error;

/// One problem found in a scene file, located at `file:line:column` (1-based).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SceneDiagnostic {
    /// The scene's file name as given by the caller (`<embedded>` for the default scene).
    pub file: String,
    /// 1-based line.
    pub line: usize,
    /// 1-based column (in characters).
    pub column: usize,
    /// What is wrong and what was expected, lowercase.
    pub message: String,
}

impl std::fmt::Display for SceneDiagnostic {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{}:{}:{}: {}",
            self.file, self.line, self.column, self.message
        )
    }
}

/// Every diagnostic of one scene file (validation reports all independent problems at once).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SceneErrors(pub Vec<SceneDiagnostic>);

impl std::fmt::Display for SceneErrors {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        for (i, d) in self.0.iter().enumerate() {
            if i > 0 {
                writeln!(f)?;
            }
            write!(f, "{d}")?;
        }
        Ok(())
    }
}

/// Everything that can go wrong when checking or running a scene.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum Error {
    /// The scene file is invalid (exit code 2).
    #[error("invalid scene:\n{0}")]
    Scene(SceneErrors),
    /// The scene file cannot be read (exit code 2: the user's argument is wrong).
    #[error("cannot read scene `{}`", path.display())]
    SceneUnreadable {
        /// The path given.
        path: PathBuf,
        /// The cause.
        #[source]
        source: std::io::Error,
    },
    /// A file could not be read or written.
    #[error("{what} `{}`", path.display())]
    Io {
        /// What was being done (lowercase, e.g. "cannot read scene").
        what: &'static str,
        /// The path involved.
        path: PathBuf,
        /// The cause.
        #[source]
        source: std::io::Error,
    },
    /// A method failed during a run; what was computed before the failing step is kept.
    #[error("method `{method}` failed at step {}: {}", failure.step, failure.cause)]
    MethodFailed {
        /// The method's label in the scene (and what it was run for).
        method: String,
        /// The step that failed and why.
        failure: MethodFailure,
    },
    /// A method, system or command that cannot run here (e.g. the exact solution of an
    /// unbound orbit, or a system whose parameters are invalid).
    #[error("{what} `{name}` cannot run: {reason}")]
    NotAvailable {
        /// "method" or "system".
        what: &'static str,
        /// Its name in the scene.
        name: String,
        /// Why.
        reason: String,
    },
    /// An effect asks for states at times the run does not reach (before its start, after
    /// its end, or in a run of a number of steps; exit code 2: the scene is wrong).
    #[error("effect `{effect}` {reason}")]
    ChosenTime {
        /// The effect's kind.
        effect: &'static str,
        /// What it asks and what the run covers.
        reason: String,
    },
    /// The output folder cannot be used (exit code 2: the user's argument is wrong).
    #[error("refusing to write to `{}`: {reason}", path.display())]
    OutputRefused {
        /// The requested output folder.
        path: PathBuf,
        /// Why.
        reason: String,
    },
    /// A figure could not be rendered.
    #[error("cannot render figure `{name}`: {reason}")]
    Plot {
        /// The figure's file stem.
        name: String,
        /// The backend's message.
        reason: String,
    },
    /// A Hamiltonian given as text is malformed (exit code 2): every error, each under the
    /// expression with a caret line at its position.
    #[error("invalid Hamiltonian:\n{diagnostics}")]
    Hamiltonian {
        /// The errors, rendered.
        diagnostics: String,
    },
    /// The run's effects would keep more memory than allowed (exit code 2): refused before
    /// anything runs.
    #[error("refusing to run: {detail}")]
    MemoryLimit {
        /// The estimate, in bytes.
        estimate: u64,
        /// The limit, in bytes.
        limit: u64,
        /// What would keep it, the limit, and what to do.
        detail: String,
    },
    /// `H` or its gradient is not finite at the initial state (outside `H`'s domain, e.g.
    /// Kepler at `q = 0` or `sqrt(q1)` at `q1 < 0`, or overflowing): exit code 2, refused
    /// before any method runs.
    #[error("H is not finite at the initial state: {detail}")]
    InitialState {
        /// The state, what is not finite there, and what was expected.
        detail: String,
    },
    /// A fixed-step method run for a time would need more steps than the cap on runs given a
    /// duration in time (`RunOptions::max_steps`): exit code 2, refused before any method
    /// runs (the run would otherwise stop at the cap, short of the end time).
    #[error("method `{method}` would need {steps:.3e} steps of dt = {dt} to reach t = {t_end}, more than the cap of {max_steps} steps on a run given a duration in time: give a larger `dt`, a shorter duration, or the number of steps (`steps = N`, not capped)")]
    TooManySteps {
        /// The method's label.
        method: String,
        /// The steps it would need.
        steps: f64,
        /// Its step.
        dt: f64,
        /// The end time.
        t_end: f64,
        /// The cap.
        max_steps: usize,
    },
    /// A method's first step moves the initial state by less than double precision resolves
    /// at the state's scale (`simulate::preflight`): the step would change nothing, and the
    /// solver has nothing to work with. Exit code 2, refused before any method runs.
    #[error("method `{method}`: a step of dt = {dt:e} moves the initial state by about {change:.3e} (dt times the largest component of grad H), below what double precision resolves at the state's scale (eps * max |z0| = {resolved:.3e}): the step would not change the state; expected a step of at least {min_step:.3e} in {unit}")]
    StepUnresolved {
        /// The method's label.
        method: String,
        /// Its first physical step (`dt`, or `lambda0 * dtau` for DTH).
        dt: f64,
        /// What the step moves the state by: `dt * max |grad H(z0)|`.
        change: f64,
        /// The smallest change double precision resolves: `eps * max |z0|`.
        resolved: f64,
        /// The smallest step that resolves, in the scene's key (`unit`).
        min_step: f64,
        /// The scene key the step is given in (`dt`, or `dtau` with `lambda0`).
        unit: &'static str,
    },
    /// Memory the scene asks for that the system refused (exit code 2: too much was asked),
    /// although its estimate was within the limit (a limit set above what the machine has).
    #[error("cannot allocate {what}: {reason}: ask for less (e.g. fewer members), or a --max-memory the machine has")]
    Allocation {
        /// What was being allocated, with its size.
        what: String,
        /// The allocator's reason.
        reason: String,
    },
    /// A system registration is invalid (e.g. a duplicate name).
    #[error("invalid system registration `{name}`: {reason}")]
    Registration {
        /// The system's name.
        name: String,
        /// The rule it breaks.
        reason: String,
    },
}

impl Error {
    /// The process exit code for this error: 2 for bad input (scene errors), 1 otherwise.
    pub fn exit_code(&self) -> i32 {
        match self {
            Error::Scene(_)
            | Error::SceneUnreadable { .. }
            | Error::OutputRefused { .. }
            | Error::Hamiltonian { .. }
            | Error::MemoryLimit { .. }
            | Error::InitialState { .. }
            | Error::TooManySteps { .. }
            | Error::StepUnresolved { .. }
            | Error::ChosenTime { .. }
            | Error::Allocation { .. } => 2,
            _ => 1,
        }
    }
}

/// Why a method stopped early.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum FailureCause {
    /// The integrator failed (Newton, breakdown, a non-finite state, ...).
    #[error(transparent)]
    Integrator(#[from] dth::Error),
    /// A run given a duration in time reached the cap on its steps
    /// (`RunOptions::max_steps`) before its end time (e.g. DTH whose `lambda` became tiny):
    /// what it computed up to there is kept.
    #[error("the cap of {max_steps} steps on a run given a duration in time was reached at t = {t}, before the end time {t_end}: give a larger step or the number of steps (`steps = N`, not capped)")]
    StepCap {
        /// The cap.
        max_steps: usize,
        /// The time reached.
        t: f64,
        /// The end time asked for.
        t_end: f64,
    },
    /// The run was interrupted (the `dth` command: SIGINT or SIGTERM) before this step: what
    /// it computed up to there is kept.
    #[error("interrupted (SIGINT or SIGTERM) before this step")]
    Interrupted,
    /// The sampled exact solution could not be computed at this time.
    #[error("the exact solution is not available at t = {t}")]
    NoExactSolution {
        /// The time asked for.
        t: f64,
    },
}

/// A method run's failure after `step - 1` successful steps (`step` 0: it failed at its
/// start, before any state); the observer has every state up to there.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("step {step}: {cause}")]
pub struct MethodFailure {
    /// The step that failed.
    pub step: usize,
    /// Why.
    #[source]
    pub cause: FailureCause,
}

impl MethodFailure {
    /// The integrator's `error` at `step`.
    pub fn integrator(step: usize, error: dth::Error) -> Self {
        MethodFailure {
            step,
            cause: FailureCause::Integrator(error),
        }
    }
}
