//! DTH of order 4, 6 and 8 by symmetric composition (`DthOptions::with_order`), and runs that
//! end exactly at a given time (`Dth::step_toward`): observed orders against the exact Kepler
//! solution, time reversibility of a composed step, energy at every sub-step midpoint, the
//! other problems, breakdown and the robust mode.

use dth_core::dth::{Dth, DthOptions, Solver};
use dth_core::kepler::KeplerOrbit;
use dth_core::nalgebra::Const;
use dth_core::nalgebra::{SVector, Vector2, Vector4};
use dth_core::observer::StepKind;
use dth_core::systems::{HenonHeiles, Kepler, Pendulum};
use dth_core::{Error, Hamiltonian};

const EPS: f64 = f64::EPSILON;

fn thesis_z0() -> Vector4<f64> {
    Vector4::new(0.5, 0.0, 0.0, 1.2)
}

fn options(dtau: f64, order: u32) -> DthOptions {
    DthOptions::new(dtau)
        .and_then(|o| o.with_order(order))
        .expect("valid options")
}

/// Run to `t_end` exactly; the final state, its time and the largest `|H - H(zbar_0)|` seen at
/// a step's midpoint.
fn run_to<H: Hamiltonian<Const<D>> + Clone, const D: usize>(
    h: &H,
    z0: SVector<f64, D>,
    options: DthOptions,
    t_end: f64,
) -> (SVector<f64, D>, f64, f64) {
    let e0 = h.value(&z0);
    let mut dth = Dth::new(h.clone(), z0, options).expect("valid start");
    let mut worst = 0.0_f64;
    loop {
        let (r, done) = dth
            .step_toward(t_end)
            .unwrap_or_else(|e| panic!("order {}: {e}", options.order()));
        worst = worst.max((h.value(&r.z) - e0).abs());
        if done {
            return (*dth.zbar(), dth.tbar(), worst);
        }
    }
}

/// Least-squares slope of `log(error)` against `log(dtau)`.
fn slope(points: &[(f64, f64)]) -> f64 {
    let n = points.len() as f64;
    let (xs, ys): (Vec<f64>, Vec<f64>) = points.iter().map(|(h, e)| (h.ln(), e.ln())).unzip();
    let (mx, my) = (xs.iter().sum::<f64>() / n, ys.iter().sum::<f64>() / n);
    let sxy: f64 = xs.iter().zip(&ys).map(|(x, y)| (x - mx) * (y - my)).sum();
    let sxx: f64 = xs.iter().map(|x| (x - mx) * (x - mx)).sum();
    sxy / sxx
}

/// Observed order on the thesis orbit (e = 0.44) after three periods, ending exactly at
/// `T = 3 x 3.748..`: the slope of the global error against `dtau` over a factor 2 of `dtau`
/// (five step sizes; halving alone gives 7.6-8.0 at order 8: where the pericentre passages
/// fall on the grid moves the error by a few percent), with every error well above the
/// roundoff floor (about 5e-14 here).
#[test]
fn observed_orders_against_the_exact_kepler_solution() {
    let kepler = Kepler::thesis();
    let z0 = thesis_z0();
    let orbit = KeplerOrbit::new(&kepler, &z0).expect("elliptic");
    let t_end = 3.0 * orbit.elements().period;
    for (order, dtaus) in [
        (2, [0.04, 0.035, 0.03, 0.025, 0.02]),
        (4, [0.08, 0.07, 0.06, 0.05, 0.04]),
        (6, [0.08, 0.07, 0.06, 0.05, 0.04]),
        (8, [0.05, 0.04375, 0.0375, 0.03125, 0.025]),
    ] {
        let points: Vec<(f64, f64)> = dtaus
            .iter()
            .map(|&dtau| {
                let (z, t, energy) = run_to(&kepler, z0, options(dtau, order), t_end);
                assert!(
                    (t - t_end).abs() <= 4.0 * EPS * t_end,
                    "order {order}: ends at {t}"
                );
                // |H| = 0.56, terms of size 2: a few eps.
                assert!(energy <= 4.0 * EPS, "order {order}: energy {energy:e}");
                (dtau, (z - orbit.state_at(t_end)).norm())
            })
            .collect();
        let observed = slope(&points);
        println!("order {order}: observed {observed:.3} from {points:?}");
        assert!(
            (observed - f64::from(order)).abs() <= 0.3,
            "order {order}: observed {observed:.3} from {points:?}"
        );
        // Ten times the roundoff floor: the slope is not bent by roundoff.
        assert!(points.iter().all(|p| p.1 > 5e-13), "{points:?}");
    }
}

/// The largest component of `a - b` relative to the larger component size, in eps.
fn ulps<const D: usize>(a: &SVector<f64, D>, b: &SVector<f64, D>) -> f64 {
    (a - b).amax() / (a.amax().max(b.amax()) * EPS)
}

/// One composed step, then its sub-steps with `-gamma_i dtau` in reverse order: back at the
/// start (midpoint, lambda and time) to roundoff, at every order and with both Newton solvers,
/// with the negative sub-steps of the forward step run forwards in time on the way back.
#[test]
fn one_composed_step_is_time_reversible() {
    let kepler = Kepler::thesis();
    for (order, solver) in [2, 4, 6, 8]
        .into_iter()
        .flat_map(|o| [(o, Solver::Joint), (o, Solver::Nested)])
    {
        let o = options(0.1, order).with_solver(solver);
        let mut dth = Dth::new(kepler, thesis_z0(), o).expect("valid start");
        // Start away from the pericentre, where lambda changes along the step.
        for _ in 0..3 {
            dth.step().expect("step");
        }
        let (z, lambda, t) = (*dth.zbar(), dth.lambda(), dth.tbar());
        dth.step().expect("composed step");
        assert!(dth.tbar() > t);
        for &gamma in o.composition().coefficients().iter().rev() {
            dth.step_with(-gamma * o.dtau()).expect("backward sub-step");
        }
        // Each sub-step solves to a few eps; 2 x 17 of them add up to at most ~30 eps.
        let dz = ulps(dth.zbar(), &z);
        let dl = (dth.lambda() - lambda).abs() / (lambda * EPS);
        let dt = (dth.tbar() - t).abs() / (t * EPS);
        println!(
            "order {order}, {solver:?}: back to start within {dz:.1} eps (z), {dl:.1} (lambda), {dt:.1} (t)"
        );
        assert!(
            dz <= 32.0 && dl <= 32.0 && dt <= 32.0,
            "order {order}: {dz} {dl} {dt}"
        );
    }
}

/// Energy at the midpoint of every sub-step (backwards ones included) within a few eps of
/// `|H|`; a composed step is exactly its sub-steps (bit for bit), and `lambda` stays positive.
#[test]
fn energy_is_exact_at_every_sub_step_midpoint() {
    let kepler = Kepler::thesis();
    let z0 = thesis_z0();
    let e0 = kepler.value(&z0);
    for order in [4, 6, 8] {
        let o = options(0.1, order);
        let mut composed = Dth::new(kepler, z0, o).expect("valid start");
        let mut manual = Dth::new(kepler, z0, o).expect("valid start");
        let mut worst = 0.0_f64;
        let mut backwards = 0;
        // Two orbits: through pericentre and apocentre.
        for _ in 0..60 {
            composed.step().expect("composed step");
            for &gamma in o.composition().coefficients() {
                let t = manual.tbar();
                let r = manual.step_with(gamma * o.dtau()).expect("sub-step");
                backwards += usize::from(r.t < t);
                worst = worst.max((kepler.value(&r.z) - e0).abs());
                assert!(r.dth.is_some_and(|d| d.lambda > 0.0));
            }
            assert_eq!(manual.zbar(), composed.zbar());
            assert_eq!(manual.lambda(), composed.lambda());
            assert_eq!(manual.tbar(), composed.tbar());
        }
        println!(
            "order {order}: max |H - H0| = {worst:e} over all sub-steps, {backwards} backwards"
        );
        assert!(backwards > 0);
        // |H| = 0.56; its terms are of size 2: 4 eps.
        assert!(worst <= 4.0 * EPS, "order {order}: {worst:e}");
    }
}

/// `T` given, the run ends on it (thesis orbit, `T = 11.2450`: plain DTH used to stop at
/// 11.2507, the first midpoint past it), every order.
#[test]
fn runs_end_exactly_at_the_requested_time() {
    let kepler = Kepler::thesis();
    let t_end = 11.245;
    for order in [2, 4, 6, 8] {
        let (_, t, _) = run_to(&kepler, thesis_z0(), options(0.06277, order), t_end);
        assert!((t - t_end).abs() <= 4.0 * EPS * t_end, "order {order}: {t}");
        // Only the last step is shortened, and says so.
        let mut dth = Dth::new(kepler, thesis_z0(), options(0.06277, order)).expect("start");
        let mut kinds = Vec::new();
        loop {
            let (r, done) = dth.step_toward(t_end).expect("step");
            // The borrowed record is the one returned (the shortened step's too).
            assert_eq!(dth.record_ref(), &r);
            kinds.push(r.kind);
            if done {
                break;
            }
        }
        assert_eq!(kinds.pop(), Some(StepKind::Shortened));
        assert!(kinds.iter().all(|k| *k == StepKind::Dth));
    }
    // Before the current time: a typed error; at it, nothing to do.
    let mut dth = Dth::new(kepler, thesis_z0(), options(0.1, 4)).expect("valid start");
    assert!(matches!(
        dth.step_toward(-0.1),
        Err(Error::InvalidOption { name: "t_end", .. })
    ));
    assert_eq!(dth.step_toward(0.0), Ok((dth.record(), true)));
    assert_eq!(dth.k(), 0);
    assert!(matches!(
        dth.step_with(0.0),
        Err(Error::InvalidOption { name: "dtau", .. })
    ));
}

/// The error at `T` of runs at `dtau`, `dtau/2`, `dtau/4`: where there is no exact solution,
/// the differences of successive runs fall by `2^p` (their ratio gives the order).
fn self_convergence<H: Hamiltonian<Const<D>> + Clone, const D: usize>(
    h: &H,
    z0: SVector<f64, D>,
    dtau: f64,
    order: u32,
    t_end: f64,
) -> f64 {
    let runs: Vec<SVector<f64, D>> = [1.0, 0.5, 0.25]
        .iter()
        .map(|f| {
            let (z, t, energy) = run_to(h, z0, options(dtau * f, order), t_end);
            // These two have the plain energy residual: lambda, and so the time, carries a
            // relative noise of about eps / (h lambda)^2 per sub-step (1e-13 at h lambda = 0.03),
            // and the end time is found to within it.
            assert!((t - t_end).abs() <= 1e-13 * t_end, "{t}");
            // H of size 1 or below here, with terms of size 1: a few eps.
            assert!(energy <= 4.0 * EPS, "order {order}: energy {energy:e}");
            z
        })
        .collect();
    let (d1, d2) = ((runs[0] - runs[1]).norm(), (runs[1] - runs[2]).norm());
    (d1 / d2).log2()
}

/// Kepler at e = 0.7 (exact solution), Henon-Heiles and the pendulum (self-convergence):
/// each order runs, conserves energy at every step, and shows its order.
#[test]
fn orders_on_kepler_e07_henon_heiles_and_the_pendulum() {
    // Kepler e = 0.7 from its pericentre r = 0.5 (m = 1/2, k = 1): speed sqrt(mu (1 + e) / r).
    let kepler = Kepler::thesis();
    let z0 = Vector4::new(0.5, 0.0, 0.0, 0.5 * (2.0f64 * 1.7 / 0.5).sqrt());
    let orbit = KeplerOrbit::new(&kepler, &z0).expect("elliptic");
    let t_end = 3.0 * orbit.elements().period;
    for (order, dtau) in [(4, 0.04), (6, 0.04), (8, 0.04)] {
        let points: Vec<(f64, f64)> = [1.0, 0.875, 0.75, 0.625, 0.5]
            .iter()
            .map(|f| f * dtau)
            .map(|d| {
                let (z, _, energy) = run_to(&kepler, z0, options(d, order), t_end);
                assert!(energy <= 4.0 * EPS, "order {order}: energy {energy:e}");
                (d, (z - orbit.state_at(t_end)).norm())
            })
            .collect();
        let observed = slope(&points);
        println!("kepler e = 0.7, order {order}: observed {observed:.3} from {points:?}");
        // At order 8 the next term of the error (h^10) still dominates over this range (the
        // last pair alone gives 8.2; smaller steps reach roundoff): at least the order.
        let tolerance = if order == 8 { 2.0 } else { 0.3 };
        assert!(
            observed >= f64::from(order) - 0.3 && observed <= f64::from(order) + tolerance,
            "{points:?}"
        );
    }
    // Henon-Heiles at E = 1/8 from q = (0, 0.1), p2 = 0; pendulum at amplitude 2 rad.
    let v: f64 = 0.5 * 0.01 - 0.001 / 3.0;
    let hh0 = Vector4::new(0.0, 0.1, (2.0 * (0.125 - v)).sqrt(), 0.0);
    let pendulum0 = Vector2::new(2.0, 0.0);
    for (order, dtau) in [(4, 0.4), (6, 0.4), (8, 0.4)] {
        let hh = self_convergence(&HenonHeiles, hh0, dtau, order, 10.0);
        let pendulum = self_convergence(&Pendulum::normalized(), pendulum0, dtau, order, 10.0);
        println!("order {order}: henon-heiles {hh:.3}, pendulum {pendulum:.3}");
        for observed in [hh, pendulum] {
            assert!(
                (observed - f64::from(order)).abs() <= 0.3,
                "order {order}: {observed}"
            );
        }
    }
}

/// Kepler at e = 0.9 (`Psi` changes sign on the orbit): every order stops with a breakdown,
/// as order 2 does; in robust mode every order goes through with fallback steps and keeps the
/// energy at every step.
#[test]
fn breakdown_and_robust_mode_at_every_order() {
    let kepler = Kepler::thesis();
    let z0 = Vector4::new(0.5, 0.0, 0.0, 1.9f64.sqrt());
    let e0 = kepler.value(&z0);
    for order in [2, 4, 6, 8] {
        let o = options(0.0157, order);
        let mut dth = Dth::new(kepler, z0, o).expect("valid start");
        let stopped = (0..1000).find_map(|_| dth.step().err());
        assert!(
            matches!(stopped, Some(Error::Breakdown { psi, .. }) if psi < 0.0),
            "order {order}: {stopped:?}"
        );
        let mut dth = Dth::new(kepler, z0, o.with_robust(true)).expect("valid start");
        let (mut fallback, mut worst) = (0, 0.0_f64);
        for _ in 0..1000 {
            let r = dth.step().unwrap_or_else(|e| panic!("order {order}: {e}"));
            // The borrowed record is the returned one, also after a fallback step that
            // resumed DTH (the resume changes the state's lambda after the record is made).
            assert_eq!(dth.record_ref(), &r, "order {order}, step {}", r.k);
            fallback += usize::from(r.kind == StepKind::Fallback);
            worst = worst.max((kepler.value(&r.z) - e0).abs());
            assert!(r.dth.is_some_and(|d| d.lambda > 0.0));
        }
        println!(
            "order {order}: {fallback} steps with fallback sub-steps, energy {worst:e}, t = {}",
            dth.tbar()
        );
        assert!(fallback > 0 && fallback < 1000, "order {order}: {fallback}");
        // |H| = 0.05, terms of size 4: a few eps of those.
        assert!(worst <= 1e-14, "order {order}: {worst:e}");
        // And after the steps of a run that ends at a given time, through the fallbacks.
        let t_end = dth.tbar() + 20.0;
        let mut fallback = 0;
        loop {
            let (r, done) = dth
                .step_toward(t_end)
                .unwrap_or_else(|e| panic!("order {order}: {e}"));
            assert_eq!(dth.record_ref(), &r, "order {order}, step {}", r.k);
            fallback += usize::from(r.kind == StepKind::Fallback);
            if done {
                break;
            }
        }
        assert!(
            fallback > 0,
            "order {order}: no fallback on the way to t_end"
        );
    }
}

/// A run that ends at a given time on a fallback step which resumes DTH: the borrowed record
/// is the one `step_toward` returned. (The resume sets the state's `lambda` to the law of
/// time's after the step's record is made, so the record cannot be rebuilt from the state.)
#[test]
fn a_run_ending_on_a_resuming_fallback_step_keeps_its_record() {
    let kepler = Kepler::thesis();
    let z0 = Vector4::new(0.5, 0.0, 0.0, 1.9f64.sqrt());
    for order in [2, 4] {
        let o = options(0.0157, order).with_robust(true);
        let mut dth = Dth::new(kepler, z0, o).expect("valid start");
        // The first step that falls back and resumes DTH, and the state before it.
        let (before, t_end) = (0..1000)
            .find_map(|_| {
                let before = dth.clone();
                let r = dth.step().unwrap_or_else(|e| panic!("order {order}: {e}"));
                (r.kind == StepKind::Fallback && !dth.in_fallback()).then_some((before, r.t))
            })
            .unwrap_or_else(|| panic!("order {order}: no fallback step resumed DTH"));
        // Ending exactly where that step ends takes the same step as the last one.
        let mut again = before;
        let (r, done) = again.step_toward(t_end).expect("the same step");
        assert!(done && r.kind == StepKind::Fallback, "order {order}: {r:?}");
        assert_eq!(again.record_ref(), &r, "order {order}");
    }
}
