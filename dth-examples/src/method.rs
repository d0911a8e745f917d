//! The one seam between scenes and integrators: [`run_method`] maps a [`MethodSpec`] to a
//! [`MethodRunner`] and drives it with the scene's [`Observer`].
//!
//! **Where the real integrators plug in.** `dth_core::dth` (the stepper) and
//! `dth_core::methods` (the peers) are not merged yet. Each gets one arm in [`run_method`]:
//! implement [`MethodRunner`] for it (a few lines that call its step function in a loop and
//! hand every state to the observer) and replace the matching `not_available` arm. Until then
//! those arms return [`Error::NotAvailable`], and the only runnable method is
//! [`TestProbeEuler`], which exists solely so the scene pipeline can be tested end to end.
//! Method `exact` ([`ExactSampler`]) is complete here; it runs once a system implements
//! [`SceneSystem::exact_solution`] (Kepler's waits for `dth_core::kepler`).

use dth::nalgebra::SVector;
use dth::Hamiltonian;

use crate::catalogue::SceneSystem;
use crate::error::Error;
use crate::scene::{MethodKind, MethodSpec, StepSpec};

/// One state handed to observers: step `k`, physical time, the state, and for DTH the segment's
/// `lambda` and the vertex `z^(k)` at time `t^(k)`.
#[derive(Debug, Clone, Copy)]
pub struct StepView<'a, const D: usize> {
    /// Step index (0 is the initial state).
    pub step: usize,
    /// Physical time of `z`.
    pub t: f64,
    /// The state (DTH: the midpoint `zbar_k`).
    pub z: &'a SVector<f64, D>,
    /// `lambda_k = dt/dtau` (DTH only).
    pub lambda: Option<f64>,
    /// The vertex `z^(k)` and its time `t^(k)` (DTH only).
    pub vertex: Option<(f64, &'a SVector<f64, D>)>,
}

/// Receives every state of a run. `()` is the observer that takes nothing (a run with no
/// effects is monomorphized with it, so it stores nothing and calls nothing per step).
pub trait Observer<const D: usize> {
    /// Called once per state, starting with the initial one (`step = 0`).
    fn observe(&mut self, view: &StepView<'_, D>);
}

impl<const D: usize> Observer<D> for () {
    #[inline(always)]
    fn observe(&mut self, _view: &StepView<'_, D>) {}
}

impl<const D: usize, A: Observer<D>, B: Observer<D>> Observer<D> for (A, B) {
    #[inline(always)]
    fn observe(&mut self, view: &StepView<'_, D>) {
        self.0.observe(view);
        self.1.observe(view);
    }
}

impl<const D: usize, O: Observer<D>> Observer<D> for &mut O {
    #[inline(always)]
    fn observe(&mut self, view: &StepView<'_, D>) {
        (**self).observe(view);
    }
}

/// When a run stops.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Stop {
    /// After this many steps.
    Steps(usize),
    /// At the first state with `t >= t_end`, or after `max_steps` steps, whichever is first.
    Time {
        /// End time.
        t_end: f64,
        /// Safety cap.
        max_steps: usize,
    },
}

impl Stop {
    /// `true` once step `k` at time `t` ends the run.
    pub fn done(&self, k: usize, t: f64) -> bool {
        match *self {
            Stop::Steps(n) => k >= n,
            Stop::Time { t_end, max_steps } => t >= t_end || k >= max_steps,
        }
    }
}

/// How a run ended.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RunEnd {
    /// Steps taken.
    pub steps: usize,
    /// Final physical time.
    pub t: f64,
}

/// A failure after `step` successful steps; the observer has everything up to there.
#[derive(Debug, Clone, PartialEq)]
pub struct MethodFailure {
    /// The step that failed.
    pub step: usize,
    /// Why.
    pub reason: String,
}

/// An integrator driven by the scene runner: from `z0` at `t0`, step until `stop`, show every
/// state to `observer`.
pub trait MethodRunner<const D: usize, H: Hamiltonian<D>> {
    /// Runs; on failure the observer has seen every state computed before the failing step.
    fn run<O: Observer<D>>(
        &self,
        system: &H,
        z0: SVector<f64, D>,
        t0: f64,
        stop: Stop,
        observer: &mut O,
    ) -> Result<RunEnd, MethodFailure>;
}

/// Explicit Euler, `z_{k+1} = z_k + dt J grad H(z_k)`.
///
/// **Exists only to exercise the scene pipeline in tests** (it needs nothing from the
/// unmerged stepper and peers). It is first order and not symplectic; do not use it to study a
/// system. Scenes name it `test_probe_euler`.
#[derive(Debug, Clone, Copy)]
pub struct TestProbeEuler {
    /// Time step.
    pub dt: f64,
}

impl<const D: usize, H: Hamiltonian<D>> MethodRunner<D, H> for TestProbeEuler {
    fn run<O: Observer<D>>(
        &self,
        system: &H,
        z0: SVector<f64, D>,
        t0: f64,
        stop: Stop,
        observer: &mut O,
    ) -> Result<RunEnd, MethodFailure> {
        let mut z = z0;
        let mut k = 0;
        let mut t = t0;
        observer.observe(&StepView {
            step: 0,
            t,
            z: &z,
            lambda: None,
            vertex: None,
        });
        while !stop.done(k, t) {
            let next = z + dth::j_times(&system.gradient(&z)) * self.dt;
            if let Some(i) = next.iter().position(|x| !x.is_finite()) {
                return Err(MethodFailure {
                    step: k + 1,
                    reason: format!("state component {i} became non-finite"),
                });
            }
            z = next;
            k += 1;
            t = t0 + k as f64 * self.dt;
            observer.observe(&StepView {
                step: k,
                t,
                z: &z,
                lambda: None,
                vertex: None,
            });
        }
        Ok(RunEnd { steps: k, t })
    }
}

/// The system's exact solution sampled at `t0 + k dt` ([`SceneSystem::exact_solution`]).
#[derive(Debug, Clone, Copy)]
pub struct ExactSampler {
    /// Sampling interval.
    pub dt: f64,
}

impl ExactSampler {
    fn run<const D: usize, S: SceneSystem<D>, O: Observer<D>>(
        &self,
        system: &S,
        z0: SVector<f64, D>,
        t0: f64,
        stop: Stop,
        observer: &mut O,
    ) -> Result<RunEnd, MethodFailure> {
        let mut k = 0;
        let mut t = t0;
        observer.observe(&StepView {
            step: 0,
            t,
            z: &z0,
            lambda: None,
            vertex: None,
        });
        while !stop.done(k, t) {
            k += 1;
            t = t0 + k as f64 * self.dt;
            let z = system
                .exact_solution(&z0, t - t0)
                .ok_or_else(|| MethodFailure {
                    step: k,
                    reason: format!("the exact solution is not available at t = {t}"),
                })?;
            observer.observe(&StepView {
                step: k,
                t,
                z: &z,
                lambda: None,
                vertex: None,
            });
        }
        Ok(RunEnd { steps: k, t })
    }
}

/// Runs the method a scene names. The single dispatch point (see the module docs).
pub fn run_method<const D: usize, H: SceneSystem<D>, O: Observer<D>>(
    spec: &MethodSpec,
    system: &H,
    z0: SVector<f64, D>,
    t0: f64,
    stop: Stop,
    observer: &mut O,
) -> Result<Result<RunEnd, MethodFailure>, Error> {
    let not_available = |reason: &str| Error::NotAvailable {
        what: "method",
        name: spec.kind.name().to_string(),
        reason: reason.to_string(),
    };
    match (spec.kind, spec.step) {
        (MethodKind::TestProbeEuler, StepSpec::Fixed { dt }) => {
            Ok(TestProbeEuler { dt }.run(system, z0, t0, stop, observer))
        }
        (MethodKind::Exact, StepSpec::Fixed { dt }) => {
            if !H::HAS_EXACT || system.exact_solution(&z0, 0.0).is_none() {
                return Err(not_available(
                    "this system's exact solution is not implemented yet (Kepler: dth_core::kepler, not merged into this branch)",
                ));
            }
            Ok(ExactSampler { dt }.run(system, z0, t0, stop, observer))
        }
        // Plug-in point for the DTH stepper (dth_core::dth, issue 3).
        (MethodKind::Dth, _) => Err(not_available(
            "the DTH stepper (dth_core::dth) is not merged into this branch yet",
        )),
        // Plug-in points for the peers (dth_core::methods, issue 3).
        (
            MethodKind::Trapezoidal
            | MethodKind::Midpoint
            | MethodKind::DiscreteMechanics
            | MethodKind::StormerVerlet
            | MethodKind::Rk4
            | MethodKind::GaussLegendre2
            | MethodKind::DiscreteGradient,
            _,
        ) => Err(not_available(
            "the peer methods (dth_core::methods) are not merged into this branch yet",
        )),
        (MethodKind::TestProbeEuler | MethodKind::Exact, StepSpec::Dth { .. }) => Err(
            not_available("this method takes a fixed step `dt`, not DTH's `dtau`"),
        ),
    }
}
