//! `dth.integrate`: one call runs a whole integration in Rust (`dth::solve`), without the GIL
//! and interruptible by Ctrl-C, and returns a [`Solution`].

use std::sync::atomic::AtomicBool;

use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use dth::event::Event;
use dth::nalgebra::{DVector, DefaultAllocator, Dim, OVector};
use dth::runtime::{RuntimeHamiltonian, StateFunction};
use dth::solve::Integrator;
use dth::{solve, Alloc};

use crate::args::{self, start, Chosen, End};
use crate::catalogue::Special;
use crate::errors::IntegrationError;
use crate::hamiltonian::Hamiltonian;
use crate::regularized::Physical;
use crate::sized::{self, Job};
use crate::solution::Solution;
use dth_examples::regularized::MAX_PHYSICAL;

/// What a run is asked to do, read from the keyword arguments.
struct Request {
    /// A number of steps or a time (a number of orbits is resolved to its time).
    end: End,
    t0: f64,
    every: usize,
    save_at: Option<Vec<f64>>,
    max_steps: Option<usize>,
    energy_errors: bool,
    events: Events,
    /// `regularize=`: the run is on `K`, and everything it reports is mapped back.
    physical: Option<Physical>,
    /// `double_double=True`: the start's low part (the run solves its steps in double-double).
    low: Option<DVector<f64>>,
}

/// The events a run watches (`events=`, `stop_on=`): each name, its condition compiled as the
/// function whose negative values are the condition, and whether it ends the run.
#[derive(Default)]
struct Events {
    names: Vec<String>,
    functions: Vec<StateFunction>,
    stops: Vec<bool>,
}

impl Events {
    /// `events` (a dict of name to `"lhs < rhs"` or `"lhs > rhs"`, in the grammar of `h`'s
    /// text over its coordinates, `t` and parameters) and `stop_on` (a name or a list of
    /// names) compiled for `h`; a `ValueError` naming the event for a condition that does not
    /// compile, or a `stop_on` name that is not an event.
    fn read(
        h: &RuntimeHamiltonian,
        events: Option<&Bound<'_, PyDict>>,
        stop_on: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Events> {
        let params: Vec<(&str, f64)> = h.parameters().collect();
        let mut read = Events::default();
        for (name, when) in events.into_iter().flat_map(|d| d.iter()) {
            let name: String = name.extract().map_err(|_| {
                PyTypeError::new_err("events: the keys are the events' names (str)")
            })?;
            let when: String = when.extract().map_err(|_| {
                PyTypeError::new_err(format!(
                    "event `{name}`: its condition is a str, `lhs < rhs` or `lhs > rhs`"
                ))
            })?;
            let refused = |why: String| PyValueError::new_err(format!("event `{name}`: {why}"));
            let g = dth_examples::scene::condition_function(&when).map_err(refused)?;
            let f = StateFunction::new(&g, h.degrees_of_freedom(), h.time_dependent(), &params)
                .map_err(|e| refused(e.to_string()))?;
            read.names.push(name);
            read.functions.push(f);
            read.stops.push(false);
        }
        let stop_on: Vec<String> = match stop_on {
            None => Vec::new(),
            Some(s) => match s.extract::<String>() {
                Ok(one) => vec![one],
                Err(_) => s.extract().map_err(|_| {
                    PyTypeError::new_err("stop_on is an event's name or a list of names")
                })?,
            },
        };
        for name in stop_on {
            let Some(i) = read.names.iter().position(|n| *n == name) else {
                return Err(PyValueError::new_err(format!(
                    "stop_on names `{name}`, which is not one of the events ({})",
                    if read.names.is_empty() {
                        "none given: add it to events=".to_string()
                    } else {
                        read.names.join(", ")
                    }
                )));
            };
            read.stops[i] = true;
        }
        Ok(read)
    }

    /// The events as the driver watches them: on the run's states, or on their physical
    /// `(q, p)` in a regularized run (`physical`).
    fn watched<'a, D: Dim>(
        &'a self,
        physical: Option<&'a Physical>,
    ) -> impl Iterator<Item = Event<'a, D>>
    where
        DefaultAllocator: Alloc<D>,
    {
        self.names
            .iter()
            .zip(&self.functions)
            .zip(&self.stops)
            .map(move |((name, f), &stop)| {
                let mut scratch = Vec::new();
                // A value that is not finite is the run's `EventNotANumber`, naming the event.
                let event = Event::new(name.clone(), move |t, z: &OVector<f64, D>| {
                    let value = match physical {
                        Some(p) => {
                            let mut physical = [0.0; MAX_PHYSICAL];
                            f.value_at(t, p.state_in(z.as_slice(), &mut physical), &mut scratch)
                        }
                        None => f.value_at(t, z.as_slice(), &mut scratch),
                    };
                    value.unwrap_or(f64::NAN)
                });
                if stop {
                    event.stop()
                } else {
                    event
                }
            })
    }
}

/// Integrates `h` from `z0` with `method`, saving every `every`-th state, and returns a
/// `Solution` (numpy arrays of the saved times and states, the step kinds, energy errors,
/// and for DTH its vertices, multipliers and Psi).
///
/// integrate(h, z0, method="dth", *, dtau=None, dt=None, order=None, robust=None,
///           lambda0=None, steps=None, t_end=None, orbits=None, t0=0.0, every=None,
///           save_at=None, max_steps=None, energy_errors=True, raise_on_failure=False,
///           events=None, stop_on=None, regularize=None, centre=None, double_double=False)
///
/// Arguments:
///   h: a `dth.Hamiltonian`.
///   z0: the initial state (q1..qn, p1..pn), any 1-D sequence of D numbers. For DTH it is
///     the first midpoint zbar_0, and every saved midpoint keeps H(zbar_0) to roundoff. For
///     a time-dependent H the state is extended, z = (q1..qn, t, p1..pn, p_t): give either
///     the physical (q, p), extended with t0 and p_t = -H(q, p, t0), or the whole z.
///   method: "dth" (Discrete-Time Hamiltonian dynamics) or a fixed-step peer:
///     "midpoint", "gauss_legendre2", "stormer_verlet" (separable H only), "rk4",
///     "trapezoidal", "discrete_gradient" (Gonzalez's, energy-conserving),
///     "discrete_mechanics" (Greenspan's, energy- and angular-momentum-conserving, for the
///     central forces dth.systems.kepler and dth.systems.free_particle), "exact" (the
///     exact solution sampled every dt: dth.systems.kepler on an elliptic orbit,
///     dth.systems.free_particle). The last two run on the catalogue's compiled system of
///     which the Hamiltonian is the text; another Hamiltonian raises ValueError.
///   dtau: DTH's step in the discrete time tau (the physical step is lambda * dtau).
///   dt: a peer's physical step.
///   order: DTH's order, 2 (default), 4, 6 or 8 (a composition of DTH steps).
///   robust: DTH's robust mode: where Psi changes sign and DTH has no root, take an
///     energy-conserving discrete-gradient step instead (counted in `fallback_steps`).
///   lambda0: DTH's first guess of lambda = dt/dtau (default 1).
///   steps: run this many steps; or
///   t_end: run until this physical time, ending exactly on it (a shortened last step); or
///   orbits: run for this many orbit periods of z0, that is until t0 + orbits * period, as
///     a scene's `orbits` duration (dth.systems.kepler on a bound orbit and
///     dth.systems.harmonic_oscillator know their period; another Hamiltonian raises
///     ValueError: give t_end or steps).
///   t0: the initial time (default 0).
///   every: save every `every`-th state (default 1; the last one is always saved).
///   save_at: ascending times to land on exactly; only the states there and at t_end are
///     saved (with `t_end`; not with `every`).
///   max_steps: fail with "StepCap" after this many steps.
///   energy_errors: compute H - H(z0) at the saved states (default True).
///   raise_on_failure: raise `IntegrationError` (with the partial solution as `.solution`)
///     instead of returning a Solution whose `failure` says what stopped it.
///   events: a dict of name to condition, `"lhs < rhs"` or `"lhs > rhs"` in the grammar of the
///     Hamiltonian's text (its coordinates q1..qn, p1..pn, `t` and its parameters), e.g.
///     `{"close": "q1^2 + q2^2 < 0.05^2"}`. An event fires where its condition becomes true
///     between two states of the run (one true at the start waits until it has stopped
///     holding); its time is located to roundoff on the method's own states, and it is
///     recorded in the Solution's `events` as (name, t, z).
///   stop_on: an event's name, or a list of them, that ends the run where it fires: the
///     run's last state is the event's (`Solution.stopped` names it); the run is complete.
///   regularize: "levi-civita" (planar, n = 2) or "ks" (Kustaanheimo-Stiefel, in space,
///     n = 3), method "dth" only: DTH runs on the regularized K = |u|^2 (H + p_t) of the
///     Hamiltonian's text, a harmonic oscillator for Kepler, whose Psi keeps its sign through
///     close approaches, so eccentric orbits and collisions need no robust mode. Everything
///     stays physical: z0 is (q, p), every saved state, vertex and event state is (q, p),
///     times are physical (t_end is landed on exactly), `lam` is dt/dtau, the energy errors
///     are those of H; only `psi` is K's. As a scene's `[system] regularize`.
///   centre: the point of the close approaches (default: the origin), substituted into the
///     text as q = c + q'; write that point in H with the same digits (0.99 cancels 0.99).
///   double_double: with regularize, start from the exact image of z0 (the energy in
///     double-double) and solve every DTH step in double-double: about 20% more per step, and
///     the run ends within DTH's truncation error where one from doubles stays about 1e-16 of
///     the time elapsed off (Kepler at e = 0.999 after 100 orbits: 1.3e-11 instead of 1e-9).
///
/// Ctrl-C stops a run within a fraction of a second with KeyboardInterrupt.
///
/// >>> import dth
/// >>> h = dth.Hamiltonian("p1^2/2 + q1^2/2")
/// >>> s = dth.integrate(h, [1.0, 0.0], dtau=0.1, t_end=10.0)
/// >>> float(s.t[-1])
/// 10.0
/// >>> bool(abs(s.energy_error).max() < 1e-15)
/// True
/// >>> s = dth.integrate(h, [1.0, 0.0], dtau=0.01, t_end=10.0,
/// ...                   events={"zero": "q1 < 0"}, stop_on="zero")
/// >>> ((name, t, z),) = s.events   # q1 = cos t: zero near pi/2, to the method's accuracy
/// >>> s.stopped, bool(abs(z.item(0)) < 1e-14), bool(abs(t - 1.5707963) < 1e-4), float(s.t[-1]) == t
/// ('zero', True, True, True)
#[pyfunction]
#[pyo3(signature = (
    h, z0, method = "dth", *, dtau = None, dt = None, order = None, robust = None,
    lambda0 = None, steps = None, t_end = None, orbits = None, t0 = 0.0, every = None,
    save_at = None, max_steps = None, energy_errors = true, raise_on_failure = false,
    events = None, stop_on = None, regularize = None, centre = None, double_double = false
))]
#[allow(clippy::too_many_arguments)]
pub fn integrate(
    py: Python<'_>,
    h: PyRef<'_, Hamiltonian>,
    z0: &Bound<'_, PyAny>,
    method: &str,
    dtau: Option<f64>,
    dt: Option<f64>,
    order: Option<u32>,
    robust: Option<bool>,
    lambda0: Option<f64>,
    steps: Option<usize>,
    t_end: Option<f64>,
    orbits: Option<f64>,
    t0: f64,
    every: Option<usize>,
    save_at: Option<Vec<f64>>,
    max_steps: Option<usize>,
    energy_errors: bool,
    raise_on_failure: bool,
    events: Option<&Bound<'_, PyDict>>,
    stop_on: Option<&Bound<'_, PyAny>>,
    regularize: Option<&str>,
    centre: Option<Vec<f64>>,
    double_double: bool,
) -> PyResult<Solution> {
    let z0 = start(&h.h, z0, "z0", t0)?;
    let chosen = args::method(method, dtau, dt, order, robust, lambda0)?;
    let end = args::end(steps, t_end, orbits)?;
    let end = args::resolve_end(end, h.catalogue(), &h.h, &z0, t0)?;
    if every == Some(0) {
        return Err(PyValueError::new_err("every must be at least 1"));
    }
    if save_at.is_some() && !matches!(end, End::Time(_)) {
        return Err(PyTypeError::new_err(
            "save_at=... needs t_end=... (or orbits=...): a run to a number of steps lands on no time",
        ));
    }
    if save_at.is_some() && every.is_some() {
        return Err(PyTypeError::new_err(
            "give every or save_at, not both: save_at keeps only the states at its times",
        ));
    }
    let every = every.unwrap_or(1);
    let events = Events::read(&h.h, events, stop_on)?;
    if double_double && regularize.is_none() {
        return Err(PyTypeError::new_err(
            "double_double solves a regularized run in double-double: give regularize too",
        ));
    }
    let mut physical = Physical::from_args(&h.h, h.text(), (regularize, centre), method)?;
    let (start, low) = match &mut physical {
        Some(p) if double_double => {
            let (w0, low) = p.start_double_double(&z0, t0)?;
            (w0, Some(low))
        }
        Some(p) => (p.start(&z0, t0)?, None),
        None => (z0.clone(), None),
    };
    let request = Request {
        end,
        t0,
        every,
        save_at,
        max_steps,
        energy_errors,
        events,
        physical,
        low,
    };
    let job = Run {
        py,
        z0: &start,
        request: &request,
        raise_on_failure,
    };
    if let (Some(p), Chosen::Method(method)) = (&request.physical, &chosen) {
        // K's dimension (6 or 10) runs at `Dyn`.
        return job.run(p.k(), *method, DVector::clone);
    }
    debug_assert!(
        request.physical.is_none(),
        "Physical::read accepts method \"dth\" only"
    );
    match chosen {
        Chosen::Method(method) => sized::dispatch(&h.h, method, job)?,
        Chosen::Special(special, dt) => {
            if special == Special::Exact {
                if let Some(reason) = crate::catalogue::exact_unavailable(h.catalogue(), &h.h, &z0)?
                {
                    return Err(PyValueError::new_err(reason));
                }
            }
            crate::catalogue::dispatch(h.catalogue(), &h.h, special, dt, job)?
        }
    }
}

/// One run, as a [`Job`]: at the size the dispatch picks.
struct Run<'a, 'py> {
    py: Python<'py>,
    z0: &'a DVector<f64>,
    request: &'a Request,
    raise_on_failure: bool,
}

impl Job for Run<'_, '_> {
    type Output = PyResult<Solution>;

    fn run<D, H, I, S>(self, h: &H, method: I, state: S) -> Self::Output
    where
        D: Dim,
        H: dth::Hamiltonian<D> + Sync,
        I: Integrator<D, H> + Clone + Send + Sync,
        S: Fn(&DVector<f64>) -> OVector<f64, D> + Sync,
        DefaultAllocator: Alloc<D>,
        OVector<f64, D>: Send,
        dth::Solution<D>: Send,
    {
        let low = self.request.low.as_ref().map(&state);
        let result = drive(self.py, h, (state(self.z0), low), method, self.request)?;
        let names = &self.request.events.names;
        let physical = self.request.physical.as_ref();
        finish(
            self.py,
            result,
            (self.z0.len(), physical),
            names,
            self.raise_on_failure,
        )
    }
}

/// What [`drive`] returns: the solution, or the error with the partial one (boxed: it is
/// large and crosses a thread).
type Outcome<D> = Result<dth::Solution<D>, Box<dth::RunError<dth::Solution<D>>>>;

/// Runs `request` with `method` on `h` from `z0` on a worker thread, without the GIL,
/// interruptible.
fn drive<D: Dim, H: dth::Hamiltonian<D> + Sync, I: Integrator<D, H> + Send>(
    py: Python<'_>,
    h: &H,
    (z0, low): (OVector<f64, D>, Option<OVector<f64, D>>),
    method: I,
    request: &Request,
) -> PyResult<Outcome<D>>
where
    DefaultAllocator: Alloc<D>,
    OVector<f64, D>: Send,
    dth::Solution<D>: Send,
{
    let flag = AtomicBool::new(false);
    crate::interrupt::run(py, &flag, || {
        let mut run = solve(h, z0, method).start_time(request.t0).interrupt(&flag);
        if let Some(low) = low {
            run = run.start_low(low);
        }
        run = request.end.apply(run);
        run = match &request.save_at {
            Some(times) => run.save_at(times.iter().copied()),
            None => run.save_every(request.every),
        };
        if let Some(n) = request.max_steps {
            run = run.max_steps(n);
        }
        if !request.energy_errors {
            run = run.without_energy_errors();
        }
        for event in request.events.watched(request.physical.as_ref()) {
            run = run.event(event);
        }
        run.run().map_err(Box::new)
    })
}

/// The Python result of a run: its `Solution`, or for a failed run the partial one (raised in
/// an `IntegrationError` with `raise_on_failure`); a run refused before its first step is a
/// `ValueError`.
fn finish<D: Dim>(
    py: Python<'_>,
    result: Outcome<D>,
    dim: (usize, Option<&Physical>),
    events: &[String],
    raise_on_failure: bool,
) -> PyResult<Solution>
where
    DefaultAllocator: Alloc<D>,
{
    match result {
        Ok(solution) => Ok(Solution::new(py, solution, dim, events)),
        Err(failed) => {
            let error = failed.error;
            // Refused before the first step: bad arguments, not a failed run.
            if failed.partial.is_empty() {
                return Err(PyValueError::new_err(error.to_string()));
            }
            let mut partial = failed.partial;
            if partial.failure.is_none() {
                partial.failure = Some(error);
            }
            let solution = Solution::new(py, partial, dim, events);
            if raise_on_failure {
                let message = format!(
                    "the run stopped before its end: {}",
                    solution.failure_message()
                );
                let kind = solution.failure_kind.clone();
                let err = IntegrationError::new_err(message);
                let value = err.value(py);
                value.setattr("kind", kind)?;
                value.setattr("solution", Py::new(py, solution)?)?;
                return Err(err);
            }
            Ok(solution)
        }
    }
}
