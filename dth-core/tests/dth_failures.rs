//! Every failure path of the DTH stepper returns its typed error, with data, and keeps what
//! was computed.

use dth_core::dth::{integrate, Dth, DthOptions, Solver, Trajectory};
use dth_core::nalgebra::Const;
use dth_core::nalgebra::{Vector2, Vector4};
use dth_core::observer::StepRecord;
use dth_core::systems::{Kepler, Pendulum};
use dth_core::{Error, Hamiltonian};

mod fixtures;
use fixtures::{Saddle, Walled};

fn kepler_z0() -> Vector4<f64> {
    Vector4::new(0.5, 0.0, 0.0, 1.2)
}

#[test]
fn non_finite_initial_state_is_rejected_with_its_index() {
    let mut z = kepler_z0();
    z[2] = f64::NAN;
    let r = Dth::new(Kepler::thesis(), z, DthOptions::thesis_kepler());
    assert!(matches!(
        r,
        Err(Error::NonFiniteInitialState { index: 2, .. })
    ));
    z[2] = f64::INFINITY;
    let r = integrate(Kepler::thesis(), z, DthOptions::thesis_kepler(), 10);
    let e = r.expect_err("infinite component");
    assert!(matches!(
        e.error,
        Error::NonFiniteInitialState { index: 2, .. }
    ));
    assert!(e.partial.is_empty());
}

#[test]
fn non_finite_hamiltonian_at_zbar0_is_rejected() {
    // Kepler at the origin: H = -inf.
    let r = Dth::new(
        Kepler::thesis(),
        Vector4::zeros(),
        DthOptions::thesis_kepler(),
    );
    assert!(matches!(r, Err(Error::NonFinite { step: 0, .. })));
}

#[test]
fn an_equilibrium_start_is_refused_as_one() {
    // The pendulum at rest hanging down (q = 0, p = 0): grad H = 0, every lambda solves the
    // step, and Newton would meet a singular matrix at step 1.
    let r = Dth::new(
        Pendulum::normalized(),
        Vector2::new(0.0, 0.0),
        DthOptions::thesis_kepler(),
    );
    assert!(matches!(r, Err(Error::Equilibrium)), "{r:?}");
    let e = integrate(
        Pendulum::normalized(),
        Vector2::zeros(),
        DthOptions::thesis_kepler(),
        10,
    )
    .expect_err("equilibrium");
    assert!(matches!(e.error, Error::Equilibrium) && e.partial.is_empty());
    // Next to it, DTH runs.
    let mut dth = Dth::new(
        Pendulum::normalized(),
        Vector2::new(0.0, 1e-3),
        DthOptions::thesis_kepler(),
    )
    .expect("a small oscillation");
    dth.advance(10).expect("steps");
}

#[test]
fn iteration_limit_gives_newton_diverged_with_data() {
    let options = DthOptions::thesis_kepler()
        .with_max_iterations(1)
        .expect("valid");
    for solver in [Solver::Joint, Solver::Nested] {
        let mut dth = Dth::new(Kepler::thesis(), kepler_z0(), options.with_solver(solver))
            .expect("valid start");
        let before = *dth.record_ref();
        assert_eq!((before.k, before.z, before.t), (0, kepler_z0(), 0.0));
        let r = dth.step();
        let diverged = matches!(
            r,
            Err(Error::NewtonDiverged { step: 1, iterations: 1, residual }) if residual > 0.0
        );
        assert!(diverged, "{solver:?}: {r:?}");
        // The state is unchanged, and so is the record of it.
        assert_eq!(dth.k(), 0);
        assert_eq!(dth.zbar(), &kepler_z0());
        assert_eq!(dth.record_ref(), &before);
        // Stepping again fails the same way: a failed step leaves nothing behind.
        assert_eq!(dth.step(), r);
    }
}

#[test]
fn singular_newton_matrix_is_reported() {
    // From zbar_0 = (0, 1) with h = 2, lambda_0 = 1 (all exact in binary): the explicit
    // predictor lands on q = -3, p = 3 where Psi = 0, so the law-of-time lambda predictor
    // falls back to lambda = 1, and A = I - (h lambda / 2) J Hess = [[1, 1], [1, 1]] is
    // exactly singular.
    let options = DthOptions::new(2.0).expect("valid");
    for solver in [Solver::Joint, Solver::Nested] {
        let mut dth =
            Dth::new(Saddle, Vector2::new(0.0, 1.0), options.with_solver(solver)).expect("start");
        let r = dth.step();
        assert!(
            matches!(r, Err(Error::SingularMatrix { step: 1 })),
            "{solver:?}: {r:?}"
        );
    }
}

#[test]
fn non_finite_value_mid_run_stops_and_keeps_the_partial_trajectory() {
    // Amplitude 1.2 > 1: the orbit reaches the wall after about a quarter period.
    let options = DthOptions::new(0.1).expect("valid");
    let z0 = Vector2::new(0.0, 1.2);
    let e = integrate(Walled, z0, options, 1_000).expect_err("must hit the wall");
    let Error::NonFinite { step, .. } = e.error else {
        panic!("expected NonFinite, got {:?}", e.error);
    };
    let t = &e.partial;
    println!("stopped at step {step} with {} midpoints kept", t.len());
    assert!(step > 1, "ran some steps first");
    assert_eq!(t.len(), step, "midpoints 0..step-1 are kept");
    assert_eq!(
        t.vertices().len(),
        step + 1,
        "closed by the last right vertex"
    );
    // What was kept is a valid DTH trajectory: energy exact at its midpoints (Thm 4).
    for zbar in t.midpoints() {
        assert!((Walled.value(zbar) - 0.72).abs() < 64.0 * f64::EPSILON);
    }
    // The stepper API keeps its state at the last accepted step.
    let mut dth = Dth::new(Walled, z0, options).expect("start");
    let mut seen = 0usize;
    let mut count = |_: &StepRecord<Const<2>>| seen += 1;
    let r = dth.run(1_000, &mut count);
    assert!(matches!(r, Err(Error::NonFinite { step: s, .. }) if s == step));
    assert_eq!(dth.k(), step - 1);
    assert_eq!(seen, step);
}

#[test]
fn runs_resume_and_a_no_op_observer_stores_nothing() {
    let options = DthOptions::thesis_kepler();
    let mut dth = Dth::new(Kepler::thesis(), kepler_z0(), options).expect("start");
    let mut t = Trajectory::new();
    dth.run(10, &mut t).expect("run");
    dth.run(5, &mut ()).expect("run");
    dth.run(10, &mut t).expect("run");
    // 0..=10 then 16..=25 (11..=15 went to the no-op observer).
    assert_eq!(t.len(), 21);
    assert_eq!(t.vertices().len(), 22);
    let whole = integrate(Kepler::thesis(), kepler_z0(), options, 25).expect("run");
    assert_eq!(whole.get(25), t.iter().last());
    assert_eq!(whole.get(10), t.get(10));
    let mut csv = Vec::new();
    whole.write_csv(&mut csv).expect("in-memory write");
    let text = String::from_utf8(csv).expect("utf8");
    assert_eq!(text.lines().count(), 27);
    assert!(text.starts_with("k,tbar,lambda,zbar_1,"));
}

#[test]
fn no_positive_root_beyond_e_0_79_is_a_breakdown_before_newton() {
    // Kepler with q = (0.5, 0), p = (0, 1.38): e ~ 0.90, beyond sqrt(5/8) where Psi changes
    // sign along the orbit, and dtau = 0.2: the step has no positive root near lambda_0
    // (Newton used to converge to a negative one). The sign change of Psi at the predicted
    // midpoint is caught before Newton runs.
    let options = DthOptions::new(0.2).expect("valid");
    let z0 = Vector4::new(0.5, 0.0, 0.0, 1.38);
    let e = integrate(Kepler::thesis(), z0, options, 100).expect_err("no positive root");
    assert!(
        matches!(e.error, Error::Breakdown { step: 1, psi, psi_previous, lambda_predicted, .. }
            if psi < 0.0 && psi_previous > 0.0 && lambda_predicted < 0.0),
        "{:?}",
        e.error
    );
    assert_eq!(e.partial.len(), 1, "zbar_0 is kept");
}

#[test]
fn negative_lambda_root_is_rejected_as_spurious() {
    // The pendulum in libration (H = -0.455, Psi > 0 on the whole orbit) with a grossly too
    // large step, dtau lambda_0 = 3 (half a period): the predictor lands far off the energy
    // surface (no breakdown verdict from it), Newton converges to a root with lambda < 0, and
    // three orbit steps ahead Psi keeps its sign, so this is the solver's spurious root, not a
    // breakdown of the method. It must not be accepted.
    let options = DthOptions::new(1.0)
        .and_then(|o| o.with_lambda0(3.0))
        .expect("valid");
    let z0 = Vector2::new(0.3, 1.0);
    let e = integrate(Pendulum::normalized(), z0, options, 10).expect_err("spurious root");
    assert!(
        matches!(e.error, Error::SpuriousRoot { step: 1, lambda } if lambda < 0.0),
        "{:?}",
        e.error
    );
    assert_eq!(e.partial.len(), 1, "zbar_0 is kept");
}
