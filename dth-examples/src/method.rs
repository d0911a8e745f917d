//! Method dispatch: [`run_method`] maps a scene's [`MethodSpec`] to an integrator and drives
//! it with the caller's observer. The one place a method name becomes code.
//!
//! Every arm goes through the run driver ([`crate::driver`]): the DTH stepper
//! ([`DthRunner`], through [`SceneSystem::run_dth`] so that systems run without DTH never
//! instantiate it), the fixed-step peers of `dth::methods` ([`run_peer`]), Greenspan's
//! discrete mechanics through [`SceneSystem::run_discrete_mechanics`] (central-force systems
//! only), and the system's exact solution sampled every `dt` ([`run_exact`]).

use dth::event::Watch;
use dth::methods::{
    steps_until, DiscreteGradient, GaussLegendre2, ImplicitMidpoint, Rk4, RunEnd, StormerVerlet,
    Trapezoidal,
};
use dth::nalgebra::{DefaultAllocator, Dim, OVector};
use dth::observer::{Observer, StepRecord};
use dth::Alloc;

use crate::driver::{events, run_peer, DthRunner, FailureCause, Limit, MethodFailure, Stop};
use crate::error::Error;
use crate::scene::{MethodKind, MethodSpec, StepSpec};
use crate::system::SceneSystem;

/// The system's exact solution ([`SceneSystem::exact_solution`]) sampled at `t0 + k dt` from
/// `z0` until `stop` (a run until a time: its last sample at that time), shown to `observer`
/// like a fixed-step method's states, and at the stop's chosen times as landings; the stop's
/// events are located on the exact solution between samples (`dth::event::Watch`), and one
/// that stops the run ends it there.
pub fn run_exact<D: Dim, S: SceneSystem<D>, O: Observer<D>>(
    system: &S,
    dt: f64,
    z0: OVector<f64, D>,
    t0: f64,
    stop: Stop,
    observer: &mut O,
) -> Result<RunEnd<D>, MethodFailure>
where
    DefaultAllocator: Alloc<D>,
{
    let mut record = StepRecord::fixed(0, t0, z0.clone());
    observer.on_step(&record);
    // The events, located on the exact solution itself between two samples.
    let mut watch = Watch::new(events(stop.events()));
    watch
        .start(t0, &z0)
        .map_err(|e| MethodFailure::integrator(0, e))?;
    // Every `dt`, and a run until a time lands on it, as the integrators do.
    let landing = match stop.limit {
        Limit::Time { t_end, .. } => Some((steps_until(t0, t_end, dt), t_end)),
        Limit::Steps(_) => None,
    };
    let mut times = stop.times().iter().copied().peekable();
    for k in 1..=stop.fixed_steps(t0, dt) {
        if let Some(interrupted) = stop.interruption(record.k) {
            return Err(interrupted);
        }
        let t = match landing {
            Some((last, t_end)) if k == last => t_end,
            _ => t0 + k as f64 * dt,
        };
        let exact = |t: f64| {
            system.exact_solution(&z0, t - t0).ok_or(MethodFailure {
                step: k,
                cause: FailureCause::NoExactSolution { t },
            })
        };
        let z = exact(t)?;
        let crossed = watch
            .crossed(t, &z)
            .map_err(|e| MethodFailure::integrator(k, e))?;
        let fired = if crossed {
            let mut missing = None;
            let mut land = |t: f64| match exact(t) {
                Ok(z) => Ok(StepRecord::fixed(k, t, z)),
                Err(failure) => {
                    missing = Some(failure);
                    Err(dth::Error::MissingEnd)
                }
            };
            let located = watch.locate(&mut land);
            match (located, missing) {
                (Ok(fired), _) => fired,
                (Err(_), Some(failure)) => return Err(failure),
                (Err(e), None) => return Err(MethodFailure::integrator(k, e)),
            }
        } else {
            Vec::new()
        };
        let stopped = watch.stopping(&fired).map(|(_, _, r)| r.clone());
        let stops = stopped.is_some();
        // The chosen times before this sample (and before a stop), as the integrators land on
        // them.
        let last = stopped.as_ref().map_or(t, |r| r.t);
        while let Some(&at) = times.peek().filter(|&&at| at < t && at <= last) {
            times.next();
            observer.on_landing(&StepRecord::fixed(k, at, exact(at)?));
        }
        for (i, _, r) in &fired {
            observer.on_event(*i, r);
        }
        (record.z, record.t) = match stopped {
            Some(r) => (r.z, r.t),
            None => (z, t),
        };
        record.k = k;
        observer.on_step(&record);
        if stops {
            break;
        }
    }
    if let Some(failure) = stop.cut_short(record.k, record.t) {
        return Err(failure);
    }
    Ok(RunEnd {
        z: record.z,
        t: record.t,
        steps: record.k,
    })
}

/// Why the method `spec` cannot run on `system` from `z0`, when that depends on the system's
/// instance or the initial state rather than on the scene alone (validation checks the
/// rest): `exact` needs an exact solution for this state (Kepler: an elliptic orbit), and
/// `stormer_verlet` a separable `H`. `None` when it can run. [`run_method`] refuses with it,
/// and `simulate::preflight` asks it of every method before any runs, so that a method
/// that cannot run does not discard what the ones before it computed.
pub fn unavailable<D: Dim, H: SceneSystem<D>>(
    spec: &MethodSpec,
    system: &H,
    z0: &OVector<f64, D>,
) -> Option<&'static str>
where
    DefaultAllocator: Alloc<D>,
{
    match spec.kind {
        MethodKind::Exact if !H::HAS_EXACT || system.exact_solution(z0, 0.0).is_none() => Some(
            "this system has no exact solution for this initial state (Kepler: an elliptic orbit is needed)",
        ),
        MethodKind::StormerVerlet if !system.flags().separable => {
            Some("Stormer-Verlet needs a separable H = T(p) + V(q)")
        }
        _ => None,
    }
}

/// Runs the method a scene names. The single dispatch point (see the module docs).
pub fn run_method<D: Dim, H: SceneSystem<D>, O: Observer<D>>(
    spec: &MethodSpec,
    system: &H,
    z0: OVector<f64, D>,
    t0: f64,
    stop: Stop,
    observer: &mut O,
) -> Result<Result<RunEnd<D>, MethodFailure>, Error>
where
    DefaultAllocator: Alloc<D>,
{
    let not_available = |reason: &str| Error::NotAvailable {
        what: "method",
        name: spec.kind.name().to_string(),
        reason: reason.to_string(),
    };
    if let Some(reason) = unavailable(spec, system, &z0) {
        return Err(not_available(reason));
    }
    let dt = match (spec.kind, spec.step) {
        (
            MethodKind::Dth,
            StepSpec::Dth {
                dtau,
                lambda0,
                solver,
                robust,
                order,
                double_double,
            },
        ) => {
            let runner = DthRunner::new(dtau, lambda0, solver, robust, order)
                .map_err(|e| not_available(&e.to_string()))?
                .with_double_double(double_double);
            return system
                .run_dth(&runner, z0, t0, stop, observer)
                .ok_or_else(|| {
                    not_available(if system.flags().psi_identically_zero {
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
            Ok(run_peer($method, system, dt, z0, t0, stop, observer))
        };
    }
    match spec.kind {
        MethodKind::Exact => Ok(run_exact(system, dt, z0, t0, stop, observer)),
        MethodKind::Trapezoidal => peer!(Trapezoidal::new()),
        MethodKind::Midpoint => peer!(ImplicitMidpoint::new()),
        MethodKind::StormerVerlet => peer!(StormerVerlet::new()),
        MethodKind::Rk4 => peer!(Rk4::new()),
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
