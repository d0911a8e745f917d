//! Robust mode keeps the energy at the roundoff of `H`'s terms at every point through a close
//! encounter of two bodies far from the origin (`hard_support::pair`), as in a cluster.
//!
//! The pair's positions are of size 1 and rounded to `1e-16`, its separation is `1e-5` at
//! pericentre: `sum_i |z_i dH/dz_i|` (what rounding every coordinate by half an ulp moves `H`
//! by) is `|q| / r = 1e5` times the terms' size `T + |V|`. A point projected onto `H = H0`
//! along `grad H` alone is rounded where `H` is most sensitive and stays off by that much
//! (without the momenta's move: 4,484 `eps` of `T + |V|` here); the momenta's move brings a
//! fallback node to the terms' roundoff (`dth::robust::project_momenta`). The facade's
//! `tests/robust_energy.rs` checks the same on a 50-body cluster.

mod hard_support;

use dth_core::dth::{Dth, DthOptions};
use dth_core::observer::StepKind;
use dth_core::Hamiltonian;
use hard_support::pair::{Pair, V8};

/// The largest `|H - H0| / (T + |V|)` over the fallback nodes and `|H - H0| / s(z)` over every
/// point of `steps` robust steps of `dtau` from `z0` (first multiplier `lambda0`), and the
/// fallback steps taken.
fn worst(z0: V8, (dtau, lambda0): (f64, f64), steps: usize) -> (f64, f64, usize) {
    let e0 = Pair.value(&z0);
    let options = DthOptions::new(dtau)
        .expect("dtau > 0")
        .with_lambda0(lambda0)
        .expect("lambda0 > 0")
        .with_robust(true);
    let mut dth = Dth::new(Pair, z0, options).expect("start");
    let (mut terms, mut roundoff, mut fallback) = (0.0f64, 0.0f64, 0);
    for k in 1..=steps {
        let r = dth
            .step()
            .unwrap_or_else(|e| panic!("the robust run stopped at step {k}: {e}"));
        fallback += usize::from(r.kind == StepKind::Fallback);
        let value = Pair.value(&r.z);
        let t = Pair::kinetic(&r.z);
        let deviation = (value - e0).abs();
        if r.kind == StepKind::Fallback {
            terms = terms.max(deviation / (t + (value - t).abs()));
        }
        let s = r.z.component_mul(&Pair.gradient(&r.z)).abs().sum();
        roundoff = roundoff.max(deviation / s.max(e0.abs()));
    }
    (terms, roundoff, fallback)
}

/// Pericentre `1e-5` (`a = 1e-3`, `e = 0.99`); the first physical step `lambda0 dtau = 2e-8` of
/// the order of the passage (`r / v = 1.6e-8`); 400 steps, 328 of them fallback steps (DTH
/// runs where `Psi` does not cancel, `dth::robust`).
///
/// DTH's midpoints are not moved along the momenta (that would break the quadratic invariants
/// DTH keeps at its vertices, see `project_momenta`): they keep the roundoff of `s(z)`, which
/// here is up to `|q| / r` times that of `T + |V|` (measured: 579 eps of `T + |V|`, 0.2 eps of
/// `s(z)`). The bound against `T + |V|` is therefore on the fallback nodes.
///
/// Bounds: a node the momenta's move leaves alone is within `8 eps max(|E|, 2T)` of `H = E`
/// (`dth::robust::MOVE_MOMENTA_ABOVE`), at most `16 eps (T + |V|)`; a moved one keeps the
/// momenta's own rounding (at most `eps T`) and the rounding of the two evaluations of `H`
/// compared (a few `eps` of `T + |V|` each). Measured: 6.0 eps (4,484 eps without the move).
/// Against `s(z)`, 8 eps as in `robust_long_run.rs`: this run stays below 0.01 eps.
#[test]
fn a_close_pair_far_from_the_origin() {
    let eps = f64::EPSILON;
    let (terms, roundoff, fallback) = worst(Pair::at_pericentre(1e-3, 0.99), (0.002, 1e-5), 400);
    println!(
        "terms {:.2} eps, roundoff {:.2} eps, {fallback} fallback steps",
        terms / eps,
        roundoff / eps
    );
    assert!(fallback > 0, "no fallback step");
    assert!(
        terms <= 16.0 * eps,
        "|H - H0| / (T + |V|) = {:.1} eps",
        terms / eps
    );
    assert!(
        roundoff <= 8.0 * eps,
        "|H - H0| / s = {:.1} eps",
        roundoff / eps
    );
}
