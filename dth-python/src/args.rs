//! The keyword arguments `integrate` and `ensemble` share: the method and its step, where a
//! run ends, and the initial state (extended for a time-dependent H).

use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;

use dth::nalgebra::{DVector, DefaultAllocator, Dim};
use dth::observer::Observer;
use dth::solve::{Integrator, Solve};
use dth::{Alloc, DthOptions, Method};

use dth::runtime::RuntimeHamiltonian;

use crate::catalogue::Special;
use crate::errors::option_error;

/// The method names `integrate` accepts.
pub const METHODS: [&str; 9] = [
    "dth",
    "midpoint",
    "gauss_legendre2",
    "stormer_verlet",
    "rk4",
    "trapezoidal",
    "discrete_gradient",
    "discrete_mechanics",
    "exact",
];

/// The method a call asks for, with its step and options.
#[derive(Clone, Copy, Debug)]
pub enum Chosen {
    /// DTH or a peer for every Hamiltonian: runs on the text.
    Method(Method),
    /// A method of the catalogue system, with its step `dt`.
    Special(Special, f64),
}

/// How long a run lasts, as asked.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Duration {
    /// This many steps.
    Steps(usize),
    /// Until this time, exactly.
    Time(f64),
    /// This many orbit periods of the initial state (the system's period from `z0`), that is
    /// until the time `t0 + orbits * period`, as a scene's `orbits` duration.
    Orbits(f64),
}

/// Where a run ends: a [`Duration`] resolved ([`resolve_end`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum End {
    /// This many steps.
    Steps(usize),
    /// Until this time, exactly.
    Time(f64),
}

impl End {
    /// `run` ending here.
    pub fn apply<'a, H, D, I, O>(self, run: Solve<'a, H, D, I, O>) -> Solve<'a, H, D, I, O>
    where
        D: Dim,
        DefaultAllocator: Alloc<D>,
        H: dth::Hamiltonian<D>,
        I: Integrator<D, H>,
        O: Observer<D>,
    {
        match self {
            End::Steps(n) => run.steps(n),
            End::Time(t) => run.until(t),
        }
    }
}

/// The initial state `name`: of `h`'s dimension, or for a time-dependent `h` also the
/// physical `(q, p)`, extended with `t0` and `p_t = -H(q, p, t0)` so that `calH = 0`.
pub fn start(
    h: &RuntimeHamiltonian,
    z0: &Bound<'_, PyAny>,
    name: &str,
    t0: f64,
) -> PyResult<DVector<f64>> {
    let dim = h.dimension();
    if !extended(h) {
        return Ok(DVector::from_vec(crate::state::read(z0, name, dim)?));
    }
    start_from(h, crate::state::values(z0, name, dim)?, name, t0)
}

/// Whether `h`'s state is extended with `t` and `p_t`.
pub fn extended(h: &RuntimeHamiltonian) -> bool {
    h.time_dependent() && !h.regularized()
}

/// [`start`] from the values read.
pub fn start_from(
    h: &RuntimeHamiltonian,
    values: Vec<f64>,
    name: &str,
    t0: f64,
) -> PyResult<DVector<f64>> {
    let dim = h.dimension();
    if values.len() == dim {
        return Ok(DVector::from_vec(values));
    }
    if !extended(h) || values.len() + 2 != dim {
        let physical = if extended(h) {
            format!("{} (q, p: extended with t0 and p_t = -H) or ", dim - 2)
        } else {
            String::new()
        };
        return Err(PyValueError::new_err(format!(
            "{name} has length {}, expected {physical}{dim} ({})",
            values.len(),
            crate::state::layout(dim)
        )));
    }
    let z = dth::dth::lift(&DVector::from_vec(values), t0);
    dth::dth::set_momentum_of_time(h, z).map_err(|e| PyValueError::new_err(e.to_string()))
}

/// The method `name` with its step and options, each argument checked against the method.
pub fn method(
    name: &str,
    dtau: Option<f64>,
    dt: Option<f64>,
    order: Option<u32>,
    robust: Option<bool>,
    lambda0: Option<f64>,
) -> PyResult<Chosen> {
    match name {
        "dth" => dth_options(dtau, dt, order, robust, lambda0).map(Chosen::Method),
        name if METHODS.contains(&name) => peer(name, dt, dtau, order, robust, lambda0),
        name => Err(unknown_method(name)),
    }
}

/// Where the run ends: exactly one of `steps`, `t_end` and `orbits`.
pub fn end(steps: Option<usize>, t_end: Option<f64>, orbits: Option<f64>) -> PyResult<Duration> {
    match (steps, t_end, orbits) {
        (Some(n), None, None) => Ok(Duration::Steps(n)),
        (None, Some(t), None) => Ok(Duration::Time(t)),
        (None, None, Some(k)) if k.is_finite() && k >= 0.0 => Ok(Duration::Orbits(k)),
        (None, None, Some(k)) => Err(PyValueError::new_err(format!(
            "orbits must be a finite number of orbits, at least 0, not {k}"
        ))),
        _ => Err(PyTypeError::new_err(
            "give exactly one of steps=... (a number of steps), t_end=... (a time) and \
             orbits=... (a number of orbit periods)",
        )),
    }
}

/// Where a run of `duration` from `z0` at `t0` ends: a number of orbits becomes the time
/// `t0 + orbits * period`, the period the catalogue system's from `z0`
/// ([`crate::catalogue::period`]), as the `dth` command turns a scene's `orbits` into a time.
pub fn resolve_end(
    duration: Duration,
    catalogue: Option<&str>,
    h: &RuntimeHamiltonian,
    z0: &DVector<f64>,
    t0: f64,
) -> PyResult<End> {
    Ok(match duration {
        Duration::Steps(n) => End::Steps(n),
        Duration::Time(t) => End::Time(t),
        Duration::Orbits(k) => End::Time(t0 + k * crate::catalogue::period(catalogue, h, z0)?),
    })
}

/// DTH's options, or an error naming the peer arguments given to DTH.
fn dth_options(
    dtau: Option<f64>,
    dt: Option<f64>,
    order: Option<u32>,
    robust: Option<bool>,
    lambda0: Option<f64>,
) -> PyResult<Method> {
    if dt.is_some() {
        return Err(PyTypeError::new_err(
            "dt is the step of the fixed-step methods; DTH takes dtau (its step in the \
             discrete time tau: the physical step is lambda * dtau)",
        ));
    }
    let dtau = dtau.ok_or_else(|| PyTypeError::new_err("method=\"dth\" needs dtau=..."))?;
    let mut options = DthOptions::new(dtau).map_err(|e| option_error(&e))?;
    if let Some(order) = order {
        options = options.with_order(order).map_err(|e| option_error(&e))?;
    }
    if let Some(robust) = robust {
        options = options.with_robust(robust);
    }
    if let Some(lambda0) = lambda0 {
        options = options
            .with_lambda0(lambda0)
            .map_err(|e| option_error(&e))?;
    }
    Ok(Method::Dth(options))
}

/// A fixed-step peer, or an error naming the DTH arguments given to it.
fn peer(
    name: &str,
    dt: Option<f64>,
    dtau: Option<f64>,
    order: Option<u32>,
    robust: Option<bool>,
    lambda0: Option<f64>,
) -> PyResult<Chosen> {
    let dth_only = [
        ("dtau", dtau.is_some()),
        ("order", order.is_some()),
        ("robust", robust.is_some()),
        ("lambda0", lambda0.is_some()),
    ];
    if let Some((arg, _)) = dth_only.iter().find(|(_, given)| *given) {
        return Err(PyTypeError::new_err(format!(
            "{arg} is an option of method=\"dth\"; method={name:?} takes dt"
        )));
    }
    let dt = dt.ok_or_else(|| PyTypeError::new_err(format!("method={name:?} needs dt=...")))?;
    let method = match name {
        "discrete_mechanics" => return Ok(Chosen::Special(Special::DiscreteMechanics, dt)),
        "exact" => return Ok(Chosen::Special(Special::Exact, dt)),
        "midpoint" => Method::Midpoint { dt },
        "gauss_legendre2" => Method::GaussLegendre2 { dt },
        "stormer_verlet" => Method::StormerVerlet { dt },
        "rk4" => Method::Rk4 { dt },
        "trapezoidal" => Method::Trapezoidal { dt },
        "discrete_gradient" => Method::DiscreteGradient { dt },
        _ => return Err(unknown_method(name)),
    };
    Ok(Chosen::Method(method))
}

/// `method=` names no method: the list, and the closest name.
fn unknown_method(name: &str) -> PyErr {
    let closest = METHODS
        .iter()
        .map(|m| (strsim::levenshtein(name, m), *m))
        .min()
        .filter(|(d, _)| *d <= 3)
        .map(|(_, m)| format!(" (did you mean {m:?}?)"))
        .unwrap_or_default();
    PyValueError::new_err(format!(
        "unknown method {name:?}{closest}: expected one of {}",
        METHODS.join(", ")
    ))
}
