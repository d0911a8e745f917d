//! Scenes and the `dth` command: run Hamiltonian systems from TOML scene files, compute only
//! the requested effects, and write CSV, JSON, figures and a static `index.html`.
//!
//! A scene may also write its own Hamiltonian (`[system] hamiltonian = "..."`), which runs
//! without recompiling ([`runtime_system`]).
//!
//! The binary is thin; everything is here so a user can run a scene on their own system from
//! their own crate: implement [`system::SceneSystem`] for it (a `hamiltonian!` type or a
//! hand-written `Hamiltonian`), register it in a [`catalogue::Catalogue`], and call
//! [`check_scene`] / [`run_scene`]. See `examples/custom_system.rs`.
//!
//! # Layers
//! Each module imports only from the ones listed before it:
//!
//! 1. [`error`] (the error type, how a method run fails), [`plot`] (figure primitives),
//!    [`output`] (the staged output folder), [`json`] (JSON with non-finite numbers as
//!    strings);
//! 2. [`scene`]: its schema (the validated types), the serde form, and validation against a
//!    [`scene::SystemLookup`];
//! 3. [`driver`]: when runs stop, the fixed-step and DTH drivers, one observer protocol
//!    (`dth::observer`); [`regularized`]: DTH on a scene's regularized `K`, every record mapped
//!    back to physical coordinates;
//! 4. [`system`] (what a scene needs of a system) and [`systems`] (the built-in ones);
//! 5. [`method`] (a scene's method name to an integrator), [`normal_modes`] (a chain's linear
//!    normal modes and their energies), [`effects`] (observers for the requested effects),
//!    [`singularity`] (whether a regularization applies at a state: a `1/r`-like singularity
//!    in two or three degrees of freedom), [`fallback`] (what robust DTH's fallback steps
//!    were and why, from the step records) and [`events`] (a scene's `[[event]]` conditions
//!    compiled, and what fired);
//! 6. [`budget`] (the memory a run's effects will keep, checked before it runs), then
//!    [`simulate`]: every method of a scene on a system, results in memory, and [`probe`]
//!    (`dth check`'s look at the sign of `Psi` along a scene's orbit);
//! 7. [`report`]: CSV, figures, Table 4.1, the thesis's figures, `index.html`;
//! 8. [`ensemble`] (ensemble scenes: members on every core and MPI rank, their table and
//!    figures) and [`pipeline`]: simulate, report, stage;
//! 9. [`runtime_system`] (a scene's Hamiltonian given as text, compiled when the scene loads:
//!    a [`system::SceneSystem`] of dimension `Dyn`), then [`catalogue`]: the systems scenes can
//!    name, each bound to the pipeline, and the same path for a text Hamiltonian; then this
//!    file and `main.rs`.
//!
//! [`gallery`] (the documentation's figures, `dth gallery`) runs scenes and the benchmark
//! through this file's [`run_scene`], so it sits at the top with the command.
//!
//! [`workprecision`] (the benchmark behind `dth workprecision`) and [`derive`](mod@derive) (what the
//! symbolic engine derives from a Hamiltonian as text, `dth derive`) sit beside the scene
//! stack and use only layer 1 (and `derive` the scene's names of the regularizations).
//!
//! ```
//! use dth_examples::{catalogue::Catalogue, check_scene};
//! let scene = check_scene(dth_examples::DEFAULT_SCENE, "thesis-kepler.toml", &Catalogue::builtin())
//!     .unwrap();
//! assert_eq!(scene.system, "kepler");
//! ```
#![warn(missing_docs)]

use std::path::Path;

pub mod error;
pub mod json;
pub mod output;
pub mod plot;

pub mod scene;

pub mod driver;
pub mod regularized;

pub mod system;
pub mod systems;

pub mod effects;
pub mod events;
pub mod fallback;
pub mod method;
pub mod normal_modes;
pub mod output_times;
pub mod singularity;

pub mod budget;
pub mod probe;
pub mod simulate;
pub mod step_time;

pub mod report;

pub mod ensemble;
pub mod pipeline;

pub mod runtime_system;

pub mod catalogue;
pub mod cli;
pub mod gallery;

#[cfg(test)]
mod docs_check;

pub mod derive;
pub mod workprecision;

pub use error::Error;
pub use pipeline::RunError;

/// The default scene (the thesis's Kepler experiment), embedded in the binary.
pub const DEFAULT_SCENE: &str = include_str!("../scenes/thesis-kepler.toml");

/// The file name shown in diagnostics of the embedded default scene.
pub const DEFAULT_SCENE_NAME: &str = "thesis-kepler.toml (embedded)";

/// The default output folder's parent: a run of scene `NAME.toml` writes `dth-out/NAME/`.
pub const DEFAULT_OUT: &str = "dth-out";

/// Parses and validates a scene (no computation).
pub fn check_scene(
    text: &str,
    file: &str,
    catalogue: &catalogue::Catalogue,
) -> Result<scene::Scene, Error> {
    scene::parse(text, file, catalogue)
}

/// Validates and runs a scene into `out` (staged; moved into place once every output is
/// written).
///
/// # Errors
/// [`RunError::NotRun`] when the scene is invalid or cannot run (nothing is written), and
/// [`RunError::MethodsFailed`] when a method failed mid-run: the outputs are written and the
/// error carries their report, so a caller cannot mistake a partial run for a complete one;
/// [`RunError::Interrupted`] likewise for a run stopped through `RunOptions::interrupt`.
pub fn run_scene(
    text: &str,
    file: &str,
    catalogue: &catalogue::Catalogue,
    out: &Path,
    options: &simulate::RunOptions,
) -> Result<report::RunReport, RunError> {
    let scene = scene::parse(text, file, catalogue)?;
    output::check_target(out)?;
    catalogue.run(&scene, out, options)
}

/// Reads a scene file.
pub fn read_scene(path: &Path) -> Result<String, Error> {
    std::fs::read_to_string(path).map_err(|source| Error::SceneUnreadable {
        path: path.to_path_buf(),
        source,
    })
}

/// The thesis's Table 4.1 with the embedded default scene's settings: its methods that the
/// table has, the `comparison_table` effect only, run on the built-in Kepler system.
///
/// # Errors
/// A method that fails ([`Error::MethodFailed`]): the table needs every row.
pub fn table41(options: &simulate::RunOptions) -> Result<report::table41::Table, Error> {
    use scene::{EffectSpec, MethodKind};
    let catalogue = catalogue::Catalogue::builtin();
    let mut scene = check_scene(DEFAULT_SCENE, DEFAULT_SCENE_NAME, &catalogue)?;
    scene.effects = vec![EffectSpec::ComparisonTable];
    // The table needs neither the square of initial conditions nor the figures.
    scene.ensemble = None;
    scene.thesis_figures = false;
    scene.methods.retain(|m| {
        matches!(
            m.kind,
            MethodKind::Trapezoidal
                | MethodKind::Midpoint
                | MethodKind::DiscreteMechanics
                | MethodKind::Dth
        )
    });
    // The catalogue's `hamiltonian!` Kepler with the scene's parameters (validation filled in
    // every declared parameter: m = 1/2 and k = 1 by default).
    let param = |name: &str| {
        scene
            .params
            .get(name)
            .copied()
            .ok_or_else(|| Error::NotAvailable {
                what: "system",
                name: scene.system.clone(),
                reason: format!("the default scene has no parameter `{name}`"),
            })
    };
    let kepler = systems::Kepler {
        m: param("m")?,
        k: param("k")?,
    };
    let results = simulate::compute(&kepler, &scene, options)?;
    let mut summaries = Vec::with_capacity(results.len());
    for r in results {
        if let Some(failure) = r.failure {
            return Err(Error::MethodFailed {
                method: r.summary.label,
                failure,
            });
        }
        summaries.push(r.summary);
    }
    Ok(report::table41::rows_from(&summaries))
}
