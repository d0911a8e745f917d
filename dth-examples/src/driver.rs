//! How long a scene's run lasts and when it is interrupted ([`Stop`]), how it fails
//! ([`MethodFailure`]), and the two ways every method of a scene is run, both through the
//! library's one driver (`dth::solve`): the fixed-step peers ([`run_peer`]) and the DTH
//! stepper ([`DthRunner`]). Both report every state to one `dth::observer::Observer` and end
//! with a `dth::methods::RunEnd`, or with a typed [`MethodFailure`]; a run until a time ends
//! exactly on it, whatever the method.
//!
//! Nothing here knows scenes or systems beyond `dth::Hamiltonian`.

use dth::dth::{DthOptions, Solver};
use dth::event::Event;
use dth::methods::{steps_until, OneStepMethod, RunEnd};
use dth::nalgebra::{DefaultAllocator, Dim, OVector};
use dth::observer::Observer;
use dth::solve::{solve, Integrator, Method, Peer};
use dth::Alloc;
use dth::Hamiltonian;
use std::sync::atomic::{AtomicBool, Ordering};

pub use crate::error::{FailureCause, MethodFailure};

/// How long a run lasts.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Limit {
    /// After this many steps.
    Steps(usize),
    /// At `t_end`, exactly (every method lands its last state on it), or after `max_steps`
    /// steps, whichever is first (the latter a failure, `FailureCause::StepCap`).
    Time {
        /// End time.
        t_end: f64,
        /// Safety cap.
        max_steps: usize,
    },
}

impl Limit {
    /// The end time of a run until a time (`None`: a number of steps).
    pub fn end_time(&self) -> Option<f64> {
        match *self {
            Limit::Time { t_end, .. } => Some(t_end),
            Limit::Steps(_) => None,
        }
    }
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
pub struct Stop<'a> {
    /// How long the run lasts.
    pub limit: Limit,
    /// Set: stop before the next step.
    interrupt: Option<&'static AtomicBool>,
    /// Times to land on beside the run, strictly inside it and ascending
    /// ([`crate::output_times::OutputTimes::landings`]).
    times: &'a [f64],
    /// The events the run watches ([`Stop::with_events`]).
    events: &'a [Watched<'a>],
}

/// A function of the state an event watches (`dth::event`): it fires where the value turns
/// negative. `z` is in the run's layout (the system's `(q, p)`, or its extended state), `t` its
/// time; `scratch` is the caller's, kept from call to call.
pub trait Condition: Sync {
    /// The value at `z` at time `t` (NaN where it cannot be computed: the run then fails
    /// naming the event).
    fn value(&self, t: f64, z: &[f64], scratch: &mut Vec<f64>) -> f64;
}

/// An event a run watches: its name, whether it ends the run, its condition.
#[derive(Clone, Copy)]
pub struct Watched<'a> {
    /// Its name.
    pub name: &'a str,
    /// The run ends where it fires.
    pub stop: bool,
    /// Fires where this turns negative.
    pub condition: &'a dyn Condition,
}

/// The library's events (`dth::event::Event`) for the `watched` ones, in their order.
pub fn events<'a, D: Dim>(watched: &'a [Watched<'a>]) -> Vec<Event<'a, D>>
where
    DefaultAllocator: Alloc<D>,
{
    watched
        .iter()
        .map(|w| {
            let mut scratch = Vec::new();
            let event = Event::new(w.name, move |t, z: &OVector<f64, D>| {
                w.condition.value(t, z.as_slice(), &mut scratch)
            });
            if w.stop {
                event.stop()
            } else {
                event
            }
        })
        .collect()
}

impl std::fmt::Debug for Watched<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Watched")
            .field("name", &self.name)
            .field("stop", &self.stop)
            .finish_non_exhaustive()
    }
}

impl From<Limit> for Stop<'static> {
    fn from(limit: Limit) -> Self {
        Stop {
            limit,
            interrupt: None,
            times: &[],
            events: &[],
        }
    }
}

impl Stop<'static> {
    /// After `n` steps ([`Limit::Steps`]), not interruptible.
    pub fn steps(n: usize) -> Self {
        Limit::Steps(n).into()
    }

    /// At `t_end` or after `max_steps` steps ([`Limit::Time`]), not interruptible.
    pub fn time(t_end: f64, max_steps: usize) -> Self {
        Limit::Time { t_end, max_steps }.into()
    }
}

impl<'a> Stop<'a> {
    /// The same stop, interrupted once `flag` is set (`None`: never).
    pub fn with_interrupt(mut self, flag: Option<&'static AtomicBool>) -> Self {
        self.interrupt = flag;
        self
    }

    /// The same interrupt flag (and times) with another limit.
    pub fn with_limit(mut self, limit: Limit) -> Self {
        self.limit = limit;
        self
    }

    /// The same stop, with the run landing on `times` beside itself (ascending, strictly
    /// inside a run that ends at a time) and showing the states there to its observer as
    /// landings (`dth::observer::Observer::on_landing`).
    pub fn with_times<'b>(self, times: &'b [f64]) -> Stop<'b>
    where
        'a: 'b,
    {
        Stop {
            limit: self.limit,
            interrupt: self.interrupt,
            times,
            events: self.events,
        }
    }

    /// The times it lands on ([`Stop::with_times`]).
    pub fn times(&self) -> &'a [f64] {
        self.times
    }

    /// The same stop, watching `events` (and no other): each is located where it fires,
    /// shown to the observer (`dth::observer::Observer::on_event`, numbered in this order),
    /// and a stop ends the run there.
    pub fn with_events<'b>(self, events: &'b [Watched<'b>]) -> Stop<'b>
    where
        'a: 'b,
    {
        Stop {
            limit: self.limit,
            interrupt: self.interrupt,
            times: self.times,
            events,
        }
    }

    /// The events it watches ([`Stop::with_events`]).
    pub fn events(&self) -> &'a [Watched<'a>] {
        self.events
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

    /// The number of steps a fixed-step method with step `dt > 0` takes from `t0`: to land
    /// on `t_end` (`dth::methods::steps_until`, as `dth::solve` runs it), capped at
    /// `max_steps`.
    pub fn fixed_steps(&self, t0: f64, dt: f64) -> usize {
        match self.limit {
            Limit::Steps(n) => n,
            Limit::Time { t_end, max_steps } => steps_until(t0, t_end, dt).min(max_steps),
        }
    }
}

/// Runs `integrator` on `system` from `z0` at `t0` until `stop` through `dth::solve`, every
/// state shown to `observer`, only the first and last kept, and `H` evaluated only where the
/// method needs it (what a scene computes beyond that is its effects').
fn drive<D: Dim, H, I, O>(
    integrator: I,
    system: &H,
    (z0, low): (OVector<f64, D>, Option<OVector<f64, D>>),
    t0: f64,
    stop: Stop,
    observer: &mut O,
) -> Result<RunEnd<D>, MethodFailure>
where
    DefaultAllocator: Alloc<D>,
    H: Hamiltonian<D>,
    I: Integrator<D, H>,
    O: Observer<D>,
{
    let mut run = solve(system, z0, integrator)
        .save_every(usize::MAX)
        .without_energy_errors();
    if let Some(low) = low {
        run = run.start_low(low);
    }
    // A time-dependent H's clock is its t coordinate.
    if !system.flags().time_dependent {
        run = run.start_time(t0);
    }
    run = match stop.limit {
        Limit::Steps(n) => run.steps(n),
        Limit::Time { t_end, max_steps } => run.until(t_end).max_steps(max_steps),
    };
    if !stop.times.is_empty() {
        run = run.land_at(stop.times.iter().copied());
    }
    if let Some(flag) = stop.interrupt {
        run = run.interrupt(flag);
    }
    for event in events(stop.events) {
        run = run.event(event);
    }
    match run.observer(observer).run() {
        Ok(solution) => match (solution.end_state(), solution.end_time()) {
            (Some(z), Some(t)) => Ok(RunEnd {
                z: z.clone(),
                t,
                steps: solution.steps,
            }),
            // A solution that reached its end has its end state.
            _ => Err(MethodFailure::integrator(0, dth::Error::MissingEnd)),
        },
        Err(failed) => {
            // Nothing computed: the start failed (step 0); else the step after the last.
            let step = if failed.partial.is_empty() {
                0
            } else {
                failed.partial.steps + 1
            };
            Err(match failed.error {
                dth::Error::StepCap {
                    max_steps,
                    t,
                    t_end,
                    ..
                } => MethodFailure {
                    step,
                    cause: FailureCause::StepCap {
                        max_steps,
                        t,
                        t_end,
                    },
                },
                dth::Error::Interrupted { step } => MethodFailure {
                    step,
                    cause: FailureCause::Interrupted,
                },
                error => MethodFailure::integrator(step, error),
            })
        }
    }
}

/// Runs a fixed-step peer (`dth::methods`) with step `dt` from `z0` at `t0` until `stop`,
/// showing every state to `observer`; a run until a time lands on it (its last step is what
/// is left). On failure the observer has seen every state before the failing step.
pub fn run_peer<D: Dim, H, M, O>(
    method: M,
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
    drive(
        Peer::new(method, dt),
        system,
        (z0, None),
        t0,
        stop,
        observer,
    )
}

/// The DTH stepper (`dth::dth::Dth`) driven until a [`Stop`]: every midpoint `zbar_k` is shown
/// with its time `tbar_k`, `lambda_k` and the left vertex `z^(k)` at `t^(k)`.
#[derive(Debug, Clone, Copy)]
pub struct DthRunner {
    /// Step, `lambda_0` and Newton settings.
    pub options: DthOptions,
    /// A regularized run starts in double-double and solves its steps so
    /// ([`DthRunner::with_double_double`]).
    pub double_double: bool,
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
            double_double: false,
        })
    }

    /// A regularized run (`crate::regularized::Regularized::run`) starts from the exact
    /// image of the physical start and solves every step in double-double (a scene's
    /// `double_double = true`); other runs are unaffected.
    pub fn with_double_double(mut self, double_double: bool) -> Self {
        self.double_double = double_double;
        self
    }

    /// Runs from the first midpoint `zbar_0 = z0` at time `t0` (for a time-dependent `H` the
    /// `t` coordinate of `z0` is the clock) until `stop`; on failure the observer has seen
    /// every midpoint computed before the failing step. A run until a time ends exactly on it:
    /// its last step is shortened (or stretched, by at most half a step) in `tau` so that the
    /// last midpoint lands on `t_end` to roundoff (`dth::dth::Dth::step_toward`), and that
    /// midpoint and its time are the run's end (its segment has its own `dtau`, so the vertex
    /// invariants of plain DTH jump once at its vertex). `start` is `(z0, low)`: from the
    /// midpoint `z0 + low` where `low` is given (a start in double-double, a regularized run's
    /// with [`DthRunner::with_double_double`]: see `dth::Solve::start_low`).
    pub fn run<D: Dim, H: Hamiltonian<D>, O: Observer<D>>(
        &self,
        system: &H,
        start: (OVector<f64, D>, Option<OVector<f64, D>>),
        t0: f64,
        stop: Stop,
        observer: &mut O,
    ) -> Result<RunEnd<D>, MethodFailure>
    where
        DefaultAllocator: Alloc<D>,
    {
        drive(Method::Dth(self.options), system, start, t0, stop, observer)
    }
}
