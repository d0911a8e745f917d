//! Runs on a text Hamiltonian at the size its dimension picks: a state of dimension 2 or 4 at
//! `Const<N>` through [`dth::runtime::Fixed`] (stack vectors, fixed-size LU, as the scene
//! runner runs small texts), any other at `Dyn` on the [`RuntimeHamiltonian`] itself. The
//! same compiled code either way, so the same derivatives. `integrate` and `ensemble` both
//! go through [`dispatch`].

use std::sync::Arc;

use pyo3::exceptions::PyRuntimeError;
use pyo3::prelude::*;

use dth::nalgebra::{DVector, DefaultAllocator, Dim, OVector, SVector};
use dth::runtime::{Fixed, RuntimeHamiltonian};
use dth::solve::Integrator;
use dth::{Alloc, Method};

/// What runs with a method on a Hamiltonian of a size chosen for it: by [`dispatch`] (a text)
/// or by [`crate::catalogue::dispatch`] (a catalogue system).
pub trait Job {
    /// What the job returns.
    type Output;

    /// Runs `method` on `h`, whose states are `OVector<f64, D>`; `state` converts a `DVector`
    /// of `h`'s dimension to one. A run clones `method` (a method keeps state from step to
    /// step).
    fn run<D, H, I, S>(self, h: &H, method: I, state: S) -> Self::Output
    where
        D: Dim,
        H: dth::Hamiltonian<D> + Sync,
        I: Integrator<D, H> + Clone + Send + Sync,
        S: Fn(&DVector<f64>) -> OVector<f64, D> + Sync,
        DefaultAllocator: Alloc<D>,
        OVector<f64, D>: Send,
        dth::Solution<D>: Send;
}

/// Runs `job` with `method` on `h` at the size its dimension picks (see the module docs).
pub fn dispatch<J: Job>(
    h: &Arc<RuntimeHamiltonian>,
    method: Method,
    job: J,
) -> PyResult<J::Output> {
    match h.dimension() {
        2 => fixed::<2, J>(h, method, job),
        4 => fixed::<4, J>(h, method, job),
        _ => Ok(job.run(&**h, method, DVector::clone)),
    }
}

/// `job` at `Const<N>` through [`Fixed`].
fn fixed<const N: usize, J: Job>(
    h: &Arc<RuntimeHamiltonian>,
    method: Method,
    job: J,
) -> PyResult<J::Output> {
    let view =
        Fixed::<N>::new(Arc::clone(h)).map_err(|e| PyRuntimeError::new_err(e.to_string()))?;
    Ok(job.run(&view, method, |z: &DVector<f64>| {
        SVector::<f64, N>::from_column_slice(z.as_slice())
    }))
}
