//! The pipeline of `dth run`: simulate a validated scene on a concrete system, report the
//! results into a staged folder, and move the folder into place only when everything
//! succeeded ([`run_system`]).

use std::path::Path;

use crate::error::Error;
use crate::output::Staging;
use crate::report::{csv, figures, html, table41, thesis, write_file, write_json, RunReport};
use crate::scene::Scene;
use crate::simulate::{compute, initial_state, MethodSummary, RunOptions};
use crate::system::SceneSystem;

/// Runs `scene` on `system` and writes the output folder `out` (see [`crate::output`] for
/// the rules: staged, moved into place only on success, replaces only dth output folders).
///
/// A method that fails mid-run does not abort the run: its results up to the failing step
/// are written, and the failure is in [`RunReport::failures`] (the `dth` command then exits
/// with code 1 after writing).
pub fn run_system<const D: usize, S: SceneSystem<D>>(
    system: &S,
    scene: &Scene,
    out: &Path,
    options: &RunOptions,
) -> Result<RunReport, Error> {
    let staging = Staging::new(out)?;
    let results = compute(system, scene, options)?;
    let dir = staging.path().to_path_buf();
    let mut files = csv::write(&dir, scene, &results)?;
    files.extend(figures::write(
        &dir,
        scene,
        &results,
        system.invariant_names(),
    )?);
    let methods: Vec<MethodSummary> = results.into_iter().map(|r| r.summary).collect();
    let (table41, thesis_figures) = if scene.thesis_figures {
        let z0 = initial_state(system, scene)?;
        let figures = thesis::figures(system, scene, &z0, &dir, options)?;
        for f in &figures {
            files.push(format!("{}.png", f.stem));
            files.push(format!("{}.svg", f.stem));
        }
        let table = table41::rows_from(&methods);
        write_json(&dir.join("table41.json"), &table)?;
        files.push("table41.json".into());
        (Some(table), figures)
    } else {
        (None, Vec::new())
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
    };
    write_file(&dir.join("index.html"), html::index(scene, &report))?;
    write_json(&dir.join("summary.json"), &report)?;
    report.out = staging.commit()?;
    Ok(report)
}
