//! `dth.Hamiltonian`: a Hamiltonian read as text (the `hamiltonian!` grammar: `q1..qn`,
//! `p1..pn`, `t`, parameters, indexed sums) and compiled to machine code when built, with its
//! exact derivatives.

use std::collections::BTreeMap;
use std::sync::Arc;

use numpy::ndarray::Array2;
use numpy::{IntoPyArray, PyArray1};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;

use dth::runtime::{Backend, RuntimeHamiltonian};

use crate::errors::hamiltonian_error;
use crate::state;

/// A Hamiltonian's text and parameters ([`Hamiltonian::source`]).
pub struct Source {
    text: String,
    params: Vec<(String, f64)>,
}

impl Source {
    /// A new compiled copy.
    pub fn compile(&self) -> PyResult<RuntimeHamiltonian> {
        let params: Vec<(&str, f64)> = self.params.iter().map(|(n, v)| (n.as_str(), *v)).collect();
        RuntimeHamiltonian::new(&self.text, &params)
            .map_err(|e| pyo3::exceptions::PyRuntimeError::new_err(e.to_string()))
    }
}

/// An index array.
type Indices<'py> = Bound<'py, PyArray1<usize>>;

/// A Hamiltonian H(q, p) (or H(q, p, t)) read from text, its value, gradient, Hessian and
/// Psi = (J grad H)^T Hess H (J grad H) derived exactly and compiled when it is built.
///
/// Hamiltonian(text, params=None)
///
/// `text` uses the grammar of the Rust macro `hamiltonian!`: coordinates `q1..qn`, momenta
/// `p1..pn`, the time `t`, named parameters, `+ - * / ^`, `sqrt exp ln sin cos ...`, and
/// indexed sums `sum(i = 1..N, ...)` with a `where` clause. `params` maps each parameter
/// the text names to its value. A text that does not compile raises `HamiltonianError`
/// (a `ValueError`) with the `line` and `column` of the offending token.
///
/// >>> import dth
/// >>> h = dth.Hamiltonian("(p1^2 + p2^2)/(2*m) - k*(q1^2 + q2^2)^(-1/2)", params={"m": 0.5, "k": 1.0})
/// >>> h.dim
/// 4
/// >>> h.value([0.5, 0.0, 0.0, 1.2])
/// -0.56
#[pyclass(module = "dth", name = "Hamiltonian")]
pub struct Hamiltonian {
    /// Shared with the fixed-size views (`dth::runtime::Fixed`) a run of small dimension uses.
    pub(crate) h: Arc<RuntimeHamiltonian>,
    text: String,
    /// The catalogue system this is the text of (`dth.systems`), when it has that system's
    /// dimension: what `orbits=`, `"exact"` and `"discrete_mechanics"` need
    /// ([`crate::catalogue`]).
    catalogue: Option<String>,
}

impl Hamiltonian {
    /// The catalogue system this is the text of, if any.
    pub fn catalogue(&self) -> Option<&str> {
        self.catalogue.as_deref()
    }

    /// `text` compiled with `params` (without the GIL: a large lattice takes a while).
    fn build(py: Python<'_>, text: &str, params: Option<BTreeMap<String, f64>>) -> PyResult<Self> {
        let params = params.unwrap_or_default();
        let pairs: Vec<(&str, f64)> = params.iter().map(|(k, v)| (k.as_str(), *v)).collect();
        let built = py.detach(|| RuntimeHamiltonian::new(text, &pairs));
        let h = built.map_err(|e| hamiltonian_error(py, text, &e))?;
        Ok(Hamiltonian {
            h: Arc::new(h),
            text: text.to_string(),
            catalogue: None,
        })
    }

    /// The state argument `z` as a vector of this Hamiltonian's dimension.
    fn state(&self, z: &Bound<'_, PyAny>) -> PyResult<Vec<f64>> {
        state::read(z, "z", self.h.dimension())
    }

    /// The Hessian's nonzeros at `z` as `(rows, cols, values)`.
    fn sparse_hessian<'py>(
        &self,
        py: Python<'py>,
        z: &[f64],
    ) -> PyResult<Bound<'py, pyo3::types::PyTuple>> {
        let pattern = self.h.hessian_pattern().ok_or_else(|| {
            PyValueError::new_err(
                "sparse=True: this Hamiltonian has no Hessian pattern (hessian_pattern() is \
                 None: only a lattice written with indexed sums has one); use hessian(z) for \
                 the dense matrix",
            )
        })?;
        let mut values = vec![0.0; pattern.len()];
        self.h
            .hessian_nonzeros_slice(z, &mut values)
            .map_err(Self::evaluation)?;
        let rows: Vec<usize> = pattern.iter().map(|&(i, _)| i).collect();
        let cols: Vec<usize> = pattern.iter().map(|&(_, j)| j).collect();
        pyo3::types::PyTuple::new(
            py,
            [
                rows.into_pyarray(py).into_any(),
                cols.into_pyarray(py).into_any(),
                values.into_pyarray(py).into_any(),
            ],
        )
    }

    /// Its text and current parameters, to compile copies from (one per thread of an
    /// ensemble whose members have their own parameters).
    pub fn source(&self) -> Source {
        Source {
            text: self.text.clone(),
            params: self
                .h
                .parameters()
                .map(|(n, v)| (n.to_string(), v))
                .collect(),
        }
    }

    /// An evaluation error (a non-finite value, a state outside the domain) as `ValueError`.
    fn evaluation(e: dth::runtime::RuntimeError) -> PyErr {
        PyValueError::new_err(e.to_string())
    }
}

#[pymethods]
impl Hamiltonian {
    #[new]
    #[pyo3(signature = (text, params = None))]
    fn new(py: Python<'_>, text: &str, params: Option<BTreeMap<String, f64>>) -> PyResult<Self> {
        Self::build(py, text, params)
    }

    /// `text` as the twin of the catalogue system `system` (what `dth.systems` builds): it
    /// then has that system's period, exact solution and central force, when the text has the
    /// system's dimension (a lattice or an N-body text of another size is a plain text).
    /// `dth.systems`' tests hold each text to its system, to the bit.
    #[staticmethod]
    #[pyo3(name = "_catalogue_twin", signature = (system, text, params = None))]
    fn catalogue_twin(
        py: Python<'_>,
        system: &str,
        text: &str,
        params: Option<BTreeMap<String, f64>>,
    ) -> PyResult<Self> {
        let mut h = Self::build(py, text, params)?;
        let dim = crate::catalogue::dimension(system)
            .ok_or_else(|| PyValueError::new_err(format!("no catalogue system `{system}`")))?;
        if h.h.dimension() == dim {
            h.catalogue = Some(system.to_string());
        }
        Ok(h)
    }

    /// The catalogue system this is the text of (`dth.systems`), or None: a text of that
    /// system's size, for which `orbits=`, `"exact"` and `"discrete_mechanics"` use the
    /// system's period, exact solution and central force.
    #[getter]
    fn system(&self) -> Option<&str> {
        self.catalogue()
    }

    /// The dimension D = 2n of the state z = (q1..qn, p1..pn).
    #[getter]
    fn dim(&self) -> usize {
        self.h.dimension()
    }

    /// The text it was built from.
    #[getter]
    pub(crate) fn text(&self) -> &str {
        &self.text
    }

    /// What the engine found: `separable` (H = T(p) + V(q)), `time_dependent` (uses `t`),
    /// `regularized`, `psi_identically_zero` (DTH's Psi vanishes everywhere, so DTH cannot
    /// run), `structured_newton` (Newton uses the Hessian's sparsity), and `backend`
    /// ("jit" or "interpreter").
    #[getter]
    fn flags<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        d.set_item("separable", self.h.separable())?;
        d.set_item("time_dependent", self.h.time_dependent())?;
        d.set_item("regularized", self.h.regularized())?;
        d.set_item("psi_identically_zero", self.h.psi_identically_zero())?;
        d.set_item("structured_newton", self.h.structured_newton())?;
        let backend = match self.h.backend() {
            Backend::Jit => "jit",
            _ => "interpreter",
        };
        d.set_item("backend", backend)?;
        Ok(d)
    }

    /// The parameters and their values, as a new dict (change one with `set_parameter`).
    #[getter]
    fn params<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        for (name, value) in self.h.parameters() {
            d.set_item(name, value)?;
        }
        Ok(d)
    }

    /// The engine's warnings about the text (a term that cancels, a sum that does not loop).
    #[getter]
    fn warnings(&self) -> Vec<String> {
        self.h.warnings().iter().map(|w| w.to_string()).collect()
    }

    /// Sets parameter `name` to `value` (no recompilation). Raises `HamiltonianError` for a
    /// name the text does not use or a value that is not finite.
    fn set_parameter(&mut self, py: Python<'_>, name: &str, value: f64) -> PyResult<()> {
        // A run holds a view only while it runs, and a run holds this object borrowed.
        let h = Arc::get_mut(&mut self.h).ok_or_else(|| {
            pyo3::exceptions::PyRuntimeError::new_err(
                "the Hamiltonian is in use by a running integration",
            )
        })?;
        h.set_parameter(name, value)
            .map_err(|e| hamiltonian_error(py, &self.text, &e))
    }

    /// H(z).
    fn value(&self, z: &Bound<'_, PyAny>) -> PyResult<f64> {
        let z = self.state(z)?;
        self.h.value_slice(&z).map_err(Self::evaluation)
    }

    /// The gradient dH/dz at z, an array of shape (D,).
    fn gradient<'py>(
        &self,
        py: Python<'py>,
        z: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let z = self.state(z)?;
        let mut g = vec![0.0; z.len()];
        self.h
            .gradient_slice(&z, &mut g)
            .map_err(Self::evaluation)?;
        Ok(g.into_pyarray(py))
    }

    /// The Hessian d2H/dz2 at z: a dense array of shape (D, D), or with `sparse=True` its
    /// structural nonzeros as `(rows, cols, values)`, three arrays over the upper triangle and
    /// diagonal (i <= j) in the order of `hessian_pattern()` (the engine's own sparse
    /// evaluation, without the dense matrix: what a lattice of thousands of sites wants).
    /// `sparse=True` on a Hamiltonian without a pattern (a small system, treated as dense)
    /// raises ValueError.
    #[pyo3(signature = (z, sparse = false))]
    fn hessian<'py>(
        &self,
        py: Python<'py>,
        z: &Bound<'py, PyAny>,
        sparse: bool,
    ) -> PyResult<Bound<'py, PyAny>> {
        let z = self.state(z)?;
        if sparse {
            return self.sparse_hessian(py, &z).map(|t| t.into_any());
        }
        let d = z.len();
        let mut m = vec![0.0; d * d];
        self.h.hessian_slice(&z, &mut m).map_err(Self::evaluation)?;
        // Symmetric, so the storage order does not matter.
        let array =
            Array2::from_shape_vec((d, d), m).map_err(|e| PyValueError::new_err(e.to_string()))?;
        Ok(array.into_pyarray(py).into_any())
    }

    /// The Hessian's structural nonzeros as `(rows, cols)`, two int arrays over the upper
    /// triangle and diagonal (i <= j), or None when the engine gives no pattern (a small
    /// system, treated as dense).
    fn hessian_pattern<'py>(&self, py: Python<'py>) -> Option<(Indices<'py>, Indices<'py>)> {
        let pattern = self.h.hessian_pattern()?;
        let rows: Vec<usize> = pattern.iter().map(|&(i, _)| i).collect();
        let cols: Vec<usize> = pattern.iter().map(|&(_, j)| j).collect();
        Some((rows.into_pyarray(py), cols.into_pyarray(py)))
    }

    /// Psi(z) = (J grad H)^T Hess H (J grad H): DTH needs it to keep its sign along an orbit.
    fn psi(&self, z: &Bound<'_, PyAny>) -> PyResult<f64> {
        let z = self.state(z)?;
        self.h.psi_slice(&z).map_err(Self::evaluation)
    }

    /// What the engine derives from the text, as the `dth derive` command prints it: the
    /// simplified H, its flags, gradient, Hessian and Psi.
    fn derive(&self) -> PyResult<String> {
        let names: Vec<String> = self.h.parameters().map(|(n, _)| n.to_string()).collect();
        let names: Vec<&str> = names.iter().map(String::as_str).collect();
        dth_examples::derive::derive(&self.text, &names).map_err(|e| match e {
            dth_examples::Error::Hamiltonian { .. } => {
                crate::errors::HamiltonianError::new_err(e.to_string())
            }
            other => pyo3::exceptions::PyRuntimeError::new_err(other.to_string()),
        })
    }

    fn __repr__(&self) -> String {
        let params: Vec<String> = self
            .h
            .parameters()
            .map(|(n, v)| format!("{n:?}: {v:?}"))
            .collect();
        if params.is_empty() {
            format!("Hamiltonian({:?})", self.text)
        } else {
            format!(
                "Hamiltonian({:?}, params={{{}}})",
                self.text,
                params.join(", ")
            )
        }
    }
}
