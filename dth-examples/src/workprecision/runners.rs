//! Sweeps: run one method over its ladder of step sizes, timed and with diagnostics.
//!
//! Each point is run once with diagnostics (errors, iterations; not timed) and then timed
//! without them: the timed run only integrates to `T` and returns the final state, which is
//! passed through [`black_box`] so the work cannot be optimized away.

use dth::nalgebra::Const;
use std::hint::black_box;
use std::time::Instant;

use dth::dth::{Dth, DthOptions};
use dth::methods::{run, OneStepMethod};
use dth::nalgebra::SVector;
use dth::observer::{StepKind, StepRecord};
use dth::{Error as CoreError, Hamiltonian};

use super::problem::Problem;
use super::{Record, WorkPrecisionOptions};

/// The swept parameters of one problem.
pub(crate) struct Ladder {
    /// Fixed steps of the peers.
    pub dt: Vec<f64>,
    /// DTH steps in `tau` (with `lambda_0 = 1`).
    pub dtau: Vec<f64>,
    /// DOP853 tolerances (`rtol = atol`).
    pub tolerance: Vec<f64>,
}

/// A DTH run may not take more steps than this (a guard against a multiplier that collapses).
const MAX_DTH_STEPS: usize = 20_000_000;

/// Wall times of repeated runs of `f`.
pub(crate) struct Timing {
    /// Median.
    pub median: f64,
    /// Fastest run.
    pub min: f64,
    /// Number of runs.
    pub runs: usize,
}

impl Timing {
    /// Store into a record.
    pub fn store(self, record: &mut Record) {
        record.time = self.median;
        record.time_min = self.min;
        record.timed_runs = self.runs;
    }
}

/// Median wall time of `f`: at least `options.repeats()` runs and at least `min_timing` seconds,
/// at most 101 runs.
pub(crate) fn median_time(options: &WorkPrecisionOptions, mut f: impl FnMut() -> bool) -> Timing {
    let mut times = Vec::new();
    let mut total = 0.0;
    while times.len() < options.repeats() || (total < options.min_timing && times.len() < 101) {
        let start = Instant::now();
        let ok = black_box(f());
        let t = start.elapsed().as_secs_f64();
        if !ok {
            // A run that failed under diagnostics fails the same way here; do not time it.
            return Timing {
                median: f64::NAN,
                min: f64::NAN,
                runs: 0,
            };
        }
        times.push(t);
        total += t;
    }
    times.sort_by(f64::total_cmp);
    Timing {
        median: times[times.len() / 2],
        min: times[0],
        runs: times.len(),
    }
}

/// A record with the diagnostic fields unset.
pub(crate) fn blank(
    system: &'static str,
    method: &'static str,
    parameter_kind: &'static str,
    parameter: f64,
) -> Record {
    Record {
        system,
        method,
        parameter_kind,
        parameter,
        steps: 0,
        mean_dt: f64::NAN,
        time: f64::NAN,
        time_min: f64::NAN,
        timed_runs: 0,
        global_error: f64::NAN,
        vertex_error: None,
        energy_error: f64::NAN,
        vertex_energy_error: None,
        invariant_error: None,
        vertex_invariant_error: None,
        newton_per_step: None,
        evaluations_per_step: None,
        fallback_steps: None,
        failure: None,
    }
}

/// Running maximum of `|Q(z) - Q(z_0)|`.
pub(crate) struct MaxDeviation {
    reference: f64,
    pub max: f64,
}

impl MaxDeviation {
    pub fn new(reference: f64) -> Self {
        MaxDeviation {
            reference,
            max: 0.0,
        }
    }
    pub fn push(&mut self, value: f64) {
        // NaN propagates: a NaN state is a failure, not a small error.
        let d = (value - self.reference).abs();
        if d.is_nan() || d > self.max {
            self.max = d;
        }
    }
}

/// One peer method over the `dt` ladder. `make` builds a fresh method value per run (its
/// iteration counter starts at 0).
pub(crate) fn sweep_peer<H, M, const D: usize>(
    problem: &Problem<H, D>,
    options: &WorkPrecisionOptions,
    ladder: &Ladder,
    make: impl Fn() -> M,
    records: &mut Vec<Record>,
) where
    H: Hamiltonian<Const<D>> + Clone,
    M: OneStepMethod<Const<D>, H>,
{
    let h = &problem.hamiltonian;
    let z0 = &problem.z0;
    let t_end = problem.info.t_end;
    for &dt_target in &ladder.dt {
        let steps = (t_end / dt_target).round().max(1.0) as usize;
        let dt = t_end / steps as f64;
        let mut record = blank(problem.info.name, (problem.rename)(M::NAME), "dt", dt);
        record.steps = steps;
        record.mean_dt = dt;
        let mut energy = MaxDeviation::new(h.value(z0));
        let mut invariant = problem.invariant.map(|f| (f, MaxDeviation::new(f(z0))));
        let mut method = make();
        let result = run(&mut method, h, z0, 0.0, dt, steps, &mut |r: &StepRecord<
            Const<D>,
        >| {
            energy.push(h.value(&r.z));
            if let Some((f, dev)) = invariant.as_mut() {
                dev.push(f(&r.z));
            }
        });
        match result {
            Ok(end) => {
                record.global_error = (problem.error)(&end.z, &problem.reference.at(end.t));
                record.energy_error = energy.max;
                record.invariant_error = invariant.map(|(_, d)| d.max);
                let iterations = method.newton_iterations();
                if iterations > 0 {
                    record.newton_per_step = Some(iterations as f64 / steps as f64);
                }
                median_time(options, || {
                    let mut m = make();
                    let end = run(&mut m, h, z0, 0.0, dt, steps, &mut ());
                    black_box(end).is_ok()
                })
                .store(&mut record);
            }
            Err(e) => record.failure = Some(format!("step {}: {}", e.partial.steps + 1, e.error)),
        }
        records.push(record);
    }
}

/// Integrate DTH (of any order) until its last midpoint lands on `t_end`
/// ([`Dth::step_toward`]: the last step is shortened or stretched in `tau` so that its
/// midpoint time is `t_end` to roundoff). Returns that midpoint and its time; `observe` sees
/// the stepper at every step, with `true` after the last one.
fn dth_to_time<H: Hamiltonian<Const<D>> + Clone, const D: usize>(
    hamiltonian: &H,
    z0: &SVector<f64, D>,
    options: DthOptions,
    t_end: f64,
    mut observe: impl FnMut(&Dth<H, Const<D>>, bool),
) -> Result<(SVector<f64, D>, f64), (CoreError, usize)> {
    let mut dth = Dth::new(hamiltonian.clone(), *z0, options).map_err(|e| (e, 0))?;
    observe(&dth, false);
    loop {
        if dth.k() >= MAX_DTH_STEPS {
            return Err((
                CoreError::InvalidOption {
                    name: "dtau",
                    value: options.dtau(),
                    reason: "needs more than MAX_DTH_STEPS steps to reach T",
                },
                dth.k(),
            ));
        }
        let k = dth.k();
        let (_, reached) = dth.step_toward(t_end).map_err(|e| (e, k + 1))?;
        observe(&dth, reached);
        if reached {
            return Ok((*dth.zbar(), dth.tbar()));
        }
    }
}

/// How a DTH sweep sets Newton's stall tolerance.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Stall {
    /// The library default (`2^-40`), what a user gets.
    Default,
    /// Scaled with the conditioning of the energy equation: `64 eps / (dtau lambda_mean)^2`,
    /// clamped to `[2^-40, 1e-6]`.
    ///
    /// Why: `g_lambda = dH/dlambda` is `O(h^2)` (`h = dtau lambda`), so roundoff in `H` of size
    /// `eps |H|` moves `lambda` by `eps |H| / |g_lambda| ~ eps / h^2` relative: the updates of
    /// `lambda` stop shrinking at that floor. The default `2^-40` is below it once
    /// `h < ~3e-3` on the thesis orbit, and Newton then runs to its iteration limit with a
    /// scaled residual of 1e-17 (measured: every DTH run at 512 points per period and finer
    /// failed that way). The residual criterion (64 eps) is unchanged, so `H(zbar_k) = H(zbar_0)` is
    /// still solved to roundoff; only `lambda`'s noise, set by the conditioning, is accepted.
    /// At `h = 0.15` (thesis settings) the formula gives `6.3e-13`, the default.
    Scaled,
}

impl Stall {
    fn tolerance(self, h: f64) -> Option<f64> {
        match self {
            Stall::Default => None,
            Stall::Scaled => Some((64.0 * f64::EPSILON / (h * h)).clamp(2f64.powi(-40), 1e-6)),
        }
    }
}

/// What DTH integrates for a problem: its own Hamiltonian ([`Integrated::own`]), or a
/// regularized `K` on another state space (Levi-Civita's `(u, t, P, p_t)`) with the map of its
/// states back to the problem's, where every error is measured. DTH's record times are
/// physical either way (a regularized `K` carries `t` as a coordinate, which the stepper reads
/// as its clock).
pub(crate) struct Integrated<'a, K, const E: usize, const D: usize> {
    /// The Hamiltonian DTH steps.
    pub hamiltonian: &'a K,
    /// Its initial state (the problem's `z_0`, mapped).
    pub z0: SVector<f64, E>,
    /// A state of `hamiltonian` as the problem's state.
    pub physical: fn(&SVector<f64, E>) -> SVector<f64, D>,
}

impl<'a, H, const D: usize> Integrated<'a, H, D, D> {
    /// The problem's own Hamiltonian and state.
    pub fn own(problem: &'a Problem<H, D>) -> Self {
        Integrated {
            hamiltonian: &problem.hamiltonian,
            z0: problem.z0,
            physical: |z| *z,
        }
    }
}

/// DTH with the given solver over the `dtau` ladder, on the problem's own Hamiltonian.
#[allow(clippy::too_many_arguments)]
pub(crate) fn sweep_dth<H: Hamiltonian<Const<D>> + Clone, const D: usize>(
    problem: &Problem<H, D>,
    options: &WorkPrecisionOptions,
    ladder: &Ladder,
    name: &'static str,
    base: DthOptions,
    stall: Stall,
    records: &mut Vec<Record>,
) {
    let own = Integrated::own(problem);
    sweep_dth_on(problem, &own, options, ladder, name, base, stall, records);
}

/// DTH with the given solver over the `dtau` ladder, stepping `integrated` (the problem's own
/// Hamiltonian, or a regularized one) and measuring every error on the problem's states. The
/// ladder's `dtau` are divided by the mean `dt/dtau` of `integrated` ([`mean_lambda`]), so that
/// the same rung is the same mean number of steps per period whatever DTH steps.
#[allow(clippy::too_many_arguments)]
pub(crate) fn sweep_dth_on<H, K, const D: usize, const E: usize>(
    problem: &Problem<H, D>,
    integrated: &Integrated<'_, K, E, D>,
    options: &WorkPrecisionOptions,
    ladder: &Ladder,
    name: &'static str,
    base: DthOptions,
    stall: Stall,
    records: &mut Vec<Record>,
) where
    H: Hamiltonian<Const<D>> + Clone,
    K: Hamiltonian<Const<E>> + Clone,
{
    let h = &problem.hamiltonian;
    let z0 = &problem.z0;
    let (k, w0, physical) = (integrated.hamiltonian, &integrated.z0, integrated.physical);
    let t_end = problem.info.t_end;
    let lambda_mean = mean_lambda(integrated, problem.info.period, base);
    for &dtau in ladder
        .dtau
        .iter()
        .map(|d| d / lambda_mean)
        .collect::<Vec<_>>()
        .iter()
    {
        let mut record = blank(problem.info.name, (problem.rename)(name), "dtau", dtau);
        let with_stall = |o: DthOptions| match stall.tolerance(dtau * lambda_mean) {
            Some(t) => o.with_stall_tolerance(t),
            None => Ok(o),
        };
        let dth_options = match base.with_dtau(dtau).and_then(with_stall) {
            Ok(o) => o,
            Err(e) => {
                record.failure = Some(e.to_string());
                records.push(record);
                continue;
            }
        };
        // Midpoints are measured against zbar_0 = z_0; vertices against the first vertex
        // z^(0) = zbar_0 - (h/2) zbar'_0 (thesis Table 4.1 convention): the vertex polygon
        // conserves quadratic invariants at the value of z^(0), which differs from z_0's by
        // O(h^2). That constant offset is in the global error, not in the conservation.
        let e0 = h.value(z0);
        let mut energy = MaxDeviation::new(e0);
        let i0 = problem.invariant.map(|f| f(z0));
        let mut invariant = i0.map(MaxDeviation::new);
        let mut vertex_energy: Option<MaxDeviation> = None;
        let mut vertex_invariant: Option<MaxDeviation> = None;
        let mut factorizations = 0u64;
        let mut steps = 0usize;
        let mut fallback_steps = 0usize;
        // The left vertex of the current segment and its time.
        let mut last_vertex = (*z0, 0.0);
        let result = dth_to_time(k, w0, dth_options, t_end, |dth, last| {
            let r = dth.record();
            // A DTH stepper's records always carry its DTH data.
            let Some(d) = r.dth else { return };
            let (z, vertex) = (physical(&r.z), physical(&d.vertex));
            energy.push(h.value(&z));
            factorizations += u64::from(r.factorizations);
            steps = r.k;
            fallback_steps += usize::from(r.kind == StepKind::Fallback);
            if last {
                // The last step is shortened in tau to land on T: an exact DTH step (its
                // midpoint energy is measured above), but its segment has its own
                // half-length, so its left vertex is not a vertex of the polygon of equal
                // steps, and the vertex invariants jump there once, by O(h^2). The vertex
                // measures are over the equal steps.
                return;
            }
            vertex_energy
                .get_or_insert_with(|| MaxDeviation::new(h.value(&vertex)))
                .push(h.value(&vertex));
            if let (Some(f), Some(m)) = (problem.invariant, invariant.as_mut()) {
                m.push(f(&z));
                vertex_invariant
                    .get_or_insert_with(|| MaxDeviation::new(f(&vertex)))
                    .push(f(&vertex));
            }
            last_vertex = (vertex, d.vertex_time);
        });
        match result {
            Ok((w, t)) => {
                let z = physical(&w);
                record.steps = steps;
                record.mean_dt = t_end / steps.max(1) as f64;
                // At the midpoint's own time: t_end to roundoff (with the plain energy
                // residual, to lambda's noise, ~1e-13 relative).
                record.global_error = (problem.error)(&z, &problem.reference.at(t));
                let (v, tv) = last_vertex;
                record.vertex_error = Some((problem.error)(&v, &problem.reference.at(tv)));
                record.energy_error = energy.max;
                record.vertex_energy_error = vertex_energy.map(|d| d.max);
                record.invariant_error = invariant.map(|d| d.max);
                record.vertex_invariant_error = vertex_invariant.map(|d| d.max);
                record.newton_per_step = Some(factorizations as f64 / steps.max(1) as f64);
                record.fallback_steps = Some(fallback_steps);
                median_time(options, || {
                    black_box(dth_to_time(k, w0, dth_options, t_end, |_, _| ())).is_ok()
                })
                .store(&mut record);
            }
            Err((e, step)) => record.failure = Some(format!("step {step}: {e}")),
        }
        records.push(record);
    }
}

/// Mean `lambda = dt/dtau` over one period at about 256 physical steps per period, from
/// `lambda_0 = 1`.
///
/// DTH's step equations depend on `dtau` and `lambda` only through `dtau lambda`, so the
/// ladder `dtau = dt / lambda_mean` puts DTH at the same mean number of points per period as
/// the peers at `dt`. A first probe at `dtau = period / 256` gives an estimate `lambda_1`; a
/// second probe at `dtau = period / (256 lambda_1)` gives the mean at the intended resolution.
/// The second probe matters where the mean `lambda` is far from 1: on the e = 0.9 Kepler orbit
/// (mean about 29 from `lambda_0 = 1` at pericenter) the first probe takes only ~9 physical
/// steps per period and reads 11; on e = 0.7 the two differ by 1.6%, elsewhere by 0.2% or less.
///
/// Where plain DTH breaks down on the orbit (`Psi` changes sign), the probe runs in robust
/// mode: plain DTH is then swept at the `dtau` of the robust mode it is compared with, and
/// fails by its breakdown, not by a step far too large. (Where DTH does not break down, robust
/// mode takes the same steps.) 1 if every probe fails, the first estimate if only the second
/// does.
///
/// On a regularized `K` (Levi-Civita) `dt/dtau` is `|u|^2 = r` times DTH's own `lambda`, which
/// stays at `lambda_0` there (the regularized Kepler problem is an oscillator, its `Psi`
/// constant on `K = 0`): the ladder then takes equal steps in the fictitious time, `n` per
/// orbit.
fn mean_lambda<K: Hamiltonian<Const<E>> + Clone, const E: usize, const D: usize>(
    integrated: &Integrated<'_, K, E, D>,
    period: f64,
    base: DthOptions,
) -> f64 {
    let probe = |options: DthOptions, dtau: f64| -> Option<f64> {
        let mut dth = Dth::new(
            integrated.hamiltonian.clone(),
            integrated.z0,
            options.with_dtau(dtau).ok()?,
        )
        .ok()?;
        while dth.tbar() < period && dth.k() < 1_000_000 {
            dth.step().ok()?;
        }
        let lambda = dth.tbar() / (dth.k() as f64 * dtau);
        (lambda.is_finite() && lambda > 0.0).then_some(lambda)
    };
    let dtau = period / PROBE_STEPS;
    let (options, first) = match probe(base, dtau) {
        Some(lambda) => (base, lambda),
        None => {
            let robust = base.with_robust(true);
            match probe(robust, dtau) {
                Some(lambda) => (robust, lambda),
                None => return 1.0,
            }
        }
    };
    probe(options, dtau / first).unwrap_or(first)
}

/// Physical steps per period of [`mean_lambda`]'s probe.
const PROBE_STEPS: f64 = 256.0;

#[cfg(test)]
mod tests {
    use super::*;
    use dth::kepler::KeplerOrbit;
    use dth::nalgebra::Vector4;
    use dth::systems::Kepler;

    /// DTH's state at T, reached by a last step that lands on it, is second order: halving
    /// `dtau` divides the error against the exact Kepler solution by about 4.
    #[test]
    fn dth_state_at_t_is_second_order() {
        let kepler = Kepler::thesis();
        let z0 = Vector4::new(0.5, 0.0, 0.0, 1.2);
        let orbit = KeplerOrbit::new(&kepler, &z0).unwrap();
        // An end time that is not a vertex time of either run.
        let t_end = 0.77 * orbit.elements().period;
        let error = |dtau: f64| {
            let options = DthOptions::new(dtau).unwrap();
            let (z, t) = dth_to_time(&kepler, &z0, options, t_end, |_, _| ()).unwrap();
            assert!((t - t_end).abs() <= 4.0 * f64::EPSILON * t_end);
            (z - orbit.state_at(t_end)).norm()
        };
        let (e1, e2, e3) = (error(0.02), error(0.01), error(0.005));
        // Asymptotic ratio 4; the leading error term dominates here to within 10%.
        for ratio in [e1 / e2, e2 / e3] {
            assert!((3.6..4.4).contains(&ratio), "{e1:e} {e2:e} {e3:e}");
        }
    }

    /// The Kepler e = 0.9 orbit from pericenter, as the sweep has it.
    fn eccentric_kepler() -> Problem<Kepler, 4> {
        use crate::workprecision::problem::ProblemInfo;
        use crate::workprecision::reference::Reference;
        let kepler = Kepler::thesis();
        let z0 = Vector4::new(0.5, 0.0, 0.0, 1.9f64.sqrt());
        let orbit = KeplerOrbit::new(&kepler, &z0).unwrap();
        let period = orbit.elements().period;
        Problem {
            info: ProblemInfo {
                name: "kepler_e09",
                title: "Kepler, e = 0.9",
                t_end: period,
                period,
                invariant: None,
            },
            hamiltonian: kepler,
            z0,
            reference: Reference::exact("kepler_e09", move |t| orbit.state_at(t)),
            invariant: None,
            error: |a, b| (a - b).norm(),
            rename: |name| name,
        }
    }

    /// The ladder's promise: `dtau = period / (n lambda_mean)` takes about `n` steps per
    /// period, also where `lambda` is far from 1 (robust DTH on e = 0.9 from `lambda_0 = 1` at
    /// pericenter, mean about 29; a single probe at `period / 256` reads about 11 there).
    #[test]
    fn mean_lambda_puts_dth_at_the_intended_steps_per_period() {
        let problem = eccentric_kepler();
        let period = problem.info.period;
        for order in [2, 8] {
            let base = DthOptions::thesis_kepler()
                .with_robust(true)
                .with_order(order)
                .unwrap();
            let lambda = mean_lambda(&Integrated::own(&problem), period, base);
            let n = 64.0;
            let options = base.with_dtau(period / (n * lambda)).unwrap();
            let mut steps = 0;
            dth_to_time(
                &problem.hamiltonian,
                &problem.z0,
                options,
                period,
                |dth, _| {
                    steps = dth.k();
                },
            )
            .unwrap_or_else(|e| panic!("order {order}: {e:?}"));
            let ratio = steps as f64 / n;
            assert!(
                (0.85..1.15).contains(&ratio),
                "order {order}: {steps} steps"
            );
        }
    }

    /// Plain DTH breaks down on e = 0.9; its `dtau` ladder is the robust mode's, so that it
    /// fails by the breakdown at the `dtau` it is compared at.
    #[test]
    fn a_plain_dth_that_breaks_down_is_probed_in_robust_mode() {
        let problem = eccentric_kepler();
        let (own, period) = (Integrated::own(&problem), problem.info.period);
        let plain = mean_lambda(&own, period, DthOptions::thesis_kepler());
        let robust = mean_lambda(&own, period, DthOptions::thesis_kepler().with_robust(true));
        assert_eq!(plain, robust);
        assert!(robust > 10.0, "{robust}");
        let options = DthOptions::new(problem.info.period / (64.0 * plain)).unwrap();
        let run = dth_to_time(
            &problem.hamiltonian,
            &problem.z0,
            options,
            problem.info.t_end,
            |_, _| (),
        );
        assert!(
            matches!(run, Err((CoreError::Breakdown { .. }, _))),
            "{run:?}"
        );
    }
}
