//! Thesis Table 4.1, fixed-step rows: Kepler `H = p1^2 + p2^2 - 1/r` from q = (0.5, 0),
//! p = (0, 1.2), dt = 0.15, 10,000 steps; average absolute deviation over k = 1..N of energy and
//! angular momentum from their initial values (`docs/thesis.md#table-4-1`).
//!
//! Acceptance: entries that are not at roundoff within 1% of the thesis; roundoff entries at
//! most 3e-14.

use dth_core::diagnostics::{planar_angular_momentum, AverageAbsoluteDeviation};
use dth_core::kepler::{Table41Row, THESIS_TABLE_4_1};
use dth_core::methods::{run, DiscreteMechanics, ImplicitMidpoint, OneStepMethod, Trapezoidal};
use dth_core::nalgebra::Const;
use dth_core::nalgebra::Vector4;
use dth_core::systems::Kepler;
use dth_core::Hamiltonian;

const DT: f64 = 0.15;
const STEPS: usize = 10_000;
/// The bound for entries at roundoff: ~135 eps for O(1) quantities averaged over 10^4
/// steps of a random walk of per-step roundoff (eps sqrt(N) ~ 2e-14 at worst).
const ROUNDOFF: f64 = 3e-14;

/// (energy, angular momentum) average absolute deviations.
fn table_row<M: OneStepMethod<Const<4>, Kepler>>(mut method: M) -> (f64, f64) {
    let h = Kepler::thesis();
    let z0 = Vector4::new(0.5, 0.0, 0.0, 1.2);
    let energy = AverageAbsoluteDeviation::new(|z: &Vector4<f64>| h.value(z));
    let l = AverageAbsoluteDeviation::new(planar_angular_momentum);
    let mut both = (energy, l);
    let end = run(&mut method, &h, &z0, 0.0, DT, STEPS, &mut both).expect("run");
    let (energy, l) = both;
    assert_eq!(end.steps, STEPS);
    assert_eq!(energy.count(), STEPS);
    (energy.mean().unwrap(), l.mean().unwrap())
}

/// The thesis's row for `method`.
fn thesis(method: &str) -> Table41Row {
    THESIS_TABLE_4_1
        .into_iter()
        .find(|r| r.method == method)
        .expect("a row of the thesis's table")
}

fn within_one_percent(ours: f64, thesis: f64, what: &str) {
    let rel = (ours - thesis).abs() / thesis;
    assert!(
        rel < 0.01,
        "{what}: ours {ours:.4e}, thesis {thesis:.4e} ({:.2}%)",
        100.0 * rel
    );
}

fn at_roundoff(ours: f64, what: &str) {
    assert!(ours <= ROUNDOFF, "{what}: {ours:e} > {ROUNDOFF:e}");
}

#[test]
fn trapezoidal_row() {
    let (e, l) = table_row(Trapezoidal::new());
    eprintln!("trapezoidal: E {e:.4e} L {l:.4e}");
    let t = thesis("trapezoidal");
    within_one_percent(e, t.energy, "trapezoidal energy");
    within_one_percent(l, t.angular_momentum, "trapezoidal angular momentum");
}

#[test]
fn midpoint_row() {
    let (e, l) = table_row(ImplicitMidpoint::new());
    eprintln!("midpoint: E {e:.4e} L {l:.4e}");
    within_one_percent(e, thesis("midpoint").energy, "midpoint energy");
    at_roundoff(l, "midpoint angular momentum"); // the thesis's is roundoff too
}

#[test]
fn discrete_mechanics_row() {
    let (e, l) = table_row(DiscreteMechanics::new());
    eprintln!("discrete mechanics: E {e:.4e} L {l:.4e}");
    // Both of the thesis's values are roundoff (below 1e-13) too.
    let t = thesis("discrete_mechanics");
    assert!(t.energy < 1e-13 && t.angular_momentum < 1e-13);
    at_roundoff(e, "discrete mechanics energy");
    at_roundoff(l, "discrete mechanics angular momentum");
}
