//! `dth.ensemble`: many initial states (or parameter values) integrated with one method,
//! members spread over the cores (rayon), without the GIL and interruptible; each member's
//! result is independent of the thread count (a member is one `dth::solve` run, computed
//! whole by one thread, its chaos indicators by the scene ensembles' own observer,
//! `dth_examples::ensemble::chaos::Megno`).

use std::collections::BTreeMap;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

use numpy::ndarray::Array2;
use numpy::{IntoPyArray, PyArray1, PyArray2, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::exceptions::{PyRuntimeError, PyTypeError, PyValueError};
use pyo3::prelude::*;
use rayon::prelude::*;

use dth::nalgebra::{DVector, DefaultAllocator, Dim, OVector};
use dth::observer::{Observer, StepRecord};
use dth::runtime::RuntimeHamiltonian;
use dth::solve::Integrator;
use dth::{solve, Alloc};
use dth_examples::ensemble::chaos::{Indicators, Megno};

use crate::args::{self, Chosen, End};
use crate::catalogue::Special;
use crate::hamiltonian::{Hamiltonian, Source};
use crate::regularized::Physical;
use crate::sized::{self, Job};

/// The result of `dth.ensemble`, one row per member (in the order of `z0s`, or of the
/// parameter values).
///
/// Attributes:
///   final: the last state each member reached, shape (M, D) (DTH: its last midpoint).
///   t_end: its time, shape (M,).
///   energy_error: the largest |H(z) - H(z0)| over the member's steps, shape (M,).
///   steps: steps taken, shape (M,); fallback_steps: robust-mode fallback steps among them.
///   failure: per member, None or what stopped it (its row is then where it stopped).
///   failed: the number of members that did not reach their end.
///   megno: with megno=True (or lyapunov=True), MEGNO's running mean `<Y>` at the end, shape
///     (M,): about 2 on a regular (quasi-periodic) orbit, growing like lambda t / 2 on a
///     chaotic one; NaN where no time passed or the variational equations broke down.
///     None when not asked.
///   lyapunov: likewise, Benettin's estimate ln|delta(t)| / t of the maximal Lyapunov
///     exponent, shape (M,).
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
    #[pyo3(get)]
    megno: Option<Py<PyArray1<f64>>>,
    #[pyo3(get)]
    lyapunov: Option<Py<PyArray1<f64>>>,
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
    /// MEGNO and the Lyapunov estimate, when asked and computed.
    indicators: Option<Indicators>,
}

/// What every member shares.
struct Plan<'a> {
    t0: f64,
    max_steps: Option<usize>,
    flag: &'a AtomicBool,
    /// Compute MEGNO and the Lyapunov estimate.
    chaos: bool,
    /// The length of a reported state (physical).
    dim: usize,
}

/// One member to run: its initial state, its end and (a parameter grid) its parameters.
struct Start {
    /// The state the method starts from (regularized: `K`'s, from the physical row).
    z0: DVector<f64>,
    end: End,
    params: Vec<(String, f64)>,
    /// Regularized: the physical row's `H(z0)`, which the energy errors are measured from.
    energy0: f64,
}

/// One member's run, as a [`Job`]: the largest energy error over every step, observed as it
/// goes (nothing but the last state is kept), and the chaos indicators when asked.
struct Run<'a> {
    start: &'a Start,
    plan: &'a Plan<'a>,
    /// `regularize=`: the member runs DTH on this `K` (with its parameters) and reports the
    /// physical `(q, p)`, time and energy error.
    physical: Option<&'a Physical>,
}

impl Job for Run<'_> {
    type Output = Member;

    fn run<D, H, I, S>(self, h: &H, method: I, state: S) -> Member
    where
        D: Dim,
        H: dth::Hamiltonian<D> + Sync,
        I: Integrator<D, H> + Clone + Send + Sync,
        S: Fn(&DVector<f64>) -> OVector<f64, D> + Sync,
        DefaultAllocator: Alloc<D>,
        OVector<f64, D>: Send,
        dth::Solution<D>: Send,
    {
        let plan = self.plan;
        let z0 = state(&self.start.z0);
        // The energy the errors are measured from: the physical row's (regularized), or `h`'s.
        let h0 = match self.physical {
            Some(_) => self.start.energy0,
            None => h.value(&z0),
        };
        let mut worst = 0.0f64;
        let mut megno = plan.chaos.then(|| Megno::new(h));
        let observe = |r: &StepRecord<D>| {
            let error = match self.physical {
                Some(p) => p.energy_error_from(r.z.as_slice(), h0),
                None => h.value(&r.z) - h0,
            };
            worst = worst.max(error.abs());
            if let Some(m) = megno.as_mut() {
                m.on_step(r);
            }
        };
        let mut run = solve(h, z0, method)
            .start_time(plan.t0)
            .save_every(usize::MAX)
            .without_energy_errors()
            .interrupt(plan.flag)
            .observe(observe);
        run = self.start.end.apply(run);
        if let Some(n) = plan.max_steps {
            run = run.max_steps(n);
        }
        let (solution, failure) = match run.run() {
            Ok(s) => (s, None),
            Err(e) => (e.partial, Some(e.error.to_string())),
        };
        let failure = failure.or_else(|| solution.failure.as_ref().map(|e| e.to_string()));
        let (last, t) = match (solution.z.last(), solution.t.last(), self.physical) {
            // (A regularized run's midpoint times are its `t` coordinate: physical.)
            (Some(w), Some(&t), Some(p)) => (p.state(w.as_slice()), t),
            (Some(z), Some(&t), None) => (z.iter().copied().collect(), t),
            _ => (vec![f64::NAN; plan.dim], f64::NAN),
        };
        Member {
            last,
            t,
            energy_error: worst,
            steps: solution.steps,
            fallback_steps: solution.fallback_steps,
            failure,
            indicators: megno.as_ref().and_then(Megno::indicators),
        }
    }
}

/// A member that did not start: Ctrl-C came first.
fn not_started(start: &Start, plan: &Plan<'_>, physical: Option<&Physical>) -> Member {
    let last = match physical {
        Some(p) => p.state(start.z0.as_slice()),
        None => start.z0.iter().copied().collect(),
    };
    Member {
        last,
        t: plan.t0,
        energy_error: 0.0,
        steps: 0,
        fallback_steps: 0,
        failure: Some("interrupted before it started".to_string()),
        indicators: None,
    }
}

/// A thread's own copy of what its members run on (a parameter grid's: each member sets its
/// parameters on it): the Hamiltonian, or the regularization (its `K` and physical `H`).
enum ThreadCopy {
    Plain(Arc<RuntimeHamiltonian>),
    Regularized(Box<Physical>),
}

impl ThreadCopy {
    /// Compiled from `source`, regularized as `physical` is when given.
    fn new(source: &Source, physical: Option<&Physical>) -> PyResult<Self> {
        let h = source.compile()?;
        Ok(match physical {
            Some(p) => ThreadCopy::Regularized(Box::new(p.copy_for(h)?)),
            None => ThreadCopy::Plain(Arc::new(h)),
        })
    }

    /// Sets parameter `name` (of `K` too, regularized).
    fn set_parameter(&mut self, name: &str, value: f64) -> PyResult<()> {
        match self {
            ThreadCopy::Plain(h) => Arc::get_mut(h)
                .ok_or_else(|| {
                    PyRuntimeError::new_err("internal error: a member's Hamiltonian is shared")
                })?
                .set_parameter(name, value)
                .map_err(|e| PyValueError::new_err(e.to_string())),
            ThreadCopy::Regularized(p) => p.set_parameter(name, value),
        }
    }

    /// What [`member`] runs on.
    fn run_on(&self) -> (&Arc<RuntimeHamiltonian>, Option<&Physical>) {
        match self {
            ThreadCopy::Plain(h) => (h, None),
            ThreadCopy::Regularized(p) => (p.hamiltonian(), Some(p)),
        }
    }
}

/// Runs one member on `h` (with its parameters set), or on the regularized `K` of
/// `physical` (likewise), with the method chosen.
fn member(
    (h, physical): (&Arc<RuntimeHamiltonian>, Option<&Physical>),
    catalogue: Option<&str>,
    chosen: Chosen,
    start: &Start,
    plan: &Plan<'_>,
) -> PyResult<Member> {
    if plan.flag.load(Ordering::Relaxed) {
        return Ok(not_started(start, plan, physical));
    }
    let job = Run {
        start,
        plan,
        physical,
    };
    if let (Some(p), Chosen::Method(method)) = (physical, chosen) {
        // K's dimension (6 or 10) runs at `Dyn`; `Physical::read` accepts method "dth" only.
        return Ok(job.run(p.k(), method, DVector::clone));
    }
    match chosen {
        Chosen::Method(method) => sized::dispatch(h, method, job),
        Chosen::Special(special, dt) => crate::catalogue::dispatch(catalogue, h, special, dt, job),
    }
}

/// Integrates every row of `z0s` (or every value of a parameter grid) with the same method
/// and returns an `Ensemble` (the final states, their times, energy errors, steps, failures
/// and, when asked, MEGNO and the Lyapunov estimate, one row per member).
///
/// ensemble(h, z0s, method="dth", *, dtau=None, dt=None, order=None, robust=None,
///          lambda0=None, steps=None, t_end=None, orbits=None, t0=0.0, max_steps=None,
///          threads=None, params=None, megno=False, lyapunov=False, regularize=None,
///          centre=None)
///
/// Arguments are those of `integrate`, with:
///   z0s: the initial states, an (M, D) array (for a time-dependent H also (M, D - 2): the
///     physical states, each extended with t0 and p_t = -H). With `params`, also one state
///     (D,) that every member starts from.
///   params: a parameter grid, a dict from parameter names to 1-D arrays of M values each:
///     member i has the parameters `{name: values[i]}` (the others are h's). One member per
///     value: for a grid over two parameters, give the pairs, e.g. from
///     `np.meshgrid(a, b)` raveled. With an (M, D) z0s, member i starts from row i.
///   orbits: as in `integrate`, from each member's own state and parameters.
///   threads: worker threads (default: every core). The results are the same for any
///     number: each member is computed whole by one thread.
///   megno, lyapunov: compute the chaos indicators MEGNO `<Y>` and Benettin's Lyapunov
///     estimate from the variational equations along each member's run (the scene
///     ensembles' own observer: the tangent vector carried by the trapezoidal rule from
///     state to state with the exact Hessian); either one fills both `megno` and `lyapunov`.
///   regularize, centre: as in `integrate` (method "dth" only): every member runs DTH on the
///     regularized K, from its physical row; `final`, `t_end` and `energy_error` are
///     physical ((q, p), the time, |H - H(z0)|), `steps` are K's; with `params`, K has each
///     member's. Not with megno/lyapunov (the variational equations would run in K's
///     fictitious time).
///
/// A member that fails does not stop the others: its `failure` says why and its row holds
/// the last state it reached. Ctrl-C stops the whole ensemble with KeyboardInterrupt.
///
/// >>> import dth, numpy as np
/// >>> h = dth.Hamiltonian("p1^2/2 + q1^2/2")
/// >>> e = dth.ensemble(h, np.array([[1.0, 0.0], [0.0, 2.0]]), dtau=0.1, t_end=5.0)
/// >>> e.final.shape, e.failed
/// ((2, 2), 0)
/// >>> spring = dth.Hamiltonian("p1^2/2 + k*q1^2/2", params={"k": 1.0})
/// >>> g = dth.ensemble(spring, [1.0, 0.0], params={"k": np.linspace(1, 4, 4)}, dtau=0.1,
/// ...                  steps=10)
/// >>> g.final.shape
/// (4, 2)
#[pyfunction]
#[pyo3(signature = (
    h, z0s, method = "dth", *, dtau = None, dt = None, order = None, robust = None,
    lambda0 = None, steps = None, t_end = None, orbits = None, t0 = 0.0, max_steps = None,
    threads = None, params = None, megno = false, lyapunov = false, regularize = None,
    centre = None
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
    orbits: Option<f64>,
    t0: f64,
    max_steps: Option<usize>,
    threads: Option<usize>,
    params: Option<BTreeMap<String, Vec<f64>>>,
    megno: bool,
    lyapunov: bool,
    regularize: Option<&str>,
    centre: Option<Vec<f64>>,
) -> PyResult<Ensemble> {
    let dim = h.h.dimension();
    let chosen = args::method(method, dtau, dt, order, robust, lambda0)?;
    let duration = args::end(steps, t_end, orbits)?;
    let physical = regularized(&h, method, (regularize, centre), megno || lyapunov)?;
    let grid = params.map(|p| grid(&h, p)).transpose()?;
    let rows = states(&h, z0s, grid.as_ref().map(Vec::len))?;
    // Each member's start and end, with its own parameters (a grid: a scratch copy of `h`, or
    // of the regularization, which holds its own `h`).
    let source = h.source();
    let (mut scratch, mut scratch_physical) = match (&grid, &physical) {
        (Some(_), None) => (Some(source.compile()?), None),
        (Some(_), Some(p)) => (None, Some(p.copy_for(source.compile()?)?)),
        (None, _) => (None, None),
    };
    let starts = rows
        .into_iter()
        .enumerate()
        .map(|(i, row)| {
            let params = grid.as_ref().map(|g| g[i].clone()).unwrap_or_default();
            if let Some(p) = scratch_physical.as_mut() {
                for (name, value) in &params {
                    p.set_parameter(name, *value).map_err(|e| {
                        PyValueError::new_err(format!("params[{name:?}][{i}]: {}", e.value(py)))
                    })?;
                }
            }
            let runtime: &RuntimeHamiltonian = match (scratch.as_mut(), &scratch_physical) {
                (Some(copy), _) => {
                    for (name, value) in &params {
                        copy.set_parameter(name, *value).map_err(|e| {
                            PyValueError::new_err(format!("params[{name:?}][{i}]: {e}"))
                        })?;
                    }
                    copy
                }
                // (Its parameters set above.)
                (None, Some(p)) => p.hamiltonian(),
                (None, None) => &h.h,
            };
            let name = format!("z0s[{i}]");
            let z0 = args::start_from(runtime, row, &name, t0)?;
            let in_member =
                |e: PyErr| PyValueError::new_err(format!("member {i}: {}", e.value(py)));
            let end =
                args::resolve_end(duration, h.catalogue(), runtime, &z0, t0).map_err(in_member)?;
            let (z0, energy0) = match scratch_physical.as_ref().or(physical.as_ref()) {
                Some(p) => p.start_of(&z0, t0).map_err(in_member)?,
                None => (z0, f64::NAN),
            };
            if let Chosen::Special(Special::Exact, _) = chosen {
                if let Some(reason) =
                    crate::catalogue::exact_unavailable(h.catalogue(), runtime, &z0)?
                {
                    return Err(in_member(PyValueError::new_err(reason)));
                }
            }
            Ok(Start {
                z0,
                end,
                params,
                energy0,
            })
        })
        .collect::<PyResult<Vec<Start>>>()?;
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
        t0,
        max_steps,
        flag: &flag,
        chaos: megno || lyapunov,
        dim,
    };
    let shared: &Arc<RuntimeHamiltonian> = &h.h;
    let catalogue = h.catalogue();
    let members: Vec<Member> = crate::interrupt::run(py, &flag, || {
        pool.install(|| match grid {
            None => starts
                .par_iter()
                .map(|start| {
                    let run_on = (shared, physical.as_ref());
                    member(run_on, catalogue, chosen, start, &plan)
                })
                .collect::<PyResult<Vec<Member>>>(),
            // Each thread its own copy of `h` (and of the regularization), its parameters set
            // per member.
            Some(_) => starts
                .par_iter()
                .map_init(
                    || ThreadCopy::new(&source, physical.as_ref()),
                    |copy, start| {
                        let copy = copy
                            .as_mut()
                            .map_err(|e| PyRuntimeError::new_err(e.to_string()))?;
                        for (name, value) in &start.params {
                            copy.set_parameter(name, *value)?;
                        }
                        member(copy.run_on(), catalogue, chosen, start, &plan)
                    },
                )
                .collect::<PyResult<Vec<Member>>>(),
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
        megno: plan
            .chaos
            .then(|| column(py, &members, |r| r.indicators.map_or(f64::NAN, |i| i.megno))),
        lyapunov: plan.chaos.then(|| {
            column(py, &members, |r| {
                r.indicators.map_or(f64::NAN, |i| i.lyapunov)
            })
        }),
        failure: members.into_iter().map(|r| r.failure).collect(),
    })
}

/// `regularize=` and `centre=` read as `integrate` reads them ([`Physical::from_args`]),
/// refused with the chaos indicators (their variational equations would run in `K`'s fictitious
/// time).
fn regularized(
    h: &Hamiltonian,
    method: &str,
    (regularize, centre): (Option<&str>, Option<Vec<f64>>),
    chaos: bool,
) -> PyResult<Option<Physical>> {
    if chaos && regularize.is_some() {
        return Err(PyValueError::new_err(
            "regularize with megno or lyapunov: the variational equations would run in K's fictitious time, and the indicators would not be the physical ones; drop regularize (robust=True runs through a breakdown) or the indicators",
        ));
    }
    Physical::from_args(&h.h, h.text(), (regularize, centre), method)
}

/// The parameter grid `params`: per member, its (name, value) pairs; every array of the same
/// length, every name one of `h`'s parameters.
fn grid(h: &Hamiltonian, params: BTreeMap<String, Vec<f64>>) -> PyResult<Vec<Vec<(String, f64)>>> {
    let known: Vec<&str> = h.h.parameters().map(|(n, _)| n).collect();
    if let Some(name) = params.keys().find(|n| !known.contains(&n.as_str())) {
        return Err(PyValueError::new_err(format!(
            "params: unknown parameter `{name}`: the Hamiltonian has {}",
            if known.is_empty() {
                "no parameters".to_string()
            } else {
                known.join(", ")
            }
        )));
    }
    let mut lengths = params.iter().map(|(n, v)| (n, v.len()));
    let Some((first, m)) = lengths.next() else {
        return Err(PyValueError::new_err(
            "params is empty: give at least one parameter and its values",
        ));
    };
    if let Some((name, len)) = lengths.find(|(_, len)| *len != m) {
        return Err(PyValueError::new_err(format!(
            "params: `{name}` has {len} values and `{first}` {m}: one value of each per member"
        )));
    }
    Ok((0..m)
        .map(|i| params.iter().map(|(n, v)| (n.clone(), v[i])).collect())
        .collect())
}

/// The rows of `z0s`: an (M, D) array, or with a grid of `members` also one state for all.
fn states(
    h: &Hamiltonian,
    z0s: &Bound<'_, PyAny>,
    members: Option<usize>,
) -> PyResult<Vec<Vec<f64>>> {
    let dim = h.h.dimension();
    let converted = z0s
        .py()
        .import("numpy")?
        .call_method1("asarray", (z0s, "float64"))
        .map_err(|_| PyTypeError::new_err("z0s must be an (M, D) array of floats"))?;
    if let (Some(m), Ok(row)) = (
        members,
        converted.extract::<numpy::PyReadonlyArray1<'_, f64>>(),
    ) {
        return Ok(vec![row.as_array().to_vec(); m]);
    }
    let one = if members.is_some() {
        ", or one state (D,) for every member of the grid"
    } else {
        ""
    };
    let array = converted
        .extract::<PyReadonlyArray2<'_, f64>>()
        .map_err(|_| {
            let shape = converted
                .getattr("shape")
                .map(|s| s.to_string())
                .unwrap_or_default();
            PyValueError::new_err(format!(
                "z0s has shape {shape}, expected (M, {dim}): one initial state per row{one}"
            ))
        })?;
    let rows = array.shape()[0];
    if let Some(m) = members.filter(|&m| m != rows) {
        return Err(PyValueError::new_err(format!(
            "z0s has {rows} rows and params {m} values: one initial state per member, or one (D,) for all"
        )));
    }
    let view = array.as_array();
    Ok((0..rows).map(|i| view.row(i).to_vec()).collect())
}
