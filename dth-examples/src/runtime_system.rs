//! Scenes whose `[system]` gives the Hamiltonian as text (`hamiltonian = "..."`): the
//! expression validation read ([`TextHamiltonian`]) built into a
//! [`dth::runtime::RuntimeHamiltonian`] (the engine's derivatives compiled to machine code
//! when the scene loads) and run through the same pipeline as a catalogue system.
//!
//! Running needs the core to take a phase-space dimension known only at run time
//! (`docs/runtime_dimension.md`): until it does, [`run`] and [`estimate`] refuse with
//! [`Error::NotAvailable`] saying so, after validation has checked everything else.

use dth::runtime::RuntimeHamiltonian;

use crate::budget::MemoryEstimate;
use crate::error::Error;
use crate::pipeline::RunError;
use crate::report::RunReport;
use crate::scene::{Scene, TextHamiltonian};
use crate::simulate::RunOptions;

/// The scene's Hamiltonian given as text, compiled with the scene's parameters.
///
/// # Errors
/// [`Error::NotAvailable`] when the scene names a catalogue system, or (for a scene built by
/// hand, since validation reports these at their place in the file) when the expression or
/// a parameter is refused.
///
/// ```
/// use dth_examples::{catalogue::Catalogue, check_scene, runtime_system::build};
/// let scene = check_scene(
///     "[system]\nhamiltonian = \"p1^2/2 + k*q1^2/2\"\nparams = { k = 4.0 }\n\
///      [initial]\nq = [1.0]\np = [0.0]\n[[method]]\nkind = \"midpoint\"\ndt = 0.1\n\
///      [duration]\nsteps = 10\n",
///     "spring.toml",
///     &Catalogue::builtin(),
/// )?;
/// let h = build(&scene)?;
/// assert_eq!(h.value(&[1.0, 0.0]).unwrap(), 2.0);
/// # Ok::<(), dth_examples::Error>(())
/// ```
pub fn build(scene: &Scene) -> Result<RuntimeHamiltonian, Error> {
    let h = text(scene)?;
    let params: Vec<(&str, f64)> = scene.params.iter().map(|(k, &v)| (k.as_str(), v)).collect();
    RuntimeHamiltonian::new(&h.source, &params).map_err(|e| Error::NotAvailable {
        what: "system",
        name: scene.system.clone(),
        reason: e.to_string(),
    })
}

/// The scene's [`TextHamiltonian`].
fn text(scene: &Scene) -> Result<&TextHamiltonian, Error> {
    scene
        .hamiltonian
        .as_ref()
        .ok_or_else(|| Error::NotAvailable {
            what: "system",
            name: scene.system.clone(),
            reason: "the scene names a catalogue system, not a Hamiltonian given as text".into(),
        })
}

/// Why a Hamiltonian given as text does not run in this build.
fn not_yet(scene: &Scene) -> Error {
    Error::NotAvailable {
        what: "system",
        name: scene.system.clone(),
        reason: "the scene is valid, but running a Hamiltonian given as text needs the core to take a phase-space dimension known at run time (docs/runtime_dimension.md), which this build does not have yet".into(),
    }
}

/// Runs a validated scene whose Hamiltonian is given as text into `out`, as
/// [`crate::catalogue::Catalogue::run`] runs a catalogue system.
///
/// # Errors
/// [`Error::NotAvailable`] in this build (nothing is written): see the module docs.
pub fn run(
    scene: &Scene,
    out: &std::path::Path,
    options: &RunOptions,
) -> Result<RunReport, RunError> {
    let _ = (text(scene)?, out, options);
    Err(not_yet(scene).into())
}

/// What the run's effects would keep in memory, as
/// [`crate::catalogue::Catalogue::estimate`] gives it for a catalogue system.
///
/// # Errors
/// [`Error::NotAvailable`] in this build: see the module docs.
pub fn estimate(scene: &Scene, options: &RunOptions) -> Result<MemoryEstimate, Error> {
    let _ = (text(scene)?, options);
    Err(not_yet(scene))
}
