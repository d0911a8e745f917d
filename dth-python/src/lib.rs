//! The extension module `dth._dth` of the Python package `dth`: a run-time Hamiltonian read as
//! text ([`hamiltonian::Hamiltonian`]), one call that runs a whole integration in Rust
//! ([`integrate::integrate`]) and its result ([`solution::Solution`]), and the exceptions
//! ([`errors`]). The pure-Python package around it (`python/dth/`) re-exports these, adds
//! `dth.systems` and carries the type stubs.
//!
//! Every long call runs without the GIL on a worker thread and polls Python's signal
//! handlers, so Ctrl-C stops it within [`interrupt::POLL`] ([`interrupt::run`]).

use pyo3::prelude::*;

pub mod args;
pub mod catalogue;
pub mod ensemble;
pub mod errors;
pub mod hamiltonian;
pub mod integrate;
pub mod interrupt;
pub mod regularized;
pub mod scene;
pub mod sized;
pub mod solution;
pub mod state;

/// The module `dth._dth`.
#[pymodule]
fn _dth(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    // numpy's C API is loaded on its first use, which runs Python code (numpy's version
    // check). Loaded here, at import, no later call runs Python code before its worker
    // starts, so a Ctrl-C in that window stays pending for the worker's poll (`interrupt`)
    // instead of interrupting the load (which the numpy crate turns into a panic).
    numpy::PyArray1::<f64>::zeros(py, 0, false);
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add(
        "HamiltonianError",
        py.get_type::<errors::HamiltonianError>(),
    )?;
    m.add(
        "IntegrationError",
        py.get_type::<errors::IntegrationError>(),
    )?;
    m.add_class::<hamiltonian::Hamiltonian>()?;
    m.add_class::<solution::Solution>()?;
    m.add("SceneError", py.get_type::<scene::SceneError>())?;
    m.add_class::<ensemble::Ensemble>()?;
    m.add_function(wrap_pyfunction!(integrate::integrate, m)?)?;
    m.add_function(wrap_pyfunction!(ensemble::ensemble, m)?)?;
    m.add_function(wrap_pyfunction!(scene::run_scene_into, m)?)?;
    m.add_function(wrap_pyfunction!(catalogue::builtin, m)?)?;
    m.add_function(wrap_pyfunction!(catalogue::evaluate, m)?)?;
    m.add("METHODS", args::METHODS.to_vec())?;
    Ok(())
}
