//! Scenes and the `dth` command: run Hamiltonian systems from TOML scene files, compute only
//! the requested effects, and write CSV, JSON, figures and a static `index.html`.
//!
//! The binary is thin; everything is here so a user can run a scene on their own system from
//! their own crate: implement [`catalogue::SceneSystem`] for it (a `hamiltonian!` type or a
//! hand-written `Hamiltonian`), register it in a [`catalogue::Catalogue`], and call
//! [`check_scene`] / [`run_scene`]. See `examples/custom_system.rs`.
//!
//! ```
//! use dth_examples::{catalogue::Catalogue, check_scene};
//! let scene = check_scene(dth_examples::DEFAULT_SCENE, "thesis-kepler.toml", &Catalogue::builtin())
//!     .unwrap();
//! assert_eq!(scene.system, "kepler");
//! ```
#![warn(missing_docs)]

use std::path::Path;

pub mod catalogue;
pub mod effects;
pub mod error;
pub mod html;
pub mod method;
pub mod output;
pub mod plot;
pub mod run;
pub mod scene;
pub mod systems;
pub mod table41;
pub mod thesis;
pub mod workprecision;

pub use error::Error;

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

/// Validates and runs a scene into `out` (staged; moved into place only on success).
pub fn run_scene(
    text: &str,
    file: &str,
    catalogue: &catalogue::Catalogue,
    out: &Path,
    options: &run::RunOptions,
) -> Result<run::RunReport, Error> {
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
