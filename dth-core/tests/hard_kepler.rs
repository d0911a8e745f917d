//! DTH on hard Kepler orbits: eccentricities 0.44 and 0.7 at 25, 100 and 1000 points per
//! orbit; 0.9, 0.99 and 0.999, where Psi changes sign along the orbit (above sqrt(5/8) ~ 0.79):
//! a typed breakdown, then the robust mode through it; dtau from 0.2 down to 1e-6.
//!
//! Orbits start at pericentre q = (0.5, 0), p = (0, sqrt(1 + e)) (the thesis's orbit for
//! e = 0.44; m = 1/2, k = 1), with lambda_0 = 1 there.

use dth_core::dth::{integrate, Dth, DthOptions, Trajectory};
use dth_core::kepler::KeplerOrbit;
use dth_core::nalgebra::Const;
use dth_core::nalgebra::Vector4;
use dth_core::observer::StepKind;
use dth_core::systems::Kepler;
use dth_core::{Error, Hamiltonian};

const EPS: f64 = f64::EPSILON;
/// dtau of the thesis, 25 points per orbit at e = 0.44 (and, measured, at e = 0.7).
const THESIS_DTAU: f64 = 0.06277;

fn start(e: f64) -> Vector4<f64> {
    Vector4::new(0.5, 0.0, 0.0, (1.0 + e).sqrt())
}

/// Size of the terms of H at z (|T| + |V|): the scale of its evaluation roundoff.
fn terms(z: &Vector4<f64>) -> f64 {
    z[2] * z[2] + z[3] * z[3] + 1.0 / z[0].hypot(z[1])
}

/// Max |H(zbar) - H0| / terms over midpoints and robust nodes.
fn worst_energy(t: &Trajectory<Const<4>>, e0: f64) -> f64 {
    let k = Kepler::thesis();
    t.midpoints()
        .iter()
        .map(|z| (k.value(z) - e0).abs() / terms(z))
        .fold(0.0, f64::max)
}

/// Max over vertices of the distance to the exact orbit through zbar_0 (at t = 0), up to
/// time `t_max`.
fn phase_error(t: &Trajectory<Const<4>>, orbit: &KeplerOrbit, t_max: f64) -> f64 {
    t.vertices()
        .iter()
        .zip(t.vertex_times())
        .filter(|(_, &tv)| tv <= t_max)
        .map(|(z, &tv)| (z - orbit.state_at(tv)).amax())
        .fold(0.0, f64::max)
}

#[test]
fn kepler_e044_and_e07_at_25_100_1000_points_per_orbit() {
    let kepler = Kepler::thesis();
    for e in [0.44, 0.7] {
        let orbit = KeplerOrbit::new(&kepler, &start(e)).expect("elliptic");
        let period = orbit.elements().period;
        let mut errors = Vec::new();
        for points in [25usize, 100, 1000] {
            // Steps per orbit scale like 1/dtau at fixed lambda_0 (law of time).
            let dtau = THESIS_DTAU * 25.0 / points as f64;
            let options = DthOptions::new(dtau).expect("valid");
            let t = integrate(kepler, start(e), options, 3 * points)
                .unwrap_or_else(|err| panic!("e {e}, {points} points: {:?}", err.error));
            let per_orbit = t.midpoint_times().iter().filter(|&&x| x < period).count();
            let e0 = kepler.value(&start(e));
            let de = worst_energy(&t, e0);
            let dl = t
                .vertices()
                .windows(2)
                .map(|w| (Kepler::angular_momentum(&w[1]) - Kepler::angular_momentum(&w[0])).abs())
                .fold(0.0, f64::max);
            let err = phase_error(&t, &orbit, period);
            println!(
                "e {e}, dtau {dtau:.3e}: {per_orbit} points per orbit, max |dH|/terms {:.1} eps, \
                 max per-step vertex dL {:.1} eps, max error over one orbit {err:.2e}, mean \
                 Newton iterations {:.2}",
                de / EPS,
                dl / EPS,
                t.iterations()[1..]
                    .iter()
                    .map(|&i| f64::from(i))
                    .sum::<f64>()
                    / (t.len() - 1) as f64
            );
            assert!(
                (per_orbit as f64 / points as f64 - 1.0).abs() < 0.1,
                "{per_orbit}"
            );
            // Energy at midpoints (Thm 4): solved and projected to roundoff of H's terms.
            assert!(de <= 8.0 * EPS, "{de:e}");
            // Quadratic invariant at vertices (Thm 7): per-step roundoff of the vertex
            // arithmetic, a few eps of |q||p| <= 4.
            assert!(dl <= 16.0 * EPS, "{dl:e}");
            errors.push(err);
        }
        // Second order in the step: 4x and 10x more points cut the error ~16x and ~100x.
        assert!(errors[0] / errors[1] > 10.0, "e {e}: {errors:?}");
        assert!(errors[1] / errors[2] > 60.0, "e {e}: {errors:?}");
    }
}

#[test]
fn kepler_dtau_from_0_2_down_to_1e_minus_6() {
    // The thesis orbit over a fixed stretch of tau (so the small steps stay affordable): every
    // step size works, with energy exact at midpoints and the vertex angular momentum
    // conserved per step, and the law of time gives lambda in the orbit's range.
    let kepler = Kepler::thesis();
    let e0 = kepler.value(&start(0.44));
    // dtau = 0.2 is too large for this orbit: at step 14 (lambda ~ 2.9, r ~ 0.6) h lambda / 2
    // reaches sqrt(m r^3 / (2k)), where I - (h lambda/2) J Hess H is singular (J Hess H has the
    // real eigenvalues +-sqrt(2k / (m r^3)) of the radial instability): a typed failure, and
    // the robust mode carries the run through those steps.
    let options = DthOptions::new(0.2).expect("valid");
    let err = integrate(kepler, start(0.44), options, 400).expect_err("dtau 0.2");
    assert!(
        matches!(err.error, Error::SingularMatrix { step: 14 }),
        "{:?}",
        err.error
    );
    let t = integrate(kepler, start(0.44), options.with_robust(true), 400).expect("robust");
    println!(
        "dtau 0.2, robust: {} of 400 steps fallback",
        t.fallback_steps()
    );
    assert!(t.fallback_steps() > 0 && worst_energy(&t, e0) <= 8.0 * EPS);
    for dtau in [0.15, 0.1, THESIS_DTAU, 1e-2, 1e-3, 1e-4, 1e-5, 1e-6] {
        let steps = ((2.0 / dtau) as usize).clamp(20, 2_000);
        let options = DthOptions::new(dtau).expect("valid");
        let t = integrate(kepler, start(0.44), options, steps)
            .unwrap_or_else(|err| panic!("dtau {dtau}: {:?}", err.error));
        let de = worst_energy(&t, e0);
        let dl = t
            .vertices()
            .windows(2)
            .map(|w| (Kepler::angular_momentum(&w[1]) - Kepler::angular_momentum(&w[0])).abs())
            .fold(0.0, f64::max);
        println!(
            "dtau {dtau:.0e}: {steps} steps, |dH|/terms {:.1} eps, vertex dL {:.1} eps",
            de / EPS,
            dl / EPS
        );
        assert!(
            de <= 8.0 * EPS && dl <= 16.0 * EPS,
            "dtau {dtau}: {de:e} {dl:e}"
        );
        assert!(t.lambdas().iter().all(|&l| l > 0.5 && l < 5.0));
    }
}

/// Run the robust mode for `steps` steps; check energy at every point, that the fallback steps
/// are marked and that DTH is resumed.
fn robust_run(e: f64, dtau: f64, steps: usize) -> Trajectory<Const<4>> {
    let kepler = Kepler::thesis();
    let options = DthOptions::new(dtau).expect("valid").with_robust(true);
    let t = integrate(kepler, start(e), options, steps)
        .unwrap_or_else(|err| panic!("robust e {e}: {:?}", err.error));
    let e0 = kepler.value(&start(e));
    let de = worst_energy(&t, e0);
    let fallback = t.fallback_steps();
    let transitions = t.kinds().windows(2).filter(|w| w[0] != w[1]).count();
    let l0 = Kepler::angular_momentum(&start(e));
    // Kepler's exact-divided-difference fallback conserves L from node to node (gbar_q is
    // parallel to q0 + q1, as in Greenspan's discrete mechanics); DTH conserves it at vertices,
    // not at midpoints, so L differs between excursions by the O(h^2) midpoint deviation.
    // Per fallback step (consecutive fallback nodes): roundoff only.
    let records: Vec<_> = t.iter().collect();
    let dl_nodes = records
        .windows(2)
        .filter(|w| w[0].kind == StepKind::Fallback && w[1].kind == StepKind::Fallback)
        .map(|w| {
            // Relative to the roundoff scale of L: the solve's residual f (a few eps |z|) times
            // |q| (up to 100 at the apocentre of e = 0.99), plus |q||p| for the products.
            let z = &w[1].z;
            let scale = z[0].hypot(z[1]) * z.amax().max(z[2].hypot(z[3]));
            (Kepler::angular_momentum(&w[1].z) - Kepler::angular_momentum(&w[0].z)).abs() / scale
        })
        .fold(0.0, f64::max);
    let _ = l0;
    println!(
        "robust e {e}, dtau {dtau}: {fallback} of {} steps fallback, {transitions} transitions, \
         t_end {:.1}, max |dH|/terms {:.1} eps, max per-step |dL| / (|q| |z|) between fallback nodes {:.1} eps",
        t.len(),
        t.midpoint_times()[t.len() - 1],
        de / EPS,
        dl_nodes / EPS
    );
    assert!(de <= 8.0 * EPS, "{de:e}");
    // L per fallback step, relative to its roundoff scale: a few eps (the projection along
    // grad H moves z by a few ulps too).
    assert!(dl_nodes <= 16.0 * EPS, "{dl_nodes:e}");
    assert!(fallback > 0);
    assert_eq!(t.kinds()[0], StepKind::Dth);
    // Fallback nodes carry lambda = dt / dtau of their step, positive and finite.
    assert!(t.lambdas().iter().all(|l| l.is_finite() && *l > 0.0));
    t
}

#[test]
fn kepler_e09_e099_e0999_break_down_then_run_through_in_robust_mode() {
    let kepler = Kepler::thesis();
    let dtau = THESIS_DTAU / 4.0;
    for e in [0.9, 0.99, 0.999] {
        let err = integrate(
            kepler,
            start(e),
            DthOptions::new(dtau).expect("ok"),
            100_000,
        )
        .expect_err("Psi changes sign along the orbit");
        println!("e {e}: {} after {} midpoints", err.error, err.partial.len());
        let Error::Breakdown {
            step,
            time,
            psi,
            psi_previous,
            lambda,
            lambda_predicted,
        } = err.error
        else {
            panic!("e {e}: expected Breakdown, got {:?}", err.error);
        };
        assert_eq!(err.partial.len(), step, "midpoints 0..step-1 kept");
        assert!(time > 0.0 && lambda > 0.0);
        // Psi changes sign (the law of time then asks for lambda < 0) or lambda blows up.
        assert!(
            (psi * psi_previous < 0.0 && lambda_predicted < 0.0) || lambda_predicted > 8.0 * lambda,
            "{psi} {psi_previous} {lambda_predicted}"
        );
        // What was computed is a valid DTH trajectory.
        assert!(worst_energy(&err.partial, kepler.value(&start(e))) <= 8.0 * EPS);
    }
    // Robust mode: e = 0.9 over two orbits (period 49.7), e = 0.99 and 0.999 through their
    // first breakdown and a long stretch of fallback steps.
    let orbit = KeplerOrbit::new(&kepler, &start(0.9)).expect("elliptic");
    let period = orbit.elements().period;
    let mut dth = Dth::new(
        kepler,
        start(0.9),
        DthOptions::new(dtau).expect("ok").with_robust(true),
    )
    .expect("start");
    let mut resumed = 0usize;
    let mut last = StepKind::Dth;
    while dth.tbar() < 2.0 * period {
        let r = dth.step().expect("robust step");
        if last == StepKind::Fallback && dth.kind() == StepKind::Dth {
            resumed += 1;
        }
        last = r.kind;
    }
    assert!(
        resumed >= 2,
        "DTH resumed after each pericentre passage: {resumed}"
    );
    let t = robust_run(0.9, dtau, 6_000);
    assert!(t
        .kinds()
        .windows(2)
        .any(|w| w == [StepKind::Fallback, StepKind::Dth]));
    robust_run(0.99, dtau, 20_000);
    robust_run(0.999, dtau, 20_000);
}

#[test]
fn robust_mode_changes_nothing_where_dth_works() {
    // Zero cost where no step breaks down: the same steps, bit for bit, all marked DTH.
    let options = DthOptions::thesis_kepler();
    let plain = integrate(Kepler::thesis(), start(0.44), options, 2_000).expect("thesis orbit");
    let robust = integrate(
        Kepler::thesis(),
        start(0.44),
        options.with_robust(true),
        2_000,
    )
    .expect("thesis orbit");
    assert_eq!(plain, robust);
    assert_eq!(robust.fallback_steps(), 0);
    assert!(robust.kinds().iter().all(|k| *k == StepKind::Dth));
}

#[test]
fn near_collision_orbit_e_0999_through_pericentre_in_robust_mode() {
    // a = 1, e = 0.999: pericentre r = 0.001 (speed 63, Hess H ~ 1/r^3 = 1e9), from apocentre
    // with lambda_0 = 1. DTH breaks down on the way in; the fallback steps shrink with the law
    // of time (|Psi|^(-1/3)) through the close approach and halve where their Newton fails,
    // DTH resumes near pericentre and apocentre. After one period the orbit closes, second
    // order in dtau; energy exact at every point; nothing non-finite.
    let kepler = Kepler::thesis();
    let e = 0.999f64;
    let z0 = Vector4::new(-(1.0 + e), 0.0, 0.0, -(0.5 * (1.0 - e) / (1.0 + e)).sqrt());
    let orbit = KeplerOrbit::new(&kepler, &z0).expect("elliptic");
    let period = orbit.elements().period;
    let e0 = kepler.value(&z0);
    let mut errors = Vec::new();
    for dtau in [0.01, 0.001] {
        let options = DthOptions::new(dtau).expect("ok").with_robust(true);
        let mut dth = Dth::new(kepler, z0, options).expect("start");
        let (mut r_min, mut worst, mut steps, mut fallback) = (f64::MAX, 0.0f64, 0usize, 0usize);
        while dth.tbar() < period {
            let r = dth
                .step()
                .unwrap_or_else(|err| panic!("dtau {dtau}: {err}"));
            steps += 1;
            fallback += usize::from(r.kind == StepKind::Fallback);
            r_min = r_min.min(r.z[0].hypot(r.z[1]));
            let scale = r.z.component_mul(&kepler.gradient(&r.z)).abs().sum();
            worst = worst.max((kepler.value(&r.z) - e0).abs() / scale);
            assert!(steps < 100_000, "dtau {dtau}: too many steps");
        }
        let err = (dth.zbar() - orbit.state_at(dth.tbar())).amax();
        println!(
            "near collision e 0.999, dtau {dtau}: {steps} steps ({fallback} fallback) per orbit, \
             r_min {r_min:.2e}, |dH| {:.1} eps, error after one orbit {err:.2e}",
            worst / EPS
        );
        assert!(worst <= 8.0 * EPS, "{worst:e}");
        assert!(r_min < 2e-3, "went through pericentre: {r_min}");
        errors.push(err);
    }
    // 10x smaller dtau: ~100x smaller error (second order); require 30x. (The ratio follows
    // the roundoff of the fallback steps' halvings through the pericentre at r = 1e-3: 48 on
    // this code; a one-ulp change of |q| alone once gave 26.)
    assert!(errors[0] / errors[1] > 30.0, "{errors:?}");
}
