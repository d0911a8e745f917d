//! DTH on a regularized Hamiltonian, seen in physical coordinates: a scene's
//! `[system] regularize = "levi-civita" | "ks"` (with an optional `centre`) runs method `dth` on
//! `K = |u|^2 (H + p_t)` (`dth_symbolic::regularize`), where `Psi` keeps its sign through close
//! approaches to the centre, and every record of that run is mapped back to the physical
//! `(t, q, p)` here, in one place ([`Regularized::run`]): the effects, the fallback watch, the
//! summary and the figures see the physical state and evaluate the physical `H`, as for any
//! other method; a duration in `time` is physical time, and the run ends exactly on it (the
//! stepper reads `K`'s `t` coordinate as its clock).
//!
//! - **The start.** The scene's `(q, p)` at `t0` is mapped with `dth::regularize::LeviCivita::start`
//!   (or `KustaanheimoStiefel::start`, on the fibre where the bilinear invariant is zero), with
//!   `p_t = -H(q, p)` so that the run starts on `K = 0`.
//! - **Each record.** `zbar` and the vertex map back with `physical` (`q = c + q(u)`,
//!   `p = A(u) P / (2 |u|^2)`); the times are `K`'s `t` coordinate; `lambda` becomes the
//!   physical `dt/dtau = |u|^2 lambda_K` of the step (`dt/ds = dK/dp_t = |u|^2` at the
//!   midpoint); `Psi` stays `K`'s, the one whose sign DTH's existence needs.
//! - **The centre.** `q = c + q'` with `p` unchanged is canonical, so it is a substitution in
//!   the text (`crate::scene::translated`): `q_i` becomes `(q_i + c_i)` before the engine regularizes, and
//!   a distance written about the same point, `((q1 - c1)^2 + q2^2)^(-1/2)`, simplifies to
//!   `|q'|^(-1)`, which the regularization cancels exactly. Write `c` in the text with the same
//!   digits as in `centre` (the engine's numbers are exact decimals, so `0.99` cancels `0.99`);
//!   a centre hidden behind a parameter (`1 - mu`) does not cancel, and `K` then has terms that
//!   only cancel numerically near the centre.
//!
//! The peers of a regularized scene (midpoint, Gauss-Legendre, ...) run on the physical `H`,
//! as in any scene: they do not need the regularization (a fixed step in the fictitious time
//! could not land on a physical end time), and beside DTH they show what it changes.
//!
//! ```
//! use dth_examples::scene::translated;
//! assert_eq!(
//!     translated("((q1 - 0.99)^2 + q2^2)^(-1/2)", &[0.99, 0.0]).unwrap(),
//!     "(((q1 + 0.99) - 0.99)^2 + q2^2)^(-1/2)"
//! );
//! ```

use dth::methods::RunEnd;
use dth::nalgebra::{DVector, DefaultAllocator, Dim, Dyn, OVector, SVector, Vector4, Vector6};
use dth::observer::{DthRecord, Observer, StepRecord};
use dth::regularize::{KustaanheimoStiefel, LeviCivita};
use dth::runtime::{RuntimeError, RuntimeHamiltonian};
use dth::Alloc;

use crate::driver::{Condition, DthRunner, MethodFailure, Stop, Watched};
use crate::scene::{translated, IndexedCentre, Regularization, RegularizeMap};

/// The most physical coordinates a map has (`q`, `p` in space): room for
/// [`Regularized::physical_state`].
pub const MAX_PHYSICAL: usize = 6;

/// Why a scene's regularized `K` was not built.
#[derive(Debug, thiserror::Error)]
pub enum RegularizeError {
    /// The engine refused the text or its parameters (a text that is not planar, or not
    /// spatial for KS, or uses `t`).
    #[error("{0}")]
    Text(#[from] RuntimeError),
    /// The centre is not the origin and the text indexes `q[..]` (in a sum): only the
    /// coordinates written out are translated.
    #[error(transparent)]
    IndexedCentre(#[from] IndexedCentre),
}

/// A scene's regularized `K`, compiled, with the map between its states and the physical ones.
#[derive(Debug)]
pub struct Regularized {
    /// `K`, which also keeps the physical `H`'s value program: the start's energy, in
    /// double-double (`RuntimeHamiltonian::physical_energy_slice`), whatever type the scene's
    /// system is.
    k: RuntimeHamiltonian,
    map: RegularizeMap,
    centre: Vec<f64>,
}

impl Regularized {
    /// `K` of the Hamiltonian `regularization.source` (parameters `params`) under
    /// `regularization`: the text translated to its centre (`crate::scene::translated`), then
    /// regularized and compiled (`RuntimeHamiltonian::levi_civita` or `::kustaanheimo_stiefel`).
    ///
    /// # Errors
    /// [`RegularizeError::Text`] with the engine's error, as `RuntimeHamiltonian::levi_civita`
    /// gives it; [`RegularizeError::IndexedCentre`] from `crate::scene::translated`.
    pub fn compile(
        regularization: &Regularization,
        params: &[(&str, f64)],
    ) -> Result<Self, RegularizeError> {
        let text = translated(&regularization.source, &regularization.centre)?;
        let k = match regularization.map {
            RegularizeMap::LeviCivita => RuntimeHamiltonian::levi_civita(&text, params),
            RegularizeMap::Ks => RuntimeHamiltonian::kustaanheimo_stiefel(&text, params),
        }?;
        Ok(Regularized {
            k,
            map: regularization.map,
            centre: regularization.centre.clone(),
        })
    }

    /// The compiled `K` (on `(u, t, P, p_t)`).
    pub fn k(&self) -> &RuntimeHamiltonian {
        &self.k
    }

    /// Sets `K`'s parameter `name`, as the physical Hamiltonian's is set (no recompilation): a
    /// parameter of `H` that the regularization cancelled is not one of `K`'s, and setting it
    /// changes nothing.
    ///
    /// # Errors
    /// `RuntimeError::NonFiniteParameter` for a value that is not finite.
    pub fn set_parameter(&mut self, name: &str, value: f64) -> Result<(), RuntimeError> {
        match self.k.set_parameter(name, value) {
            Err(RuntimeError::UnknownParameter { .. }) if value.is_finite() => Ok(()),
            result => result,
        }
    }

    /// The regularized start of the physical state `z = (q, p)` at time `t`, and its energy
    /// `H(z)`: `p_t = -H(z)` (so `K = 0`), with `H(z)` in double-double at the state as it is
    /// represented about the centre (`RuntimeHamiltonian::physical_energy_slice`): the orbit's
    /// period follows it, and at an eccentric pericentre the plain sum loses digits of it.
    ///
    /// # Errors
    /// `dth::Error::NonFiniteInitialState` for a value that is not finite,
    /// `dth::Error::InvalidOption` (`q`) at the centre, where the momenta have no image,
    /// `dth::Error::InvalidOption` (`H(z0)`) for an energy that is zero to the roundoff of
    /// `H`'s terms (a parabolic orbit: `K`'s `Psi` is proportional to the energy for a
    /// Kepler-like `H`, so its sign, which DTH needs, is rounding noise there), and
    /// `dth::Error::WrongStateLength` for a `z` that is not `2n` long.
    pub fn start(&self, z: &[f64], t: f64) -> Result<(DVector<f64>, f64), dth::Error> {
        let (w, _, energy) = self.start_in(z, t, false)?;
        Ok((w, energy))
    }

    /// [`Regularized::start`] in double-double: the start, its low part (what the roundings
    /// of the state dropped, the energy's included: `dth_core::regularize`'s
    /// `start_double_double`) and `H(z)` rounded, for a run solved in double-double
    /// (`dth::Solve::start_low`).
    ///
    /// # Errors
    /// As [`Regularized::start`].
    pub fn start_double_double(
        &self,
        z: &[f64],
        t: f64,
    ) -> Result<(DVector<f64>, DVector<f64>, f64), dth::Error> {
        self.start_in(z, t, true)
    }

    /// [`Regularized::start`], with the low part when `double_double` (zeros otherwise).
    fn start_in(
        &self,
        z: &[f64],
        t: f64,
        double_double: bool,
    ) -> Result<(DVector<f64>, DVector<f64>, f64), dth::Error> {
        let n = self.map.n();
        if z.len() != 2 * n {
            return Err(dth::Error::WrongStateLength {
                what: "z0",
                expected: 2 * n,
                found: z.len(),
            });
        }
        let mut shifted = [0.0; MAX_PHYSICAL];
        shifted[..2 * n].copy_from_slice(z);
        for (q, c) in shifted.iter_mut().zip(&self.centre) {
            *q -= c;
        }
        let (hi, lo) = self
            .k
            .physical_energy_double_double_slice(&shifted[..2 * n])?;
        let energy = hi + lo;
        let dvector = |w: &[f64]| DVector::from_column_slice(w);
        let (w, low) = match (self.map, double_double) {
            (RegularizeMap::LeviCivita, false) => {
                let w = LeviCivita::start(&Vector4::from_column_slice(&shifted[..4]), t, energy)?;
                (dvector(w.as_slice()), DVector::zeros(6))
            }
            (RegularizeMap::LeviCivita, true) => {
                let z = Vector4::from_column_slice(&shifted[..4]);
                let (w, low) = LeviCivita::start_double_double(&z, t, (hi, lo))?;
                (dvector(w.as_slice()), dvector(low.as_slice()))
            }
            (RegularizeMap::Ks, false) => {
                let w =
                    KustaanheimoStiefel::start(&Vector6::from_column_slice(&shifted), t, energy)?;
                (dvector(w.as_slice()), DVector::zeros(10))
            }
            (RegularizeMap::Ks, true) => {
                let z = Vector6::from_column_slice(&shifted);
                let (w, low) = KustaanheimoStiefel::start_double_double(&z, t, (hi, lo))?;
                (dvector(w.as_slice()), dvector(low.as_slice()))
            }
        };
        // The terms of H at z, sum |z_i dH/dz_i|, from K's: dK/dw = |u|^2 dH/dw off p_t.
        let gradient = dth::Hamiltonian::gradient(&self.k, &w);
        let terms = w
            .iter()
            .zip(gradient.iter())
            .take(w.len() - 1)
            .map(|(x, g)| (x * g).abs())
            .sum::<f64>()
            / self.dt_ds(w.as_slice());
        if energy.abs() <= 8.0 * f64::EPSILON * terms {
            return Err(dth::Error::InvalidOption {
                name: "H(z0)",
                value: energy,
                reason: "the energy is zero to the roundoff of H's terms (a parabolic orbit about the centre): the regularized K's Psi is proportional to the energy for a Kepler-like H, so its sign, which DTH needs, is rounding noise; start on a clearly elliptic (E < 0) or hyperbolic (E > 0) orbit, or run unregularized in robust mode",
            });
        }
        Ok((w, low, energy))
    }

    /// The physical state `(q, p)` of the regularized state `w` into `out` (its first `2n`
    /// values), and its time.
    pub fn physical_into(&self, w: &[f64], out: &mut [f64]) -> f64 {
        let n = self.map.n();
        let (z, t) = match self.map {
            RegularizeMap::LeviCivita => {
                let (z, t) = LeviCivita::physical(&Vector6::from_column_slice(&w[..6]));
                let mut all = [0.0; MAX_PHYSICAL];
                all[..4].copy_from_slice(z.as_slice());
                (all, t)
            }
            RegularizeMap::Ks => {
                let (z, t) =
                    KustaanheimoStiefel::physical(&SVector::<f64, 10>::from_column_slice(&w[..10]));
                let mut all = [0.0; MAX_PHYSICAL];
                all.copy_from_slice(z.as_slice());
                (all, t)
            }
        };
        out[..2 * n].copy_from_slice(&z[..2 * n]);
        for (q, c) in out.iter_mut().zip(&self.centre) {
            *q += c;
        }
        t
    }

    /// The physical `(q, p)` of the regularized state `w`, in `out` (no allocation: what
    /// conditions on the physical state read at every step).
    pub fn physical_state<'a>(&self, w: &[f64], out: &'a mut [f64; MAX_PHYSICAL]) -> &'a [f64] {
        self.physical_into(w, out);
        &out[..2 * self.map.n()]
    }

    /// `dt/ds = dK/dp_t = |u|^2` at the regularized state `w`: DTH's multiplier on `K` times
    /// this is the physical `dt/dtau`.
    pub fn dt_ds(&self, w: &[f64]) -> f64 {
        let u = match self.map {
            RegularizeMap::LeviCivita => &w[..2],
            RegularizeMap::Ks => &w[..4],
        };
        u.iter().map(|x| x * x).sum()
    }

    /// Runs DTH (`runner`) on `K` from the physical start `z0` at `t0` until `stop`, every
    /// record shown to `observer` in physical coordinates (see the [module docs](self)); the
    /// end is physical. The start's energy is `H(z0)` in double-double ([`Regularized::start`]):
    /// the rounding of the plain sum would set the period.
    ///
    /// A start the map refuses (the centre, a value that is not finite) is the method's
    /// failure at step 0.
    pub fn run<D: Dim, O: Observer<D>>(
        &self,
        runner: &DthRunner,
        z0: OVector<f64, D>,
        t0: f64,
        stop: Stop,
        observer: &mut O,
    ) -> Result<RunEnd<D>, MethodFailure>
    where
        DefaultAllocator: Alloc<D>,
    {
        let physical_z0: Vec<f64> = z0.iter().copied().collect();
        let (w0, low, _) = self
            .start_in(&physical_z0, t0, runner.double_double)
            .map_err(|e| MethodFailure::integrator(0, e))?;
        let mut view = PhysicalView {
            map: self,
            record: StepRecord::fixed(0, t0, z0.clone()),
            vertex: z0,
            observer,
        };
        // The events' conditions are on the physical state.
        let mapped: Vec<Physical> = stop
            .events()
            .iter()
            .map(|w| Physical {
                map: self,
                condition: w.condition,
            })
            .collect();
        let watched: Vec<Watched> = stop
            .events()
            .iter()
            .zip(&mapped)
            .map(|(w, condition)| Watched { condition, ..*w })
            .collect();
        let stop = stop.with_events(&watched);
        let low = runner.double_double.then_some(low);
        let end = runner.run::<Dyn, _, _>(&self.k, (w0, low), t0, stop, &mut view)?;
        let mut z = view.vertex;
        let t = self.physical_into(end.z.as_slice(), Slice::of(&mut z).0);
        Ok(RunEnd {
            z,
            t,
            steps: end.steps,
        })
    }
}

/// A condition on the physical state, read on the regularized one.
struct Physical<'a> {
    map: &'a Regularized,
    condition: &'a dyn Condition,
}

impl Condition for Physical<'_> {
    fn value(&self, t: f64, w: &[f64], scratch: &mut Vec<f64>) -> f64 {
        let mut z = [0.0; MAX_PHYSICAL];
        let z = self.map.physical_state(w, &mut z);
        self.condition.value(t, z, scratch)
    }
}

/// A mutable view of a state's values as a slice, whatever its dimension type (nalgebra's
/// owned vectors are contiguous).
struct Slice<'a>(&'a mut [f64]);

impl<'a> Slice<'a> {
    fn of<D: Dim>(z: &'a mut OVector<f64, D>) -> Self
    where
        DefaultAllocator: Alloc<D>,
    {
        Slice(z.as_mut_slice())
    }
}

/// The observer of a run on `K` that shows `observer` each record in physical coordinates
/// (see the [module docs](self)); `record` and `vertex` are its reused storage.
struct PhysicalView<'a, D: Dim, O>
where
    DefaultAllocator: Alloc<D>,
{
    map: &'a Regularized,
    record: StepRecord<D>,
    vertex: OVector<f64, D>,
    observer: &'a mut O,
}

impl<D: Dim, O: Observer<D>> Observer<Dyn> for PhysicalView<'_, D, O>
where
    DefaultAllocator: Alloc<D>,
{
    fn on_step(&mut self, r: &StepRecord<Dyn>) {
        self.physical(r);
        self.observer.on_step(&self.record);
    }

    fn on_landing(&mut self, r: &StepRecord<Dyn>) {
        self.physical(r);
        self.observer.on_landing(&self.record);
    }

    fn on_event(&mut self, event: usize, r: &StepRecord<Dyn>) {
        self.physical(r);
        self.observer.on_event(event, &self.record);
    }

    fn on_finish(&mut self, last_vertex: &DVector<f64>, last_vertex_time: f64) {
        self.map
            .physical_into(last_vertex.as_slice(), Slice::of(&mut self.vertex).0);
        self.observer.on_finish(&self.vertex, last_vertex_time);
    }
}

impl<D: Dim, O> PhysicalView<'_, D, O>
where
    DefaultAllocator: Alloc<D>,
{
    /// `self.record` = `r` in physical coordinates.
    fn physical(&mut self, r: &StepRecord<Dyn>) {
        let w = r.z.as_slice();
        let record = &mut self.record;
        record.k = r.k;
        record.kind = r.kind;
        record.iterations = r.iterations;
        record.factorizations = r.factorizations;
        record.t = r.t;
        self.map.physical_into(w, Slice::of(&mut record.z).0);
        match &r.dth {
            Some(d) => {
                let out = record.dth.get_or_insert_with(|| DthRecord {
                    lambda: 0.0,
                    vertex: self.vertex.clone(),
                    vertex_time: 0.0,
                    psi: 0.0,
                });
                out.lambda = d.lambda * self.map.dt_ds(w);
                self.map
                    .physical_into(d.vertex.as_slice(), Slice::of(&mut out.vertex).0);
                out.vertex_time = d.vertex_time;
                out.psi = d.psi;
            }
            None => record.dth = None,
        }
    }
}
