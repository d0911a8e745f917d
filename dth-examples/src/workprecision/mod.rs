//! Work-precision benchmark: what each accuracy costs in wall time, for DTH and every peer.
//!
//! [`run`] sweeps the step size of every method (the tolerance of the outside reference,
//! DOP853 from the `differential-equations` crate) over more than two decades on seven
//! problems ([`problems`]) and measures, for each point:
//!
//! - **wall time**: median of repeated runs in this process (no diagnostics inside the timed
//!   run: it only integrates to the final time `T`);
//! - **global error**: Euclidean norm of the phase-space error at the fixed physical time `T`
//!   against the exact solution (Kepler, forced oscillator) or a converged reference (2-stage
//!   Gauss-Legendre at a tiny step, checked against itself at half that step, evaluated between
//!   its steps by cubic Hermite interpolation). DTH (every order) ends exactly at `T`: its last
//!   step is shortened or stretched in `tau` so that its last midpoint lands on `T` to roundoff
//!   (`Dth::step_toward`), and that midpoint is compared with the reference at its own time.
//!   For comparison the harness also records the error at DTH's last vertex, at that vertex's
//!   own time ([`Record::vertex_error`]). Regularized DTH (`dth_lc`, `dth8_lc`: Kepler
//!   regularized by Levi-Civita, on `(u, t, P, p_t)`) ends the same way at physical `T`, and
//!   every state it produces is mapped back to `(q, p)` before anything is measured;
//! - **maximum energy deviation** `max_k |H(z_k) - H(z_0)|` over every state the method produces
//!   (DTH: at its midpoints, where it conserves energy, and separately at its vertices against
//!   the first vertex `z^(0)`, the thesis's Table 4.1 convention);
//! - **maximum invariant deviation** (angular momentum, Kepler only), same convention (DTH's
//!   vertices conserve it: they are measured against `z^(0)`, whose angular momentum differs
//!   from `z_0`'s by `O(h^2)`);
//! - **Newton iterations per step** (implicit methods; the nested DTH solver counts LU
//!   factorizations, inner and outer).
//!
//! Output in the chosen directory: `workprecision.json` and `workprecision.csv` (one row per
//! run), `summary.md` (the tables of `docs/performance.md`), and one PNG + SVG diagram per
//! system and error kind, `<system>_<kind>.{png,svg}` (error against wall time, log-log).
//!
//! ```no_run
//! use dth_examples::workprecision::{run, WorkPrecisionOptions};
//! let summary = run(&WorkPrecisionOptions::quick(), std::path::Path::new("target/wp"))?;
//! println!("{} runs, files: {:?}", summary.records.len(), summary.files);
//! # Ok::<(), dth_examples::workprecision::Error>(())
//! ```

mod external;
mod plot;
pub mod problem;
pub mod problems;
mod reference;
mod report;
mod runners;

use std::path::{Path, PathBuf};

use serde::Serialize;

pub use report::Machine;

/// Settings of a work-precision run. Build with [`Default`] (the full sweep) or
/// [`WorkPrecisionOptions::quick`] and adjust with the `with_*` methods.
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub struct WorkPrecisionOptions {
    quick: bool,
    repeats: usize,
    min_timing: f64,
    /// Only these problems (`None`: all).
    problems: Option<Vec<&'static str>>,
}

impl Default for WorkPrecisionOptions {
    /// The full sweep: 10 orbits (periods) per problem, step sizes over 3.3 decades, timing
    /// the median of at least 5 repeats and at least 0.05 s of repeated runs.
    fn default() -> Self {
        WorkPrecisionOptions {
            quick: false,
            repeats: 5,
            min_timing: 0.05,
            problems: None,
        }
    }
}

impl WorkPrecisionOptions {
    /// The CI smoke test: one period per problem, three step sizes per method, one timed run.
    /// Its times say nothing; it checks that everything runs and is written.
    pub fn quick() -> Self {
        WorkPrecisionOptions {
            quick: true,
            repeats: 1,
            min_timing: 0.0,
            problems: None,
        }
    }

    /// Minimum number of timed repeats per point (the median is reported). Default 5, quick 1.
    ///
    /// # Errors
    /// [`Error::InvalidOption`] for 0.
    pub fn with_repeats(mut self, repeats: usize) -> Result<Self, Error> {
        if repeats == 0 {
            return Err(Error::InvalidOption {
                name: "repeats",
                reason: "must be at least 1",
            });
        }
        self.repeats = repeats;
        Ok(self)
    }

    /// Keep repeating a timed run until this many seconds were spent on it (beyond the
    /// minimum number of repeats, at most 101). Default 0.05 s, quick 0.
    ///
    /// # Errors
    /// [`Error::InvalidOption`] when negative or not finite.
    pub fn with_min_timing(mut self, seconds: f64) -> Result<Self, Error> {
        if !(seconds.is_finite() && seconds >= 0.0) {
            return Err(Error::InvalidOption {
                name: "min_timing",
                reason: "must be finite and non-negative",
            });
        }
        self.min_timing = seconds;
        Ok(self)
    }

    /// Sweep only the problems named (`kepler_e09_regularized`, ...: [`problems::NAMES`]), in
    /// their usual order. Default: every problem.
    ///
    /// ```
    /// use dth_examples::workprecision::WorkPrecisionOptions;
    /// let options = WorkPrecisionOptions::default().with_problems(&["kepler_e09_regularized"])?;
    /// assert!(WorkPrecisionOptions::default().with_problems(&["kepler"]).is_err());
    /// # Ok::<(), dth_examples::workprecision::Error>(())
    /// ```
    ///
    /// # Errors
    /// [`Error::UnknownProblem`] for a name that is not a problem's.
    pub fn with_problems<S: AsRef<str>>(mut self, names: &[S]) -> Result<Self, Error> {
        let mut chosen = Vec::with_capacity(names.len());
        for name in names {
            let name = name.as_ref();
            let known = problems::NAMES
                .iter()
                .find(|n| **n == name)
                .ok_or_else(|| Error::UnknownProblem {
                    name: name.to_string(),
                })?;
            chosen.push(*known);
        }
        self.problems = Some(chosen);
        Ok(self)
    }

    /// Whether the problem `name` is swept.
    fn sweeps(&self, name: &str) -> bool {
        self.problems
            .as_ref()
            .is_none_or(|chosen| chosen.contains(&name))
    }

    /// Whether this is the quick smoke-test sweep.
    pub fn is_quick(&self) -> bool {
        self.quick
    }
    /// Minimum number of timed repeats.
    pub fn repeats(&self) -> usize {
        self.repeats
    }
}

/// Why a work-precision run stopped. A method that fails at some step size is *not* an error:
/// it is recorded in [`Record::failure`] and the sweep goes on.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// A bad option.
    #[error("invalid option `{name}`: {reason}")]
    InvalidOption {
        /// The option.
        name: &'static str,
        /// What is wrong.
        reason: &'static str,
    },
    /// A problem name that is not one of [`problems::NAMES`].
    #[error("unknown work-precision problem `{name}`: expected one of {}", problems::NAMES.join(", "))]
    UnknownProblem {
        /// The name given.
        name: String,
    },
    /// Writing an output file failed.
    #[error("cannot write `{}`", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The cause.
        #[source]
        source: std::io::Error,
    },
    /// Serializing the results failed.
    #[error("cannot serialize the results to JSON")]
    Json(#[from] serde_json::Error),
    /// Drawing a diagram failed (boxed: the crate's error wraps this one).
    #[error("cannot draw a work-precision diagram")]
    Plot(#[source] Box<crate::error::Error>),
    /// The reference solution of a problem could not be computed or did not converge.
    #[error("reference solution of `{system}`: {message}")]
    Reference {
        /// The problem.
        system: &'static str,
        /// What went wrong.
        message: String,
    },
}

impl From<crate::error::Error> for Error {
    fn from(e: crate::error::Error) -> Self {
        Error::Plot(Box::new(e))
    }
}

/// One run of one method at one step size on one problem.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Record {
    /// Problem name (file-name safe, e.g. `kepler_e044`).
    pub system: &'static str,
    /// Method name (e.g. `dth_joint`, `dth8` (order 8), `dth_lc` (regularized by
    /// Levi-Civita), `midpoint`, `dop853`).
    pub method: &'static str,
    /// What `parameter` is: `"dt"`, `"dtau"` (DTH) or `"tol"` (DOP853, `rtol = atol`).
    pub parameter_kind: &'static str,
    /// The swept parameter.
    pub parameter: f64,
    /// Steps taken to reach `T` (accepted steps for DOP853).
    pub steps: usize,
    /// Mean physical time step `T / steps`.
    pub mean_dt: f64,
    /// Median wall time of the timed runs, seconds.
    pub time: f64,
    /// Fastest of the timed runs, seconds (less sensitive to a loaded machine than the median).
    pub time_min: f64,
    /// Number of timed runs behind the median.
    pub timed_runs: usize,
    /// Global phase-space error at `T` (see the module docs for DTH).
    pub global_error: f64,
    /// DTH only: error at its last vertex before `T`, against the reference at that vertex's
    /// own time.
    pub vertex_error: Option<f64>,
    /// `max |H - H(z_0)|` over the states produced (DTH: midpoints).
    pub energy_error: f64,
    /// DTH only: `max |H - H(z^(0))|` over its vertices, against the first vertex
    /// `z^(0) = zbar_0 - (h/2) zbar'_0` (thesis Table 4.1).
    pub vertex_energy_error: Option<f64>,
    /// `max |I - I(z_0)|` of the problem's invariant (angular momentum), if it has one
    /// (DTH: midpoints).
    pub invariant_error: Option<f64>,
    /// DTH only: the invariant deviation over its vertices, against the first vertex.
    pub vertex_invariant_error: Option<f64>,
    /// Newton iterations per step (implicit methods; nested DTH: factorizations per step).
    pub newton_per_step: Option<f64>,
    /// Right-hand-side evaluations per step (DOP853 only).
    pub evaluations_per_step: Option<f64>,
    /// DTH only: steps the robust mode took as fallback steps instead of DTH steps
    /// (`StepKind::Fallback`; above order 2, composed steps with a fallback step inside), out
    /// of [`Record::steps`]. 0 without robust mode.
    pub fallback_steps: Option<usize>,
    /// Why the run failed (then the error fields are NaN and the point is not plotted).
    pub failure: Option<String>,
}

/// How well a problem's reference solution is converged.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ReferenceCheck {
    /// Problem name.
    pub system: &'static str,
    /// `"exact"` or `"gauss_legendre2"`.
    pub kind: &'static str,
    /// Step of the reference run (0 for exact solutions).
    pub step: f64,
    /// Estimated error of the reference at `T` (Richardson: difference to the run at twice
    /// the step, divided by 15; 0 for exact solutions).
    pub estimated_error: f64,
}

/// What [`run`] produced.
#[derive(Clone, Debug, Serialize)]
pub struct Summary {
    /// Machine and date.
    pub machine: Machine,
    /// Whether this was the quick sweep.
    pub quick: bool,
    /// Every run.
    pub records: Vec<Record>,
    /// The reference solutions and their accuracy.
    pub references: Vec<ReferenceCheck>,
    /// The problems: name, title, final time `T` and characteristic period.
    pub problems: Vec<problem::ProblemInfo>,
    /// The tables of `summary.md` (markdown).
    #[serde(skip)]
    pub tables: String,
    /// Every file written.
    #[serde(skip)]
    pub files: Vec<PathBuf>,
}

/// Run the work-precision sweep and write results, tables and diagrams into `out` (created if
/// missing).
///
/// # Errors
/// [`Error::Reference`] when a reference solution fails its convergence check,
/// [`Error::Io`]/[`Error::Json`]/[`Error::Plot`] when an output cannot be written. Method
/// failures are recorded, not returned.
pub fn run(options: &WorkPrecisionOptions, out: &Path) -> Result<Summary, Error> {
    std::fs::create_dir_all(out).map_err(|source| Error::Io {
        path: out.to_path_buf(),
        source,
    })?;
    let machine = Machine::detect();
    let mut records = Vec::new();
    let mut references = Vec::new();
    let mut infos = Vec::new();
    for problem in problems::all(options)? {
        if options.sweeps(problem.name()) {
            problem.sweep(options, &mut records, &mut references, &mut infos)?;
        }
    }
    let tables = report::tables(&records, &infos, &references);
    let mut summary = Summary {
        machine,
        quick: options.quick,
        records,
        references,
        problems: infos,
        tables,
        files: Vec::new(),
    };
    summary.files = report::write_all(&summary, out)?;
    summary
        .files
        .extend(plot::diagrams(&summary.records, &summary.problems, out)?);
    Ok(summary)
}
