//! The run driver: how long a run lasts ([`Stop`]), how it fails ([`MethodFailure`]), and the
//! two integrator drivers every method of a scene goes through, the fixed-step peers
//! ([`run_peer`]) and the DTH stepper ([`DthRunner`]). Both report every state to one
//! `dth::observer::Observer` and end with a `dth::methods::RunEnd`, or with a typed
//! [`MethodFailure`].
//!
//! Nothing here knows scenes or systems beyond `dth::Hamiltonian`.

use dth::dth::{Dth, DthOptions, Solver};
use dth::methods::{self, OneStepMethod, RunEnd};
use dth::nalgebra::{DefaultAllocator, Dim, OVector};
use dth::observer::Observer;
use dth::Alloc;
use dth::Hamiltonian;

pub use crate::error::{FailureCause, MethodFailure};

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

    /// The failure of a run that is done at step `k` and time `t` only because the cap
    /// `max_steps` of a [`Stop::Time`] stopped it short of `t_end` (`None` when it reached its
    /// end): the run did not compute what it was asked for, so it failed at step `k + 1`.
    pub fn cut_short(&self, k: usize, t: f64) -> Option<MethodFailure> {
        match *self {
            Stop::Time { t_end, max_steps } if k >= max_steps && t < t_end => Some(MethodFailure {
                step: k + 1,
                cause: FailureCause::StepCap {
                    max_steps,
                    t,
                    t_end,
                },
            }),
            _ => None,
        }
    }

    /// The number of steps a fixed-step method with step `dt > 0` takes from `t0`: the first
    /// `k` with `t0 + k dt >= t_end` (the clock is `t0 + k dt`, as `dth::methods::run`
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

/// Runs a fixed-step peer (`dth::methods`) with step `dt` from `z0` at `t0` until `stop`,
/// showing every state to `observer`. On failure the observer has seen every state before the
/// failing step.
pub fn run_peer<D: Dim, H, M, O>(
    method: &mut M,
    system: &H,
    dt: f64,
    z0: OVector<f64, D>,
    t0: f64,
    stop: Stop,
    observer: &mut O,
) -> Result<RunEnd<D>, MethodFailure>
where
    DefaultAllocator: Alloc<D>,
    H: Hamiltonian<D>,
    M: OneStepMethod<D, H>,
    O: Observer<D>,
{
    let steps = stop.fixed_steps(t0, dt);
    let end = methods::run(method, system, &z0, t0, dt, steps, observer)
        .map_err(|e| MethodFailure::integrator(e.partial.steps + 1, e.error))?;
    match stop.cut_short(end.steps, end.t) {
        Some(failure) => Err(failure),
        None => Ok(end),
    }
}

/// The DTH stepper (`dth::dth::Dth`) driven until a [`Stop`]: every midpoint `zbar_k` is shown
/// with its time `tbar_k`, `lambda_k` and the left vertex `z^(k)` at `t^(k)`.
#[derive(Debug, Clone, Copy)]
pub struct DthRunner {
    /// Step, `lambda_0` and Newton settings.
    pub options: DthOptions,
}

impl DthRunner {
    /// The runner for a scene's DTH step (`dtau`, `lambda0`, `solver`, robust mode, order).
    ///
    /// # Errors
    /// `dth::Error::InvalidOption` for a `dtau` or `lambda0` that is not positive and finite,
    /// or an order other than 2, 4, 6, 8.
    pub fn new(
        dtau: f64,
        lambda0: f64,
        solver: Solver,
        robust: bool,
        order: u32,
    ) -> Result<Self, dth::Error> {
        Ok(DthRunner {
            options: DthOptions::default()
                .with_dtau(dtau)?
                .with_lambda0(lambda0)?
                .with_order(order)?
                .with_solver(solver)
                .with_robust(robust),
        })
    }

    /// Runs from the first midpoint `zbar_0 = z0` at time `t0` (for a time-dependent `H` the
    /// `t` coordinate of `z0` is the clock) until `stop`; on failure the observer has seen
    /// every midpoint computed before the failing step. A run until a time ends exactly on it:
    /// its last step is shortened (or stretched, by at most half a step) in `tau` so that the
    /// last midpoint lands on `t_end` to roundoff (`dth::dth::Dth::step_toward`), and that
    /// midpoint and its time are the run's end (its segment has its own `dtau`, so the vertex
    /// invariants of plain DTH jump once at its vertex).
    pub fn run<D: Dim, H: Hamiltonian<D> + Clone, O: Observer<D>>(
        &self,
        system: &H,
        z0: OVector<f64, D>,
        t0: f64,
        stop: Stop,
        observer: &mut O,
    ) -> Result<RunEnd<D>, MethodFailure>
    where
        DefaultAllocator: Alloc<D>,
    {
        let start = |e| MethodFailure::integrator(0, e);
        let mut dth = Dth::new(system.clone(), z0, self.options).map_err(start)?;
        if !system.flags().time_dependent {
            dth = dth.with_tbar0(t0).map_err(start)?;
        }
        let mut record = dth.record();
        loop {
            observer.on_step(&record);
            if let Some(failure) = stop.cut_short(record.k, record.t) {
                return Err(failure);
            }
            if stop.done(record.k, record.t) {
                return Ok(RunEnd {
                    z: record.z,
                    t: record.t,
                    steps: record.k,
                });
            }
            let failed = |e| MethodFailure::integrator(record.k + 1, e);
            record = match stop {
                Stop::Time { t_end, .. } => {
                    let (r, reached) = dth.step_toward(t_end).map_err(failed)?;
                    if reached {
                        observer.on_step(&r);
                        return Ok(RunEnd {
                            z: r.z,
                            t: r.t,
                            steps: r.k,
                        });
                    }
                    r
                }
                Stop::Steps(_) => dth.step().map_err(failed)?,
            };
        }
    }
}
