//! The robust mode converges, ends where it is asked to, keeps the energy at roundoff, and
//! runs DTH wherever `Psi` allows it: Kepler at e = 0.9 and 0.99, the pendulum in rotation and
//! a strongly driven pendulum, where `Psi` changes sign along every orbit.
//!
//! Errors are global: the final state against Kepler's equation, or against a 2-stage
//! Gauss-Legendre reference whose own error (checked here against the same method at half its
//! step) is far below the errors measured. The observed order over three halvings of `dtau` is
//! `log2(e_0 / e_3) / 3`.

use dth::dth::{Dth, DthOptions};
use dth::kepler::KeplerOrbit;
use dth::methods::{run, GaussLegendre2};
use dth::nalgebra::{Const, SVector, Vector2, Vector4};
use dth::observer::StepKind;
use dth::systems::{Kepler, Pendulum};
use dth::Hamiltonian;

dth::hamiltonian! {
    /// A pendulum whose gravity is modulated strongly (`a w^2 = 1.2`): `Psi` gains `H_tt`,
    /// which changes sign with the drive.
    #[derive(Clone, Copy, Debug)]
    struct DrivenPendulum = p1^2/2 - (1 + 3/10*cos(2*t))*cos(q1)
}

const EPS: f64 = f64::EPSILON;

/// The end of a robust run.
struct End<const D: usize> {
    z: SVector<f64, D>,
    t: f64,
    steps: usize,
    fallback: usize,
    /// Largest `|H - H0| / s(z)` over every point, `s(z) = max(|H0|, sum_i |z_i dH/dz_i|)` the
    /// roundoff scale of evaluating `H`.
    energy: f64,
}

/// A robust run of order `order` from `z0` that ends at `t_end` (`Dth::step_toward`).
fn robust_to<H: Hamiltonian<Const<D>> + Clone, const D: usize>(
    h: &H,
    z0: SVector<f64, D>,
    dtau: f64,
    order: u32,
    t_end: f64,
) -> End<D> {
    let options = DthOptions::new(dtau)
        .and_then(|o| o.with_order(order))
        .expect("valid options")
        .with_robust(true);
    let mut dth = Dth::new(h.clone(), z0, options).expect("valid start");
    let e0 = h.value(&z0);
    let (mut steps, mut fallback, mut energy) = (0, 0, 0.0f64);
    loop {
        let (r, done) = dth
            .step_toward(t_end)
            .unwrap_or_else(|e| panic!("dtau {dtau}, order {order}: {e}"));
        steps += 1;
        fallback += usize::from(r.kind == StepKind::Fallback);
        let scale =
            r.z.component_mul(&h.gradient(&r.z))
                .abs()
                .sum()
                .max(e0.abs());
        energy = energy.max((h.value(&r.z) - e0).abs() / scale);
        if done {
            return End {
                z: *dth.zbar(),
                t: dth.tbar(),
                steps,
                fallback,
                energy,
            };
        }
    }
}

/// Check what every robust run must do: end at `t_end` to the roundoff of the time sum, keep
/// the energy at every point to the roundoff of evaluating `H` (each point is projected onto
/// `H = H0`: a few eps, 8 allowing for the projection's own evaluation; the issue asks for
/// 1e-14), and return its error against `exact`.
fn checked<const D: usize>(
    name: &str,
    dtau: f64,
    end: &End<D>,
    t_end: f64,
    exact: &SVector<f64, D>,
) -> f64 {
    let error = (end.z - exact).amax();
    println!(
        "{name}, dtau {dtau:.3e}: {} steps, {} fallback, ends at {} (T = {t_end}), error {error:.3e}, energy {:.1} eps",
        end.steps,
        end.fallback,
        end.t,
        end.energy / EPS
    );
    assert!(
        (end.t - t_end).abs() <= 4.0 * EPS * t_end,
        "{name}: ended at {} for {t_end}",
        end.t
    );
    assert!(end.energy <= 8.0 * EPS, "{name}: energy {:e}", end.energy);
    error
}

/// The observed order over three halvings (`errors` at `dtau, dtau/2, dtau/4, dtau/8`), and
/// each halving's; the overall one must be at least 1.9, each at least 1.5 (the steps cross the
/// bands where `Psi` changes sign at places that move with `dtau`, which makes single halvings
/// wobble around 2).
fn assert_second_order(name: &str, errors: &[f64; 4]) {
    let each: Vec<f64> = errors.windows(2).map(|w| (w[0] / w[1]).log2()).collect();
    let overall = (errors[0] / errors[3]).log2() / 3.0;
    println!("{name}: observed order {overall:.3} ({each:.3?})");
    assert!(overall >= 1.9, "{name}: {overall} from {errors:?}");
    assert!(each.iter().all(|&o| o >= 1.5), "{name}: {each:?}");
}

#[test]
fn kepler_at_e09_and_e099_converges_at_second_order_and_ends_at_t() {
    let kepler = Kepler::thesis();
    for (e, dtau) in [(0.9, 0.004), (0.99, 0.002)] {
        // Pericentre r = 0.5 (m = 1/2, k = 1), three orbits.
        let z0 = Vector4::new(0.5, 0.0, 0.0, (1.0f64 + e).sqrt());
        let orbit = KeplerOrbit::new(&kepler, &z0).expect("elliptic");
        let t_end = 3.0 * orbit.elements().period;
        let exact = orbit.state_at(t_end);
        let mut errors = [0.0; 4];
        for (i, error) in errors.iter_mut().enumerate() {
            let dtau = dtau / f64::from(1 << i);
            let end = robust_to(&kepler, z0, dtau, 2, t_end);
            assert!(end.fallback > 0, "e {e}: Psi changes sign on this orbit");
            *error = checked(&format!("kepler e {e}"), dtau, &end, t_end, &exact);
            // The bar for the robust mode at e = 0.9: within 1e-3 of Kepler's
            // equation at `dtau = 0.001` after three orbits (1.15e-2 when it was filed, 1.41e-3
            // with a fallback law bounded at DTH's edge value; 9.2e-4 now, `dth::robust`).
            if e == 0.9 && dtau == 0.001 {
                assert!(*error <= 1e-3, "e 0.9, dtau 0.001: {error:e}");
            }
        }
        assert_second_order(&format!("kepler e {e}"), &errors);
    }
}

/// `|Psi| / sum_ij |v_i H_ij v_j|` (`v = J grad H`, `Psi = sum_ij v_i H_ij v_j`): 0 where
/// `Psi` changes sign, 1 where its terms do not cancel.
fn cancellation<H: Hamiltonian<Const<4>>>(h: &H, z: &Vector4<f64>) -> f64 {
    let g = h.gradient(z);
    let hess = h.hessian(z);
    let v = Vector4::new(g[2], g[3], -g[0], -g[1]);
    let mut terms = 0.0;
    for i in 0..4 {
        for j in 0..4 {
            terms += (v[i] * hess[(i, j)] * v[j]).abs();
        }
    }
    v.dot(&(hess * v)).abs() / terms
}

/// On Kepler at e = 0.9, `Psi` is negative for 1.12 < r < 6.38 and positive inside and outside
/// (`Psi = u^3 (12 L^2 u^2 - 6 u - 8 H)`, `u = 1/r`): DTH runs on both sides of each sign change
/// and fallback steps bridge only the bands around them. No fallback step on the apocentre arc
/// r > 8 (apocentre 9.5), where `Psi` has kept its sign since r = 6.38; every DTH midpoint is
/// where `Psi` does not cancel, every fallback node near where it does.
#[test]
fn kepler_at_e09_runs_dth_wherever_psi_keeps_its_sign() {
    let kepler = Kepler::thesis();
    let z0 = Vector4::new(0.5, 0.0, 0.0, 1.9f64.sqrt());
    let period = KeplerOrbit::new(&kepler, &z0)
        .expect("elliptic")
        .elements()
        .period;
    let options = DthOptions::new(0.002).expect("valid").with_robust(true);
    let mut dth = Dth::new(kepler, z0, options).expect("valid start");
    let (mut apocentre_dth, mut apocentre_fallback, mut negative_dth) = (0, 0, 0);
    let (mut dth_min, mut fallback_max, mut arc_min) = (f64::INFINITY, 0.0f64, f64::INFINITY);
    while dth.tbar() < period {
        let r = dth.step().expect("robust step");
        let radius = r.z[0].hypot(r.z[1]);
        let ratio = cancellation(&kepler, &r.z);
        match r.kind {
            StepKind::Fallback => {
                apocentre_fallback += usize::from(radius > 8.0);
                fallback_max = fallback_max.max(ratio);
            }
            _ => {
                apocentre_dth += usize::from(radius > 8.0);
                if radius > 8.0 {
                    arc_min = arc_min.min(ratio);
                }
                negative_dth += usize::from(r.dth.is_some_and(|d| d.psi < 0.0));
                dth_min = dth_min.min(ratio);
            }
        }
    }
    println!(
        "e 0.9, one orbit: apocentre arc {apocentre_dth} DTH and {apocentre_fallback} fallback \
         steps; {negative_dth} DTH midpoints with Psi < 0; smallest |Psi| / terms at a DTH \
         midpoint {dth_min:.3}, largest at a fallback node {fallback_max:.3}, smallest on the \
         apocentre arc {arc_min:.3}"
    );
    // The arc is where Psi has kept its sign, with its terms far from cancelling.
    assert!(arc_min > 0.2, "{arc_min}");
    assert_eq!(apocentre_fallback, 0);
    assert!(apocentre_dth > 10 && negative_dth > 10);
    // The robust mode leaves DTH below 6.5% (order 2) and resumes from 10%, deciding at the end
    // of each step: a DTH midpoint may lie one step inside the band, a fallback node one step
    // past its edge. Neither lies deep inside the other's region (under a quarter of 6.5%, a
    // doubling of 10%).
    assert!(dth_min >= 0.0125, "{dth_min}");
    assert!(fallback_max < 0.2, "{fallback_max}");
}

/// A 2-stage Gauss-Legendre reference at `t_end` with `n` steps, checked against `2 n` steps:
/// its own error must be below a thousandth of `floor`.
fn reference<H: Hamiltonian<Const<D>>, const D: usize>(
    h: &H,
    z0: &SVector<f64, D>,
    t0: f64,
    t_end: f64,
    n: usize,
    floor: f64,
) -> SVector<f64, D> {
    let at = |n: usize| {
        run(
            &mut GaussLegendre2::new(),
            h,
            z0,
            t0,
            (t_end - t0) / n as f64,
            n,
            &mut (),
        )
        .expect("reference")
        .z
    };
    let (coarse, fine) = (at(n), at(2 * n));
    let own = (coarse - fine).amax();
    assert!(own < 1e-3 * floor, "reference error {own:e} vs {floor:e}");
    fine
}

#[test]
fn pendulum_in_rotation_converges_at_second_order_and_ends_at_t() {
    let pendulum = Pendulum::normalized();
    // The run of the issue: q = 0, p = 2.5, dtau = 0.05, to t = 100 (it stopped at 99.9909).
    let z0 = Vector2::new(0.0, 2.5);
    let end = robust_to(&pendulum, z0, 0.05, 2, 100.0);
    assert!(end.fallback > 0);
    checked("pendulum rotation, issue's run", 0.05, &end, 100.0, &end.z);
    let t_end = 20.0;
    let runs: Vec<(f64, End<2>)> = [0.01, 0.005, 0.0025, 0.00125]
        .into_iter()
        .map(|dtau| (dtau, robust_to(&pendulum, z0, dtau, 2, t_end)))
        .collect();
    let exact = reference(&pendulum, &z0, 0.0, t_end, 20_000, 1e-6);
    let errors: Vec<f64> = runs
        .iter()
        .map(|(dtau, end)| checked("pendulum rotation", *dtau, end, t_end, &exact))
        .collect();
    assert!(runs.iter().all(|(_, end)| end.fallback > 0));
    assert_second_order(
        "pendulum rotation",
        &[errors[0], errors[1], errors[2], errors[3]],
    );
}

#[test]
fn strongly_driven_pendulum_converges_at_second_order_and_ends_at_t() {
    let driven = DrivenPendulum;
    // Extended phase space z = (q, t, p, p_t) with p_t = -H(t0, q, p): from q = 1, p = 0 at t = 0.
    let mut z0 = Vector4::new(1.0, 0.0, 0.0, 0.0);
    z0[3] = -driven.value(&z0);
    let t_end = 20.0;
    let runs: Vec<(f64, End<4>)> = [0.01, 0.005, 0.0025, 0.00125]
        .into_iter()
        .map(|dtau| (dtau, robust_to(&driven, z0, dtau, 2, t_end)))
        .collect();
    let exact = reference(&driven, &z0, 0.0, t_end, 20_000, 1e-6);
    let errors: Vec<f64> = runs
        .iter()
        .map(|(dtau, end)| checked("driven pendulum", *dtau, end, t_end, &exact))
        .collect();
    assert!(runs.iter().all(|(_, end)| end.fallback > 0));
    assert_second_order(
        "driven pendulum",
        &[errors[0], errors[1], errors[2], errors[3]],
    );
}

/// The least-squares slope of `log(error)` against `log(dtau)`.
fn fitted_order(dtaus: &[f64], errors: &[f64]) -> f64 {
    let n = dtaus.len() as f64;
    let (x, y): (Vec<f64>, Vec<f64>) = dtaus
        .iter()
        .zip(errors)
        .map(|(d, e)| (d.ln(), e.ln()))
        .unzip();
    let (mx, my) = (x.iter().sum::<f64>() / n, y.iter().sum::<f64>() / n);
    let sxy: f64 = x.iter().zip(&y).map(|(a, b)| (a - mx) * (b - my)).sum();
    let sxx: f64 = x.iter().map(|a| (a - mx) * (a - mx)).sum();
    sxy / sxx
}

/// Above order 2 a fallback stretch is a composition of discrete-gradient steps with the
/// coefficients of the DTH composition (the discrete-gradient step is symmetric), and a
/// composed DTH step any of whose sub-steps lands inside a band is redone as one, so the run
/// keeps a high order through the bands where `Psi` changes sign. Kepler e = 0.9, three orbits.
///
/// The order is the least-squares slope over a range of `dtau` (above the roundoff floor,
/// about 1e-12 here), not one halving: single halvings wobble (order 4: 3.1 to 4.6; order 8:
/// 0.5 to 14) as the band edges fall between steps differently at each `dtau`, while plain DTH
/// of the same orders on e = 0.75, which has no band, gives 4.00 and 7.9-8.7 per halving.
/// Measured: order 4, 3.77 over `dtau` 0.008 to 0.0005; order 8, 6.0 over 0.02 to 0.0035 (not
/// 8: the fallback stretches' share of the error, not yet explained). The bounds are a little
/// below these; the plateau that order 8 had (errors of 4e-5 to 1e-4 for `dtau` 0.04 to 0.01,
/// sub-steps reaching into a band) would fail them.
#[test]
fn kepler_at_e09_keeps_orders_4_and_8_through_the_fallback_stretches() {
    let kepler = Kepler::thesis();
    let z0 = Vector4::new(0.5, 0.0, 0.0, 1.9f64.sqrt());
    let orbit = KeplerOrbit::new(&kepler, &z0).expect("elliptic");
    let t_end = 3.0 * orbit.elements().period;
    let exact = orbit.state_at(t_end);
    let order_over = |order: u32, dtaus: &[f64]| {
        let errors: Vec<f64> = dtaus
            .iter()
            .map(|&dtau| {
                let end = robust_to(&kepler, z0, dtau, order, t_end);
                assert!(end.fallback > 0);
                let name = format!("kepler e 0.9, order {order}");
                checked(&name, dtau, &end, t_end, &exact)
            })
            .collect();
        let fitted = fitted_order(dtaus, &errors);
        let shown: Vec<String> = errors.iter().map(|e| format!("{e:.3e}")).collect();
        println!("order {order}: fitted {fitted:.3} from {shown:?}");
        fitted
    };
    let four = order_over(4, &[0.008, 0.004, 0.002, 0.001, 0.0005]);
    assert!(four >= 3.6, "order 4: {four}");
    let eight = order_over(8, &[0.02, 0.014, 0.01, 0.0075, 0.005, 0.0035]);
    assert!(eight >= 5.5, "order 8: {eight}");
}

/// At coarse steps the last step toward `T` meets the pericentre passage: neither DTH scaled
/// nor one fallback step of all the time left (1.3 time units, where the law of time's
/// fallback step is a few tenths) converges there. The run still ends at `T`, with fallback
/// steps of at most the law's size toward it. The `dtau` values are ones at which the last
/// step fell short before (order 2: 0.0665 reached 49.560 of 49.673; order 8: 0.108 stopped at
/// 48.70), and their neighbours over ten orbits.
#[test]
fn kepler_at_e09_ends_at_t_at_coarse_steps() {
    let kepler = Kepler::thesis();
    let z0 = Vector4::new(0.5, 0.0, 0.0, 1.9f64.sqrt());
    let orbit = KeplerOrbit::new(&kepler, &z0).expect("elliptic");
    let period = orbit.elements().period;
    let cases = [
        (2, 0.066_461_801_051_765_23, 1.0),
        (2, 0.0665, 1.0),
        (8, 0.108, 1.0),
        (8, 0.2157, 10.0),
        (8, 0.1079, 10.0),
        (8, 0.0763, 10.0),
    ];
    for (order, dtau, orbits) in cases {
        let t_end = orbits * period;
        let end = robust_to(&kepler, z0, dtau, order, t_end);
        let name = format!("kepler e 0.9, order {order}, {orbits} orbits");
        checked(&name, dtau, &end, t_end, &orbit.state_at(t_end));
    }
}
