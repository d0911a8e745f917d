//! What one work-precision problem is (`Problem`) and what the results say about it
//! ([`ProblemInfo`]): the data the runners measure and the reports print, apart from the list
//! of problems ([`super::problems`]) that drives them.

use dth::nalgebra::SVector;
use serde::Serialize;

use super::reference::Reference;

/// Name, title and time scales of a problem, as written to the results.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ProblemInfo {
    /// File-name safe name (`kepler_e044`, ...).
    pub name: &'static str,
    /// Title for diagrams and tables.
    pub title: &'static str,
    /// Final time `T` of every run.
    pub t_end: f64,
    /// Characteristic period (orbit period, libration period, `2 pi / omega`).
    pub period: f64,
    /// Name of the invariant besides the energy, if any.
    pub invariant: Option<&'static str>,
}

/// One problem: Hamiltonian, initial state, reference and diagnostics.
pub(crate) struct Problem<H, const D: usize> {
    pub info: ProblemInfo,
    pub hamiltonian: H,
    pub z0: SVector<f64, D>,
    pub reference: Reference<D>,
    /// The invariant besides the energy (angular momentum), if any.
    pub invariant: Option<fn(&SVector<f64, D>) -> f64>,
    /// The error of a state against the reference state at the same time.
    pub error: fn(&SVector<f64, D>, &SVector<f64, D>) -> f64,
    /// The method name as recorded (identity, or the `_generated` name of a variant).
    pub rename: fn(&'static str) -> &'static str,
}
