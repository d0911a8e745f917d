//! A fixed-step run between calls ([`FixedRun`]): its clock, its steps, and what it does
//! beside them ([`Beside`]): the checks before each step, the chosen times it lands on and the
//! events it watches.

use nalgebra::{DefaultAllocator, Dim, OVector};

use super::{at_step, check_dt, check_state, steps_until, OneStepMethod, RunEnd};
use crate::error::RunError;
use crate::event::Watch;
use crate::hamiltonian::Alloc;
use crate::observer::{Observer, StepRecord};
use crate::{Error, Hamiltonian};

/// How far [`FixedRun::advance`] steps.
#[derive(Clone, Copy, Debug)]
pub(crate) enum Span {
    /// This many steps of `dt`.
    Steps(usize),
    /// Steps of `dt` (`dt > 0`) until this time, the last one shortened to land on it exactly.
    Until(f64),
}

/// What a run does beside its steps: `check(k)`, asked before step `k`, stops the run with its
/// error; the chosen `times` (ascending, after the last state) are landed on beside the run;
/// the `watch`'s events are located in the step where they fire.
pub(crate) struct Beside<'b, 'e, D: Dim>
where
    DefaultAllocator: Alloc<D>,
{
    pub(crate) check: Option<&'b mut dyn FnMut(usize) -> Result<(), Error>>,
    pub(crate) times: &'b [f64],
    pub(crate) watch: Option<&'b mut Watch<'e, D>>,
}

impl<D: Dim> Beside<'_, '_, D>
where
    DefaultAllocator: Alloc<D>,
{
    /// Nothing beside the steps.
    pub(crate) fn nothing() -> Self {
        Beside {
            check: None,
            times: &[],
            watch: None,
        }
    }
}

/// How [`FixedRun::advance`] ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Advanced {
    /// It took its steps.
    Done,
    /// An event stopped the run (its state is the run's last).
    Stopped,
}

/// A fixed-step run between calls of [`FixedRun::advance`]: the last state (its time and step
/// count), and the storage the steps reuse.
pub(crate) struct FixedRun<D: Dim>
where
    DefaultAllocator: Alloc<D>,
{
    /// The last accepted state.
    pub(crate) end: RunEnd<D>,
    /// The start time: step `k` ends at `t0 + k dt` (the clock is not a running sum).
    t0: f64,
    /// The next state, written by the method and swapped with `end.z` once accepted.
    next: OVector<f64, D>,
    /// The record shown to the observer.
    record: StepRecord<D>,
    /// The method's Newton iterations counted so far.
    iterations: usize,
}

impl<D: Dim> FixedRun<D>
where
    DefaultAllocator: Alloc<D>,
{
    /// Checks the input (`dt` finite and non-zero, `z0` of `h`'s dimension and finite, `t0`
    /// finite) and shows the initial state to `observer`.
    pub(crate) fn start<H, M, O>(
        method: &M,
        h: &H,
        z0: &OVector<f64, D>,
        t0: f64,
        dt: f64,
        observer: &mut O,
    ) -> Result<Self, RunError<RunEnd<D>>>
    where
        H: Hamiltonian<D>,
        M: OneStepMethod<D, H>,
        O: Observer<D>,
    {
        let end = RunEnd {
            z: z0.clone(),
            t: t0,
            steps: 0,
        };
        let checked = check_dt(dt)
            .and_then(|()| check_state(h, z0, "z0"))
            .and_then(
                |()| match z0.iter().enumerate().find(|(_, v)| !v.is_finite()) {
                    Some((index, &value)) => Err(Error::NonFiniteInitialState { index, value }),
                    None => Ok(()),
                },
            )
            .and_then(|()| {
                if t0.is_finite() {
                    Ok(())
                } else {
                    Err(Error::InvalidOption {
                        name: "t0",
                        value: t0,
                        reason: "must be finite",
                    })
                }
            });
        if let Err(error) = checked {
            return Err(RunError {
                error,
                partial: end,
            });
        }
        let record = StepRecord::fixed(0, t0, z0.clone());
        observer.on_step(&record);
        Ok(FixedRun {
            next: z0.clone(),
            end,
            t0,
            record,
            iterations: method.newton_iterations(),
        })
    }

    /// Steps `span` on from the last state, showing each new state to `observer`, and
    /// `beside` each step: its check first, then (once the step is computed) the landings on
    /// the chosen times it reaches and the events that fired in it, shown before the step
    /// itself. An event that stops the run makes its state the run's last (the landings after
    /// it are not made). On error the run stays at its last accepted state.
    ///
    /// The clock is `t0 + k dt` from the run's start `t0` (not a running sum: no accumulated
    /// rounding); with [`Span::Until`] the run goes on to step `m - 1` and a last step of
    /// `t_b - (t0 + (m - 1) dt)` ends at `t_b` itself, where `m = steps_until(t0, t_b, dt)`
    /// is the least number of steps from the start that reaches `t_b` (a last step that would
    /// only make up the rounding of `(t_b - t0) / dt` is merged into the one before). A chosen
    /// time `target` is landed on in step `steps_until(t0, target, dt)`, from its start, with a
    /// step of `target - t` (the state a run [`Span::Until`] `target` ends with, bit for bit).
    pub(crate) fn advance<H, M, O>(
        &mut self,
        method: &mut M,
        h: &H,
        dt: f64,
        span: Span,
        beside: &mut Beside<'_, '_, D>,
        observer: &mut O,
    ) -> Result<Advanced, Error>
    where
        H: Hamiltonian<D>,
        M: OneStepMethod<D, H>,
        O: Observer<D>,
    {
        let steps = match span {
            Span::Steps(n) => n,
            Span::Until(t_b) => steps_until(self.t0, t_b, dt).saturating_sub(self.end.steps),
        };
        for j in 1..=steps {
            let k = self.end.steps + 1;
            if let Some(check) = beside.check.as_mut() {
                check(k)?;
            }
            let (size, t) = match span {
                Span::Until(t_b) if j == steps => (t_b - self.end.t, t_b),
                _ => (dt, self.t0 + k as f64 * dt),
            };
            step_checked(method, h, &self.end.z, size, k, &mut self.next)?;
            let mut iterations = self.spent(method);
            // The events of this step, located; the run ends at the first that stops it.
            let mut fired = Vec::new();
            if let Some(watch) = beside.watch.as_mut() {
                if watch.crossed(t, &self.next)? {
                    fired = watch.locate(&mut |t| self.land(method, h, t, k))?;
                    iterations += self.spent(method);
                }
            }
            let stop = beside
                .watch
                .as_ref()
                .and_then(|w| w.stopping(&fired))
                .map(|(_, _, r)| r.clone());
            let last_t = stop.as_ref().map_or(t, |r| r.t);
            while let Some((&target, rest)) = beside.times.split_first() {
                if steps_until(self.t0, target, dt) > k || target > last_t {
                    break;
                }
                let mut landed = self.land(method, h, target, k)?;
                landed.iterations = self.spent(method);
                observer.on_landing(&landed);
                beside.times = rest;
            }
            for (i, _, record) in &fired {
                observer.on_event(*i, record);
            }
            match &stop {
                Some(stopped) => {
                    self.end.z.copy_from(&stopped.z);
                    self.end.t = stopped.t;
                }
                None => {
                    std::mem::swap(&mut self.end.z, &mut self.next);
                    self.end.t = t;
                }
            }
            self.end.steps = k;
            self.record.k = k;
            self.record.t = self.end.t;
            self.record.iterations = iterations;
            self.record.z.copy_from(&self.end.z);
            observer.on_step(&self.record);
            if stop.is_some() {
                return Ok(Advanced::Stopped);
            }
        }
        Ok(Advanced::Done)
    }

    /// The state at `target` in step `k` (after the last accepted state, at most a step `dt`
    /// on): one step of `target - t` from the last state, beside the run, which stays where it
    /// was. Its iterations are not counted here ([`FixedRun::spent`]).
    fn land<H, M>(
        &self,
        method: &mut M,
        h: &H,
        target: f64,
        k: usize,
    ) -> Result<StepRecord<D>, Error>
    where
        H: Hamiltonian<D>,
        M: OneStepMethod<D, H>,
    {
        let mut z = self.end.z.clone();
        if target == self.end.t {
            return Ok(StepRecord::fixed(k - 1, target, z));
        }
        step_checked(method, h, &self.end.z, target - self.end.t, k, &mut z)?;
        Ok(StepRecord::fixed(k, target, z))
    }

    /// The method's Newton iterations since the last call.
    fn spent<H, M>(&mut self, method: &M) -> u32
    where
        H: Hamiltonian<D>,
        M: OneStepMethod<D, H>,
    {
        let total = method.newton_iterations();
        let spent = u32::try_from(total.saturating_sub(self.iterations)).unwrap_or(u32::MAX);
        self.iterations = total;
        spent
    }
}

/// Step `k` of `size` from `z` into `next`, checked finite: the run's first step on its own
/// (`h` may differ from the method's last), then steps on one `h`.
fn step_checked<D: Dim, H, M>(
    method: &mut M,
    h: &H,
    z: &OVector<f64, D>,
    size: f64,
    k: usize,
    next: &mut OVector<f64, D>,
) -> Result<(), Error>
where
    DefaultAllocator: Alloc<D>,
    H: Hamiltonian<D>,
    M: OneStepMethod<D, H>,
{
    let stepped = if k == 1 {
        method.step_into(h, z, size, next)
    } else {
        method.continue_into(h, z, size, next)
    };
    match stepped {
        Ok(()) if next.iter().all(|v| v.is_finite()) => Ok(()),
        Ok(()) => Err(Error::MethodNonFinite {
            method: M::NAME,
            step: k,
            what: "state",
        }),
        Err(error) => Err(at_step(error, k)),
    }
}
