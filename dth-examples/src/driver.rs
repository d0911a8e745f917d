//! The run driver: how long a run lasts and when it is interrupted ([`Stop`]), how it fails ([`MethodFailure`]), and the
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
use std::sync::atomic::{AtomicBool, Ordering};

pub use crate::error::{FailureCause, MethodFailure};

/// How long a run lasts.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Limit {
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

/// When a run stops: at its [`Limit`], or at the next step boundary once its interrupt flag
/// is set (the `dth` command sets it on SIGINT or SIGTERM; a library caller through
/// `RunOptions::with_interrupt`). An interrupted run ends with
/// [`FailureCause::Interrupted`]: what it computed up to there is kept, as for a failure.
///
/// ```
/// use std::sync::atomic::{AtomicBool, Ordering};
/// use dth_examples::driver::{Limit, Stop};
/// static FLAG: AtomicBool = AtomicBool::new(false);
/// let stop = Stop::steps(10).with_interrupt(Some(&FLAG));
/// assert_eq!(stop.limit, Limit::Steps(10));
/// assert!(stop.interruption(3).is_none());
/// FLAG.store(true, Ordering::Relaxed);
/// assert_eq!(stop.interruption(3).map(|f| f.step), Some(4));
/// ```
#[derive(Debug, Clone, Copy)]
pub struct Stop {
    /// How long the run lasts.
    pub limit: Limit,
    /// Set: stop before the next step.
    interrupt: Option<&'static AtomicBool>,
}

impl From<Limit> for Stop {
    fn from(limit: Limit) -> Self {
        Stop {
            limit,
            interrupt: None,
        }
    }
}

impl Stop {
    /// After `n` steps ([`Limit::Steps`]), not interruptible.
    pub fn steps(n: usize) -> Self {
        Limit::Steps(n).into()
    }

    /// At `t_end` or after `max_steps` steps ([`Limit::Time`]), not interruptible.
    pub fn time(t_end: f64, max_steps: usize) -> Self {
        Limit::Time { t_end, max_steps }.into()
    }

    /// The same stop, interrupted once `flag` is set (`None`: never).
    pub fn with_interrupt(mut self, flag: Option<&'static AtomicBool>) -> Self {
        self.interrupt = flag;
        self
    }

    /// The same interrupt flag with another limit.
    pub fn with_limit(mut self, limit: Limit) -> Self {
        self.limit = limit;
        self
    }

    /// `true` once the interrupt flag is set.
    pub fn interrupted(&self) -> bool {
        self.interrupt.is_some_and(|f| f.load(Ordering::Relaxed))
    }

    /// The failure of a run interrupted after step `k` (it stops before step `k + 1`), or
    /// `None` while the flag is not set. Drivers ask it at every step boundary.
    pub fn interruption(&self, k: usize) -> Option<MethodFailure> {
        self.interrupted().then_some(MethodFailure {
            step: k + 1,
            cause: FailureCause::Interrupted,
        })
    }

    /// `true` once step `k` at time `t` ends the run.
    pub fn done(&self, k: usize, t: f64) -> bool {
        match self.limit {
            Limit::Steps(n) => k >= n,
            Limit::Time { t_end, max_steps } => t >= t_end || k >= max_steps,
        }
    }

    /// The failure of a run that is done at step `k` and time `t` only because the cap
    /// `max_steps` of a [`Limit::Time`] stopped it short of `t_end` (`None` when it reached its
    /// end): the run did not compute what it was asked for, so it failed at step `k + 1`.
    pub fn cut_short(&self, k: usize, t: f64) -> Option<MethodFailure> {
        match self.limit {
            Limit::Time { t_end, max_steps } if k >= max_steps && t < t_end => {
                Some(MethodFailure {
                    step: k + 1,
                    cause: FailureCause::StepCap {
                        max_steps,
                        t,
                        t_end,
                    },
                })
            }
            _ => None,
        }
    }

    /// The number of steps a fixed-step method with step `dt > 0` takes from `t0`: the first
    /// `k` with `t0 + k dt >= t_end` (the clock is `t0 + k dt`, as `dth::methods::run`
    /// computes it), capped at `max_steps`.
    pub fn fixed_steps(&self, t0: f64, dt: f64) -> usize {
        match self.limit {
            Limit::Steps(n) => n,
            Limit::Time { t_end, max_steps } => {
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

/// A fixed-step method that refuses its next step once `interrupt` is set: `dth::methods::run`
/// then ends as for a failed step, and [`run_peer`] reports the interruption (`refused`).
struct Interruptible<'a, M> {
    method: &'a mut M,
    interrupt: &'static AtomicBool,
    refused: bool,
}

impl<M> Interruptible<'_, M> {
    /// An error (and `refused`) once `interrupt` is set.
    #[inline]
    fn check(&mut self) -> Result<(), dth::Error> {
        if self.interrupt.load(Ordering::Relaxed) {
            self.refused = true;
            // Never shown: `run_peer` reports `FailureCause::Interrupted` instead.
            return Err(dth::Error::InvalidOption {
                name: "interrupt",
                value: f64::NAN,
                reason: "the run was interrupted",
            });
        }
        Ok(())
    }
}

impl<D: Dim, H: Hamiltonian<D>, M: OneStepMethod<D, H>> OneStepMethod<D, H> for Interruptible<'_, M>
where
    DefaultAllocator: Alloc<D>,
{
    const NAME: &'static str = M::NAME;
    const ORDER: u32 = M::ORDER;

    #[inline]
    fn step_into(
        &mut self,
        h: &H,
        z: &OVector<f64, D>,
        dt: f64,
        z1: &mut OVector<f64, D>,
    ) -> Result<(), dth::Error> {
        self.check()?;
        self.method.step_into(h, z, dt, z1)
    }

    /// Forwarded as such: `run` continues a run on the same `H` through it, which lets a
    /// method reuse what the last step left (Stormer-Verlet its last force).
    #[inline]
    fn continue_into(
        &mut self,
        h: &H,
        z: &OVector<f64, D>,
        dt: f64,
        z1: &mut OVector<f64, D>,
    ) -> Result<(), dth::Error> {
        self.check()?;
        self.method.continue_into(h, z, dt, z1)
    }

    fn newton_iterations(&self) -> usize {
        self.method.newton_iterations()
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
    let end = match stop.interrupt {
        None => methods::run(method, system, &z0, t0, dt, steps, observer),
        Some(interrupt) => {
            let mut method = Interruptible {
                method,
                interrupt,
                refused: false,
            };
            let end = methods::run(&mut method, system, &z0, t0, dt, steps, observer);
            if let (Err(e), true) = (&end, method.refused) {
                return Err(MethodFailure {
                    step: e.partial.steps + 1,
                    cause: FailureCause::Interrupted,
                });
            }
            end
        }
    }
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
            options: DthOptions::new(dtau)?
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
            if let Some(interrupted) = stop.interruption(record.k) {
                return Err(interrupted);
            }
            let failed = |e| MethodFailure::integrator(record.k + 1, e);
            record = match stop.limit {
                Limit::Time { t_end, .. } => {
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
                Limit::Steps(_) => dth.step().map_err(failed)?,
            };
        }
    }
}
