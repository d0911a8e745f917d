//! The one driver (`dth_core::solve`): every method ends exactly where asked, lands on chosen
//! times with its own states, keeps what it computed when it fails, and checks its plan.

use std::sync::atomic::AtomicBool;

use dth_core::kepler::KeplerOrbit;
use dth_core::methods::{self, DiscreteMechanics, ImplicitMidpoint};
use dth_core::nalgebra::{Const, Vector4};
use dth_core::observer::{Recorder, StepKind, StepRecord};
use dth_core::solve::{solve, Method, Peer, Solution};
use dth_core::systems::{ForcedOscillator, Kepler};
use dth_core::{DthOptions, Error, Hamiltonian, RunError};

fn thesis_z0() -> Vector4<f64> {
    Vector4::new(0.5, 0.0, 0.0, 1.2)
}

/// Every method the enum names, at steps fine enough for the thesis orbit.
fn every_method() -> Vec<Method> {
    vec![
        Method::Dth(DthOptions::new(0.02).unwrap()),
        Method::Dth(DthOptions::new(0.05).unwrap().with_order(8).unwrap()),
        Method::Dth(DthOptions::new(0.02).unwrap().with_robust(true)),
        Method::Trapezoidal { dt: 0.005 }, // its error constant is the largest here
        Method::Midpoint { dt: 0.01 },
        Method::GaussLegendre2 { dt: 0.02 },
        Method::Rk4 { dt: 0.01 },
        Method::StormerVerlet { dt: 0.01 },
        Method::DiscreteGradient { dt: 0.01 },
    ]
}

/// The time sum's rounding: a DTH landing is accepted within a few eps of the end
/// (`Dth::step_toward`); a fixed-step method's last time is the end itself.
fn landed(method: &Method, t: f64, t_end: f64) -> bool {
    match method {
        Method::Dth(_) => (t - t_end).abs() <= 4.0 * f64::EPSILON * t_end,
        _ => t == t_end,
    }
}

#[test]
fn every_method_ends_exactly_at_t() {
    let kepler = Kepler::thesis();
    let t_end = 3.3456; // not a multiple of any step, most of an orbit
    for method in every_method() {
        let run = solve(&kepler, thesis_z0(), method)
            .until(t_end)
            .run()
            .unwrap();
        let t = run.end_time().unwrap();
        assert!(landed(&method, t, t_end), "{}: ended at {t}", run.method);
        assert_eq!(run.method, method.name());
        assert_eq!(
            run.len(),
            run.steps + 1,
            "{}: every state saved",
            run.method
        );
        assert_eq!(run.k, (0..=run.steps).collect::<Vec<_>>());
        // The state at T against Kepler's equation: every method here is accurate to 1e-2
        // at these steps (order 2 at dt = 0.01 over about 4.5 orbits).
        let exact = KeplerOrbit::new(&kepler, &thesis_z0()).unwrap().state_at(t);
        let error = (run.end_state().unwrap() - exact).amax();
        assert!(error < 1e-2, "{}: error {error:e} at T", run.method);
        assert_eq!(run.dth.is_some(), matches!(method, Method::Dth(_)));
    }
}

/// The last step of a fixed-step method is what is left, so the global error at `T` keeps the
/// method's order: halving `dt` divides it by about 4 (implicit midpoint) at a `T` that no
/// step divides.
#[test]
fn the_shortened_last_step_keeps_the_order() {
    let kepler = Kepler::thesis();
    let t_end = 3.0 + 1.0 / 3.0;
    let exact = KeplerOrbit::new(&kepler, &thesis_z0())
        .unwrap()
        .state_at(t_end);
    let error = |dt: f64| {
        let run = solve(&kepler, thesis_z0(), Method::Midpoint { dt })
            .until(t_end)
            .save_every(usize::MAX)
            .run()
            .unwrap();
        assert_eq!(run.len(), 2, "the start and the end");
        (run.end_state().unwrap() - exact).amax()
    };
    let (coarse, fine) = (error(0.007), error(0.0035));
    let order = (coarse / fine).log2();
    assert!((order - 2.0).abs() < 0.1, "order {order}");
}

/// On a grid that divides `T` exactly (binary fractions), the driver's states are those of
/// `methods::run`, bit for bit: the same steps, the same clock.
#[test]
fn a_dividing_grid_is_the_plain_run() {
    let kepler = Kepler::thesis();
    let mut recorder = Recorder::new();
    methods::run(
        &mut ImplicitMidpoint::new(),
        &kepler,
        &thesis_z0(),
        0.0,
        0.125,
        40,
        &mut recorder,
    )
    .unwrap();
    let run = solve(&kepler, thesis_z0(), Method::Midpoint { dt: 0.125 })
        .until(5.0)
        .run()
        .unwrap();
    assert_eq!(run.t, recorder.t);
    assert_eq!(run.z, recorder.z);
    assert!(run.newton_iterations > 0);
}

/// `save_at` keeps the method's own state at each time, landed on beside the run: the run's
/// own steps and end are those of a run without the times; a fixed-step method's state at a
/// time is the one a run ending there ends with (bit for bit), a DTH one an exact midpoint of
/// a step shortened onto it (energy at roundoff), as accurate as the method.
#[test]
fn save_at_lands_on_each_time_beside_the_run() {
    let kepler = Kepler::thesis();
    // Two times within one step, and one on the fixed steps' grid.
    let times = [0.0, 1.5, 1.5005, 2.75, 4.0];
    let t_end = 4.5;
    let exact = KeplerOrbit::new(&kepler, &thesis_z0()).unwrap();
    for method in every_method() {
        let run = solve(&kepler, thesis_z0(), method)
            .save_at(times)
            .until(t_end)
            .run()
            .unwrap();
        let name = run.method;
        assert_eq!(run.len(), times.len() + 1, "{name}: the times and the end");
        for (t, want) in run.t.iter().zip(times.iter().chain([&t_end])) {
            assert!(landed(&method, *t, *want), "{name}: {t} for {want}");
        }
        assert_eq!(run.z[0], thesis_z0());
        let plain = solve(&kepler, thesis_z0(), method)
            .until(t_end)
            .run()
            .unwrap();
        assert_eq!(run.end_state(), plain.end_state(), "{name}: the run itself");
        assert_eq!(run.steps, plain.steps, "{name}");
        for (i, &want) in times.iter().enumerate().skip(1) {
            let z = &run.z[i];
            // Every method here is accurate to 1e-2 at these steps (see above).
            let error = (z - exact.state_at(run.t[i])).amax();
            assert!(error < 1e-2, "{name}: error {error:e} at {want}");
            match method {
                Method::Dth(_) => {
                    // Each term of H is at most ~2 here: roundoff is a few eps of that.
                    let drift = (kepler.value(z) - kepler.value(&thesis_z0())).abs();
                    assert!(drift <= 16.0 * f64::EPSILON, "{name}: |H - H0| = {drift:e}");
                    assert_ne!(run.kinds[i], StepKind::Fallback, "{name}");
                }
                _ => {
                    let to = solve(&kepler, thesis_z0(), method)
                        .until(want)
                        .run()
                        .unwrap();
                    assert_eq!(z, to.end_state().unwrap(), "{name} at {want}");
                    assert_eq!(run.k[i], to.steps, "{name} at {want}");
                }
            }
        }
    }
    // With an end of its own the end is kept too, after the chosen times.
    let run = solve(&kepler, thesis_z0(), Method::Rk4 { dt: 0.1 })
        .save_at([1.0, 2.0])
        .until(3.0)
        .run()
        .unwrap();
    assert_eq!(run.t, [1.0, 2.0, 3.0]);
}

/// Robust DTH lands on chosen times inside its fallback stretches too (Kepler e = 0.9, whose
/// pericentre passage is one), with the energy exact there and the run unchanged.
#[test]
fn robust_dth_lands_inside_fallback_stretches() {
    let kepler = Kepler::thesis();
    // At pericentre r = 0.5 of H = p^2 - 1/r, p^2 = 1 + e (e = 0.44: the thesis's 1.2).
    let z0 = Vector4::new(0.5, 0.0, 0.0, 1.9_f64.sqrt());
    let options = DthOptions::new(0.01).unwrap().with_robust(true);
    let t_end = 2.0;
    let times: Vec<f64> = (1..40).map(|i| f64::from(i) * 0.05).collect();
    let run = solve(&kepler, z0, Method::Dth(options))
        .save_at(times.iter().copied())
        .until(t_end)
        .run()
        .unwrap();
    let plain = solve(&kepler, z0, Method::Dth(options))
        .until(t_end)
        .run()
        .unwrap();
    assert!(plain.fallback_steps > 0, "the stretch this test is about");
    assert_eq!(run.end_state(), plain.end_state());
    assert_eq!(run.len(), times.len() + 1, "the times and the end");
    let h0 = kepler.value(&z0);
    let fallback = run
        .kinds
        .iter()
        .filter(|k| **k == StepKind::Fallback)
        .count();
    assert!(fallback > 0, "some times lie in the fallback stretch");
    for (t, z) in run.t.iter().zip(&run.z) {
        // |H| terms are at most ~4 near pericentre: roundoff is a few eps of that.
        let drift = (kepler.value(z) - h0).abs();
        assert!(drift <= 32.0 * f64::EPSILON, "|H - H0| = {drift:e} at {t}");
    }
    for (t, want) in run.t.iter().zip(&times) {
        assert!(
            (t - want).abs() <= 4.0 * f64::EPSILON * want.max(1.0),
            "{t} for {want}"
        );
    }
}

#[test]
fn save_every_keeps_every_nth_and_the_last() {
    let kepler = Kepler::thesis();
    let run = solve(&kepler, thesis_z0(), Method::Rk4 { dt: 0.1 })
        .steps(23)
        .save_every(5)
        .run()
        .unwrap();
    assert_eq!(run.k, [0, 5, 10, 15, 20, 23]);
    assert_eq!(run.steps, 23);
    let e = 1e-3; // RK4 at dt = 0.1 on the thesis orbit: energy drifts, but not far
    assert!(run.energy_error[0] == 0.0 && run.max_energy_error() < e);
}

/// A closure observer infers its record type and sees every state, saved or not; the DTH
/// midpoints conserve the energy to roundoff (|H| = 0.56: a few eps).
#[test]
fn a_closure_observes_every_state() {
    let kepler = Kepler::thesis();
    let e0 = kepler.value(&thesis_z0());
    let mut seen = 0;
    let mut worst = 0.0_f64;
    let run = solve(
        &kepler,
        thesis_z0(),
        Method::Dth(DthOptions::thesis_kepler()),
    )
    .steps(200)
    .save_every(50)
    .observe(|r| {
        seen += 1;
        worst = worst.max((kepler.value(&r.z) - e0).abs());
    })
    .run()
    .unwrap();
    assert_eq!(seen, 201);
    assert_eq!(run.len(), 5);
    assert!(worst <= 4.0 * f64::EPSILON, "{worst:e}");
    let series = run.dth.as_ref().unwrap();
    assert_eq!(series.lambda.len(), 5);
    assert!(series.last_vertex.is_some());
}

/// DTH at e = 0.9 breaks down without the robust mode: the run fails, keeps its states, and
/// `?` makes it a `dth_core::Error`; the robust mode ends at `T` and says how many steps were
/// fallback steps.
#[test]
fn a_failure_keeps_what_was_computed() {
    let kepler = Kepler::thesis();
    let z0 = Vector4::new(0.5, 0.0, 0.0, 1.9f64.sqrt());
    let plain = DthOptions::new(0.01).unwrap();
    let failed = solve(&kepler, z0, Method::Dth(plain))
        .until(5.0)
        .run()
        .unwrap_err();
    assert!(matches!(failed.error, Error::Breakdown { .. }));
    let partial: &Solution<Const<4>> = &failed.partial;
    assert_eq!(partial.failure.as_ref(), Some(&failed.error));
    assert!(partial.len() > 10 && partial.end_time().unwrap() < 5.0);
    let as_error: Result<(), Error> = (|| {
        solve(&kepler, z0, Method::Dth(plain)).until(5.0).run()?;
        Ok(())
    })();
    assert!(matches!(as_error, Err(Error::Breakdown { .. })));

    let robust = solve(&kepler, z0, Method::Dth(plain.with_robust(true)))
        .until(5.0)
        .run()
        .unwrap();
    assert!(landed(&Method::Dth(plain), robust.end_time().unwrap(), 5.0));
    assert!(robust.fallback_steps > 0);
    assert_eq!(
        robust.fallback_steps,
        robust
            .kinds
            .iter()
            .filter(|k| **k == StepKind::Fallback)
            .count()
    );
    // Energy at every node and midpoint, fallback steps included, to roundoff of |H| = 0.55.
    assert!(
        robust.max_energy_error() < 1e-14,
        "{:e}",
        robust.max_energy_error()
    );
}

#[test]
fn a_method_that_does_not_apply_says_so() {
    // Kepler's H is separable; Henon-Heiles too. A non-separable one: Kepler in extended
    // phase space is still separable, so take the double pendulum.
    let h = dth_core::systems::DoublePendulum::unit();
    let z0 = Vector4::new(0.3, 0.2, 0.0, 0.0);
    let err = solve(&h, z0, Method::StormerVerlet { dt: 0.01 })
        .steps(3)
        .run()
        .unwrap_err();
    assert!(
        matches!(err.error, Error::NotSeparable { .. }),
        "{:?}",
        err.error
    );
    assert_eq!(err.partial.len(), 1, "the initial state is kept");
}

#[test]
fn a_peer_of_a_narrower_class_runs_through_peer() {
    let run = solve(
        &Kepler::thesis(),
        thesis_z0(),
        Peer::new(DiscreteMechanics::new(), 0.15),
    )
    .until(3.0)
    .run()
    .unwrap();
    assert_eq!(run.end_time(), Some(3.0));
    assert!(run.max_energy_error() < 1e-14);
}

#[test]
fn the_plan_is_checked() {
    let kepler = Kepler::thesis();
    let midpoint = Method::Midpoint { dt: 0.1 };
    let start = |m| solve(&kepler, thesis_z0(), m);
    let error = |r: Result<Solution<Const<4>>, RunError<Solution<Const<4>>>>| {
        r.map(|_| ()).unwrap_err().error
    };
    assert!(matches!(error(start(midpoint).run()), Error::MissingEnd));
    assert!(matches!(
        error(start(midpoint).start_time(1.0).until(0.5).run()),
        Error::InvalidOption { name: "until", .. }
    ));
    assert!(matches!(
        error(start(midpoint).until(1.0).save_every(0).run()),
        Error::InvalidOption {
            name: "save_every",
            ..
        }
    ));
    assert!(matches!(
        error(start(midpoint).save_at([1.0, 0.5]).run()),
        Error::InvalidOption {
            name: "save_at",
            ..
        }
    ));
    assert!(matches!(
        error(start(midpoint).save_at([1.0, 2.0]).until(1.5).run()),
        Error::InvalidOption {
            name: "save_at",
            ..
        }
    ));
    assert!(matches!(
        error(start(midpoint).save_at([1.0]).steps(4).run()),
        Error::InvalidOption {
            name: "save_at",
            ..
        }
    ));
    assert!(matches!(
        error(start(Method::Midpoint { dt: -0.1 }).until(1.0).run()),
        Error::InvalidOption { name: "dt", .. }
    ));
    assert!(matches!(
        error(start(Method::Rk4 { dt: f64::NAN }).steps(1).run()),
        Error::InvalidOption { name: "dt", .. }
    ));
    let nan = Vector4::new(f64::NAN, 0.0, 0.0, 1.2);
    for method in every_method() {
        let err = solve(&kepler, nan, method).steps(1).run().unwrap_err();
        assert!(
            matches!(err.error, Error::NonFiniteInitialState { index: 0, .. }),
            "{}: {:?}",
            method.name(),
            err.error
        );
    }
}

#[test]
fn a_step_cap_and_an_interrupt_stop_a_run_and_keep_it() {
    let kepler = Kepler::thesis();
    for method in [
        Method::Dth(DthOptions::thesis_kepler()),
        Method::Rk4 { dt: 0.1 },
    ] {
        let err = solve(&kepler, thesis_z0(), method)
            .until(100.0)
            .max_steps(7)
            .run()
            .unwrap_err();
        let t = err.partial.end_time().unwrap();
        assert!(
            matches!(err.error, Error::StepCap { max_steps: 7, t: at, t_end } if at == t && t_end == 100.0),
            "{}: {:?}",
            method.name(),
            err.error
        );
        assert_eq!(err.partial.steps, 7);

        let flag = AtomicBool::new(true);
        let err = solve(&kepler, thesis_z0(), method)
            .until(100.0)
            .interrupt(&flag)
            .run()
            .unwrap_err();
        assert!(matches!(err.error, Error::Interrupted { step: 1 }));
        assert_eq!(err.partial.len(), 1);
    }
}

/// A time-dependent `H` keeps its clock in `z`: the run starts at its `t` coordinate and
/// ends with `t = T` there; DTH and a peer follow the exact forced oscillation.
#[test]
fn a_time_dependent_run_keeps_its_clock_in_the_state() {
    let h = ForcedOscillator {
        omega0: 1.0,
        force: 0.5,
        omega: 1.7,
    };
    let t0 = 0.5;
    // The exact solution is given from t = 0: start on it at t0.
    let (q0, p0) = h.exact(1.0, 0.0, t0);
    let z0 = h.initial_state(q0, p0, t0);
    let t_end = 7.25;
    let (q, p) = h.exact(1.0, 0.0, t_end);
    for method in [
        // The driven oscillator's Psi changes sign: DTH goes through in robust mode.
        Method::Dth(DthOptions::new(0.01).unwrap().with_robust(true)),
        Method::GaussLegendre2 { dt: 0.01 },
    ] {
        let run = solve(&h, z0, method).until(t_end).run().unwrap();
        assert_eq!(run.t[0], t0);
        let z = run.end_state().unwrap();
        assert!(landed(&method, run.end_time().unwrap(), t_end));
        // The t coordinate follows the clock to O(dt^2) at worst (module docs of `methods`).
        assert!((z[1] - t_end).abs() < 1e-9, "{}: t = {}", run.method, z[1]);
        assert!(
            (z[0] - q).abs().max((z[2] - p).abs()) < 1e-3,
            "{}",
            run.method
        );
        let err = solve(&h, z0, method)
            .start_time(0.0)
            .until(t_end)
            .run()
            .unwrap_err();
        assert!(matches!(
            err.error,
            Error::InvalidOption {
                name: "start_time",
                ..
            }
        ));
    }
}

/// An observer that is not a closure (here DTH's own `Trajectory`) gets the same states
/// and the last vertex.
#[test]
fn any_observer_gets_every_state_and_the_last_vertex() {
    let kepler = Kepler::thesis();
    let mut trajectory = dth_core::Trajectory::new();
    let run = solve(
        &kepler,
        thesis_z0(),
        Method::Dth(DthOptions::thesis_kepler()),
    )
    .until(6.0)
    .observer(&mut trajectory)
    .run()
    .unwrap();
    assert_eq!(trajectory.midpoints(), &run.z[..]);
    assert_eq!(trajectory.vertices().len(), run.len() + 1);
    let (last, _) = run.dth.as_ref().unwrap().last_vertex.unwrap();
    assert_eq!(trajectory.vertices().last(), Some(&last));
    assert_eq!(run.kinds.last(), Some(&StepKind::Shortened));
    let _: &StepRecord<Const<4>> = &trajectory.record(0).unwrap();
}

/// Without energy errors a run evaluates `H` only where its method does: RK4 and the implicit
/// midpoint rule use the gradient and Hessian only, so not once here.
#[test]
fn without_energy_errors_h_is_not_evaluated() {
    use std::cell::Cell;
    struct Counting(Kepler, Cell<usize>);
    impl Hamiltonian<Const<4>> for Counting {
        fn dim(&self) -> Const<4> {
            Const
        }
        fn value(&self, z: &Vector4<f64>) -> f64 {
            self.1.set(self.1.get() + 1);
            self.0.value(z)
        }
        fn gradient_into(&self, z: &Vector4<f64>, out: &mut Vector4<f64>) {
            self.0.gradient_into(z, out)
        }
        fn hessian_into(&self, z: &Vector4<f64>, out: &mut dth_core::nalgebra::Matrix4<f64>) {
            self.0.hessian_into(z, out)
        }
    }
    let h = Counting(Kepler::thesis(), Cell::new(0));
    for method in [Method::Rk4 { dt: 0.1 }, Method::Midpoint { dt: 0.1 }] {
        h.1.set(0);
        let run = solve(&h, thesis_z0(), method)
            .until(2.0)
            .without_energy_errors()
            .run()
            .unwrap();
        assert_eq!(h.1.get(), 0, "{}", run.method);
        assert!(run.energy_error.is_empty() && run.energy0.is_nan());
        assert_eq!(run.len(), run.steps + 1);
        h.1.set(0);
        let run = solve(&h, thesis_z0(), method).until(2.0).run().unwrap();
        assert_eq!(h.1.get(), 1 + run.len(), "H(z0) and one per saved state");
    }
}

/// DTH lands on any time, however close to the start of the step that reaches it (a dense
/// grid of times puts some within a millionth of a step of it), at every order.
#[test]
fn dth_lands_on_times_close_to_a_step_start() {
    let kepler = Kepler::thesis();
    let t_end = 7.5;
    let times: Vec<f64> = (1..750).map(|i| f64::from(i) * 0.01).collect();
    for dtau in [0.005, 0.01, 0.02] {
        for order in [2, 4] {
            let options = DthOptions::new(dtau).unwrap().with_order(order).unwrap();
            let run = solve(&kepler, thesis_z0(), Method::Dth(options))
                .save_at(times.iter().copied())
                .until(t_end)
                .run()
                .unwrap_or_else(|e| panic!("dtau {dtau}, order {order}: {}", e.error));
            assert_eq!(run.len(), times.len() + 1);
            for (t, want) in run.t.iter().zip(&times) {
                assert!(
                    (t - want).abs() <= 4.0 * f64::EPSILON * t_end,
                    "{t} for {want}"
                );
            }
        }
    }
}
