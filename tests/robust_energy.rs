//! Robust mode keeps the energy at roundoff at every point through close encounters: on a
//! 50-body gravitating cluster (`D = 200`, `dtau = 0.002`, a hard binary inside), with exact
//! divided differences (the Hamiltonian read from text) and with Gonzalez's discrete gradient
//! (the same `H` without them); and on Kepler at `e = 0.9` and `0.99`.
//!
//! Two scales, two bounds:
//! - The **terms' scale** `T + |V|` (kinetic energy plus the sizes of the potential's terms): the
//!   rounding of evaluating `H`, the most any state can be asked for. It does not depend on
//!   where the origin is.
//! - The **roundoff scale** `s(z) = max(|H0|, sum_i |z_i dH/dz_i|)` of `robust_long_run.rs`: what
//!   rounding each coordinate by half an ulp moves `H` by. In a cluster it is set by close
//!   pairs: positions of size 1 are known to `1e-16`, so the separation `r` of a pair only to
//!   `1e-16 / r` relative, and `s` is `|q| / r` times the terms' scale (`1e7 |H0|` here).
//!
//! Projecting each point onto `H = H0` along `grad H` alone reaches the second, not the first
//! (the point is rounded where `H` is most sensitive): on the kind of cluster run
//! (5,056 steps, no planted binary) `|H - H0|` reached `4e-7` (3.2e-6 in the issue), `2e-12`
//! of `T + |V|`, while below 1 eps of `s`. At fallback nodes a second move, of the momenta
//! alone, lands within the terms' roundoff (`dth::robust::project_momenta`); DTH midpoints are
//! not moved so (that would break the vertices' quadratic invariants) and keep the `s` bound.

#![cfg(feature = "runtime")]

use dth::dth::{Dth, DthOptions};
use dth::nalgebra::{DMatrix, DVector, DefaultAllocator, Dim, Dyn, OVector, Vector4};
use dth::observer::StepKind;
use dth::runtime::RuntimeHamiltonian;
use dth::{hamiltonian::Alloc, Derivatives, Flags, Hamiltonian};

mod cluster;
use cluster::{cluster, cluster_state};

dth::hamiltonian! {
    /// The thesis's Kepler problem (`m = 1/2`, `k = 1`).
    #[derive(Clone, Copy, Debug)]
    struct Kepler = p1^2 + p2^2 - (q1^2 + q2^2)^(-1/2)
}

/// The kinetic energy of a state with unit masses, `|p|^2 / 2`.
fn kinetic_half(z: &DVector<f64>) -> f64 {
    let m = z.len() / 2;
    (m..2 * m).map(|k| 0.5 * z[k] * z[k]).sum()
}

/// The cluster's `H` without exact divided differences: everything forwarded but the discrete
/// gradient and its defect, which take the trait's defaults (Gonzalez's midpoint discrete
/// gradient from plain differences of `H`).
struct Gonzalez<'a>(&'a RuntimeHamiltonian);

impl Hamiltonian<Dyn> for Gonzalez<'_> {
    fn dim(&self) -> Dyn {
        Hamiltonian::<Dyn>::dim(self.0)
    }
    fn flags(&self) -> Flags {
        Hamiltonian::<Dyn>::flags(self.0).with_exact_divided_differences(false)
    }
    fn hessian_pattern(&self) -> Option<&[(usize, usize)]> {
        Hamiltonian::<Dyn>::hessian_pattern(self.0)
    }
    fn value(&self, z: &DVector<f64>) -> f64 {
        Hamiltonian::<Dyn>::value(self.0, z)
    }
    fn gradient_into(&self, z: &DVector<f64>, out: &mut DVector<f64>) {
        Hamiltonian::<Dyn>::gradient_into(self.0, z, out);
    }
    fn hessian_into(&self, z: &DVector<f64>, out: &mut DMatrix<f64>) {
        Hamiltonian::<Dyn>::hessian_into(self.0, z, out);
    }
    fn hessian_nonzeros(&self, z: &DVector<f64>, values: &mut [f64]) {
        Hamiltonian::<Dyn>::hessian_nonzeros(self.0, z, values);
    }
    fn derivatives_into(&self, z: &DVector<f64>, out: &mut Derivatives<Dyn>) {
        Hamiltonian::<Dyn>::derivatives_into(self.0, z, out);
    }
}

/// What a run shows about the energy at its points.
#[derive(Debug, Default)]
struct Energy {
    /// The largest `|H - H0| / s(z)` over all points.
    roundoff: f64,
    /// The largest `|H - H0| / (T + |V|)` over the fallback nodes and over the DTH midpoints.
    terms: (f64, f64),
    /// Fallback steps taken.
    fallback: usize,
    /// The largest `s(z) / |H0|`: how close the encounters came.
    closest: f64,
    /// At the point of the largest `|H - H0|`: that deviation, and the change of `H` one ulp
    /// of the coordinate of the largest `|z_i dH/dz_i|` makes (the float grid's step there).
    largest: (f64, f64),
}

/// `steps` robust steps of `dtau` from `z0`, the first with `lambda0`, every point measured;
/// `kinetic` is `H`'s kinetic energy `T` (`H - T` the potential `V`).
fn energy<D: Dim, H: Hamiltonian<D>>(
    h: &H,
    z0: OVector<f64, D>,
    (dtau, lambda0): (f64, f64),
    steps: usize,
    kinetic: impl Fn(&OVector<f64, D>) -> f64,
) -> Energy
where
    DefaultAllocator: Alloc<D>,
{
    let e0 = h.value(&z0);
    let options = DthOptions::new(dtau)
        .expect("dtau > 0")
        .with_lambda0(lambda0)
        .expect("lambda0 > 0")
        .with_robust(true);
    let mut dth = Dth::new(h, z0, options).expect("start");
    let mut out = Energy::default();
    for k in 1..=steps {
        let r = dth
            .step()
            .unwrap_or_else(|e| panic!("the robust run stopped at step {k}: {e}"));
        let fallback = r.kind == StepKind::Fallback;
        out.fallback += usize::from(fallback);
        let value = h.value(&r.z);
        let deviation = (value - e0).abs();
        let t = kinetic(&r.z);
        let terms = deviation / (t + (value - t).abs());
        if fallback {
            out.terms.0 = out.terms.0.max(terms);
        } else {
            out.terms.1 = out.terms.1.max(terms);
        }
        let sensitivity = r.z.component_mul(&h.gradient(&r.z)).abs();
        let s = sensitivity.sum().max(e0.abs());
        out.roundoff = out.roundoff.max(deviation / s);
        out.closest = out.closest.max(s / e0.abs());
        if deviation > out.largest.0 {
            let mut moved = r.z.clone();
            let i = sensitivity.imax();
            moved[i] = f64::from_bits(moved[i].to_bits() + 1);
            out.largest = (deviation, (h.value(&moved) - value).abs());
        }
    }
    out
}

/// Bound of `|H - H0| / s(z)` (as in `robust_long_run.rs`): every coordinate of a projected
/// point is rounded by at most half an ulp, `eps/2` of `s`, and the two evaluations compared
/// (`H(z)`, `H0`) are each rounded by a few `eps` of their terms, which `s` bounds (for `1/r`
/// potentials `sum_i q_i . dV/dq_i = -V`, so `s >= 2T + |V|`). Measured: 0.4 eps (cluster,
/// 5,056 steps), 0.6 eps (Kepler).
const ROUNDOFF: f64 = 8.0 * f64::EPSILON;

/// Bound of `|H - H0| / (T + |V|)` at fallback nodes: a node the momenta's move leaves alone is
/// within `8 eps max(|E|, 2T)` of `H = E` (`dth::robust::MOVE_MOMENTA_ABOVE`), at most
/// `16 eps (T + |V|)`; a moved one keeps the momenta's own rounding (at most `eps T`) and the
/// rounding of the two evaluations of `H` compared, sums of 1,325 terms here, a few eps in
/// practice. Measured: up to 7.1 eps (cluster without the binary, 5,056 steps, both discrete
/// gradients), 6.6 eps here, 0.7 eps (Kepler). Below the issue's `1e-14` (45 eps).
const TERMS: f64 = 16.0 * f64::EPSILON;

/// The cluster's step and first multiplier: the issue's `dtau`, and a first physical step
/// `lambda0 dtau = 2e-8` of the order of the binary's pericentre passage (`r / v = 1.6e-8`);
/// from `lambda0 = 1` the first steps are a thousand times too long, and their solves fail
/// and halve a dozen times at `D = 200` before one converges.
const CLUSTER_STEP: (f64, f64) = (0.002, 1e-5);

/// Steps of the cluster, about three in four of them fallback steps (148 of 200 measured;
/// `D = 200`: dense `200 x 200` solves; the dependencies are optimized in debug builds too).
fn cluster_steps() -> usize {
    if cfg!(debug_assertions) {
        60
    } else {
        200
    }
}

/// The bounds; DTH midpoints are held to the terms' one only where `midpoints` says so.
fn check(name: &str, e: &Energy, midpoints: bool) {
    println!("{name}: {e:?}");
    let eps = f64::EPSILON;
    assert!(e.fallback > 0, "{name}: no fallback step");
    assert!(
        e.roundoff <= ROUNDOFF,
        "{name}: |H - H0| / s = {:.2} eps",
        e.roundoff / eps
    );
    assert!(
        e.terms.0 <= TERMS,
        "{name}: |H - H0| / (T + |V|) = {:.2} eps at a fallback node",
        e.terms.0 / eps
    );
    if midpoints {
        assert!(
            e.terms.1 <= TERMS,
            "{name}: |H - H0| / (T + |V|) = {:.2} eps at a DTH midpoint",
            e.terms.1 / eps
        );
    }
}

#[test]
fn cluster_with_exact_divided_differences() {
    let h = cluster();
    let z0 = cluster_state(&h);
    let e = energy(&h, z0, CLUSTER_STEP, cluster_steps(), kinetic_half);
    check("exact", &e, false);
    // The test is about close encounters: s must have gone far beyond |H0|.
    assert!(e.closest > 1e6, "no close encounter ({:e})", e.closest);
}

#[test]
fn cluster_with_gonzalez_discrete_gradient() {
    let h = cluster();
    let z0 = cluster_state(&h);
    let e = energy(
        &Gonzalez(&h),
        z0,
        CLUSTER_STEP,
        cluster_steps(),
        kinetic_half,
    );
    check("gonzalez", &e, false);
    assert!(e.closest > 1e6, "no close encounter ({:e})", e.closest);
}

#[test]
fn kepler_high_eccentricity() {
    // Pericentre 0.5 at q = (0.5, 0); p2^2 = 1 + e (H = p^2 - 1/r): about three orbits of
    // e = 0.9 at the scene's dtau.
    for e in [0.9, 0.99] {
        let z0 = Vector4::new(0.5, 0.0, 0.0, (1.0f64 + e).sqrt());
        let r = energy(&Kepler, z0, (0.0157, 1.0), 1_600, |z| {
            z[2] * z[2] + z[3] * z[3]
        });
        // Kepler's two scales are alike (`s = 2T + |V|`): the midpoints meet the terms' bound.
        check(&format!("Kepler e = {e}"), &r, true);
    }
}
