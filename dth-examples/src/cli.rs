//! The `dth` command: parsing its arguments and printing; the work is in the rest of the
//! library. The `dth` binary is [`main`]; `dth-mpi` (its own crate) installs MPI's ranks
//! (`ensemble::schedule::set_ranks`) and then calls it too.

use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, Ordering};

use crate::budget;
use crate::catalogue::Catalogue;
use crate::output::Staging;
use crate::report::table41;
use crate::scene::{EffectKind, MethodKind, RegularizeMap};
use crate::simulate::RunOptions;
use crate::step_time;
use crate::workprecision::{self, WorkPrecisionOptions};
use crate::{Error, DEFAULT_OUT, DEFAULT_SCENE, DEFAULT_SCENE_NAME};
use clap::{Parser, Subcommand};

/// What the command can fail with: a scene's error, or the work-precision benchmark's.
#[derive(Debug, thiserror::Error)]
enum CliError {
    #[error(transparent)]
    Scene(#[from] Error),
    #[error("work-precision benchmark failed")]
    WorkPrecision(#[source] workprecision::Error),
    #[error(transparent)]
    Gallery(#[from] crate::gallery::Error),
}

impl CliError {
    /// 2 for bad input, 1 otherwise (see `Error::exit_code`).
    fn exit_code(&self) -> i32 {
        match self {
            CliError::Scene(e) => e.exit_code(),
            CliError::WorkPrecision(workprecision::Error::UnknownProblem { .. }) => 2,
            CliError::WorkPrecision(_) => 1,
            CliError::Gallery(e) => e.exit_code(),
        }
    }
}

/// Discrete-Time Hamiltonian dynamics: run scenes, check them, reproduce the thesis.
///
/// Without a subcommand, runs the embedded default scene (the thesis's Kepler experiment,
/// scenes/thesis-kepler.toml) into dth-out/thesis-kepler/ (change with --out).
#[derive(Parser)]
#[command(name = "dth", version, about, long_about)]
struct Cli {
    #[command(subcommand)]
    command: Option<Command>,
    /// Output folder for the default run (default: dth-out/thesis-kepler).
    #[arg(long, global = false)]
    out: Option<PathBuf>,
    #[command(flatten)]
    limits: Limits,
}

/// The limits of a scene's run: for `run`, `check` (the memory estimate), `table41`, `gallery`
/// and the default run; the other subcommands run no scene and do not take them.
#[derive(clap::Args, Clone, Copy, Default)]
struct Limits {
    /// The most memory a run's effects may keep, e.g. 4G, 4GB, 4GiB, 512M (default: half the
    /// available memory). A scene estimated above it is refused, by `check` and `run`, before
    /// it runs.
    #[arg(long, value_parser = parse_size)]
    max_memory: Option<u64>,
    /// Threads an ensemble scene runs its members on (default: one per core; at most one per
    /// member). The files are the same for any number. Under `mpirun` (the `mpi` feature)
    /// this is per rank.
    #[arg(long, value_parser = clap::value_parser!(u16).range(1..))]
    threads: Option<u16>,
}

impl Limits {
    /// The run options with these limits.
    fn options(self) -> RunOptions {
        let mut options = RunOptions::default();
        if let Some(bytes) = self.max_memory {
            options = options.with_memory_limit(bytes);
        }
        if let Some(threads) = self.threads {
            options = options.with_threads(usize::from(threads));
        }
        options
    }
}

/// A size in bytes: a number with an optional `k`, `M`, `G` or `T` (powers of 1000), or
/// `Ki`, `Mi`, `Gi`, `Ti` (powers of 1024), and an optional `B`: `4G`, `4GB`, `4GiB`, `512M`,
/// `1000000`.
fn parse_size(s: &str) -> Result<u64, String> {
    let s = s.trim();
    let not_a_size =
        || format!("`{s}` is not a size: expected e.g. 4G, 4GB, 4GiB, 512M or 1000000");
    let rest = s.strip_suffix(['B', 'b']).unwrap_or(s);
    let (rest, binary) = match rest.strip_suffix('i') {
        Some(r) => (r, true),
        None => (rest, false),
    };
    let (digits, prefix) = match rest.char_indices().last() {
        Some((i, c)) if c.is_ascii_alphabetic() => (&rest[..i], Some(c)),
        _ => (rest, None),
    };
    let value: f64 = digits.trim().parse().map_err(|_| not_a_size())?;
    let power = match prefix.map(|c| c.to_ascii_uppercase()) {
        None if !binary => 0,
        Some('K') => 1,
        Some('M') => 2,
        Some('G') => 3,
        Some('T') => 4,
        _ => {
            return Err(format!(
                "unknown unit in `{s}`: expected k, M, G or T (powers of 1000) or Ki, Mi, Gi, Ti (powers of 1024), optionally followed by B"
            ))
        }
    };
    let factor = if binary { 1024f64 } else { 1000f64 }.powi(power);
    if !(value.is_finite() && value > 0.0) {
        return Err(format!("`{s}`: expected a positive size"));
    }
    let bytes = value * factor;
    // `as u64` saturates: `1e30T` would become 18 EB, a limit that passes every estimate
    // (saturated ones included) and lets a run allocate until the system aborts it.
    if bytes >= u64::MAX as f64 {
        return Err(format!(
            "`{s}` is more bytes than a 64-bit count holds: expected at most 18000000T"
        ));
    }
    Ok(bytes as u64)
}

#[derive(Subcommand)]
enum Command {
    /// Run a scene file and write CSV, JSON summary, figures (PNG, SVG) and index.html.
    ///
    /// The output is written to a temporary folder next to the target and moved into place
    /// once written. An existing target is written into only if it is empty or is a dth
    /// output folder (it holds a .dth-output marker, which lists what dth wrote there);
    /// otherwise the run is refused. A rerun replaces only the files dth wrote: other files
    /// in the folder stay. A run that does not complete does not replace a complete earlier
    /// result: it goes to NAME.incomplete beside it. Exit codes: 0 success, 2 bad input
    /// (scene errors, refused output folder), 1 run failures (a method failed mid-run, or an
    /// ensemble's member runs failed: what was computed is still written), 130
    /// interrupted by SIGINT or SIGTERM (Ctrl-C): the run stops at the next step and writes
    /// what it computed, `summary.json`'s `interrupted` saying where; a second signal quits
    /// at once, with nothing written and no temporary folder left.
    Run {
        /// The scene file (TOML).
        scene: PathBuf,
        /// Output folder (default: dth-out/STEM, STEM the scene file name without `.toml`).
        #[arg(long)]
        out: Option<PathBuf>,
        #[command(flatten)]
        limits: Limits,
    },
    /// Validate a scene file without running it (exit 2 and file:line:column on errors).
    ///
    /// Also probes the sign of Psi along a short stretch of the orbit (a scene with a `dth`
    /// method): where it changes sign, DTH breaks down, and a warning says where and suggests
    /// the fix (`regularize = "levi-civita"` or `"ks"` under `[system]` for a 1/r-like
    /// singularity in two or three degrees of freedom, else `robust = true`). Warnings do not
    /// change the exit code.
    Check {
        /// The scene file (TOML).
        scene: PathBuf,
        #[command(flatten)]
        limits: Limits,
    },
    /// List the systems (with parameters), methods and effects scenes can name.
    List,
    /// Print the thesis's Table 4.1 beside ours (markdown); --json also writes it as JSON.
    Table41 {
        /// Also write {"rows": [{"method", "energy", "angular_momentum"}, ...]} here.
        #[arg(long)]
        json: Option<PathBuf>,
        #[command(flatten)]
        limits: Limits,
    },
    /// Work-precision diagrams for every method: error against wall time on seven problems
    /// (docs/performance.md has the tables).
    Workprecision {
        /// Output folder (default: dth-out/workprecision).
        #[arg(long)]
        out: Option<PathBuf>,
        /// A quick smoke-test variant.
        #[arg(long)]
        quick: bool,
        /// Only this problem (repeat for more): kepler_e044, kepler_e07, kepler_e09,
        /// kepler_e09_regularized, henon_heiles, pendulum, forced_oscillator.
        #[arg(long = "problem")]
        problems: Vec<String>,
    },
    /// Redraw the documentation's figure gallery: run every scene (and work-precision
    /// problem) the manifest names, copy the figures it lists (PNG) into figures/ beside it and
    /// write gallery.md there from their captions. The runs' whole outputs stay in
    /// dth-out/gallery/. Run it from the repository's root.
    Gallery {
        /// The manifest (TOML: one [[figure]] per figure, with name, scene or workprecision,
        /// draws, title, caption).
        #[arg(default_value = "docs/gallery.toml")]
        manifest: PathBuf,
        #[command(flatten)]
        limits: Limits,
    },
    /// Show what the symbolic engine derives from a Hamiltonian (the `hamiltonian!` grammar):
    /// the simplified gradient, the Hessian's nonzero entries, Psi = (J gradH)^T HessH (J gradH),
    /// and the flags (separable, time-dependent, Psi identically zero); with `--rust`, the
    /// Rust code `hamiltonian!` emits for it instead. Exit 2 with the position of each error
    /// for a malformed expression.
    Derive {
        /// The Hamiltonian, e.g. "p1^2/(2*m) + k*q1^2/2" (quote it for the shell).
        expr: String,
        /// A parameter name the expression uses (repeat, or separate with commas).
        #[arg(long = "param", short = 'p', value_delimiter = ',', value_parser = crate::derive::param_name)]
        params: Vec<String>,
        /// Print the code `hamiltonian!` emits (the struct `GeneratedHamiltonian` with one
        /// `f64` field per parameter, and its `impl Hamiltonian<D>`), formatted.
        #[arg(long, conflicts_with = "regularize")]
        rust: bool,
        /// Show the regularized K = |u|^2 (H + p_t) instead (what `#[regularize(..)]`
        /// compiles): levi-civita for a planar H, ks for one in space.
        #[arg(long, value_enum)]
        regularize: Option<crate::derive::Regularization>,
    },
}

fn default_out(scene: &Path) -> PathBuf {
    let stem = scene
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "scene".into());
    Path::new(DEFAULT_OUT).join(stem)
}

fn run(
    text: &str,
    file: &str,
    out: &Path,
    thesis_table: bool,
    options: &RunOptions,
) -> Result<ExitCode, CliError> {
    // A run that lost a method still wrote its outputs: report them, then exit 1 (130 when
    // it was interrupted).
    let options = options.clone().with_interrupt(&INTERRUPT);
    // Graceful until the process ends: a signal after the last step (while the output is
    // committed, or after) is no reason to exit without a word; it is reported below.
    GRACEFUL.store(true, Ordering::SeqCst);
    let report = crate::run_scene(text, file, &Catalogue::builtin(), out, &options);
    let report = match report {
        Ok(report) => report,
        Err(e) => e.partial_report()?,
    };
    if crate::ensemble::schedule::is_worker_rank() {
        // An MPI rank other than 0 computed its share; rank 0 reports.
        return Ok(ExitCode::SUCCESS);
    }
    if let Some(c) = &report.ensemble {
        println!(
            "{} members: {} skipped (no real solution on the energy shell), {} not run, {} method runs failed{}{} (see ensemble.csv)",
            c.drawn,
            c.skipped,
            c.not_run,
            c.failed_runs,
            c.fallback_note(),
            c.step_check_note()
        );
    }
    let deviations = report.deviation_markdown();
    if !deviations.is_empty() {
        println!("{deviations}");
    }
    if thesis_table {
        let table = table41::rows_from(&report.methods);
        if !table.rows.is_empty() {
            let steps: Vec<String> = report
                .methods
                .iter()
                .map(|m| format!("{} {}", m.label, m.steps))
                .collect();
            println!(
                "Table 4.1 (average absolute deviation over each run; steps: {}):\n",
                steps.join(", ")
            );
            println!("{}", table41::markdown(&table));
        }
    }
    let fallback: String = [report.fallback_summary(), report.events_summary()]
        .into_iter()
        .flatten()
        .map(|f| format!(" ({f})"))
        .collect();
    println!(
        "{}: wrote {} files to {}{fallback}",
        report.title,
        report.files.len(),
        report.out.display()
    );
    println!("open {}", report.out.join("index.html").display());
    for warning in report.fallback_warnings() {
        eprintln!("warning: {warning}");
    }
    if report.out != out {
        eprintln!(
            "note: `{}` holds a complete earlier result, kept as it was; this incomplete run is in `{}`",
            out.display(),
            report.out.display()
        );
    }
    if report.interrupted.is_some() {
        eprintln!("{}", crate::pipeline::interrupted_message(&report));
        return Ok(ExitCode::from(INTERRUPTED as u8));
    }
    if INTERRUPT.load(Ordering::SeqCst) {
        eprintln!("interrupted after the last step: the output above is complete");
        return Ok(ExitCode::from(INTERRUPTED as u8));
    }
    let failed = !report.complete();
    if let Some(why) = &report.thesis_figures_failure {
        eprintln!(
            "error: the thesis's figures were not drawn: {why} (the rest of the output is written)"
        );
    }
    for m in report.failures() {
        if let Some(f) = &m.failure {
            eprintln!(
                "error: method `{}` failed at step {}: {} (its results up to there are in the output)",
                m.label, f.step, f.reason
            );
        }
    }
    // Member runs that failed are rows of the table, not lost output; but the run did not
    // compute what it was asked to, and says so last, with the exit code of a failed method.
    let members_failed = report.ensemble.filter(|c| c.failed_runs > 0);
    if let Some(c) = members_failed {
        eprintln!(
            "error: {} member runs (member and method) failed: the `failure` column of ensemble.csv says where and why",
            c.failed_runs
        );
    }
    Ok(if failed || members_failed.is_some() {
        ExitCode::from(1)
    } else {
        ExitCode::SUCCESS
    })
}

fn list() {
    let c = Catalogue::builtin();
    println!("Systems:");
    for e in c.entries() {
        let info = e.info();
        let params: Vec<String> = info
            .params
            .iter()
            .map(|p| match p.default {
                Some(d) => format!("{} = {d} ({}{})", p.name, p.doc, p.rule.bound()),
                None => format!("{} (required; {}{})", p.name, p.doc, p.rule.bound()),
            })
            .collect();
        println!(
            "  {:<20} n = {}{}{}{}\n  {:<20} {}\n  {:<20} params: {}",
            e.name(),
            info.n,
            if info.time_dependent {
                ", time-dependent"
            } else {
                ""
            },
            if info.sizable {
                " (any size: `sizes = { N = .. }` in [system])"
            } else {
                ""
            },
            // A text of the size a map regularizes.
            match RegularizeMap::ALL.into_iter().find(|m| m.n() == info.n) {
                Some(m) if info.text.is_some() => {
                    format!(
                        " (regularizable: `regularize = \"{}\"` in [system])",
                        m.name()
                    )
                }
                _ => String::new(),
            },
            "",
            e.doc(),
            "",
            if params.is_empty() {
                "none".into()
            } else {
                params.join(", ")
            }
        );
    }
    println!("\nMethods:");
    for k in MethodKind::ALL {
        println!("  {:<20} {}", k.name(), k.doc());
        // Where a method does not run everywhere, the systems it runs on, from the catalogue.
        let offered: Vec<&str> = c
            .entries()
            .iter()
            .filter(|e| e.info().offers(k))
            .map(|e| e.name())
            .collect();
        if offered.len() < c.entries().len() {
            println!("  {:<20} systems: {}", "", offered.join(", "));
        }
    }
    println!("\nEffects:");
    for k in EffectKind::ALL {
        println!("  {:<20} {}", k.name(), k.doc());
        if k == EffectKind::NormalModes {
            // The chains with fixed ends, from the catalogue.
            let chains: Vec<&str> = c
                .entries()
                .iter()
                .filter(|e| e.info().fixed_end_chain)
                .map(|e| e.name())
                .collect();
            println!("  {:<20} systems: {}", "", chains.join(", "));
        }
    }
}

/// Whether `dth ARGS...` parses (for the docs' check that every command they show is one the
/// command accepts); the error is clap's message.
#[cfg(test)]
pub(crate) fn accepts(args: &[String]) -> Result<(), String> {
    Cli::try_parse_from(std::iter::once("dth").chain(args.iter().map(String::as_str)))
        .map(drop)
        .map_err(|e| e.to_string())
}

fn main_inner(cli: Cli) -> Result<ExitCode, CliError> {
    match cli.command {
        None => {
            let out = cli
                .out
                .unwrap_or_else(|| default_out(Path::new("thesis-kepler.toml")));
            run(
                DEFAULT_SCENE,
                DEFAULT_SCENE_NAME,
                &out,
                true,
                &cli.limits.options(),
            )
        }
        Some(Command::Run { scene, out, limits }) => {
            let options = limits.options();
            let text = crate::read_scene(&scene)?;
            let out = out.unwrap_or_else(|| default_out(&scene));
            crate::output::check_outside(&scene, &out)?;
            run(&text, &scene.display().to_string(), &out, false, &options)
        }
        Some(Command::Check { scene, limits }) => {
            let options = limits.options();
            let text = crate::read_scene(&scene)?;
            let catalogue = Catalogue::builtin();
            let s = crate::check_scene(&text, &scene.display().to_string(), &catalogue)?;
            for warning in s.hamiltonian.iter().flat_map(|h| &h.warnings) {
                eprintln!("warning: {warning}");
            }
            let memory = catalogue.estimate(&s, &options)?;
            if let Some(change) = catalogue.probe_psi(&s)? {
                eprintln!("warning: {}", change.warning());
            }
            let per_step = catalogue.seconds_per_step(&s)?;
            let members = s.members.as_ref().map_or(1, |m| m.candidates());
            let threads = options.threads.unwrap_or_else(|| {
                std::thread::available_parallelism().map_or(1, std::num::NonZeroUsize::get)
            });
            let seconds = step_time::run_seconds(&memory, &per_step, members, threads);
            println!(
                "{}: ok ({}, {} method{}, {} effect{}; effects keep about {}, limit {}; stepping takes about {})",
                scene.display(),
                s.system,
                s.methods.len(),
                if s.methods.len() == 1 { "" } else { "s" },
                s.effects.len(),
                if s.effects.len() == 1 { "" } else { "s" },
                budget::human(memory.bytes()),
                budget::human(options.memory_limit()),
                step_time::human(seconds)
            );
            Ok(ExitCode::SUCCESS)
        }
        Some(Command::List) => {
            list();
            Ok(ExitCode::SUCCESS)
        }
        Some(Command::Table41 { json, limits }) => {
            let options = limits.options();
            let table = crate::table41(&options)?;
            // The file before the printing: a closed stdout ends the process (SIGPIPE).
            if let Some(path) = json {
                crate::report::write_json(&path, &table)?;
            }
            print!("{}", table41::markdown(&table));
            Ok(ExitCode::SUCCESS)
        }
        Some(Command::Gallery { manifest, limits }) => {
            let runs = Path::new(DEFAULT_OUT).join("gallery");
            let built = crate::gallery::build(&manifest, &runs, &limits.options())?;
            println!(
                "wrote {} figures and {} (the runs' outputs are in {})",
                built.files.len(),
                built.page.display(),
                runs.display()
            );
            Ok(ExitCode::SUCCESS)
        }
        Some(Command::Derive {
            expr,
            params,
            rust,
            regularize,
        }) => {
            let params: Vec<&str> = params.iter().map(String::as_str).collect();
            let text = match (rust, regularize) {
                (true, _) => crate::derive::rust(&expr, &params)?,
                (false, Some(r)) => crate::derive::derive_regularized(&expr, &params, r)?,
                (false, None) => crate::derive::derive(&expr, &params)?,
            };
            print!("{text}");
            Ok(ExitCode::SUCCESS)
        }
        Some(Command::Workprecision {
            out,
            quick,
            problems,
        }) => {
            let out = out.unwrap_or_else(|| Path::new(DEFAULT_OUT).join("workprecision"));
            let mut options = if quick {
                WorkPrecisionOptions::quick()
            } else {
                WorkPrecisionOptions::default()
            };
            if !problems.is_empty() {
                options = options
                    .with_problems(&problems)
                    .map_err(CliError::WorkPrecision)?;
            }
            let staging = Staging::new(&out)?;
            let summary =
                workprecision::run(&options, staging.path()).map_err(CliError::WorkPrecision)?;
            let out = staging.commit(true)?;
            print!("{}", summary.tables);
            println!(
                "wrote {} files ({} runs) to {}",
                summary.files.len(),
                summary.records.len(),
                out.display()
            );
            Ok(ExitCode::SUCCESS)
        }
    }
}

/// A closed stdout (`dth derive ... | head`) ends the process quietly, as it does other Unix
/// tools, instead of a panic in `println!`: SIGPIPE gets back its default action, which Rust's
/// runtime sets to "ignore". Nothing is lost: every command prints only after its output
/// folder or file is committed.
#[cfg(unix)]
fn restore_sigpipe() {
    // SAFETY: restores a signal's default disposition, first thing in `main`, before any
    // other thread exists; no handler runs Rust code.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
}

/// Exit code of a run stopped by SIGINT or SIGTERM (128 + SIGINT, the shell's convention).
const INTERRUPTED: i32 = 130;

/// Set by the first SIGINT or SIGTERM during a scene's run: the run stops at the next step
/// and writes what it computed (`RunOptions::interrupt`).
static INTERRUPT: AtomicBool = AtomicBool::new(false);

/// `true` from the start of a scene's run (`dth run`, the default scene) to the end of the
/// process: a first signal then sets [`INTERRUPT`] instead of ending the process (after the
/// last step, the run reports it and exits 130 with its output complete).
static GRACEFUL: AtomicBool = AtomicBool::new(false);

/// On SIGINT or SIGTERM: during a scene's run, the first signal stops it at the next step
/// (what it computed is written, exit 130); a second signal, or one outside a run (`table41`,
/// `workprecision`, ...), exits at once with nothing written: the staging folder is removed
/// and the previous output folder is untouched (see `output::remove_live_staging`).
fn on_signal() {
    if GRACEFUL.load(Ordering::SeqCst) && !INTERRUPT.swap(true, Ordering::SeqCst) {
        eprintln!(
            "interrupted: stopping at the next step to write what was computed (again to quit without writing)"
        );
        return;
    }
    crate::output::remove_live_staging();
    eprintln!("interrupted: nothing was written");
    std::process::exit(INTERRUPTED);
}

/// The `dth` command on the process's arguments: its exit code (0, 1 for a failed run, 2 for
/// bad input, 130 when interrupted), errors printed with their chain.
pub fn main() -> ExitCode {
    #[cfg(unix)]
    restore_sigpipe();
    if let Err(e) = ctrlc::set_handler(on_signal) {
        eprintln!("warning: cannot install the SIGINT/SIGTERM handler ({e}): an interrupted run may leave a temporary folder behind");
    }
    let cli = Cli::parse();
    match main_inner(cli) {
        Ok(code) => code,
        Err(e) => {
            print_error(&e);
            ExitCode::from(e.exit_code() as u8)
        }
    }
}

/// Prints `e` on stderr as `error: ...`, then each error it was caused by on a line of its
/// own (`  caused by: ...`): how the binaries of this crate report a failure.
pub fn print_error(e: &dyn std::error::Error) {
    eprintln!("error: {e}");
    let mut source = e.source();
    while let Some(s) = source {
        eprintln!("  caused by: {s}");
        source = s.source();
    }
}
