//! The one per-step hook of every integrator: [`Observer`], and the [`StepRecord`] the DTH
//! stepper and the fixed-step peers both fill.
//!
//! A run calls [`Observer::on_step`] once per state, starting with the initial one (`k = 0`).
//! What every method has (step index, time, state, Newton iterations) is a plain field; what
//! only DTH has (the multiplier `lambda_k`, the vertex `z^(k)`, `Psi`) is in
//! [`StepRecord::dth`], `None` for a fixed-step method. So one observer (an energy monitor, a
//! Poincare section, a progress bar) serves every method, and one written for DTH reads its
//! extra data where it is present.
//!
//! ```
//! use dth_core::methods::{run, ImplicitMidpoint};
//! use dth_core::dth::{Dth, DthOptions};
//! use dth_core::observer::StepRecord;
//! use dth_core::systems::Kepler;
//! use dth_core::{nalgebra::{Const, Vector4}, Hamiltonian};
//!
//! let h = Kepler::thesis();
//! let z0 = Vector4::new(0.5, 0.0, 0.0, 1.2);
//! let e0 = h.value(&z0);
//! let mut worst = 0.0_f64;
//! let mut energy = |r: &StepRecord<Const<4>>| worst = worst.max((h.value(&r.z) - e0).abs());
//! run(&mut ImplicitMidpoint::new(), &h, &z0, 0.0, 0.15, 100, &mut energy)?; // a peer
//! let options = DthOptions::new(0.06277)?;
//! Dth::new(h, z0, options)?.run(100, &mut energy)?; // DTH: the same observer, at midpoints
//! assert!(worst > 1e-3); // the midpoint rule does not conserve energy; DTH does
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use crate::hamiltonian::Alloc;
use nalgebra::{DefaultAllocator, Dim, OVector};

/// What produced a step of a run.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum StepKind {
    /// A step of a fixed-step method (`dth_core::methods`), or its initial state: `z` is the
    /// state `z_k` at `t_k = t_0 + k dt` (a run's last step and a landing on a chosen time,
    /// [`Observer::on_landing`]: a step of what is left).
    Fixed,
    /// A DTH step (the initial midpoint counts as one): `z` is a midpoint with
    /// `H(zbar) = H(zbar_0)`, [`DthRecord::vertex`] the left vertex of its segment.
    Dth,
    /// A fallback step of the DTH robust mode (`DthOptions::with_robust`): an
    /// energy-conserving discrete-gradient step in `(q, p)` (at order 4-8 a composition of
    /// them) of physical size `dt = lambda * dtau`, taken where `Psi` changes sign and DTH has
    /// no positive root, or where a DTH step failed. `z` and
    /// [`DthRecord::vertex`] are both the node reached, with `H(z) = H(zbar_0)`; there is no
    /// DTH segment (its vertex-based invariants, such as quadratic invariants exact at
    /// vertices, do not hold across such steps).
    Fallback,
    /// The last DTH step of a run that ends at a given time (`Dth::step_toward`), its `dtau`
    /// scaled so that its midpoint `z` lands on that time: an exact DTH midpoint
    /// (`H(zbar) = H(zbar_0)`), but its segment has its own `dtau`, so its
    /// [`DthRecord::vertex`] is not a vertex of the run's polygon of equal steps and the
    /// quadratic invariants exact at those vertices jump there once, by `O(dtau^2)`.
    Shortened,
}

/// DTH's own quantities at a step (the DTH stepper fills them; fixed-step methods have none).
#[derive(Clone, Debug, PartialEq)]
pub struct DthRecord<D: Dim>
where
    DefaultAllocator: Alloc<D>,
{
    /// Multiplier `lambda_k = dt/dtau` of segment `k`.
    pub lambda: f64,
    /// Left vertex of segment `k`: `z^(k) = zbar_k - (h/2) lambda_k J gradH(zbar_k)` (a
    /// fallback step: the node reached).
    pub vertex: OVector<f64, D>,
    /// Vertex time `t^(k) = tbar_k - h lambda_k / 2` (a fallback step: the node's time).
    pub vertex_time: f64,
    /// `Psi(zbar_k)`.
    pub psi: f64,
}

/// `Copy` for fixed sizes, as before the dimension became a type.
impl<const N: usize> Copy for DthRecord<nalgebra::Const<N>> {}

/// One state of a run, as reported after each accepted step (and for the initial state).
#[derive(Clone, Debug, PartialEq)]
pub struct StepRecord<D: Dim>
where
    DefaultAllocator: Alloc<D>,
{
    /// Step index `k` (0 for the initial state).
    pub k: usize,
    /// Time of [`StepRecord::z`]: `t_k` (fixed step), the midpoint time `tbar_k` (DTH).
    pub t: f64,
    /// The state: `z_k` (fixed step), the midpoint `zbar_k` (DTH).
    pub z: OVector<f64, D>,
    /// What produced this step.
    pub kind: StepKind,
    /// Newton iterations spent on this step (0 for `k = 0` and for explicit methods; outer
    /// iterations for DTH's nested solver).
    pub iterations: u32,
    /// LU factorizations spent on this step: DTH only (equals `iterations` for its joint
    /// solver); 0 for fixed-step methods, which do not count them.
    pub factorizations: u32,
    /// DTH's multiplier, vertex and `Psi`; `None` for fixed-step methods.
    pub dth: Option<DthRecord<D>>,
}

/// `Copy` for fixed sizes, as before the dimension became a type.
impl<const N: usize> Copy for StepRecord<nalgebra::Const<N>> {}

impl<D: Dim> StepRecord<D>
where
    DefaultAllocator: Alloc<D>,
{
    /// The record of state `z` at time `t`, step `k`, of a fixed-step method (no Newton
    /// iterations counted, no DTH part).
    pub fn fixed(k: usize, t: f64, z: OVector<f64, D>) -> Self {
        StepRecord {
            k,
            t,
            z,
            kind: StepKind::Fixed,
            iterations: 0,
            factorizations: 0,
            dth: None,
        }
    }

    /// `self = from`, into `self`'s storage: no allocation when both have the same
    /// dimension and both or neither carry a DTH part (the derived `clone_from` allocates
    /// anew), so an observer or a stepper can keep the last record per step for free.
    pub(crate) fn copy_from(&mut self, from: &StepRecord<D>) {
        self.k = from.k;
        self.t = from.t;
        self.z.copy_from(&from.z);
        self.kind = from.kind;
        self.iterations = from.iterations;
        self.factorizations = from.factorizations;
        match (&mut self.dth, &from.dth) {
            (Some(t), Some(f)) => {
                t.lambda = f.lambda;
                t.vertex.copy_from(&f.vertex);
                t.vertex_time = f.vertex_time;
                t.psi = f.psi;
            }
            (t, f) => t.clone_from(f),
        }
    }
}

/// Receives a run as it happens. Every method has a no-op default, so an observer implements
/// only what it needs, and a run with `()` stores nothing and calls nothing per step.
///
/// Closures `FnMut(&StepRecord<D>)` are observers, and so are pairs `(A, B)` of observers
/// (both see every step, `A` first).
pub trait Observer<D: Dim>
where
    DefaultAllocator: Alloc<D>,
{
    /// Called for each state: first the initial one (`k = 0`), then one per accepted step.
    /// (A DTH stepper resumed after an earlier run reports its current midpoint first if it
    /// has not been reported yet.)
    #[inline(always)]
    fn on_step(&mut self, record: &StepRecord<D>) {
        let _ = record;
    }
    /// Called when a DTH run ends (successfully or not) with the right vertex
    /// `z^(N) = zbar_{N-1} + (h/2) lambda_{N-1} J gradH(zbar_{N-1})` of the last accepted
    /// segment and its time `t^(N)`. Fixed-step methods have no vertices and do not call it.
    #[inline(always)]
    fn on_finish(&mut self, last_vertex: &OVector<f64, D>, last_vertex_time: f64) {
        let _ = (last_vertex, last_vertex_time);
    }
    /// Called with the state at a chosen time (`Solve::save_at`, in
    /// [`crate::solve`](mod@crate::solve)), landed beside the run: from the start of the step
    /// that reaches the time, a step shortened to end on it (DTH: its `dtau` scaled,
    /// [`StepKind::Shortened`] or [`StepKind::Fallback`]; a fixed-step method: a step of what
    /// is left, [`StepKind::Fixed`]), after which the run goes on from where it was, so the
    /// run's own steps ([`Observer::on_step`]) are those of a run without chosen times. Its
    /// `k` is the index of the step it shortens; it comes before that step's
    /// [`Observer::on_step`].
    #[inline(always)]
    fn on_landing(&mut self, record: &StepRecord<D>) {
        let _ = record;
    }
    /// Called with the state where event number `event` (in the order of
    /// `Solve::event`, [`crate::event`]) fired, located to roundoff inside the step that
    /// crossed it and landed on beside the run as [`Observer::on_landing`] lands; it comes
    /// after that step's landings and before its [`Observer::on_step`]. An event that stops the
    /// run is reported here, then its state again as the run's last step.
    #[inline(always)]
    fn on_event(&mut self, event: usize, record: &StepRecord<D>) {
        let _ = (event, record);
    }
}

impl<D: Dim> Observer<D> for () where DefaultAllocator: Alloc<D> {}

impl<D: Dim, F: FnMut(&StepRecord<D>)> Observer<D> for F
where
    DefaultAllocator: Alloc<D>,
{
    #[inline(always)]
    fn on_step(&mut self, record: &StepRecord<D>) {
        self(record)
    }
}

impl<D: Dim, A: Observer<D>, B: Observer<D>> Observer<D> for (A, B)
where
    DefaultAllocator: Alloc<D>,
{
    #[inline(always)]
    fn on_step(&mut self, record: &StepRecord<D>) {
        self.0.on_step(record);
        self.1.on_step(record);
    }
    #[inline(always)]
    fn on_finish(&mut self, last_vertex: &OVector<f64, D>, last_vertex_time: f64) {
        self.0.on_finish(last_vertex, last_vertex_time);
        self.1.on_finish(last_vertex, last_vertex_time);
    }
    #[inline(always)]
    fn on_landing(&mut self, record: &StepRecord<D>) {
        self.0.on_landing(record);
        self.1.on_landing(record);
    }
    #[inline(always)]
    fn on_event(&mut self, event: usize, record: &StepRecord<D>) {
        self.0.on_event(event, record);
        self.1.on_event(event, record);
    }
}

/// An observer that shows every `n`-th state (`k = 0, n, 2n, ...`) to `inner` (and DTH's last
/// vertex); `n = 0` is taken as 1. Build it with [`every`] for a closure (its record type is
/// inferred) or [`Every::new`] for any observer. (States at chosen times, and a run that ends
/// at a time, are the driver's: [`crate::solve`](mod@crate::solve).)
#[derive(Clone, Debug)]
pub struct Every<O> {
    n: usize,
    inner: O,
}

impl<O> Every<O> {
    /// `inner`, shown every `n`-th state.
    pub fn new(n: usize, inner: O) -> Self {
        Every { n: n.max(1), inner }
    }

    /// The observer inside.
    pub fn into_inner(self) -> O {
        self.inner
    }
}

/// The closure `f` called with every `n`-th state (`n = 0`: every state), its record type
/// inferred:
///
/// ```
/// use dth_core::observer::every;
/// use dth_core::{nalgebra::Vector4, systems::Kepler, Dth, DthOptions};
/// let mut dth = Dth::new(Kepler::thesis(), Vector4::new(0.5, 0.0, 0.0, 1.2), DthOptions::thesis_kepler())?;
/// let mut times = Vec::new();
/// dth.run(100, &mut every(25, |r| times.push(r.t)))?;
/// assert_eq!(times.len(), 5); // k = 0, 25, 50, 75, 100
/// # Ok::<(), dth_core::Error>(())
/// ```
pub fn every<D: Dim, F: FnMut(&StepRecord<D>)>(n: usize, f: F) -> Every<F>
where
    DefaultAllocator: Alloc<D>,
{
    Every::new(n, f)
}

impl<D: Dim, O: Observer<D>> Observer<D> for Every<O>
where
    DefaultAllocator: Alloc<D>,
{
    #[inline(always)]
    fn on_step(&mut self, record: &StepRecord<D>) {
        if record.k.is_multiple_of(self.n) {
            self.inner.on_step(record);
        }
    }
    #[inline(always)]
    fn on_finish(&mut self, last_vertex: &OVector<f64, D>, last_vertex_time: f64) {
        self.inner.on_finish(last_vertex, last_vertex_time);
    }
    /// Every landing: chosen times are chosen, not sampled.
    #[inline(always)]
    fn on_landing(&mut self, record: &StepRecord<D>) {
        self.inner.on_landing(record);
    }
    /// Every event.
    #[inline(always)]
    fn on_event(&mut self, event: usize, record: &StepRecord<D>) {
        self.inner.on_event(event, record);
    }
}

/// An [`Observer`] that stores the time and state of every step (for DTH: the midpoints; a
/// DTH run with its vertices, multipliers and Newton counts is `dth::Trajectory`).
#[derive(Clone, Debug, PartialEq)]
pub struct Recorder<D: Dim>
where
    DefaultAllocator: Alloc<D>,
{
    /// Times `t_0, t_1, ...`.
    pub t: Vec<f64>,
    /// States `z_0, z_1, ...`.
    pub z: Vec<OVector<f64, D>>,
}

impl<D: Dim> Recorder<D>
where
    DefaultAllocator: Alloc<D>,
{
    /// An empty recorder.
    pub fn new() -> Self {
        Recorder {
            t: Vec::new(),
            z: Vec::new(),
        }
    }
}

impl<D: Dim> Default for Recorder<D>
where
    DefaultAllocator: Alloc<D>,
{
    fn default() -> Self {
        Self::new()
    }
}

impl<D: Dim> Observer<D> for Recorder<D>
where
    DefaultAllocator: Alloc<D>,
{
    fn on_step(&mut self, record: &StepRecord<D>) {
        self.t.push(record.t);
        self.z.push(record.z.clone());
    }
}
