//! One driver for every integrator: [`solve`] a Hamiltonian from a state with a [`Method`]
//! (DTH of any order, robust or not, or a peer), say where it ends ([`Solve::until`] a time,
//! exactly, or [`Solve::steps`]), what it keeps ([`Solve::save_every`], [`Solve::save_at`])
//! and who watches ([`Solve::observe`]), and [`Solve::run`] it into one [`Solution`]: times,
//! states, step kinds, energy errors, DTH's multipliers and vertices, and the failure, if any.
//!
//! ```
//! use dth_core::nalgebra::Vector4;
//! use dth_core::solve::{solve, Method};
//! use dth_core::{systems::Kepler, DthOptions};
//!
//! let kepler = Kepler::thesis(); // H = p1^2 + p2^2 - (q1^2 + q2^2)^(-1/2)
//! let z0 = Vector4::new(0.5, 0.0, 0.0, 1.2);
//! let methods = [
//!     Method::Dth(DthOptions::new(0.02)?),
//!     Method::Midpoint { dt: 0.01 },
//!     Method::GaussLegendre2 { dt: 0.05 },
//! ];
//! for method in methods {
//!     let run = solve(&kepler, z0, method).until(10.0).save_every(100).run()?;
//!     // Every method ends at T: a peer's last time is T, DTH's last midpoint lands on it.
//!     assert!((run.end_time().unwrap() - 10.0).abs() <= 4.0 * f64::EPSILON * 10.0);
//!     println!("{:>15}: max |H - H0| = {:.1e}", run.method, run.max_energy_error());
//! }
//! # Ok::<(), dth_core::Error>(())
//! ```
//!
//! A method that fails keeps what it computed: [`Solve::run`] returns a [`RunError`] whose
//! `partial` is the [`Solution`] up to the last accepted step (its
//! [`failure`](Solution::failure) is the error), and `?` converts it into [`Error`].
//!
//! # Ending at a time
//! DTH lands its last midpoint on `T` by scaling the last step's `dtau`
//! ([`Dth::step_toward`]; the step is marked [`StepKind::Shortened`]); a fixed-step method
//! takes steps of `dt` and a last step of what is left (its record stays
//! [`StepKind::Fixed`]; its time is `T` itself). [`Solve::save_at`] lands on each of its
//! times the same way, but beside the run: from the start of the step that reaches a time, a
//! step shortened onto it gives the state there ([`Observer::on_landing`]), and the run goes
//! on from where it was. The saved states are the method's own states (a DTH midpoint with
//! its energy exact, not an interpolation; a fixed-step method's, bit for bit, the state a run
//! ending at that time ends with), and the run's own steps, invariants and end do not depend
//! on the times chosen
//! (landing on them in the run itself would restart its grid at each, and jump DTH's vertex
//! invariants there). A landing costs one step of a fixed-step method, about three of DTH
//! (the secant on the step's scale).
//!
//! # Time-dependent Hamiltonians
//! The clock of a time-dependent `H` (extended phase space `z = (q, t, p, p_t)`) is the `t`
//! coordinate of `z0`; [`Solve::start_time`] sets the clock of an autonomous one (default 0).

use std::sync::atomic::{AtomicBool, Ordering};

use nalgebra::{DefaultAllocator, Dim, OVector};

use crate::dth::{Dth, DthOptions};
use crate::error::RunError;
use crate::event::{Event, Fired, Watch};
use crate::hamiltonian::Alloc;
use crate::methods::{
    Advanced, Beside, DiscreteGradient, FixedRun, GaussLegendre2, ImplicitMidpoint, OneStepMethod,
    Rk4, Span, StormerVerlet, Trapezoidal,
};
use crate::observer::{Observer, StepKind, StepRecord};
use crate::{Error, Hamiltonian};

/// An integrator and its step: what [`solve`] runs. Every variant applies to every
/// [`Hamiltonian`] ([`Method::StormerVerlet`] needs a separable one and says so when it is
/// not); a method for a narrower class (Greenspan's
/// [`DiscreteMechanics`](crate::methods::DiscreteMechanics) for central forces) or one of
/// your own runs through [`Peer`].
#[derive(Clone, Copy, Debug, PartialEq)]
#[non_exhaustive]
pub enum Method {
    /// DTH with these options (step `dtau`, order, robust mode, ...).
    Dth(DthOptions),
    /// The trapezoidal rule with step `dt`.
    Trapezoidal {
        /// The step.
        dt: f64,
    },
    /// The implicit midpoint rule with step `dt`.
    Midpoint {
        /// The step.
        dt: f64,
    },
    /// The 2-stage Gauss-Legendre method (order 4) with step `dt`.
    GaussLegendre2 {
        /// The step.
        dt: f64,
    },
    /// The classical Runge-Kutta method with step `dt`.
    Rk4 {
        /// The step.
        dt: f64,
    },
    /// Stormer-Verlet (separable `H`) with step `dt`.
    StormerVerlet {
        /// The step.
        dt: f64,
    },
    /// Gonzalez's midpoint discrete gradient (energy-conserving) with step `dt`.
    DiscreteGradient {
        /// The step.
        dt: f64,
    },
}

impl Method {
    /// Its name in tables and errors (`"dth"`, `"midpoint"`, ...; a peer's is its
    /// [`OneStepMethod::NAME`]).
    pub fn name(&self) -> &'static str {
        match self {
            Method::Dth(_) => "dth",
            Method::Trapezoidal { .. } => "trapezoidal",
            Method::Midpoint { .. } => "midpoint",
            Method::GaussLegendre2 { .. } => "gauss_legendre2",
            Method::Rk4 { .. } => "rk4",
            Method::StormerVerlet { .. } => "stormer_verlet",
            Method::DiscreteGradient { .. } => "discrete_gradient",
        }
    }

    /// Its classical order (DTH: the order of its composition, 2 to 8).
    pub fn order(&self) -> u32 {
        match self {
            Method::Dth(options) => options.order(),
            Method::GaussLegendre2 { .. } | Method::Rk4 { .. } => 4,
            _ => 2,
        }
    }
}

impl From<DthOptions> for Method {
    fn from(options: DthOptions) -> Self {
        Method::Dth(options)
    }
}

/// Any [`OneStepMethod`] with its step `dt`, for [`solve`]: the methods [`Method`] does not
/// name (Greenspan's discrete mechanics, which needs a central force) and your own.
///
/// ```
/// use dth_core::methods::DiscreteMechanics;
/// use dth_core::nalgebra::Vector4;
/// use dth_core::solve::{solve, Peer};
/// use dth_core::systems::Kepler;
///
/// let z0 = Vector4::new(0.5, 0.0, 0.0, 1.2);
/// let run = solve(&Kepler::thesis(), z0, Peer::new(DiscreteMechanics::new(), 0.15))
///     .until(3.0)
///     .run()?;
/// assert_eq!(run.method, "discrete_mechanics");
/// assert!(run.max_energy_error() < 1e-14); // Greenspan's method conserves energy
/// # Ok::<(), dth_core::Error>(())
/// ```
#[derive(Clone, Debug)]
pub struct Peer<M> {
    /// The method.
    pub method: M,
    /// Its step.
    pub dt: f64,
}

impl<M> Peer<M> {
    /// `method` with step `dt` (checked when the run starts: finite and non-zero, positive
    /// to end at a time).
    pub fn new(method: M, dt: f64) -> Self {
        Peer { method, dt }
    }
}

/// What [`solve`] can run: a [`Method`] or a [`Peer`]. Implemented by this crate only.
pub trait Integrator<D: Dim, H: Hamiltonian<D>>: sealed::Sealed
where
    DefaultAllocator: Alloc<D>,
{
    /// The method's name.
    fn name(&self) -> &'static str;

    /// Runs from `z0` (plus `low`, [`Solve::start_low`]) at `t0` along `plan`, watching
    /// `watch`'s events, reporting to `sink`.
    #[doc(hidden)]
    fn drive<O: Observer<D>>(
        self,
        h: &H,
        start: (&OVector<f64, D>, Option<&OVector<f64, D>>),
        t0: f64,
        plan: &Plan<'_>,
        watch: &mut Watch<'_, D>,
        sink: &mut Sink<'_, D, O>,
    ) -> Result<(), Error>;
}

mod sealed {
    pub trait Sealed {}
    impl Sealed for super::Method {}
    impl<M> Sealed for super::Peer<M> {}
}

/// Where a run ends and where it lands on the way.
#[doc(hidden)]
#[derive(Debug)]
pub struct Plan<'a> {
    end: End,
    /// Ascending times to land on before the end (those after `t0`).
    times: &'a [f64],
    max_steps: usize,
    interrupt: Option<&'a AtomicBool>,
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum End {
    Steps(usize),
    Time(f64),
}

impl Plan<'_> {
    /// Asked before step `k`: an error once the run must stop there.
    fn check(&self, k: usize, t: f64) -> Result<(), Error> {
        if self.interrupt.is_some_and(|f| f.load(Ordering::Relaxed)) {
            return Err(Error::Interrupted { step: k });
        }
        if k > self.max_steps {
            let t_end = match self.end {
                End::Time(t_end) => t_end,
                End::Steps(_) => f64::NAN,
            };
            return Err(Error::StepCap {
                max_steps: self.max_steps,
                t,
                t_end,
            });
        }
        Ok(())
    }
}

impl<D: Dim, H: Hamiltonian<D>> Integrator<D, H> for Method
where
    DefaultAllocator: Alloc<D>,
{
    fn name(&self) -> &'static str {
        Method::name(self)
    }

    fn drive<O: Observer<D>>(
        self,
        h: &H,
        (z0, low): (&OVector<f64, D>, Option<&OVector<f64, D>>),
        t0: f64,
        plan: &Plan<'_>,
        watch: &mut Watch<'_, D>,
        sink: &mut Sink<'_, D, O>,
    ) -> Result<(), Error> {
        let z0 = (z0, low);
        match self {
            Method::Dth(options) => drive_dth(h, z0, t0, options, plan, watch, sink),
            Method::Trapezoidal { dt } => {
                drive_fixed(Trapezoidal::new(), dt, h, z0, t0, plan, watch, sink)
            }
            Method::Midpoint { dt } => {
                drive_fixed(ImplicitMidpoint::new(), dt, h, z0, t0, plan, watch, sink)
            }
            Method::GaussLegendre2 { dt } => {
                drive_fixed(GaussLegendre2::new(), dt, h, z0, t0, plan, watch, sink)
            }
            Method::Rk4 { dt } => drive_fixed(Rk4::new(), dt, h, z0, t0, plan, watch, sink),
            Method::StormerVerlet { dt } => {
                drive_fixed(StormerVerlet::<D>::new(), dt, h, z0, t0, plan, watch, sink)
            }
            Method::DiscreteGradient { dt } => {
                drive_fixed(DiscreteGradient::new(), dt, h, z0, t0, plan, watch, sink)
            }
        }
    }
}

impl<D: Dim, H: Hamiltonian<D>, M: OneStepMethod<D, H>> Integrator<D, H> for Peer<M>
where
    DefaultAllocator: Alloc<D>,
{
    fn name(&self) -> &'static str {
        M::NAME
    }

    fn drive<O: Observer<D>>(
        self,
        h: &H,
        z0: (&OVector<f64, D>, Option<&OVector<f64, D>>),
        t0: f64,
        plan: &Plan<'_>,
        watch: &mut Watch<'_, D>,
        sink: &mut Sink<'_, D, O>,
    ) -> Result<(), Error> {
        drive_fixed(self.method, self.dt, h, z0, t0, plan, watch, sink)
    }
}

/// A start's low part ([`Solve::start_low`]) is for DTH alone: another method would drop it.
fn only_dth_takes<D: Dim>(low: Option<&OVector<f64, D>>) -> Result<(), Error>
where
    DefaultAllocator: Alloc<D>,
{
    match low {
        Some(_) => Err(Error::InvalidOption {
            name: "low",
            value: 0.0,
            reason:
                "only DTH carries a start's low part (a regularized run solved in double-double)",
        }),
        None => Ok(()),
    }
}

/// A fixed-step method along `plan`.
#[allow(clippy::too_many_arguments)] // the method, its step, and `Integrator::drive`'s own
fn drive_fixed<D: Dim, H: Hamiltonian<D>, M: OneStepMethod<D, H>, O: Observer<D>>(
    mut method: M,
    dt: f64,
    h: &H,
    (z0, low): (&OVector<f64, D>, Option<&OVector<f64, D>>),
    t0: f64,
    plan: &Plan<'_>,
    watch: &mut Watch<'_, D>,
    sink: &mut Sink<'_, D, O>,
) -> Result<(), Error>
where
    DefaultAllocator: Alloc<D>,
{
    only_dth_takes(low)?;
    if matches!(plan.end, End::Time(_)) && h.flags().regularized {
        return Err(Error::InvalidOption {
            name: "dt",
            value: dt,
            reason: "a fixed-step method steps in the fictitious time of a regularized K and cannot land on a physical time: use Method::Dth, or end after .steps(n)",
        });
    }
    if matches!(plan.end, End::Time(_)) && dt.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater)
    {
        return Err(Error::InvalidOption {
            name: "dt",
            value: dt,
            reason: "must be positive to end at a time",
        });
    }
    let mut run = FixedRun::start(&method, h, z0, t0, dt, sink).map_err(|e| e.error)?;
    let mut check = |k: usize| plan.check(k, f64::NAN);
    let span = match plan.end {
        End::Steps(n) => Span::Steps(n),
        End::Time(t_end) => Span::Until(t_end),
    };
    let result = watch.start(t0, z0).and_then(|()| {
        let mut beside = Beside {
            check: Some(&mut check),
            times: plan.times,
            watch: (!watch.is_empty()).then_some(&mut *watch),
        };
        run.advance(&mut method, h, dt, span, &mut beside, sink)
    });
    match result {
        Ok(Advanced::Stopped) => sink.stopped(),
        Ok(Advanced::Done) => {}
        Err(e) => return Err(with_time(e, run.end.t)),
    }
    Ok(())
}

/// DTH along `plan`.
fn drive_dth<D: Dim, H: Hamiltonian<D>, O: Observer<D>>(
    h: &H,
    (z0, low): (&OVector<f64, D>, Option<&OVector<f64, D>>),
    t0: f64,
    options: DthOptions,
    plan: &Plan<'_>,
    watch: &mut Watch<'_, D>,
    sink: &mut Sink<'_, D, O>,
) -> Result<(), Error>
where
    DefaultAllocator: Alloc<D>,
{
    let mut dth = Dth::new(h, z0.clone(), options)?;
    if !h.flags().time_dependent {
        dth = dth.with_tbar0(t0)?;
    }
    if let Some(low) = low {
        dth = dth.with_low(low.clone())?;
    }
    // `run(0, ..)` reports the current midpoint once and the right vertex of its segment.
    dth.run(0, sink)?;
    watch.start(dth.tbar(), dth.zbar())?;
    let mut times = plan.times.iter().copied().peekable();
    let mut taken = 0;
    loop {
        if matches!(plan.end, End::Steps(n) if taken >= n) {
            break;
        }
        plan.check(dth.k() + 1, dth.tbar())
            .map_err(|e| with_time(e, dth.tbar()))?;
        let reached = match plan.end {
            End::Steps(n) => {
                dth.step_unreported()?;
                taken += 1;
                taken >= n
            }
            End::Time(t_end) => dth.advance_toward(t_end)?,
        };
        // The events of this step, located; the run ends at the first that stops it.
        let fired = if watch.crossed(dth.tbar(), dth.zbar())? {
            watch.locate(&mut |t| dth.land_within_last(t))?
        } else {
            Vec::new()
        };
        // (The time it was landed on, and its own.)
        let stop = watch.stopping(&fired).map(|(_, asked, r)| (*asked, r.t));
        // The chosen times this step reached (up to a stop), landed on beside the run.
        let last_t = stop.map_or(if reached { f64::INFINITY } else { dth.tbar() }, |s| s.1);
        while let Some(target) = times.next_if(|&t| t <= last_t) {
            sink.on_landing(&dth.land_within_last(target)?);
        }
        for (i, _, record) in &fired {
            sink.on_event(*i, record);
        }
        if let Some((asked, _)) = stop {
            // The same landing, kept: the event's state is the run's last.
            dth.end_within_last(asked)?;
            dth.run(0, sink)?;
            sink.stopped();
            break;
        }
        dth.run(0, sink)?;
        if reached {
            break;
        }
    }
    Ok(())
}

/// A [`Error::StepCap`] with the time reached filled in.
fn with_time(error: Error, t: f64) -> Error {
    match error {
        Error::StepCap {
            max_steps, t_end, ..
        } => Error::StepCap {
            max_steps,
            t,
            t_end,
        },
        other => other,
    }
}

/// A run being set up: [`solve`] starts it, the builder methods say where it ends, what it
/// keeps and who watches, [`Solve::run`] runs it.
#[must_use = "a Solve does nothing until .run()"]
pub struct Solve<'a, H, D: Dim, I, O = ()>
where
    DefaultAllocator: Alloc<D>,
{
    hamiltonian: &'a H,
    z0: OVector<f64, D>,
    method: I,
    t0: Option<f64>,
    low: Option<OVector<f64, D>>,
    end: Option<End>,
    save: Save,
    times: Vec<f64>,
    max_steps: usize,
    interrupt: Option<&'a AtomicBool>,
    energy: bool,
    events: Vec<Event<'a, D>>,
    observer: O,
}

/// An observer lent to a run ([`Solve::observer`]).
#[derive(Debug)]
pub struct Lent<'a, P>(&'a mut P);

impl<D: Dim, P: Observer<D>> Observer<D> for Lent<'_, P>
where
    DefaultAllocator: Alloc<D>,
{
    #[inline(always)]
    fn on_step(&mut self, record: &StepRecord<D>) {
        self.0.on_step(record);
    }
    #[inline(always)]
    fn on_finish(&mut self, last_vertex: &OVector<f64, D>, last_vertex_time: f64) {
        self.0.on_finish(last_vertex, last_vertex_time);
    }
    #[inline(always)]
    fn on_landing(&mut self, record: &StepRecord<D>) {
        self.0.on_landing(record);
    }
    #[inline(always)]
    fn on_event(&mut self, event: usize, record: &StepRecord<D>) {
        self.0.on_event(event, record);
    }
}

/// Which states a [`Solution`] keeps.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Save {
    /// Every `n`-th step (and the first and last states).
    Every(usize),
    /// The states landed on the chosen times.
    At,
}

/// Integrates `hamiltonian` from `z0` with `method`: a run to set up with the [`Solve`]
/// builder and start with [`Solve::run`]. See the [module docs](self).
pub fn solve<'a, H, D: Dim, I>(
    hamiltonian: &'a H,
    z0: OVector<f64, D>,
    method: I,
) -> Solve<'a, H, D, I>
where
    DefaultAllocator: Alloc<D>,
    H: Hamiltonian<D>,
    I: Integrator<D, H>,
{
    Solve {
        hamiltonian,
        z0,
        method,
        t0: None,
        low: None,
        end: None,
        save: Save::Every(1),
        times: Vec::new(),
        max_steps: usize::MAX,
        interrupt: None,
        energy: true,
        events: Vec::new(),
        observer: (),
    }
}

impl<'a, H, D: Dim, I, O> Solve<'a, H, D, I, O>
where
    DefaultAllocator: Alloc<D>,
    H: Hamiltonian<D>,
    I: Integrator<D, H>,
    O: Observer<D>,
{
    /// End exactly at the time `t_end` (not before the start).
    pub fn until(mut self, t_end: f64) -> Self {
        self.end = Some(End::Time(t_end));
        self
    }

    /// End after `n` steps (a DTH step of order 4-8 is one composed step).
    pub fn steps(mut self, n: usize) -> Self {
        self.end = Some(End::Steps(n));
        self
    }

    /// Start the clock of an autonomous `H` at `t0` (default 0). A time-dependent `H` reads
    /// its clock from the `t` coordinate of `z0`; setting another is an error at the start.
    pub fn start_time(mut self, t0: f64) -> Self {
        self.t0 = Some(t0);
        self
    }

    /// Start from `z0 + low`, a start in double-double: for a regularized `H` (its
    /// `start_double_double`), DTH then solves every step in double-double
    /// ([`Dth::with_low`], where the errors of a low part that does not fit are), about 18%
    /// more per step, and ends within its truncation error where a run from doubles is held
    /// back by roundoff (a Kepler orbit at e = 0.999 over 100 orbits: 1.3e-11 instead of
    /// 1e-9). Other methods refuse it ([`Error::InvalidOption`] `low`).
    pub fn start_low(mut self, low: OVector<f64, D>) -> Self {
        self.low = Some(low);
        self
    }

    /// Keep every `n`-th state (`k = 0, n, 2n, ...`) and the last (default: every state).
    /// Replaces an earlier [`Solve::save_at`].
    pub fn save_every(mut self, n: usize) -> Self {
        // One saving rule: the last one given (the times of a save_at no longer landed on).
        if self.save == Save::At {
            self.times.clear();
        }
        self.save = Save::Every(n);
        self
    }

    /// Keep only the states at these times (ascending, not before the start), landed on beside
    /// the run (see the [module docs](self)), and the end's (a failed run: the last state
    /// reached instead).
    /// Without [`Solve::until`], the last time is the end. Replaces an earlier
    /// [`Solve::save_every`].
    pub fn save_at(mut self, times: impl IntoIterator<Item = f64>) -> Self {
        self.save = Save::At;
        self.times = times.into_iter().collect();
        self
    }

    /// Land on these times (ascending, after the start, not after the end) beside the run, as
    /// [`Solve::save_at`] does, and show each state there to the observer
    /// ([`Observer::on_landing`]) without keeping it in the [`Solution`], which keeps what the
    /// saving rule says: for an observer that keeps what it needs. Replaces the times of an
    /// earlier `land_at` or `save_at`. The run needs an end of its own ([`Solve::until`]).
    ///
    /// ```
    /// use dth_core::nalgebra::Vector4;
    /// use dth_core::observer::{Observer, StepRecord};
    /// use dth_core::solve::{solve, Method};
    /// use dth_core::{nalgebra::Const, systems::Kepler, DthOptions};
    ///
    /// /// Keeps the times of the landed states.
    /// struct Landed(Vec<f64>);
    /// impl Observer<Const<4>> for Landed {
    ///     fn on_landing(&mut self, r: &StepRecord<Const<4>>) {
    ///         self.0.push(r.t);
    ///     }
    /// }
    /// let mut landed = Landed(Vec::new());
    /// let z0 = Vector4::new(0.5, 0.0, 0.0, 1.2);
    /// let run = solve(&Kepler::thesis(), z0, Method::Dth(DthOptions::new(0.02)?))
    ///     .until(3.0)
    ///     .save_every(usize::MAX) // the first and last states only
    ///     .land_at([1.0, 2.0])
    ///     .observer(&mut landed)
    ///     .run()?;
    /// assert_eq!(run.len(), 2);
    /// assert_eq!(landed.0.len(), 2);
    /// assert!((landed.0[1] - 2.0).abs() <= 8.0 * f64::EPSILON);
    /// # Ok::<(), dth_core::Error>(())
    /// ```
    pub fn land_at(mut self, times: impl IntoIterator<Item = f64>) -> Self {
        self.times = times.into_iter().collect();
        self
    }

    /// Stop with [`Error::StepCap`] (a failure that keeps what was computed) rather than take
    /// more than `n` steps (default: no limit).
    pub fn max_steps(mut self, n: usize) -> Self {
        self.max_steps = n;
        self
    }

    /// Stop with [`Error::Interrupted`] before the next step once `flag` is set (by a signal
    /// handler, another thread, a user interface).
    pub fn interrupt(mut self, flag: &'a AtomicBool) -> Self {
        self.interrupt = Some(flag);
        self
    }

    /// Watch `event` ([`crate::event`]): where its condition becomes true, the run locates
    /// the time to roundoff, keeps the state there in [`Solution::events`] (and shows it to the
    /// observer, [`Observer::on_event`]) and, for an event that stops the run
    /// ([`Event::stop`]), ends there ([`Solution::stopped`]). Events are numbered in the order
    /// they are added.
    pub fn event(mut self, event: Event<'a, D>) -> Self {
        self.events.push(event);
        self
    }

    /// Do not compute [`Solution::energy_error`] (it stays empty, and `energy0` is NaN): the run
    /// then evaluates `H` only where its method does, for a caller that computes only what it
    /// is asked for.
    pub fn without_energy_errors(mut self) -> Self {
        self.energy = false;
        self
    }

    /// Call `f` with every state of the run as it is computed (the initial one first), saved
    /// or not. The record type is inferred: `.observe(|r| println!("{} {}", r.t, r.z[0]))`.
    pub fn observe<F: FnMut(&StepRecord<D>)>(self, f: F) -> Solve<'a, H, D, I, F> {
        self.with_observer(f)
    }

    /// Show every state to `observer` (any [`Observer`]; it also gets DTH's last vertex),
    /// lent for the run: read it afterwards.
    pub fn observer<P: Observer<D>>(self, observer: &'a mut P) -> Solve<'a, H, D, I, Lent<'a, P>> {
        self.with_observer(Lent(observer))
    }

    fn with_observer<P: Observer<D>>(self, observer: P) -> Solve<'a, H, D, I, P> {
        Solve {
            hamiltonian: self.hamiltonian,
            z0: self.z0,
            method: self.method,
            t0: self.t0,
            low: self.low,
            end: self.end,
            save: self.save,
            times: self.times,
            max_steps: self.max_steps,
            interrupt: self.interrupt,
            energy: self.energy,
            events: self.events,
            observer,
        }
    }

    /// Runs it.
    ///
    /// # Errors
    /// [`RunError`] with the first error and the [`Solution`] up to the last accepted step
    /// (its `failure` is that error): the method's own errors (see [`Dth::step`] and
    /// [`OneStepMethod::step_into`]), [`Error::MissingEnd`] without an end,
    /// [`Error::InvalidOption`] for an end, start or saving times that do not fit
    /// (`t_end` before the start, times not ascending, `save_every(0)`), [`Error::StepCap`],
    /// [`Error::Interrupted`].
    #[allow(clippy::result_large_err)] // a run fails once; see `Dth::trajectory`
    pub fn run(self) -> Result<Solution<D>, RunError<Solution<D>>> {
        let Solve {
            hamiltonian: h,
            z0,
            method,
            t0,
            low,
            end,
            save,
            times,
            max_steps,
            interrupt,
            energy,
            events,
            mut observer,
        } = self;
        let mut watch = Watch::new(events);
        // H is evaluated only for the energy errors, and only at a state of its dimension (a
        // run-time Hamiltonian panics on another; the method reports it as an error).
        let energy = energy && crate::methods::check_state(h, &z0, "z0").is_ok();
        let energy0 = if energy { h.value(&z0) } else { f64::NAN };
        let energy_error = |z: &OVector<f64, D>| h.value(z) - energy0;
        let mut sink = Sink {
            user: &mut observer,
            energy_error: energy.then_some(&energy_error as EnergyError<'_, D>),
            solution: Solution::empty(method.name(), energy0),
            save,
            save_start: true,
            last: None,
            vertex: None,
        };
        let planned = plan(h, &z0, t0, end, save, &times).map(|(t0, end, landings)| {
            // A time at the start keeps the initial state.
            sink.save_start = matches!(save, Save::Every(_)) || times.first() == Some(&t0);
            (
                t0,
                Plan {
                    end,
                    times: &times[landings],
                    max_steps,
                    interrupt,
                },
            )
        });
        let result = planned.and_then(|(t0, plan)| {
            method.drive(h, (&z0, low.as_ref()), t0, &plan, &mut watch, &mut sink)
        });
        let mut solution = sink.finish();
        match result {
            Ok(()) => Ok(solution),
            Err(error) => {
                solution.failure = Some(error.clone());
                Err(RunError {
                    error,
                    partial: solution,
                })
            }
        }
    }
}

/// The start time, the end and the range of `times` to land on before the end (after the
/// start, before the end), checked.
fn plan<H: Hamiltonian<D>, D: Dim>(
    h: &H,
    z0: &OVector<f64, D>,
    t0: Option<f64>,
    end: Option<End>,
    save: Save,
    times: &[f64],
) -> Result<(f64, End, std::ops::Range<usize>), Error>
where
    DefaultAllocator: Alloc<D>,
{
    let invalid = |name, value, reason| {
        Err(Error::InvalidOption {
            name,
            value,
            reason,
        })
    };
    // The clock: a time-dependent H's is its t coordinate (z = (q, t, p, p_t)).
    let clock = (h.flags().time_dependent && z0.len() >= 2).then(|| z0[z0.len() / 2 - 1]);
    let t0 = match (clock, t0) {
        (Some(clock), Some(t0)) if t0 != clock => {
            return invalid(
                "start_time",
                t0,
                "a time-dependent H takes its clock from the t coordinate of z0: set t there",
            )
        }
        (Some(clock), _) => clock,
        (None, t0) => t0.unwrap_or(0.0),
    };
    if !t0.is_finite() {
        return match clock {
            // The t coordinate of z0.
            Some(_) => Err(Error::NonFiniteInitialState {
                index: z0.len() / 2 - 1,
                value: t0,
            }),
            None => invalid("start_time", t0, "must be finite"),
        };
    }
    let times_name = if save == Save::At {
        "save_at"
    } else {
        "land_at"
    };
    if let Save::Every(0) = save {
        return invalid("save_every", 0.0, "must be at least 1");
    }
    if let Some(w) = times
        .windows(2)
        .find(|w| w[0].partial_cmp(&w[1]) != Some(std::cmp::Ordering::Less))
    {
        return invalid(times_name, w[1], "times must be finite and ascending");
    }
    if let Some(&t) = times.iter().find(|t| !t.is_finite() || **t < t0) {
        return invalid(times_name, t, "must be finite and not before the start");
    }
    let end = match (end, times.last()) {
        (Some(end), _) => end,
        (None, Some(&last)) => End::Time(last),
        (None, None) => return Err(Error::MissingEnd),
    };
    match end {
        End::Time(t_end) if !(t_end.is_finite() && t_end >= t0) => {
            return invalid("until", t_end, "must be finite and not before the start")
        }
        End::Time(t_end) if times.last().is_some_and(|&t| t > t_end) => {
            return invalid(
                times_name,
                times.last().copied().unwrap_or(t_end),
                "times must not lie after the end",
            );
        }
        End::Steps(_) if !times.is_empty() => {
            return invalid(
                times_name,
                times[0],
                "a run to a number of steps cannot land on times: end it with until",
            );
        }
        _ => {}
    }
    // A time at the start is the initial state itself; one at the end is the end's landing.
    let from = times.iter().take_while(|&&t| t == t0).count();
    let to = match end {
        End::Time(t_end) if times.last() == Some(&t_end) => times.len() - 1,
        _ => times.len(),
    };
    Ok((t0, end, from.min(to)..to))
}

/// A run's result: the saved states with their times, step indices, kinds and energy errors
/// (and DTH's own series), with what the whole run spent and how it ended.
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub struct Solution<D: Dim>
where
    DefaultAllocator: Alloc<D>,
{
    /// The method's name ([`Method::name`], [`OneStepMethod::NAME`]).
    pub method: &'static str,
    /// Times of the saved states (DTH: midpoint times `tbar_k`).
    pub t: Vec<f64>,
    /// The saved states (DTH: the midpoints `zbar_k`).
    pub z: Vec<OVector<f64, D>>,
    /// Step index `k` of each saved state (0 for the initial one).
    pub k: Vec<usize>,
    /// What produced each saved state ([`StepKind::Fallback`]: a robust-mode fallback step).
    pub kinds: Vec<StepKind>,
    /// `H(z) - H(z0)` at each saved state (for a time-dependent `H`, of the extended `calH`;
    /// for a regularized one, of `K`, whose physical energy is `-p_t`); empty after
    /// [`Solve::without_energy_errors`].
    pub energy_error: Vec<f64>,
    /// `H(z0)` (NaN after [`Solve::without_energy_errors`]).
    pub energy0: f64,
    /// DTH's multipliers, vertices and `Psi` at the saved states; `None` for a fixed-step
    /// method.
    pub dth: Option<DthSeries<D>>,
    /// Steps taken (all of them, saved or not).
    pub steps: usize,
    /// Robust-mode fallback steps among them.
    pub fallback_steps: usize,
    /// Newton iterations over all steps (0 for explicit methods).
    pub newton_iterations: u64,
    /// `None` for a run that reached its end; else what stopped it (the states are those up
    /// to the last accepted step).
    pub failure: Option<Error>,
    /// The events that fired ([`Solve::event`]), in the order of their times.
    pub events: Vec<Fired<D>>,
    /// The index of the event that ended the run ([`Event::stop`]): its state is the last
    /// one; `None` for a run that went to its end (or failed).
    pub stopped: Option<usize>,
}

/// DTH's own quantities at the saved midpoints of a [`Solution`].
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub struct DthSeries<D: Dim>
where
    DefaultAllocator: Alloc<D>,
{
    /// `lambda_k = dt/dtau` of each saved midpoint's segment.
    pub lambda: Vec<f64>,
    /// Left vertex `z^(k)` of each saved midpoint's segment (a fallback step: the node).
    pub vertex: Vec<OVector<f64, D>>,
    /// Its time `t^(k)`.
    pub vertex_time: Vec<f64>,
    /// `Psi(zbar_k)`.
    pub psi: Vec<f64>,
    /// The right vertex of the last segment and its time: where the polygon of vertices
    /// ends.
    pub last_vertex: Option<(OVector<f64, D>, f64)>,
}

impl<D: Dim> Solution<D>
where
    DefaultAllocator: Alloc<D>,
{
    fn empty(method: &'static str, energy0: f64) -> Self {
        Solution {
            method,
            t: Vec::new(),
            z: Vec::new(),
            k: Vec::new(),
            kinds: Vec::new(),
            energy_error: Vec::new(),
            energy0,
            dth: None,
            steps: 0,
            fallback_steps: 0,
            newton_iterations: 0,
            failure: None,
            events: Vec::new(),
            stopped: None,
        }
    }

    /// Number of saved states.
    pub fn len(&self) -> usize {
        self.t.len()
    }

    /// `true` when no state was saved (a run that failed before its start).
    pub fn is_empty(&self) -> bool {
        self.t.is_empty()
    }

    /// The last saved state's time (the end time of a run that reached its end).
    pub fn end_time(&self) -> Option<f64> {
        self.t.last().copied()
    }

    /// The last saved state.
    pub fn end_state(&self) -> Option<&OVector<f64, D>> {
        self.z.last()
    }

    /// The largest `|H(z) - H(z0)|` over the saved states (0 when none).
    pub fn max_energy_error(&self) -> f64 {
        self.energy_error.iter().fold(0.0, |m, e| m.max(e.abs()))
    }

    /// `true` when the run reached its end.
    pub fn completed(&self) -> bool {
        self.failure.is_none()
    }
}

/// `z -> H(z) - H(z0)`.
type EnergyError<'o, D> = &'o dyn Fn(&OVector<f64, D>) -> f64;

/// The observer a run reports to: it saves what the [`Solution`] keeps and shows every state
/// to the user's observer.
#[doc(hidden)]
pub struct Sink<'o, D: Dim, O>
where
    DefaultAllocator: Alloc<D>,
{
    user: &'o mut O,
    /// `H(z) - H(z0)`.
    energy_error: Option<EnergyError<'o, D>>,
    solution: Solution<D>,
    save: Save,
    /// Keep the initial state.
    save_start: bool,
    /// The last state reported (kept for a landing or the end), and whether it is saved.
    last: Option<(StepRecord<D>, bool)>,
    /// DTH's last right vertex and its time.
    vertex: Option<(OVector<f64, D>, f64)>,
}

impl<D: Dim, O: Observer<D>> Sink<'_, D, O>
where
    DefaultAllocator: Alloc<D>,
{
    fn keep(&mut self, r: &StepRecord<D>) {
        let solution = &mut self.solution;
        let h_minus_h0 = self.energy_error.map(|e| e(&r.z));
        solution.t.push(r.t);
        solution.z.push(r.z.clone());
        solution.k.push(r.k);
        solution.kinds.push(r.kind);
        solution.energy_error.extend(h_minus_h0);
        if let Some(d) = &r.dth {
            let series = solution.dth.get_or_insert_with(|| DthSeries {
                lambda: Vec::new(),
                vertex: Vec::new(),
                vertex_time: Vec::new(),
                psi: Vec::new(),
                last_vertex: None,
            });
            series.lambda.push(d.lambda);
            series.vertex.push(d.vertex.clone());
            series.vertex_time.push(d.vertex_time);
            series.psi.push(d.psi);
        }
    }
}

impl<D: Dim, O: Observer<D>> Sink<'_, D, O>
where
    DefaultAllocator: Alloc<D>,
{
    /// Saves the last state reported, once.
    fn keep_last(&mut self) {
        if let Some((record, saved)) = self.last.take() {
            if !saved {
                self.keep(&record);
            }
            self.last = Some((record, true));
        }
    }

    /// The run ended at the event that fired last.
    fn stopped(&mut self) {
        self.solution.stopped = self.solution.events.last().map(|f| f.event);
    }

    /// The solution: the last state reached saved, DTH's last vertex shown to the user.
    fn finish(mut self) -> Solution<D> {
        self.keep_last();
        if let Some((vertex, time)) = self.vertex.take() {
            self.user.on_finish(&vertex, time);
            if let Some(series) = &mut self.solution.dth {
                series.last_vertex = Some((vertex, time));
            }
        }
        self.solution
    }
}

impl<D: Dim, O: Observer<D>> Observer<D> for Sink<'_, D, O>
where
    DefaultAllocator: Alloc<D>,
{
    fn on_step(&mut self, r: &StepRecord<D>) {
        self.user.on_step(r);
        if r.k > 0 {
            self.solution.steps = r.k;
            self.solution.newton_iterations += u64::from(r.iterations);
            if r.kind == StepKind::Fallback {
                self.solution.fallback_steps += 1;
            }
        }
        let saved = match self.save {
            Save::Every(n) => r.k.is_multiple_of(n) && (r.k > 0 || self.save_start),
            Save::At => r.k == 0 && self.save_start,
        };
        if saved {
            self.keep(r);
        }
        match &mut self.last {
            Some((last, was_saved)) => {
                last.copy_from(r);
                *was_saved = saved;
            }
            None => self.last = Some((r.clone(), saved)),
        }
    }

    fn on_landing(&mut self, r: &StepRecord<D>) {
        self.user.on_landing(r);
        self.solution.newton_iterations += u64::from(r.iterations);
        if self.save == Save::At {
            self.keep(r);
        }
    }

    fn on_event(&mut self, event: usize, r: &StepRecord<D>) {
        self.user.on_event(event, r);
        self.solution.events.push(Fired {
            event,
            t: r.t,
            z: r.z.clone(),
            k: r.k,
        });
    }

    fn on_finish(&mut self, last_vertex: &OVector<f64, D>, last_vertex_time: f64) {
        match &mut self.vertex {
            Some((v, t)) => {
                v.copy_from(last_vertex);
                *t = last_vertex_time;
            }
            None => self.vertex = Some((last_vertex.clone(), last_vertex_time)),
        }
    }
}
