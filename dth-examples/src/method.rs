//! The one seam between scenes and integrators: [`run_method`] maps a [`MethodSpec`] to a
//! [`MethodRunner`] and drives it with the scene's [`Observer`].
//!
//! Every arm calls a `dth_core` integrator: the DTH stepper ([`DthRunner`], both Newton
//! solvers, through [`SceneSystem::run_dth`] so that systems run without DTH never
//! instantiate it), the fixed-step peers of `dth_core::methods` ([`run_peer`]), Greenspan's discrete
//! mechanics through [`SceneSystem::run_discrete_mechanics`] (central-force systems only), and
//! the system's exact solution ([`ExactSampler`]).

use dth::dth::{Dth, DthOptions, StepRecord};
use dth::methods::{
    self, DiscreteGradient, GaussLegendre2, ImplicitMidpoint, OneStepMethod, Rk4, StormerVerlet,
    Trapezoidal,
};
use dth::nalgebra::SVector;
use dth::Hamiltonian;

use crate::catalogue::SceneSystem;
use crate::error::Error;
use crate::scene::{MethodKind, MethodSpec, Solver, StepSpec};

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

    /// The number of steps a fixed-step method with step `dt > 0` takes from `t0`: the first
    /// `k` with `t0 + k dt >= t_end` (the clock is `t0 + k dt`, as `dth_core::methods::run`
    /// computes it), capped at `max_steps`.
    pub fn fixed_steps(&self, t0: f64, dt: f64) -> usize {
        match *self {
            Stop::Steps(n) => n,
            Stop::Time { t_end, max_steps } => {
                let guess = ((t_end - t0) / dt).ceil().max(0.0);
                let mut k = if guess < max_steps as f64 {
                    guess as usize
                } else {
                    max_steps
                };
                // The division rounds: settle on the exact first k of the clock.
                while k < max_steps && t0 + k as f64 * dt < t_end {
                    k += 1;
                }
                while k > 0 && t0 + (k - 1) as f64 * dt >= t_end {
                    k -= 1;
                }
                k
            }
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

/// Feeds the states of a `dth_core::methods::run` to a scene [`Observer`].
struct PeerObserver<'o, O>(&'o mut O);

impl<const D: usize, O: Observer<D>> methods::Observer<D> for PeerObserver<'_, O> {
    #[inline(always)]
    fn observe(&mut self, k: usize, t: f64, z: &SVector<f64, D>) {
        self.0.observe(&StepView {
            step: k,
            t,
            z,
            lambda: None,
            vertex: None,
        });
    }
}

/// Runs a fixed-step peer (`dth_core::methods`) with step `dt` from `z0` at `t0` until `stop`,
/// showing every state to `observer`. On failure the observer has seen every state before the
/// failing step.
pub fn run_peer<const D: usize, H, M, O>(
    method: &mut M,
    system: &H,
    dt: f64,
    z0: SVector<f64, D>,
    t0: f64,
    stop: Stop,
    observer: &mut O,
) -> Result<RunEnd, MethodFailure>
where
    H: Hamiltonian<D>,
    M: OneStepMethod<D, H>,
    O: Observer<D>,
{
    let steps = stop.fixed_steps(t0, dt);
    match methods::run(
        method,
        system,
        &z0,
        t0,
        dt,
        steps,
        &mut PeerObserver(observer),
    ) {
        Ok(end) => Ok(RunEnd {
            steps: end.steps,
            t: end.t,
        }),
        Err(e) => Err(MethodFailure {
            step: e.partial.steps + 1,
            reason: e.error.to_string(),
        }),
    }
}

/// The DTH stepper (`dth_core::dth::Dth`) driven until a [`Stop`]: every midpoint `zbar_k` is
/// shown with its time `tbar_k`, `lambda_k` and the left vertex `z^(k)` at `t^(k)`.
#[derive(Debug, Clone, Copy)]
pub struct DthRunner {
    /// Step, `lambda_0` and Newton settings.
    pub options: DthOptions,
}

impl DthRunner {
    /// The runner for a scene's DTH step (`dtau`, `lambda0`, `solver`).
    pub fn new(dtau: f64, lambda0: f64, solver: Solver) -> Result<Self, dth::Error> {
        let solver = match solver {
            Solver::Joint => dth::dth::Solver::Joint,
            Solver::Nested => dth::dth::Solver::Nested,
        };
        Ok(DthRunner {
            options: DthOptions::default()
                .with_dtau(dtau)?
                .with_lambda0(lambda0)?
                .with_solver(solver),
        })
    }
}

fn dth_view<const D: usize>(r: &StepRecord<D>) -> StepView<'_, D> {
    StepView {
        step: r.k,
        t: r.tbar,
        z: &r.zbar,
        lambda: Some(r.lambda),
        vertex: Some((r.vertex_time, &r.vertex)),
    }
}

impl<const D: usize, H: Hamiltonian<D> + Clone> MethodRunner<D, H> for DthRunner {
    /// `z0` is the first midpoint `zbar_0`; `t0` its time (for a time-dependent `H` the `t`
    /// coordinate of `z0` is the clock).
    fn run<O: Observer<D>>(
        &self,
        system: &H,
        z0: SVector<f64, D>,
        t0: f64,
        stop: Stop,
        observer: &mut O,
    ) -> Result<RunEnd, MethodFailure> {
        let start = |e: dth::Error| MethodFailure {
            step: 0,
            reason: e.to_string(),
        };
        let mut dth = Dth::new(system.clone(), z0, self.options).map_err(start)?;
        if !H::TIME_DEPENDENT {
            dth = dth.with_tbar0(t0).map_err(start)?;
        }
        loop {
            let record = dth.record();
            observer.observe(&dth_view(&record));
            if stop.done(record.k, record.tbar) {
                return Ok(RunEnd {
                    steps: record.k,
                    t: record.tbar,
                });
            }
            if let Err(e) = dth.step() {
                return Err(MethodFailure {
                    step: record.k + 1,
                    reason: e.to_string(),
                });
            }
        }
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
    let dt = match (spec.kind, spec.step) {
        (
            MethodKind::Dth,
            StepSpec::Dth {
                dtau,
                lambda0,
                solver,
            },
        ) => {
            let runner =
                DthRunner::new(dtau, lambda0, solver).map_err(|e| not_available(&e.to_string()))?;
            return system
                .run_dth(&runner, z0, t0, stop, observer)
                .ok_or_else(|| {
                    not_available(if H::PSI_IDENTICALLY_ZERO {
                        "this system's Psi = (J gradH)^T HessH (J gradH) is identically zero, so the energy condition does not determine lambda (thesis Section 3.4): use a peer method"
                    } else {
                        "this system was registered without DTH (SystemEntry::runnable_without_dth)"
                    })
                });
        }
        (_, StepSpec::Fixed { dt }) => dt,
        (_, StepSpec::Dth { .. }) => {
            return Err(not_available(
                "this method takes a fixed step `dt`, not DTH's `dtau`",
            ))
        }
    };
    // Every fixed-step peer runs the same way; only the method differs (a closure cannot be
    // generic over it).
    macro_rules! peer {
        ($method:expr) => {
            Ok(run_peer(&mut $method, system, dt, z0, t0, stop, observer))
        };
    }
    match spec.kind {
        MethodKind::Exact => {
            if !H::HAS_EXACT || system.exact_solution(&z0, 0.0).is_none() {
                return Err(not_available(
                    "this system has no exact solution for this initial state (Kepler: an elliptic orbit is needed)",
                ));
            }
            Ok(ExactSampler { dt }.run(system, z0, t0, stop, observer))
        }
        MethodKind::Trapezoidal => peer!(Trapezoidal::new()),
        MethodKind::Midpoint => peer!(ImplicitMidpoint::new()),
        MethodKind::StormerVerlet => {
            if !H::SEPARABLE {
                return Err(not_available(
                    "Stormer-Verlet needs a separable H = T(p) + V(q)",
                ));
            }
            peer!(StormerVerlet::new())
        }
        MethodKind::Rk4 => peer!(Rk4),
        MethodKind::GaussLegendre2 => peer!(GaussLegendre2::new()),
        MethodKind::DiscreteGradient => peer!(DiscreteGradient::new()),
        MethodKind::DiscreteMechanics => system
            .run_discrete_mechanics(dt, z0, t0, stop, observer)
            .map_or_else(
                || {
                    Err(not_available(
                        "discrete mechanics needs a central-force system H = |p|^2/(2m) + phi(|q|)",
                    ))
                },
                Ok,
            ),
        MethodKind::Dth => Err(not_available("method `dth` takes `dtau`, not `dt`")),
    }
}
