//! What a `dth.systems` Hamiltonian knows beyond its text: the built-in system of the `dth`
//! command's catalogue it is the text of (`dth_examples::catalogue`), and from that system
//! what no text says: its orbit period (for `orbits=`, [`period`]), its exact solution
//! (`method="exact"`) and its central force (Greenspan's `method="discrete_mechanics"`).
//! Those two methods run on the catalogue's compiled system ([`dispatch`]), whose value and
//! derivatives equal the text's to the bit (tested for every entry), with the same driver as
//! every other method (`dth::solve`, through `dth::solve::Peer`).
//!
//! The parameters are the Hamiltonian's current ones (`set_parameter` changes them for these
//! too). [`builtin`] lists the catalogue and evaluates an entry, for the tests that hold
//! `dth.systems` to it.

use std::collections::BTreeMap;

use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;

use dth::methods::{DiscreteMechanics, OneStepMethod};
use dth::nalgebra::{Const, DVector, DefaultAllocator, Dim, OVector, SVector};
use dth::runtime::RuntimeHamiltonian;
use dth::solve::Peer;
use dth::systems::CentralForce;
use dth::{Alloc, Error};
use dth_examples::catalogue::Catalogue;
use dth_examples::scene::SystemLookup;
use dth_examples::system::SceneSystem;
use dth_examples::systems::{FreeParticle, HarmonicOscillator, Kepler};

use crate::sized::Job;

/// A method that runs on the catalogue system a `dth.systems` Hamiltonian is the text of,
/// not on the text ([`crate::catalogue`]): what it needs is not in the text.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Special {
    /// Greenspan's discrete mechanics (a central force `H = |p|^2/(2m) + phi(|q|)`).
    DiscreteMechanics,
    /// The system's exact solution, sampled every `dt`.
    Exact,
}

impl Special {
    /// Its name in `method=`.
    pub fn name(self) -> &'static str {
        match self {
            Special::DiscreteMechanics => "discrete_mechanics",
            Special::Exact => "exact",
        }
    }
}

/// The catalogue systems that have a period, an exact solution or a central force, with the
/// parameters `h` has now. Every other entry has none of these.
enum Twin {
    Kepler(Kepler),
    HarmonicOscillator(HarmonicOscillator),
    FreeParticle(FreeParticle),
}

/// The parameter `name` of `h`.
fn param(h: &RuntimeHamiltonian, name: &str) -> PyResult<f64> {
    h.parameters()
        .find(|(n, _)| *n == name)
        .map(|(_, v)| v)
        .ok_or_else(|| PyValueError::new_err(format!("the Hamiltonian has no parameter `{name}`")))
}

impl Twin {
    /// The catalogue system `name` with `h`'s parameters, when it is one of these.
    fn of(name: Option<&str>, h: &RuntimeHamiltonian) -> PyResult<Option<Twin>> {
        // The twin's text has the system's dimension (`dth.systems`; checked when it is built).
        let dim = match name {
            Some("harmonic_oscillator") => 2,
            _ => 4,
        };
        if h.dimension() != dim {
            return Ok(None);
        }
        Ok(match name {
            Some("kepler") => Some(Twin::Kepler(Kepler {
                m: param(h, "m")?,
                k: param(h, "k")?,
            })),
            Some("harmonic_oscillator") => Some(Twin::HarmonicOscillator(HarmonicOscillator {
                m: param(h, "m")?,
                k: param(h, "k")?,
            })),
            Some("free_particle") => Some(Twin::FreeParticle(FreeParticle { m: param(h, "m")? })),
            _ => None,
        })
    }
}

/// `what` is known only for `systems`, not for the Hamiltonian (`dth.systems.<name>` or a
/// text); `instead` says what to give instead ("" for nothing).
fn not_offered(what: &str, systems: &str, name: Option<&str>, instead: &str) -> PyErr {
    let this = match name {
        Some(name) => format!("dth.systems.{name} has none"),
        None => "a Hamiltonian built from text has none (the text does not say it)".to_string(),
    };
    PyValueError::new_err(format!(
        "{what} is known only for {systems}: {this}{instead}"
    ))
}

/// The orbit period from `z0` of the catalogue system `name` with `h`'s parameters (Kepler:
/// `2 pi sqrt(m a^3 / k)` of a bound orbit; the harmonic oscillator: `2 pi sqrt(m / k)`), the
/// catalogue's own ([`SceneSystem::period`]).
pub fn period(name: Option<&str>, h: &RuntimeHamiltonian, z0: &DVector<f64>) -> PyResult<f64> {
    let period = match Twin::of(name, h)? {
        Some(Twin::Kepler(s)) => s.period(&SVector::from_column_slice(z0.as_slice())),
        Some(Twin::HarmonicOscillator(s)) => s.period(&SVector::from_column_slice(z0.as_slice())),
        _ => {
            return Err(not_offered(
                "orbits=...: the orbit period",
                "dth.systems.kepler and dth.systems.harmonic_oscillator",
                name,
                "; give t_end=... (a time) or steps=... instead",
            ))
        }
    };
    period.ok_or_else(|| {
        PyValueError::new_err(
            "orbits=...: the initial state z0 has no orbit period (an unbound Kepler orbit, \
             H >= 0): give t_end=... (a time) or steps=... instead",
        )
    })
}

/// Runs `job` with the method `special` (step `dt`) on the catalogue system `name` with
/// `h`'s parameters, from states of dimension 4; a `ValueError` naming the method and the
/// system when the system does not offer it.
pub fn dispatch<J: Job>(
    name: Option<&str>,
    h: &RuntimeHamiltonian,
    special: Special,
    dt: f64,
    job: J,
) -> PyResult<J::Output> {
    match Twin::of(name, h)? {
        Some(Twin::Kepler(s)) => Ok(run_special(&s, special, dt, job)),
        Some(Twin::FreeParticle(s)) => Ok(run_special(&s, special, dt, job)),
        _ => Err(match special {
            Special::DiscreteMechanics => not_offered(
                "method=\"discrete_mechanics\": the central force (H = |p|^2/(2m) + phi(|q|)) Greenspan's method needs",
                "dth.systems.kepler and dth.systems.free_particle",
                name,
                "; use another method",
            ),
            Special::Exact => not_offered(
                "method=\"exact\": the exact solution",
                "dth.systems.kepler and dth.systems.free_particle",
                name,
                "; use another method",
            ),
        }),
    }
}

/// `job` with `special` on `system`, a planar central force with an exact solution.
fn run_special<S, J>(system: &S, special: Special, dt: f64, job: J) -> J::Output
where
    S: SceneSystem<Const<4>> + CentralForce<Const<4>> + Sync,
    J: Job,
{
    let state = |z: &DVector<f64>| SVector::<f64, 4>::from_column_slice(z.as_slice());
    match special {
        Special::DiscreteMechanics => {
            job.run(system, Peer::new(DiscreteMechanics::new(), dt), state)
        }
        Special::Exact => job.run(system, Peer::new(ExactSolution::default(), dt), state),
    }
}

/// Why `method="exact"` cannot start from `z0` on the catalogue system `name`, if it cannot
/// (Kepler: an orbit that is not elliptic).
pub fn exact_unavailable(
    name: Option<&str>,
    h: &RuntimeHamiltonian,
    z0: &DVector<f64>,
) -> PyResult<Option<String>> {
    let Some(Twin::Kepler(s)) = Twin::of(name, h)? else {
        return Ok(None);
    };
    // A Kepler twin has dimension 4 (`Twin::of`).
    let z = SVector::<f64, 4>::from_column_slice(z0.as_slice());
    Ok(s.exact_solution(&z, 0.0).is_none().then(|| {
        format!(
            "method=\"exact\": dth.systems.kepler has an exact solution for elliptic orbits \
             only, and z0 = {:?} has H = {:?} >= 0",
            z0.as_slice(),
            dth::Hamiltonian::value(&s, &z)
        )
    }))
}

/// The exact solution as a one-step method, for `dth::solve`: each step ends on the system's
/// exact solution ([`SceneSystem::exact_solution`]) from the run's initial state, at the time
/// elapsed since it, not on a composition of one-step flows, so no error accumulates from step
/// to step. The time elapsed is counted as the driver's clock is, `t_a + j dt` from the last
/// step of another size (not a running sum), so that from `t0 = 0` the samples are the
/// scene runner's `exact` at the same times. A step that does not continue the last one
/// (another state) starts anew from its state.
#[derive(Clone, Debug)]
struct ExactSolution<D: Dim>
where
    DefaultAllocator: Alloc<D>,
{
    /// Where the run started and its clock.
    origin: Option<Origin<D>>,
    /// The state the last step ended on.
    last: Option<OVector<f64, D>>,
}

/// The initial state of an [`ExactSolution`] run and the time elapsed since it,
/// `base + count * step`.
#[derive(Clone, Debug)]
struct Origin<D: Dim>
where
    DefaultAllocator: Alloc<D>,
{
    z0: OVector<f64, D>,
    /// The run's step (its first step's size).
    step: f64,
    /// The time elapsed at the last step of another size.
    base: f64,
    /// Steps of `step` since.
    count: u64,
}

impl<D: Dim> Default for ExactSolution<D>
where
    DefaultAllocator: Alloc<D>,
{
    fn default() -> Self {
        ExactSolution {
            origin: None,
            last: None,
        }
    }
}

impl<D: Dim> ExactSolution<D>
where
    DefaultAllocator: Alloc<D>,
{
    /// `dt` on from the origin into `z1`.
    fn advance<S: SceneSystem<D>>(
        &mut self,
        h: &S,
        dt: f64,
        z1: &mut OVector<f64, D>,
    ) -> Result<(), Error> {
        let unavailable = Error::MethodNonFinite {
            method: "exact",
            step: 0,
            what: "exact solution (none for this state)",
        };
        let origin = self.origin.as_mut().ok_or(unavailable.clone())?;
        let elapsed = if dt == origin.step {
            origin.count += 1;
            origin.base + origin.count as f64 * origin.step
        } else {
            origin.base += origin.count as f64 * origin.step + dt;
            origin.count = 0;
            origin.base
        };
        let z = h.exact_solution(&origin.z0, elapsed).ok_or(unavailable)?;
        z1.copy_from(&z);
        self.last = Some(z);
        Ok(())
    }
}

impl<D: Dim, S: SceneSystem<D>> OneStepMethod<D, S> for ExactSolution<D>
where
    DefaultAllocator: Alloc<D>,
{
    const NAME: &'static str = "exact";
    /// Exact: no order (the largest).
    const ORDER: u32 = u32::MAX;

    fn step_into(
        &mut self,
        h: &S,
        z: &OVector<f64, D>,
        dt: f64,
        z1: &mut OVector<f64, D>,
    ) -> Result<(), Error> {
        self.origin = Some(Origin {
            z0: z.clone(),
            step: dt,
            base: 0.0,
            count: 0,
        });
        self.advance(h, dt, z1)
    }

    fn continue_into(
        &mut self,
        h: &S,
        z: &OVector<f64, D>,
        dt: f64,
        z1: &mut OVector<f64, D>,
    ) -> Result<(), Error> {
        if self.origin.is_some() && self.last.as_ref() == Some(z) {
            self.advance(h, dt, z1)
        } else {
            self.step_into(h, z, dt, z1)
        }
    }
}

/// The catalogue of the `dth` command: one dict per entry, in its order, with `name`, `n`
/// (degrees of freedom), `params` (name to default), `time_dependent`, `has_period`,
/// `has_exact`, `central_force` and `dth` (whether DTH runs on it). For the tests that hold
/// `dth.systems` to the catalogue.
#[pyfunction]
#[pyo3(name = "_catalogue")]
pub fn builtin(py: Python<'_>) -> PyResult<Vec<Bound<'_, PyDict>>> {
    let catalogue = Catalogue::builtin();
    catalogue
        .entries()
        .iter()
        .map(|entry| {
            let info = entry.info();
            let d = PyDict::new(py);
            d.set_item("name", entry.name())?;
            d.set_item("n", info.n)?;
            let params: BTreeMap<&str, Option<f64>> =
                info.params.iter().map(|p| (p.name, p.default)).collect();
            d.set_item("params", params)?;
            d.set_item("time_dependent", info.time_dependent)?;
            d.set_item("has_period", info.has_period)?;
            d.set_item("has_exact", info.has_exact)?;
            d.set_item("central_force", info.central_force)?;
            d.set_item("dth", info.dth)?;
            Ok(d)
        })
        .collect()
}

/// The value and gradient at `z` of the catalogue entry `name` (its compiled `hamiltonian!`
/// type) with `params` (defaults filled in): what `dth.systems`' texts are checked against.
#[pyfunction]
#[pyo3(name = "_catalogue_evaluate")]
pub fn evaluate(
    name: &str,
    params: BTreeMap<String, f64>,
    z: Vec<f64>,
) -> PyResult<(f64, Vec<f64>)> {
    let catalogue = Catalogue::builtin();
    let entry = catalogue.get(name).ok_or_else(|| {
        PyValueError::new_err(format!(
            "no catalogue system `{name}`: expected one of {}",
            catalogue.names().join(", ")
        ))
    })?;
    let mut all: BTreeMap<String, f64> = entry
        .info()
        .params
        .iter()
        .filter_map(|p| p.default.map(|v| (p.name.to_string(), v)))
        .collect();
    all.extend(params);
    entry
        .evaluate(&all, &z)
        .map_err(|e| PyValueError::new_err(e.to_string()))
}

/// The state dimension of the catalogue system `name` (`2 n`, and `t`, `p_t` for a
/// time-dependent one), or None for a name the catalogue does not have.
pub fn dimension(name: &str) -> Option<usize> {
    let catalogue = Catalogue::builtin();
    let info = catalogue.get(name)?.info();
    Some(2 * info.n + if info.time_dependent { 2 } else { 0 })
}
