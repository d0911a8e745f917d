//! The pipeline of `dth run`: simulate a validated scene on a concrete system, report the
//! results into a staged folder, and move the folder into place only when everything
//! succeeded ([`run_system`]). A run that lost a method, or was interrupted, is an error
//! ([`RunError`]) that still carries everything written.

use dth::nalgebra::{DefaultAllocator, Dim};
use dth::Alloc;
use std::path::Path;

use crate::error::Error;
use crate::error::FailureCause;
use crate::output::Staging;
use crate::report::{
    csv, figures, html, table41, thesis, write_file, write_json, Interrupted, RunReport,
};
use crate::scene::Scene;
use crate::simulate::{compute, initial_state, MethodResult, MethodSummary, RunOptions};
use crate::system::SceneSystem;

/// Why a run did not complete: it did not run, or it ran and lost methods.
///
/// A run that lost a method is not `Ok`: a program built on [`run_system`] (or
/// `dth_examples::run_scene`) that does `run(...)?` stops there, as `dth run` exits with 1.
/// The partial report (every file written, the failures in [`RunReport::failures`]) is in
/// [`RunError::MethodsFailed`]; [`RunError::partial_report`] takes it out.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    /// The scene did not run (invalid scene, refused or unwritable output folder, a system
    /// or method that cannot run): nothing was written to the output folder.
    #[error(transparent)]
    NotRun(#[from] Error),
    /// The scene ran and every output was written, but at least one method failed mid-run
    /// (its results up to the failing step are in the output), or a run of the thesis's
    /// figures failed (they are missing; [`RunReport::thesis_figures_failure`] says why).
    #[error("{}", failures_message(report))]
    MethodsFailed {
        /// What the run wrote; [`RunReport::failures`] lists the failed methods.
        report: Box<RunReport>,
    },
    /// The run was interrupted (`RunOptions::interrupt`; the `dth` command's SIGINT and
    /// SIGTERM): it stopped at the next step and wrote what it had computed;
    /// [`RunReport::interrupted`] says where.
    #[error("{}", interrupted_message(report))]
    Interrupted {
        /// What the run wrote.
        report: Box<RunReport>,
    },
}

impl RunError {
    /// The process exit code: the error's ([`Error::exit_code`]), 1 for failed methods, 130
    /// (128 + SIGINT, the shell's convention) for an interrupted run.
    pub fn exit_code(&self) -> i32 {
        match self {
            RunError::NotRun(e) => e.exit_code(),
            RunError::MethodsFailed { .. } => 1,
            RunError::Interrupted { .. } => 130,
        }
    }

    /// The report of a run that lost methods or was interrupted (its outputs are written);
    /// the error itself when nothing ran.
    pub fn partial_report(self) -> Result<RunReport, Error> {
        match self {
            RunError::NotRun(e) => Err(e),
            RunError::MethodsFailed { report } | RunError::Interrupted { report } => Ok(*report),
        }
    }

    /// The error for a written `report` that is not complete: interrupted, or with failures;
    /// `Ok(report)` for a complete one.
    pub fn incomplete(report: RunReport) -> Result<RunReport, RunError> {
        if report.interrupted.is_some() {
            Err(RunError::Interrupted {
                report: Box::new(report),
            })
        } else if !report.complete() {
            Err(RunError::MethodsFailed {
                report: Box::new(report),
            })
        } else {
            Ok(report)
        }
    }
}

/// "interrupted before step 3 of method `a` (last state at t = 0.3); not run: b" and where
/// what was computed up to there is.
pub fn interrupted_message(report: &RunReport) -> String {
    let Some(i) = &report.interrupted else {
        return failures_message(report);
    };
    format!(
        "{i} (what was computed up to there is in `{}`)",
        report.out.display()
    )
}

/// Where `results` (of `scene`) were interrupted, if they were: the method whose failure is
/// [`FailureCause::Interrupted`] and the methods after it, which did not run.
/// Or the method whose ensemble of initial states was interrupted (its own run completed).
fn interruption(scene: &Scene, results: &[MethodResult]) -> Option<Interrupted> {
    let last = results.last()?;
    let not_run = || {
        scene.methods[results.len()..]
            .iter()
            .map(|m| m.label.clone())
            .collect()
    };
    if last.ensemble_interrupted {
        return Some(Interrupted {
            during: Some(format!(
                "the ensemble of method `{}` (its members from the interrupted one on are not in it)",
                last.summary.label
            )),
            method: None,
            step: None,
            t: None,
            not_run: not_run(),
        });
    }
    let f = last.failure.as_ref()?;
    (f.cause == FailureCause::Interrupted).then(|| Interrupted {
        during: None,
        method: Some(last.summary.label.clone()),
        step: Some(f.step),
        t: Some(last.summary.t_end),
        not_run: not_run(),
    })
}

/// "method `a` failed at step 3: why; method `b` ... (what they computed is in OUT)".
fn failures_message(report: &RunReport) -> String {
    let failed: Vec<String> = report
        .failures()
        .filter_map(|m| {
            m.failure.as_ref().map(|f| {
                format!(
                    "method `{}` failed at step {}: {}",
                    m.label, f.step, f.reason
                )
            })
        })
        .chain(
            report
                .thesis_figures_failure
                .iter()
                .map(|why| format!("the thesis's figures were not drawn: {why}")),
        )
        .collect();
    format!(
        "{} (what was computed up to there is in `{}`)",
        failed.join("; "),
        report.out.display()
    )
}

/// Runs `scene` on `system` and writes the output folder `out` (see [`crate::output`] for
/// the rules: staged, moved into place once written, replacing only what dth wrote there; an
/// incomplete run over a complete result goes beside it, [`RunReport::out`] says where).
///
/// A method that fails mid-run does not abort the run: its results up to the failing step
/// are written, the folder is moved into place, and the run returns
/// [`RunError::MethodsFailed`] with the report (the `dth` command then exits with code 1).
/// An interrupted run ([`RunOptions::interrupt`]) likewise writes what it computed and returns
/// [`RunError::Interrupted`] (exit code 130); the thesis's figures are then not drawn.
pub fn run_system<D: Dim, S: SceneSystem<D>>(
    system: &S,
    scene: &Scene,
    out: &Path,
    options: &RunOptions,
) -> Result<RunReport, RunError>
where
    DefaultAllocator: Alloc<D>,
{
    let staging = Staging::new(out)?;
    let results = compute(system, scene, options)?;
    let mut interrupted = interruption(scene, &results);
    let dir = staging.path().to_path_buf();
    let mut files = csv::write(&dir, scene, &results)?;
    files.extend(figures::write(
        &dir,
        scene,
        &results,
        system.invariant_names(),
    )?);
    let methods: Vec<MethodSummary> = results.into_iter().map(|r| r.summary).collect();
    let (table41, thesis_figures, thesis_figures_failure) = if scene.thesis_figures {
        let z0 = initial_state(system, scene)?;
        // The figures run the methods again (and at finer steps): one that fails there costs
        // the figures, not the rest of the output, which is written as for a failed method.
        // An interrupted run does not start them; one interrupted during them loses them.
        let drawn = match interrupted {
            Some(_) => Err("the run was interrupted before them".to_string()),
            None => thesis::figures(system, scene, &z0, &dir, options).map_err(|e| {
                if options.interrupted() {
                    interrupted = Some(Interrupted {
                        method: None,
                        step: None,
                        t: None,
                        not_run: Vec::new(),
                        during: Some("the thesis's figures (they are not drawn)".into()),
                    });
                    "the run was interrupted while they were computed".to_string()
                } else {
                    e.to_string()
                }
            }),
        };
        let (figures, failure) = match drawn {
            Ok(figures) => (figures, None),
            Err(why) => (Vec::new(), Some(why)),
        };
        for f in &figures {
            files.push(format!("{}.png", f.stem));
            files.push(format!("{}.svg", f.stem));
        }
        let table = table41::rows_from(&methods);
        write_json(&dir.join("table41.json"), &table)?;
        files.push("table41.json".into());
        (Some(table), figures, failure)
    } else {
        (None, Vec::new(), None)
    };
    files.push("summary.json".into());
    files.push("index.html".into());
    let mut report = RunReport {
        title: scene.title.clone(),
        system: scene.system.clone(),
        params: scene.params.clone(),
        out: out.to_path_buf(),
        methods,
        files,
        table41,
        thesis_figures,
        thesis_figures_failure,
        ensemble: None,
        interrupted,
    };
    // An incomplete run does not replace a complete earlier result (`crate::output`): the
    // summary and the page name the folder it goes to.
    let complete = report.complete();
    report.out = staging.destination(complete)?;
    write_file(&dir.join("index.html"), html::index(scene, &report))?;
    write_json(&dir.join("summary.json"), &report)?;
    report.out = staging.commit(complete)?;
    RunError::incomplete(report)
}
