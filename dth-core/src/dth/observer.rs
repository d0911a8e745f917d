//! The per-step hook of a DTH run: [`Observer`] and the [`StepRecord`] it receives.

use nalgebra::SVector;

/// What produced a step of a run.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum StepKind {
    /// A DTH step (the initial midpoint counts as one): `zbar` is a midpoint with
    /// `H(zbar) = H(zbar_0)`, `vertex` the left vertex of its segment.
    #[default]
    Dth,
    /// A fallback step of the robust mode ([`DthOptions::with_robust`]): an energy-conserving
    /// discrete-gradient step in `(q, p)` of physical size `dt = lambda * dtau`, taken where DTH
    /// has no positive root. `zbar` and `vertex` are both the node reached, with
    /// `H(zbar) = H(zbar_0)`; there is no DTH segment (its vertex-based invariants, such as
    /// quadratic invariants exact at vertices, do not hold across such steps).
    ///
    /// [`DthOptions::with_robust`]: super::DthOptions::with_robust
    Fallback,
}

/// One midpoint of a DTH trajectory, as reported after each accepted step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StepRecord<const D: usize> {
    /// Midpoint index `k` (0 for the initial midpoint).
    pub k: usize,
    /// Midpoint `zbar_k`.
    pub zbar: SVector<f64, D>,
    /// Multiplier `lambda_k = dt/dtau` of segment `k`.
    pub lambda: f64,
    /// Midpoint time `tbar_k`.
    pub tbar: f64,
    /// Left vertex of segment `k`: `z^(k) = zbar_k - (h/2) lambda_k J gradH(zbar_k)`.
    pub vertex: SVector<f64, D>,
    /// Vertex time `t^(k) = tbar_k - h lambda_k / 2`.
    pub vertex_time: f64,
    /// `Psi(zbar_k)`.
    pub psi: f64,
    /// Newton iterations spent on this midpoint (0 for `k = 0`; outer iterations for the
    /// nested solver).
    pub iterations: u32,
    /// LU factorizations spent on this midpoint (equals `iterations` for the joint solver).
    pub factorizations: u32,
    /// DTH step or robust-mode fallback step.
    pub kind: StepKind,
}

/// Receives a DTH run as it happens. Every method has a no-op default, so an observer
/// implements only what it needs and a run with [`NoObserver`] stores nothing.
///
/// Closures `FnMut(&StepRecord<D>)` are observers too.
pub trait Observer<const D: usize> {
    /// Called for each midpoint: first the current one if it has not been reported yet (the
    /// initial midpoint `k = 0` of a fresh stepper), then each new one.
    fn on_step(&mut self, record: &StepRecord<D>) {
        let _ = record;
    }
    /// Called when a run ends (successfully or not) with the right vertex
    /// `z^(N) = zbar_{N-1} + (h/2) lambda_{N-1} J gradH(zbar_{N-1})` of the last accepted
    /// segment and its time `t^(N)`.
    fn on_finish(&mut self, last_vertex: &SVector<f64, D>, last_vertex_time: f64) {
        let _ = (last_vertex, last_vertex_time);
    }
}

/// An observer that does nothing (a run with it stores nothing).
#[derive(Clone, Copy, Debug, Default)]
pub struct NoObserver;

impl<const D: usize> Observer<D> for NoObserver {}

impl<const D: usize, F: FnMut(&StepRecord<D>)> Observer<D> for F {
    fn on_step(&mut self, record: &StepRecord<D>) {
        self(record)
    }
}
