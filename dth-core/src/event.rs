//! Events: conditions on the state that a run watches ([`Event`]), located to roundoff on the
//! step where they fire, then recorded or ending the run ([`Action`]).
//!
//! An event is a function `g(t, z)`; it *fires* where the condition `g < 0` becomes true: from
//! `g >= 0` at one state of the run to `g < 0` at the next (write `lhs < rhs` as `lhs - rhs`,
//! `lhs > rhs` as `rhs - lhs`). A condition that already holds at the start fires only once it
//! has stopped holding and holds again. It is checked at the states the run reports (DTH:
//! its midpoints), so a condition that turns true and false again within one step is missed,
//! as with any event detection on a step's ends: a step small enough for the method's
//! accuracy resolves it.
//!
//! **Location.** On the step where an event fires, between its start (`t_a`, `g_a >= 0`) and
//! its end (`t_b`, `g_b < 0`), the time is found by root-finding on the method's own states at
//! times inside the step: each try is a landing beside the run, from the step's start, with
//! the step shortened to end on the try's time (`Solve::save_at`'s landings: for DTH an exact
//! midpoint, whose energy is the start's; for a fixed-step method a step of what is left), so
//! the event's state is one the method computes, not an interpolant. The iteration is the
//! Illinois variant of regula falsi (superlinear, and the bracket always shrinks), bisecting
//! when a try falls outside the bracket; it stops when the bracket is within `8 eps |t|` (the
//! rounding of a time) or `g` is zero. The event's state is that at the bracket's end where
//! the condition holds. (DTH cannot take a step much shorter than `sqrt(eps)` of its own,
//! where its energy condition is within roundoff: a landing that fails there, with the bracket
//! already within a millionth of the step, ends the search at the bracket.)
//!
//! ```
//! use dth_core::event::{Action, Event};
//! use dth_core::nalgebra::Vector4;
//! use dth_core::solve::{solve, Method};
//! use dth_core::{systems::Kepler, DthOptions};
//!
//! // The thesis orbit comes within r = 0.5 of the centre; stop once it is closer than 0.6.
//! let z0 = Vector4::new(1.0, 0.0, 0.0, 0.6);
//! let close = Event::new("close", |_t, z: &Vector4<f64>| z[0].hypot(z[1]) - 0.6).stop();
//! let run = solve(&Kepler::thesis(), z0, Method::Dth(DthOptions::new(0.01)?))
//!     .until(100.0)
//!     .event(close)
//!     .run()?;
//! let fired = &run.events[0];
//! assert_eq!(run.stopped, Some(0));
//! assert!((fired.z[0].hypot(fired.z[1]) - 0.6).abs() < 1e-13); // r = 0.6 to roundoff
//! assert_eq!(run.end_time(), Some(fired.t)); // the run ended there
//! # Ok::<(), dth_core::Error>(())
//! ```

use nalgebra::{DefaultAllocator, Dim, OVector};

use crate::hamiltonian::Alloc;
use crate::observer::StepRecord;
use crate::Error;

/// What a run does when an [`Event`] fires.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Action {
    /// Record the state (in `Solution::events`, and to the observer,
    /// `Observer::on_event`) and go on.
    Record,
    /// Record the state and end the run there: it is the run's last state (`Solution::stopped`
    /// names the event).
    Stop,
}

/// The condition an [`Event`] watches.
type Condition<'a, D> = Box<dyn FnMut(f64, &OVector<f64, D>) -> f64 + 'a>;

/// A condition on the state that a run watches (see the [module docs](self)): it fires where
/// `g(t, z) < 0` becomes true.
pub struct Event<'a, D: Dim>
where
    DefaultAllocator: Alloc<D>,
{
    name: String,
    g: Condition<'a, D>,
    action: Action,
}

impl<D: Dim> std::fmt::Debug for Event<'_, D>
where
    DefaultAllocator: Alloc<D>,
{
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Event")
            .field("name", &self.name)
            .field("action", &self.action)
            .finish_non_exhaustive()
    }
}

impl<'a, D: Dim> Event<'a, D>
where
    DefaultAllocator: Alloc<D>,
{
    /// The event `name` that fires where `g(t, z) < 0` becomes true, and is recorded
    /// ([`Action::Record`]; [`Event::stop`] to end the run there).
    pub fn new(name: impl Into<String>, g: impl FnMut(f64, &OVector<f64, D>) -> f64 + 'a) -> Self {
        Event {
            name: name.into(),
            g: Box::new(g),
            action: Action::Record,
        }
    }

    /// The same event, ending the run where it fires ([`Action::Stop`]).
    pub fn stop(mut self) -> Self {
        self.action = Action::Stop;
        self
    }

    /// Its name.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// What the run does when it fires.
    pub fn action(&self) -> Action {
        self.action
    }

    /// `g(t, z)`, checked: a NaN is an error naming the event.
    fn value(&mut self, t: f64, z: &OVector<f64, D>) -> Result<f64, Error> {
        let g = (self.g)(t, z);
        if g.is_nan() {
            return Err(Error::EventNotANumber {
                name: self.name.clone(),
                t,
            });
        }
        Ok(g)
    }
}

/// An event that fired: which, where, and the state there.
#[derive(Clone, Debug, PartialEq)]
pub struct Fired<D: Dim>
where
    DefaultAllocator: Alloc<D>,
{
    /// The event's index, in the order of `Solve::event`.
    pub event: usize,
    /// Its time.
    pub t: f64,
    /// The state there (DTH: a midpoint).
    pub z: OVector<f64, D>,
    /// The index of the step it fired in (the step from state `k - 1` to `k`).
    pub k: usize,
}

/// The events of a run, with `g` at the last state checked: what `Solve::run` watches, and
/// what a driver of its own (an exact solution sampled on a grid) watches the same way:
/// [`Watch::start`] at the first state, [`Watch::crossed`] after each step, and on a step
/// where it says `true`, [`Watch::locate`] with the driver's landing inside the step.
#[derive(Debug)]
pub struct Watch<'a, D: Dim>
where
    DefaultAllocator: Alloc<D>,
{
    events: Vec<Event<'a, D>>,
    /// `g_i` at the last state checked, its time and the time of the state before.
    last: Vec<f64>,
    t_last: f64,
    t_before: f64,
    /// The events that fired in the step just checked: index, `g` at its start and end.
    crossed: Vec<(usize, f64, f64)>,
}

impl<'a, D: Dim> Watch<'a, D>
where
    DefaultAllocator: Alloc<D>,
{
    /// Watches `events` (numbered in this order).
    pub fn new(events: Vec<Event<'a, D>>) -> Self {
        Watch {
            last: vec![f64::NAN; events.len()],
            events,
            t_last: f64::NAN,
            t_before: f64::NAN,
            crossed: Vec::new(),
        }
    }

    /// `true` when it watches no event.
    pub fn is_empty(&self) -> bool {
        self.events.is_empty()
    }

    /// The event among `fired` (what [`Watch::locate`] returned) that ends the run: the last,
    /// if it is a stop.
    pub fn stopping<'f>(
        &self,
        fired: &'f [(usize, f64, StepRecord<D>)],
    ) -> Option<&'f (usize, f64, StepRecord<D>)> {
        fired
            .last()
            .filter(|(i, _, _)| self.events[*i].action == Action::Stop)
    }

    /// `g` at the run's first state.
    ///
    /// # Errors
    /// [`Error::EventNotANumber`] for a condition that is NaN there.
    pub fn start(&mut self, t: f64, z: &OVector<f64, D>) -> Result<(), Error> {
        self.t_last = t;
        for (event, last) in self.events.iter_mut().zip(&mut self.last) {
            *last = event.value(t, z)?;
        }
        Ok(())
    }

    /// Checks the step to the state `z` at `t`: `true` when an event fired in it (then
    /// [`Watch::locate`] finds where).
    ///
    /// # Errors
    /// [`Error::EventNotANumber`] for a condition that is NaN there.
    pub fn crossed(&mut self, t: f64, z: &OVector<f64, D>) -> Result<bool, Error> {
        self.crossed.clear();
        (self.t_before, self.t_last) = (self.t_last, t);
        for (i, event) in self.events.iter_mut().enumerate() {
            let g = event.value(t, z)?;
            if self.last[i] >= 0.0 && g < 0.0 {
                self.crossed.push((i, self.last[i], g));
            }
            self.last[i] = g;
        }
        Ok(!self.crossed.is_empty())
    }

    /// The events that fired in the step checked last by [`Watch::crossed`], located with
    /// `land(t)`, the run's state at a time `t` inside the step: in the order of their times, up
    /// to the first that stops the run, each with the time it was landed on (`land(t)` again
    /// gives its state).
    ///
    /// # Errors
    /// The landing's, and [`Error::EventNotANumber`].
    pub fn locate(
        &mut self,
        land: &mut dyn FnMut(f64) -> Result<StepRecord<D>, Error>,
    ) -> Result<Vec<(usize, f64, StepRecord<D>)>, Error> {
        let (t_a, t) = (self.t_before, self.t_last);
        let crossed = std::mem::take(&mut self.crossed);
        let mut fired = Vec::with_capacity(crossed.len());
        for &(i, g_a, g_b) in &crossed {
            let (asked, record) = locate(&mut self.events[i], (t_a, g_a), (t, g_b), land)?;
            fired.push((i, asked, record));
        }
        self.crossed = crossed;
        fired.sort_by(|a, b| a.2.t.total_cmp(&b.2.t));
        if let Some(first_stop) = fired
            .iter()
            .position(|(i, _, _)| self.events[*i].action == Action::Stop)
        {
            fired.truncate(first_stop + 1);
        }
        Ok(fired)
    }
}

/// Where `event` fires between `a = (t_a, g_a)` (`g_a >= 0`) and `b = (t_b, g_b)` (`g_b < 0`):
/// the Illinois iteration of the module docs on `g(land(t))`; the time landed on and the state.
fn locate<D: Dim>(
    event: &mut Event<'_, D>,
    (mut t_a, mut g_a): (f64, f64),
    (mut t_b, mut g_b): (f64, f64),
    land: &mut dyn FnMut(f64) -> Result<StepRecord<D>, Error>,
) -> Result<(f64, StepRecord<D>), Error>
where
    DefaultAllocator: Alloc<D>,
{
    if g_a == 0.0 {
        // On the boundary at the step's start: the condition holds from there on.
        return Ok((t_a, land(t_a)?));
    }
    let width = t_b - t_a;
    let mut at_b = land(t_b)?;
    let mut asked = t_b;
    // Which end the last try replaced (an end kept twice has its g halved: Illinois).
    let mut side = 0_i8;
    // A bracket that halves at least every other try is within 8 eps |t| after about 2 x 60.
    for _ in 0..128 {
        if t_b - t_a <= 8.0 * f64::EPSILON * t_a.abs().max(t_b.abs()) {
            break;
        }
        let secant = t_b - g_b * (t_b - t_a) / (g_b - g_a);
        let t = if t_a < secant && secant < t_b {
            secant
        } else {
            0.5 * (t_a + t_b)
        };
        let record = match land(t) {
            Ok(record) => record,
            // A landing a millionth of the step from the last one may fail where the method
            // cannot take so short a step (DTH's energy condition is then within its roundoff):
            // the bracket is as small as the method resolves.
            Err(_) if t_b - t_a <= 1e-6 * width => break,
            Err(error) => return Err(error),
        };
        let g = event.value(record.t, &record.z)?;
        if g < 0.0 {
            (t_b, g_b, at_b, asked) = (t, g, record, t);
            if side == -1 {
                g_a *= 0.5;
            }
            side = -1;
        } else if g == 0.0 {
            // On the boundary itself: where the condition starts to hold.
            return Ok((t, record));
        } else {
            (t_a, g_a) = (t, g);
            if side == 1 {
                g_b *= 0.5;
            }
            side = 1;
        }
    }
    Ok((asked, at_b))
}
