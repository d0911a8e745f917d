//! The outside reference: DOP853 (Hairer's explicit Runge-Kutta of order 8 with embedded
//! 5th and 3rd order error estimators and step-size control) from the
//! [`differential-equations`](https://crates.io/crates/differential-equations) crate, on the
//! same nalgebra `SVector` states as our methods.
//!
//! It is adaptive, so its sweep is over the tolerance (`rtol = atol`), not the step. The timed
//! run asks for the state at `T` only (`t_eval`); the diagnostic run stores every accepted step
//! and takes the energy and invariant deviations over them.

use dth::nalgebra::Const;
use std::hint::black_box;

use differential_equations::prelude::{ExplicitRungeKutta, IVP, ODE};
use dth::nalgebra::SVector;
use dth::{j_times, Hamiltonian};

use super::problem::Problem;
use super::runners::{blank, median_time, Ladder, MaxDeviation};
use super::{Record, WorkPrecisionOptions};

/// `dz/dt = J gradH(z)` as a `differential-equations` ODE (the time argument is unused: a
/// time-dependent `H` lives in the extended phase space, where `t` is a coordinate).
struct HamiltonianOde<'a, H>(&'a H);

impl<H: Hamiltonian<Const<D>>, const D: usize> ODE<f64, SVector<f64, D>> for HamiltonianOde<'_, H> {
    fn diff(&self, _t: f64, z: &SVector<f64, D>, dzdt: &mut SVector<f64, D>) {
        *dzdt = j_times(&self.0.gradient(z));
    }
}

/// Generous step budget: DOP853 at `tol = 1e-14` on 10 Kepler orbits takes ~1e4 steps.
const MAX_STEPS: usize = 10_000_000;

/// DOP853 over the tolerance ladder.
pub(crate) fn sweep_dop853<H: Hamiltonian<Const<D>> + Clone, const D: usize>(
    problem: &Problem<H, D>,
    options: &WorkPrecisionOptions,
    ladder: &Ladder,
    records: &mut Vec<Record>,
) {
    let h = &problem.hamiltonian;
    let ode = HamiltonianOde(h);
    let z0 = problem.z0;
    let t_end = problem.info.t_end;
    let method = |tol: f64| {
        ExplicitRungeKutta::dop853()
            .rtol(tol)
            .atol(tol)
            .max_steps(MAX_STEPS)
    };
    for &tol in &ladder.tolerance {
        let mut record = blank(problem.info.name, "dop853", "tol", tol);
        match IVP::ode(&ode, 0.0, t_end, z0).method(method(tol)).solve() {
            Ok(solution) => {
                let mut energy = MaxDeviation::new(h.value(&z0));
                let mut invariant = problem.invariant.map(|f| (f, MaxDeviation::new(f(&z0))));
                for z in &solution.y {
                    energy.push(h.value(z));
                    if let Some((f, dev)) = invariant.as_mut() {
                        dev.push(f(z));
                    }
                }
                let (Some(&t_last), Some(z_last)) = (solution.t.last(), solution.y.last()) else {
                    record.failure = Some("no output".to_string());
                    records.push(record);
                    continue;
                };
                let steps = solution.steps.accepted;
                record.steps = steps;
                record.mean_dt = t_end / steps.max(1) as f64;
                record.global_error = (problem.error)(z_last, &problem.reference.at(t_last));
                record.energy_error = energy.max;
                record.invariant_error = invariant.map(|(_, d)| d.max);
                record.evaluations_per_step =
                    Some(solution.evals.function as f64 / steps.max(1) as f64);
                median_time(options, || {
                    let s = IVP::ode(&ode, 0.0, t_end, z0)
                        .t_eval([t_end])
                        .method(method(tol))
                        .solve();
                    black_box(s).is_ok()
                })
                .store(&mut record);
            }
            Err(e) => record.failure = Some(format!("{e}")),
        }
        records.push(record);
    }
}
