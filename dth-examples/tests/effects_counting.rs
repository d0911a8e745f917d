//! An effect that is not requested costs nothing per step: proved by counting, not timing.
//!
//! The system below counts its evaluations of `H` (only the energy effect needs them per step;
//! RK4 uses the gradient only; one more, before the run, checks the initial state) and of the
//! invariants; the runner reports how many states
//! its effect observers saw and how many numbers they stored.

use dth::nalgebra::Const;
use std::cell::Cell;

use dth::nalgebra::{SMatrix, SVector};
use dth::{ConstFlags, Flags, Hamiltonian};
use dth_examples::catalogue::Catalogue;
use dth_examples::effects::EffectOutputs;
use dth_examples::simulate::{compute, RunOptions};
use dth_examples::system::SceneSystem;
use dth_examples::systems::Kepler;

#[derive(Clone)]
struct CountingKepler {
    inner: Kepler,
    values: Cell<usize>,
    invariants: Cell<usize>,
}

impl Hamiltonian<Const<4>> for CountingKepler {
    fn dim(&self) -> Const<4> {
        Const
    }

    fn value(&self, z: &SVector<f64, 4>) -> f64 {
        self.values.set(self.values.get() + 1);
        self.inner.value(z)
    }
    fn gradient_into(&self, z: &SVector<f64, 4>, out: &mut SVector<f64, 4>) {
        *out = self.inner.gradient(z);
    }
    fn hessian_into(&self, z: &SVector<f64, 4>, out: &mut SMatrix<f64, 4, 4>) {
        *out = self.inner.hessian(z);
    }
}

/// No flags (the defaults), as `flags()` says.
impl ConstFlags for CountingKepler {
    const FLAGS: Flags = Flags::new();
}

impl SceneSystem<Const<4>> for CountingKepler {
    fn invariant_names(&self) -> &'static [&'static str] {
        &["angular_momentum"]
    }
    fn invariants(&self, z: &SVector<f64, 4>, out: &mut [f64]) {
        self.invariants.set(self.invariants.get() + 1);
        out[0] = z[0] * z[3] - z[1] * z[2];
    }
}

fn scene(effects: &str) -> dth_examples::scene::Scene {
    let text = format!(
        "[system]\nname = \"kepler\"\n[initial]\nq = [0.5, 0.0]\np = [0.0, 1.2]\n\
         [[method]]\nkind = \"rk4\"\ndt = 0.001\n[duration]\nsteps = 5000\n{effects}"
    );
    dth_examples::check_scene(&text, "counting.toml", &Catalogue::builtin()).unwrap()
}

fn counting() -> CountingKepler {
    CountingKepler {
        inner: Kepler::thesis(),
        values: Cell::new(0),
        invariants: Cell::new(0),
    }
}

#[test]
fn no_effects_observes_and_stores_nothing() {
    let sys = counting();
    let results = compute(
        &sys,
        &scene(""),
        &RunOptions::default().with_progress(false),
    )
    .unwrap();
    let r = &results[0];
    assert_eq!(r.summary.steps, 5000);
    assert_eq!(r.summary.observer_calls, 0);
    assert_eq!(r.summary.stored_values, 0);
    assert_eq!(r.outputs, EffectOutputs::default());
    // Once, before the run: `simulate::preflight` checks that H is finite at the initial
    // state. Never per step.
    assert_eq!(
        sys.values.get(),
        1,
        "H was evaluated although no effect needs it"
    );
    assert_eq!(sys.invariants.get(), 0);
}

#[test]
fn only_the_requested_effect_runs() {
    let sys = counting();
    let s = scene("[[effect]]\nkind = \"energy_deviation\"\nevery = 1000\n");
    let results = compute(&sys, &s, &RunOptions::default().with_progress(false)).unwrap();
    let r = &results[0];
    // Every state 0..=5000 is observed once, H evaluated once per state (and once before the
    // run, by the check of the initial state), no invariants.
    assert_eq!(r.summary.observer_calls, 5001);
    assert_eq!(sys.values.get(), 1 + 5001);
    assert_eq!(sys.invariants.get(), 0);
    // Stored: the energy series at steps 0, 1000, ..., 5000, three numbers each; nothing else.
    assert_eq!(r.summary.stored_values, 6 * 3);
    let o = &r.outputs;
    assert!(o.energy.is_some());
    assert!(o.trajectory.is_none() && o.invariants.is_none() && o.time_law.is_none());
    assert!(o.final_state.is_none() && o.poincare.is_empty() && o.phase.is_empty());
}

#[test]
fn comparison_table_computes_statistics_but_stores_no_series() {
    let sys = counting();
    let s = scene("[[effect]]\nkind = \"comparison_table\"\n");
    let results = compute(&sys, &s, &RunOptions::default().with_progress(false)).unwrap();
    let r = &results[0];
    // Once per state, and once before the run (the check of the initial state).
    assert_eq!(sys.values.get(), 1 + 5001);
    assert_eq!(sys.invariants.get(), 5001);
    assert_eq!(r.summary.stored_values, 0);
    let e = r.summary.energy.as_ref().unwrap();
    assert_eq!(e.points.count, 5000);
    assert!(e.points.mean > 0.0 && e.points.max >= e.points.mean);
}
