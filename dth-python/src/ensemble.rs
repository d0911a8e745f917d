//! `dth.ensemble`: many initial states integrated with one method, members spread over the
//! cores (rayon), without the GIL and interruptible; each member's result is independent of
//! the thread count (a member is one `dth::solve` run, computed whole by one thread).

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

use numpy::ndarray::Array2;
use numpy::{IntoPyArray, PyArray1, PyArray2, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::exceptions::{PyRuntimeError, PyTypeError, PyValueError};
use pyo3::prelude::*;
use rayon::prelude::*;

use dth::nalgebra::{DVector, DefaultAllocator, Dim, OVector, SVector};
use dth::observer::StepRecord;
use dth::runtime::{Fixed, RuntimeHamiltonian};
use dth::{solve, Alloc, Method};

use crate::args::{self, End};
use crate::hamiltonian::Hamiltonian;

/// The result of `dth.ensemble`, one row per member (in the order of `z0s`).
///
/// Attributes:
///   final: the last state each member reached, shape (M, D) (DTH: its last midpoint).
///   t_end: its time, shape (M,).
///   energy_error: the largest |H(z) - H(z0)| over the member's steps, shape (M,).
///   steps: steps taken, shape (M,); fallback_steps: robust-mode fallback steps among them.
///   failure: per member, None or what stopped it (its row is then where it stopped).
///   failed: the number of members that did not reach their end.
#[pyclass(module = "dth", name = "Ensemble", frozen)]
pub struct Ensemble {
    #[pyo3(get)]
    r#final: Py<PyArray2<f64>>,
    #[pyo3(get)]
    t_end: Py<PyArray1<f64>>,
    #[pyo3(get)]
    energy_error: Py<PyArray1<f64>>,
    #[pyo3(get)]
    steps: Py<PyArray1<usize>>,
    #[pyo3(get)]
    fallback_steps: Py<PyArray1<usize>>,
    #[pyo3(get)]
    failure: Vec<Option<String>>,
}

#[pymethods]
impl Ensemble {
    /// The number of members that did not reach their end.
    #[getter]
    fn failed(&self) -> usize {
        self.failure.iter().filter(|f| f.is_some()).count()
    }

    fn __len__(&self) -> usize {
        self.failure.len()
    }

    fn __repr__(&self) -> String {
        format!(
            "Ensemble(members={}, failed={})",
            self.failure.len(),
            self.failed()
        )
    }
}

/// One member's outcome.
struct Member {
    last: Vec<f64>,
    t: f64,
    energy_error: f64,
    steps: usize,
    fallback_steps: usize,
    failure: Option<String>,
}

/// What every member shares.
struct Plan<'a> {
    method: Method,
    end: End,
    t0: f64,
    max_steps: Option<usize>,
    flag: &'a AtomicBool,
}

/// Runs one member: the largest energy error over every step, observed as it goes (nothing
/// but the last state is kept).
fn member<D: Dim, H: dth::Hamiltonian<D>>(h: &H, z0: OVector<f64, D>, plan: &Plan<'_>) -> Member
where
    DefaultAllocator: Alloc<D>,
{
    let (method, end, t0, max_steps, flag) =
        (&plan.method, &plan.end, plan.t0, plan.max_steps, plan.flag);
    let dim = z0.len();
    let h0 = h.value(&z0);
    let mut worst = 0.0f64;
    let observe = |r: &StepRecord<D>| {
        worst = worst.max((h.value(&r.z) - h0).abs());
    };
    let mut run = solve(h, z0, *method)
        .start_time(t0)
        .save_every(usize::MAX)
        .without_energy_errors()
        .interrupt(flag)
        .observe(observe);
    run = match end {
        End::Steps(n) => run.steps(*n),
        End::Time(t) => run.until(*t),
    };
    if let Some(n) = max_steps {
        run = run.max_steps(n);
    }
    let (solution, failure) = match run.run() {
        Ok(s) => (s, None),
        Err(e) => (e.partial, Some(e.error.to_string())),
    };
    let failure = failure.or_else(|| solution.failure.as_ref().map(|e| e.to_string()));
    let (last, t) = match (solution.z.last(), solution.t.last()) {
        (Some(z), Some(&t)) => (z.iter().copied().collect(), t),
        _ => (vec![f64::NAN; dim], f64::NAN),
    };
    Member {
        last,
        t,
        energy_error: worst,
        steps: solution.steps,
        fallback_steps: solution.fallback_steps,
        failure,
    }
}

/// Every member at `Const<N>` through [`dth::runtime::Fixed`].
fn fixed<const N: usize>(
    h: &Arc<RuntimeHamiltonian>,
    starts: Vec<DVector<f64>>,
    plan: &Plan<'_>,
) -> PyResult<Vec<Member>> {
    let view =
        Fixed::<N>::new(Arc::clone(h)).map_err(|e| PyRuntimeError::new_err(e.to_string()))?;
    let starts = starts
        .iter()
        .map(|z| SVector::<f64, N>::from_column_slice(z.as_slice()))
        .collect();
    all(&view, starts, plan)
}

/// Every member, on the current thread pool.
fn all<D: Dim, H: dth::Hamiltonian<D> + Sync>(
    h: &H,
    starts: Vec<OVector<f64, D>>,
    plan: &Plan<'_>,
) -> PyResult<Vec<Member>>
where
    DefaultAllocator: Alloc<D>,
    OVector<f64, D>: Send,
{
    Ok(starts
        .into_par_iter()
        .map(|z0| {
            if plan.flag.load(Ordering::Relaxed) {
                return Member {
                    last: z0.iter().copied().collect(),
                    t: plan.t0,
                    energy_error: 0.0,
                    steps: 0,
                    fallback_steps: 0,
                    failure: Some("interrupted before it started".to_string()),
                };
            }
            member(h, z0, plan)
        })
        .collect())
}

/// Integrates every row of `z0s` with the same method and returns an `Ensemble` (the final
/// states, their times, energy errors, steps and failures, one row per member).
///
/// ensemble(h, z0s, method="dth", *, dtau=None, dt=None, order=None, robust=None,
///          lambda0=None, steps=None, t_end=None, t0=0.0, max_steps=None, threads=None)
///
/// Arguments are those of `integrate`, with:
///   z0s: the initial states, an (M, D) array (for a time-dependent H also (M, D - 2): the
///     physical states, each extended with t0 and p_t = -H).
///   threads: worker threads (default: every core). The results are the same for any
///     number: each member is computed whole by one thread.
///
/// A member that fails does not stop the others: its `failure` says why and its row holds
/// the last state it reached. Ctrl-C stops the whole ensemble with KeyboardInterrupt.
///
/// >>> import dth, numpy as np
/// >>> h = dth.Hamiltonian("p1^2/2 + q1^2/2")
/// >>> e = dth.ensemble(h, np.array([[1.0, 0.0], [0.0, 2.0]]), dtau=0.1, t_end=5.0)
/// >>> e.final.shape, e.failed
/// ((2, 2), 0)
#[pyfunction]
#[pyo3(signature = (
    h, z0s, method = "dth", *, dtau = None, dt = None, order = None, robust = None,
    lambda0 = None, steps = None, t_end = None, t0 = 0.0, max_steps = None, threads = None
))]
#[allow(clippy::too_many_arguments)]
pub fn ensemble(
    py: Python<'_>,
    h: PyRef<'_, Hamiltonian>,
    z0s: &Bound<'_, PyAny>,
    method: &str,
    dtau: Option<f64>,
    dt: Option<f64>,
    order: Option<u32>,
    robust: Option<bool>,
    lambda0: Option<f64>,
    steps: Option<usize>,
    t_end: Option<f64>,
    t0: f64,
    max_steps: Option<usize>,
    threads: Option<usize>,
) -> PyResult<Ensemble> {
    let dim = h.h.dimension();
    let method = args::method(method, dtau, dt, order, robust, lambda0)?;
    let end = args::end(steps, t_end)?;
    let starts = states(&h, z0s, t0)?;
    let pool = {
        let mut builder = rayon::ThreadPoolBuilder::new();
        if let Some(n) = threads {
            if n == 0 {
                return Err(PyValueError::new_err("threads must be at least 1"));
            }
            builder = builder.num_threads(n);
        }
        builder
            .build()
            .map_err(|e| PyRuntimeError::new_err(format!("cannot start the threads: {e}")))?
    };
    let flag = AtomicBool::new(false);
    let plan = Plan {
        method,
        end,
        t0,
        max_steps,
        flag: &flag,
    };
    // Small states at a fixed size, as `integrate` and the scene runner run them.
    let shared: &Arc<RuntimeHamiltonian> = &h.h;
    let members: Vec<Member> = crate::interrupt::run(py, &flag, || {
        pool.install(|| match dim {
            2 => fixed::<2>(shared, starts, &plan),
            4 => fixed::<4>(shared, starts, &plan),
            _ => all(&**shared, starts, &plan),
        })
    })??;
    let m = members.len();
    let flat: Vec<f64> = members
        .iter()
        .flat_map(|r| r.last.iter().copied())
        .collect();
    let finals = Array2::from_shape_vec((m, dim), flat)
        .map_err(|e| PyRuntimeError::new_err(e.to_string()))?;
    fn column<T: numpy::Element>(
        py: Python<'_>,
        members: &[Member],
        f: impl Fn(&Member) -> T,
    ) -> Py<PyArray1<T>> {
        members
            .iter()
            .map(f)
            .collect::<Vec<T>>()
            .into_pyarray(py)
            .unbind()
    }
    Ok(Ensemble {
        r#final: finals.into_pyarray(py).unbind(),
        t_end: column(py, &members, |r| r.t),
        energy_error: column(py, &members, |r| r.energy_error),
        steps: column(py, &members, |r| r.steps),
        fallback_steps: column(py, &members, |r| r.fallback_steps),
        failure: members.into_iter().map(|r| r.failure).collect(),
    })
}

/// The rows of `z0s` as initial states.
fn states(h: &Hamiltonian, z0s: &Bound<'_, PyAny>, t0: f64) -> PyResult<Vec<DVector<f64>>> {
    let dim = h.h.dimension();
    let converted = z0s
        .py()
        .import("numpy")?
        .call_method1("asarray", (z0s, "float64"))
        .map_err(|_| PyTypeError::new_err("z0s must be an (M, D) array of floats"))?;
    let array = converted
        .extract::<PyReadonlyArray2<'_, f64>>()
        .map_err(|_| {
            let shape = converted
                .getattr("shape")
                .map(|s| s.to_string())
                .unwrap_or_default();
            PyValueError::new_err(format!(
                "z0s has shape {shape}, expected (M, {dim}): one initial state per row"
            ))
        })?;
    let view = array.as_array();
    (0..array.shape()[0])
        .map(|i| args::start_from(h, view.row(i).to_vec(), &format!("z0s[{i}]"), t0))
        .collect()
}
