//! `dth.integrate(h, z0, "dth", ..., regularize="levi-civita" | "ks", centre=...)`: DTH on the
//! regularized `K = |u|^2 (H + p_t)` of the Hamiltonian's text, as a scene's `[system]
//! regularize` runs it (`dth_examples::regularized`, the one place the map lives): `z0` is the
//! physical `(q, p)`, and every saved state, vertex and event state comes back as `(q, p)`,
//! every time is physical (the run ends exactly at `t_end`), `lam` is the physical
//! `dt/dtau = |u|^2 lambda_K`, the energy errors are those of `H`; `psi` stays `K`'s, the one
//! whose sign DTH needs. The peers run on `H` itself, so they refuse `regularize`.

use std::sync::Arc;

use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;

use dth::nalgebra::DVector;
use dth::runtime::RuntimeHamiltonian;
use dth_examples::regularized::{Regularized, MAX_PHYSICAL};
use dth_examples::scene::{Regularization, RegularizeMap};

/// A run's regularization: the compiled `K`, the map back, and the physical `H` and energy.
pub struct Physical {
    h: Arc<RuntimeHamiltonian>,
    k: Regularized,
    /// What `K` was compiled from (for [`Physical::copy_for`]).
    regularization: Regularization,
    n: usize,
    energy0: f64,
}

impl Physical {
    /// The `regularize=` and `centre=` arguments of `integrate` and `ensemble`: `None` without
    /// a regularization (a `TypeError` for a `centre` alone), else [`Physical::read`].
    pub fn from_args(
        h: &Arc<RuntimeHamiltonian>,
        text: &str,
        (regularize, centre): (Option<&str>, Option<Vec<f64>>),
        method: &str,
    ) -> PyResult<Option<Self>> {
        match regularize {
            Some(r) => Self::read(h, text, r, centre, method).map(Some),
            None if centre.is_some() => Err(PyTypeError::new_err(
                "centre is the centre of a regularization: give regularize too",
            )),
            None => Ok(None),
        }
    }

    /// `regularize` (a map's name) about `centre` (default: the origin) for `h` (its text and
    /// parameters) run by `method`, from the physical state `z0` at `t0`; a `ValueError`
    /// saying what does not apply (a peer method, an unknown map, a Hamiltonian of the wrong
    /// size or time-dependent, a centre of the wrong length, `z0` at the centre).
    pub fn read(
        h: &Arc<RuntimeHamiltonian>,
        text: &str,
        regularize: &str,
        centre: Option<Vec<f64>>,
        method: &str,
    ) -> PyResult<Self> {
        if method != "dth" {
            return Err(PyValueError::new_err(format!(
                "regularize applies to method \"dth\", and method is {method:?}: the peers run on H itself (drop regularize for them)"
            )));
        }
        let map = RegularizeMap::from_name(regularize).ok_or_else(|| {
            PyValueError::new_err(format!(
                "regularize={regularize:?}: expected \"levi-civita\" (planar, n = 2) or \"ks\" (Kustaanheimo-Stiefel, in space, n = 3)"
            ))
        })?;
        let n = h.degrees_of_freedom();
        if n != map.n() {
            let other = RegularizeMap::ALL
                .into_iter()
                .find(|m| m.n() == n)
                .map_or(String::new(), |m| format!(": use \"{}\"", m.name()));
            return Err(PyValueError::new_err(format!(
                "\"{}\" regularizes a Hamiltonian of n = {} degrees of freedom, and this one has n = {n}{other}",
                map.name(),
                map.n()
            )));
        }
        let centre = centre.unwrap_or_else(|| vec![0.0; n]);
        if centre.len() != n {
            return Err(PyValueError::new_err(format!(
                "centre has {} values, expected {n} (one per degree of freedom)",
                centre.len()
            )));
        }
        if let Some(i) = centre.iter().position(|c| !c.is_finite()) {
            return Err(PyValueError::new_err(format!("centre[{i}] is not finite")));
        }
        let regularization = Regularization {
            map,
            centre,
            source: text.to_string(),
        };
        Self::compile(Arc::clone(h), regularization, n)
    }

    /// `K` of `regularization` compiled with `h`'s parameters.
    fn compile(
        h: Arc<RuntimeHamiltonian>,
        regularization: Regularization,
        n: usize,
    ) -> PyResult<Self> {
        let params: Vec<(&str, f64)> = h.parameters().collect();
        let k = Regularized::compile(&regularization, &params)
            .map_err(|e| PyValueError::new_err(format!("regularize: {e}")))?;
        Ok(Physical {
            h,
            k,
            regularization,
            n,
            energy0: f64::NAN,
        })
    }

    /// The same regularization of `h`, a copy of the Hamiltonian this one was read for (an
    /// ensemble's scratch copy, or a thread's, whose members set their own parameters):
    /// `K` compiled anew, owned with `h`.
    pub fn copy_for(&self, h: RuntimeHamiltonian) -> PyResult<Self> {
        Self::compile(Arc::new(h), self.regularization.clone(), self.n)
    }

    /// Sets parameter `name` of `H` and of `K` (a parameter grid's member); a `ValueError`
    /// naming what the engine refused.
    pub fn set_parameter(&mut self, name: &str, value: f64) -> PyResult<()> {
        let h = Arc::get_mut(&mut self.h).ok_or_else(|| {
            PyValueError::new_err("internal error: a regularization's Hamiltonian is shared")
        })?;
        h.set_parameter(name, value)
            .and_then(|()| self.k.set_parameter(name, value))
            .map_err(|e| PyValueError::new_err(e.to_string()))
    }

    /// The physical `H`.
    pub fn hamiltonian(&self) -> &Arc<RuntimeHamiltonian> {
        &self.h
    }

    /// The compiled `K` DTH runs on.
    pub fn k(&self) -> &RuntimeHamiltonian {
        self.k.k()
    }

    /// The regularized start of the physical `z0` at `t0` (on `K = 0`), keeping `H(z0)` as
    /// the energy the errors are measured from; a `ValueError` for a `z0` at the centre.
    pub fn start(&mut self, z0: &DVector<f64>, t0: f64) -> PyResult<DVector<f64>> {
        let (w0, energy0) = self.start_of(z0, t0)?;
        self.energy0 = energy0;
        Ok(w0)
    }

    /// [`Physical::start`] in double-double (`double_double=True`): the start and its low part,
    /// for a run that solves its steps in double-double.
    pub fn start_double_double(
        &mut self,
        z0: &DVector<f64>,
        t0: f64,
    ) -> PyResult<(DVector<f64>, DVector<f64>)> {
        let (w0, low, energy0) = self
            .k
            .start_double_double(z0.as_slice(), t0)
            .map_err(|e| PyValueError::new_err(format!("z0: {e}")))?;
        self.energy0 = energy0;
        Ok((w0, low))
    }

    /// The regularized start of the physical `z0` at `t0` and `H(z0)`, for one of many runs
    /// on this `K` (an ensemble's member); a `ValueError` for a `z0` at the centre.
    pub fn start_of(&self, z0: &DVector<f64>, t0: f64) -> PyResult<(DVector<f64>, f64)> {
        // The energy in double-double (`Regularized::start`): the regularized orbit's period
        // follows it, and at an eccentric pericentre the plain sum loses digits of it.
        self.k
            .start(z0.as_slice(), t0)
            .map_err(|e| PyValueError::new_err(format!("z0: {e}")))
    }

    /// Physical coordinates: `2n`.
    pub fn dim(&self) -> usize {
        2 * self.n
    }

    /// `H(z0)`.
    pub fn energy0(&self) -> f64 {
        self.energy0
    }

    /// `H(q, p) - H(z0)` at the regularized state `w`.
    pub fn energy_error(&self, w: &[f64]) -> f64 {
        self.energy_error_from(w, self.energy0)
    }

    /// `H(q, p) - energy0` at the regularized state `w` (a run started by
    /// [`Physical::start_of`]).
    pub fn energy_error_from(&self, w: &[f64], energy0: f64) -> f64 {
        // On the stack: an ensemble's observer calls this at every step. (`H` has the
        // physical dimension `2n` the map gives, so `value_slice` cannot refuse it.)
        let mut physical = [0.0; MAX_PHYSICAL];
        let z = self.state_in(w, &mut physical);
        self.h.value_slice(z).map_or(f64::NAN, |h| h - energy0)
    }

    /// The physical `(q, p)` of the regularized state `w`.
    pub fn state(&self, w: &[f64]) -> Vec<f64> {
        self.k.physical_state(w, &mut [0.0; MAX_PHYSICAL]).to_vec()
    }

    /// [`Physical::state`] in `out`, without allocating (an event's condition, every step).
    pub fn state_in<'a>(&self, w: &[f64], out: &'a mut [f64; MAX_PHYSICAL]) -> &'a [f64] {
        self.k.physical_state(w, out)
    }

    /// `dt/ds = |u|^2` at `w`: DTH's multiplier on `K` times this is the physical `dt/dtau`.
    pub fn time_rate(&self, w: &[f64]) -> f64 {
        self.k.dt_ds(w)
    }
}
