//! Ensemble scenes: many members (initial states and parameters drawn by a grid, seeded random
//! samples or an explicit list, optionally put on an energy shell `H = E`), each run with every
//! method of the scene for its duration, on every core and, with the `mpi` feature, across
//! MPI ranks; one table of results, every member's section crossings in one figure, and a
//! chaos map (MEGNO) when asked.
//!
//! - [`sample`]: the members a sampler draws and the energy shell;
//! - [`chaos`]: MEGNO and Benettin's Lyapunov estimate from the variational equations;
//! - [`step_check`]: a chaos map's verdicts against half the step, on a sample of members;
//! - [`member`]: one member run with every method;
//! - [`wire`]: a member's results as bytes (MPI);
//! - [`schedule`]: members over threads (rayon) and ranks (MPI), gathered in member order;
//! - [`report`]: the table (CSV, JSON), the section figure, the chaos map, `index.html`;
//! - [`run`] (here): all of it into a staged output folder.
//!
//! The files do not depend on the thread count or the number of ranks (see [`schedule`]).

pub mod chaos;
pub mod member;
pub mod report;
pub mod sample;
pub mod schedule;
pub mod step_check;
pub mod wire;

use dth::nalgebra::{DefaultAllocator, Dim};
use dth::Alloc;
use std::path::Path;

use indicatif::{ProgressBar, ProgressStyle};

use crate::error::Error;
use crate::output::Staging;
use crate::pipeline::RunError;
use crate::report::{write_file, write_json, Interrupted, RunReport};
use crate::scene::Scene;
use crate::simulate::RunOptions;
use crate::system::SceneSystem;

pub use member::Build;

/// The one progress bar of an ensemble: members done of all.
fn progress(count: usize, options: &RunOptions) -> ProgressBar {
    if !options.progress || schedule::is_worker_rank() {
        return ProgressBar::hidden();
    }
    let bar = ProgressBar::new(count as u64);
    if let Ok(style) = ProgressStyle::with_template(
        "{prefix:>20} [{bar:40}] {pos}/{len} members {elapsed} (eta {eta})",
    ) {
        bar.set_style(style.progress_chars("=> "));
    }
    bar.set_prefix("ensemble");
    bar
}

/// The report of a process that wrote nothing (an MPI rank other than 0): no files, no
/// output folder.
pub fn idle_report(scene: &Scene) -> RunReport {
    RunReport {
        title: scene.title.clone(),
        system: scene.system.clone(),
        params: scene.params.clone(),
        out: Default::default(),
        methods: Vec::new(),
        files: Vec::new(),
        table41: None,
        thesis_figures: Vec::new(),
        thesis_figures_failure: None,
        ensemble: None,
        interrupted: None,
    }
}

/// Runs the ensemble scene `scene` (it has [`Scene::members`]) with systems made by `build`
/// and writes its files into `out` (staged, moved into place when everything is written).
/// On an MPI rank other than 0 it computes its share and writes nothing (the report it
/// returns lists no files).
///
/// Members that fail or cannot run are rows of the table, not errors. An interrupted run
/// ([`RunOptions::interrupt`]) writes its table (members interrupted mid-run and members not
/// run are rows saying so) and returns [`RunError::Interrupted`].
///
/// # Errors
/// [`RunError::NotRun`] for a scene without an ensemble, an output folder that is refused,
/// or what fails for every member alike (a method the system does not offer, an energy shell
/// the system cannot be solved on).
pub fn run<D: Dim, S: SceneSystem<D>>(
    build: &Build<'_, S>,
    scene: &Scene,
    out: &Path,
    options: &RunOptions,
) -> Result<RunReport, RunError>
where
    DefaultAllocator: Alloc<D>,
{
    let members = scene.members.as_ref().ok_or_else(|| Error::NotAvailable {
        what: "ensemble of scene",
        name: scene.title.clone(),
        reason: "the scene has no `[ensemble]` with a `kind`".into(),
    })?;
    // The phase-space dimension, for the table's columns (`Dyn` knows it from a value only).
    let dim = build(&scene.params)?.dim().value();
    let worker = schedule::is_worker_rank();
    let staging = if worker {
        None
    } else {
        Some(Staging::new(out)?)
    };
    let candidates = sample::draw(members, scene)?;
    let bar = progress(candidates.len(), options);
    let results = schedule::run_members(candidates.len(), options.threads, &bar, |i| {
        member::run_member(build, scene, members, &candidates[i], options)
    })?;
    bar.finish_and_clear();
    // Every rank takes part (the members are shared out as above); rank 0 compares.
    let check = match (&members.chaos, options.interrupted()) {
        (Some(_), false) => {
            let sampled = step_check::sample(candidates.len());
            let half = step_check::halved(scene);
            let bar = progress(sampled.len(), options);
            bar.set_prefix("half-step check");
            let runs = schedule::run_members(sampled.len(), options.threads, &bar, |k| {
                member::run_member(build, &half, members, &candidates[sampled[k]], options)
            })?;
            bar.finish_and_clear();
            match (&results, runs) {
                (Some(full), Some(runs)) if !options.interrupted() => {
                    Some(step_check::compare(full, &sampled, &runs))
                }
                _ => None,
            }
        }
        _ => None,
    };
    let (Some(results), Some(staging)) = (results, staging) else {
        // A worker rank: rank 0 writes.
        return Ok(idle_report(scene));
    };
    let mut report = idle_report(scene);
    report.out = out.to_path_buf();
    let dir = staging.path().to_path_buf();
    let (mut files, counts) = report::write(&dir, scene, members, dim, &results, check)?;
    files.push("summary.json".into());
    files.push("index.html".into());
    write_file(
        &dir.join("index.html"),
        report::index(scene, &counts, &files),
    )?;
    report.files = files;
    report.ensemble = Some(counts);
    if options.interrupted() {
        // The table marks the members interrupted mid-run and the ones not run.
        report.interrupted = Some(Interrupted {
            method: None,
            step: None,
            t: None,
            not_run: Vec::new(),
            during: Some(
                "the ensemble's members (ensemble.csv marks the ones interrupted or not run)"
                    .into(),
            ),
        });
    }
    // `summary.json` has the same form as a single run's: no methods of its own (they are
    // the table's), the counts under `ensemble`.
    let complete = report.interrupted.is_none();
    report.out = staging.destination(complete)?;
    write_json(&dir.join("summary.json"), &report)?;
    report.out = staging.commit(complete)?;
    if report.interrupted.is_some() {
        return Err(RunError::Interrupted {
            report: Box::new(report),
        });
    }
    Ok(report)
}
