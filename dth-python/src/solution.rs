//! `dth.Solution`: a run's saved states as numpy arrays, with what the run spent and how it
//! ended.

use numpy::ndarray::Array2;
use numpy::{IntoPyArray, PyArray1, PyArray2};
use pyo3::prelude::*;

use dth::nalgebra::{DefaultAllocator, Dim, OVector};
use dth::observer::StepKind;
use dth::Alloc;

use crate::regularized::Physical;

/// The result of `dth.integrate`: the saved states and their times (for DTH, the midpoints
/// zbar_k at the midpoint times, where H(zbar_k) = H(zbar_0) to roundoff), what produced each
/// state, the energy errors, and DTH's own series.
///
/// Attributes:
///   method: the method's name.
///   t: times, shape (M,).
///   z: states, shape (M, D) (DTH: the midpoints).
///   k: step index of each saved state, shape (M,).
///   kinds: what produced each state, a list of "initial", "fixed" (a fixed-step method),
///     "dth", "fallback" (a robust-mode fallback step) or "shortened" (the last DTH step,
///     shortened to land on t_end).
///   energy_error: H(z) - H(z0) at each saved state, shape (M,).
///   energy0: H(z0).
///   lam: DTH's multipliers lambda_k = dt/dtau, shape (M,); None for other methods.
///   vertices: DTH's left vertices z^(k), shape (M, D); None for other methods.
///   vertex_t: their times, shape (M,); None for other methods.
///   psi: Psi(zbar_k), shape (M,); None for other methods (in a run with `regularize`, the
///     regularized K's Psi, the one whose sign DTH needs; every other array is physical).
///   steps: steps taken (saved or not); fallback_steps: robust-mode fallback steps among them;
///   newton_iterations: over all steps.
///   failure: None for a run that reached its end, else what stopped it (the arrays hold the
///     states up to the last accepted step); completed: failure is None.
///   events: the events that fired (`events=`), in order: (name, t, z) with z the state there.
///   stopped: the name of the event that ended the run (`stop_on=`), or None.
#[pyclass(module = "dth", name = "Solution", frozen)]
pub struct Solution {
    #[pyo3(get)]
    method: &'static str,
    #[pyo3(get)]
    t: Py<PyArray1<f64>>,
    #[pyo3(get)]
    z: Py<PyArray2<f64>>,
    #[pyo3(get)]
    k: Py<PyArray1<usize>>,
    #[pyo3(get)]
    kinds: Vec<&'static str>,
    #[pyo3(get)]
    energy_error: Py<PyArray1<f64>>,
    #[pyo3(get)]
    energy0: f64,
    #[pyo3(get)]
    lam: Option<Py<PyArray1<f64>>>,
    #[pyo3(get)]
    vertices: Option<Py<PyArray2<f64>>>,
    #[pyo3(get)]
    vertex_t: Option<Py<PyArray1<f64>>>,
    #[pyo3(get)]
    psi: Option<Py<PyArray1<f64>>>,
    #[pyo3(get)]
    steps: usize,
    #[pyo3(get)]
    fallback_steps: usize,
    #[pyo3(get)]
    newton_iterations: u64,
    #[pyo3(get)]
    failure: Option<String>,
    #[pyo3(get)]
    events: Vec<(String, f64, Py<PyArray1<f64>>)>,
    #[pyo3(get)]
    stopped: Option<String>,
    /// The failure's variant name (`NewtonDiverged`, `Breakdown`, `Interrupted`, ...).
    pub(crate) failure_kind: Option<String>,
}

/// The width of a saved state and how a state becomes it: the state itself, or its physical
/// `(q, p)` in a regularized run.
type Rows<'a> = (usize, &'a dyn Fn(&[f64]) -> Vec<f64>);

/// States as an (M, dim) array, each through `row` ([`Rows`]).
fn matrix<'py, D: Dim>(
    py: Python<'py>,
    states: &[OVector<f64, D>],
    (dim, row): Rows<'_>,
) -> Bound<'py, PyArray2<f64>>
where
    DefaultAllocator: Alloc<D>,
{
    let flat: Vec<f64> = states.iter().flat_map(|z| row(z.as_slice())).collect();
    // The length is M * dim by construction.
    Array2::from_shape_vec((states.len(), dim), flat)
        .unwrap_or_else(|_| Array2::zeros((0, dim)))
        .into_pyarray(py)
}

fn kind_name(kind: StepKind, k: usize) -> &'static str {
    match kind {
        _ if k == 0 => "initial",
        StepKind::Fixed => "fixed",
        StepKind::Dth => "dth",
        StepKind::Fallback => "fallback",
        StepKind::Shortened => "shortened",
        _ => "other",
    }
}

/// The name of an error's variant, from its `Debug` form (`NewtonDiverged { .. }`).
fn variant(e: &dth::Error) -> String {
    let debug = format!("{e:?}");
    debug
        .split(|c: char| !c.is_alphanumeric() && c != '_')
        .next()
        .unwrap_or("Error")
        .to_string()
}

impl Solution {
    /// From the driver's solution of a system of dimension `dim` whose events (`events=`) are
    /// named `names`, in the order watched; for a run on a regularized `K` (`physical`), every
    /// state in physical coordinates, `lam` the physical `dt/dtau` and the energy errors
    /// those of `H` (see `crate::regularized`).
    pub fn new<D: Dim>(
        py: Python<'_>,
        mut s: dth::Solution<D>,
        (dim, physical): (usize, Option<&Physical>),
        names: &[String],
    ) -> Solution
    where
        DefaultAllocator: Alloc<D>,
    {
        let identity = |z: &[f64]| z.to_vec();
        let state = |z: &[f64]| physical.map_or_else(|| z.to_vec(), |p| p.state(z));
        let rows: Rows<'_> = match physical {
            Some(p) => (p.dim(), &state),
            None => (dim, &identity),
        };
        if let Some(p) = physical {
            if !s.energy_error.is_empty() {
                s.energy_error = s.z.iter().map(|w| p.energy_error(w.as_slice())).collect();
                s.energy0 = p.energy0();
            }
            if let Some(series) = &mut s.dth {
                for (lambda, w) in series.lambda.iter_mut().zip(&s.z) {
                    *lambda *= p.time_rate(w.as_slice());
                }
            }
        }
        let kinds = s
            .kinds
            .iter()
            .zip(&s.k)
            .map(|(&kind, &k)| kind_name(kind, k))
            .collect();
        let (lam, vertices, vertex_t, psi) = match s.dth {
            Some(series) => (
                Some(series.lambda.into_pyarray(py).unbind()),
                Some(matrix(py, &series.vertex, rows).unbind()),
                Some(series.vertex_time.into_pyarray(py).unbind()),
                Some(series.psi.into_pyarray(py).unbind()),
            ),
            None => (None, None, None, None),
        };
        let name = |i: usize| names.get(i).cloned().unwrap_or_default();
        let events = s
            .events
            .iter()
            .map(|f| {
                let z: Vec<f64> = (rows.1)(f.z.as_slice());
                (name(f.event), f.t, z.into_pyarray(py).unbind())
            })
            .collect();
        Solution {
            method: s.method,
            events,
            stopped: s.stopped.map(name),
            z: matrix(py, &s.z, rows).unbind(),
            t: s.t.into_pyarray(py).unbind(),
            k: s.k.into_pyarray(py).unbind(),
            kinds,
            energy_error: s.energy_error.into_pyarray(py).unbind(),
            energy0: s.energy0,
            lam,
            vertices,
            vertex_t,
            psi,
            steps: s.steps,
            fallback_steps: s.fallback_steps,
            newton_iterations: s.newton_iterations,
            failure_kind: s.failure.as_ref().map(variant),
            failure: s.failure.map(|e| e.to_string()),
        }
    }
}

#[pymethods]
impl Solution {
    /// True when the run reached its end (`failure` is None).
    #[getter]
    fn completed(&self) -> bool {
        self.failure.is_none()
    }

    /// The failure's kind (`"NewtonDiverged"`, `"Breakdown"`, `"Interrupted"`, ...), or None.
    #[getter]
    fn failure_kind(&self) -> Option<&str> {
        self.failure_kind.as_deref()
    }

    fn __len__(&self) -> usize {
        self.kinds.len()
    }

    fn __repr__(&self) -> String {
        let end = match &self.failure {
            None => "completed".to_string(),
            Some(f) => format!("failed: {f}"),
        };
        format!(
            "Solution(method={:?}, saved={}, steps={}, fallback_steps={}, {end})",
            self.method,
            self.kinds.len(),
            self.steps,
            self.fallback_steps
        )
    }
}

impl Solution {
    /// What stopped the run ("" for a completed run).
    pub fn failure_message(&self) -> &str {
        self.failure.as_deref().unwrap_or("")
    }
}
