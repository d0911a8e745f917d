//! Exact invariants where the theory says so, reversibility of the symmetric methods, and the
//! typed failures of the driver.

use dth_core::diagnostics::{planar_angular_momentum, DeviationSeries};
use dth_core::methods::{
    run, DiscreteGradient, DiscreteMechanics, GaussLegendre2, ImplicitMidpoint, OneStepMethod, Rk4,
    StormerVerlet, Trapezoidal,
};
use dth_core::nalgebra::Const;
use dth_core::nalgebra::{Matrix4, Vector4};
use dth_core::observer::StepRecord;
use dth_core::systems::{CentralForce, Kepler};
use dth_core::Flags;
use dth_core::{Error, Hamiltonian};

/// Kepler through the trait's default (guarded) divided difference instead of the exact
/// `k / (r0 r1)` override, to test the guard inside the method.
struct GuardedKepler(Kepler);

impl Hamiltonian<Const<4>> for GuardedKepler {
    fn dim(&self) -> Const<4> {
        Const
    }

    fn flags(&self) -> Flags {
        Flags::default().with_separable(true)
    }

    fn value(&self, z: &Vector4<f64>) -> f64 {
        self.0.value(z)
    }
    fn gradient_into(&self, z: &Vector4<f64>, out: &mut Vector4<f64>) {
        *out = self.0.gradient(z);
    }
    fn hessian_into(&self, z: &Vector4<f64>, out: &mut Matrix4<f64>) {
        *out = self.0.hessian(z);
    }
}

impl CentralForce<Const<4>> for GuardedKepler {
    fn mass(&self) -> f64 {
        self.0.mass
    }
    fn phi(&self, r: f64) -> f64 {
        self.0.phi(r)
    }
    fn dphi(&self, r: f64) -> f64 {
        self.0.dphi(r)
    }
}

const THESIS_Z0: Vector4<f64> = Vector4::new(0.5, 0.0, 0.0, 1.2);

/// Max |E - E0| and |L - L0| over `steps` steps.
fn max_deviations<H: Hamiltonian<Const<4>>, M: OneStepMethod<Const<4>, H>>(
    mut method: M,
    h: &H,
    z0: &Vector4<f64>,
    dt: f64,
    steps: usize,
) -> (f64, f64) {
    let e = DeviationSeries::new(|z: &Vector4<f64>| h.value(z));
    let l = DeviationSeries::new(planar_angular_momentum);
    let mut both = (e, l);
    run(&mut method, h, z0, 0.0, dt, steps, &mut both).expect("run");
    let (e, l) = both;
    (e.max_abs(), l.max_abs())
}

/// Bound for "exact to roundoff" over 10^4 steps of O(1) quantities: the per-step rounding
/// (a few eps) random-walks, ~eps sqrt(N) = 2e-14, with a factor 5 margin.
const ROUNDOFF_MAX: f64 = 1e-13;
const STEPS: usize = 10_000;

#[test]
fn discrete_mechanics_conserves_energy_and_angular_momentum() {
    for (name, dev) in [
        (
            "exact quotient",
            max_deviations(
                DiscreteMechanics::new(),
                &Kepler::thesis(),
                &THESIS_Z0,
                0.15,
                STEPS,
            ),
        ),
        (
            "guarded quotient",
            max_deviations(
                DiscreteMechanics::new(),
                &GuardedKepler(Kepler::thesis()),
                &THESIS_Z0,
                0.15,
                STEPS,
            ),
        ),
    ] {
        eprintln!(
            "discrete mechanics ({name}): max |dE| {:.2e}, max |dL| {:.2e}",
            dev.0, dev.1
        );
        assert!(
            dev.0 < ROUNDOFF_MAX && dev.1 < ROUNDOFF_MAX,
            "{name}: {dev:?}"
        );
    }
}

#[test]
fn discrete_mechanics_guard_on_a_circular_orbit() {
    // Circular orbit: r1 = r0 up to roundoff every step, so the quotient's guard decides every
    // step; the radius, energy and L must stay put and nothing may turn NaN.
    let h = GuardedKepler(Kepler { mass: 1.0, k: 1.0 });
    let z0 = Vector4::new(1.0, 0.0, 0.0, 1.0);
    let (de, dl) = max_deviations(DiscreteMechanics::new(), &h, &z0, 0.1, STEPS);
    eprintln!("circular: max |dE| {de:.2e}, max |dL| {dl:.2e}");
    assert!(de < ROUNDOFF_MAX && dl < ROUNDOFF_MAX);
}

#[test]
fn midpoint_and_gauss_legendre_conserve_angular_momentum() {
    let h = Kepler::thesis();
    let (de, dl) = max_deviations(ImplicitMidpoint::new(), &h, &THESIS_Z0, 0.15, STEPS);
    eprintln!("midpoint: max |dE| {de:.2e}, max |dL| {dl:.2e}");
    assert!(dl < ROUNDOFF_MAX && de > 1e-3);
    let (de, dl) = max_deviations(GaussLegendre2::new(), &h, &THESIS_Z0, 0.15, STEPS);
    eprintln!("gauss-legendre 2: max |dE| {de:.2e}, max |dL| {dl:.2e}");
    assert!(dl < ROUNDOFF_MAX && de > 1e-6);
}

#[test]
fn discrete_gradient_conserves_energy() {
    // GuardedKepler forwards only value/gradient/Hessian: Gonzalez's default discrete gradient.
    let h = GuardedKepler(Kepler::thesis());
    let (de, dl) = max_deviations(DiscreteGradient::new(), &h, &THESIS_Z0, 0.15, STEPS);
    eprintln!("discrete gradient: max |dE| {de:.2e}, max |dL| {dl:.2e}");
    assert!(de < ROUNDOFF_MAX && dl > 1e-6);
    // Kepler's own exact divided differences, gbar_q = k (q0 + q1) / (r0 r1 (r0 + r1)) (parallel
    // to q0 + q1, like Greenspan's discrete mechanics), conserve L as well.
    let h = Kepler::thesis();
    let (de, dl) = max_deviations(DiscreteGradient::new(), &h, &THESIS_Z0, 0.15, STEPS);
    eprintln!("discrete gradient, exact divided differences: max |dE| {de:.2e}, max |dL| {dl:.2e}");
    assert!(de < ROUNDOFF_MAX && dl < ROUNDOFF_MAX);
}

#[test]
fn rk4_and_trapezoidal_conserve_neither() {
    // Control: the measurement can fail.
    let h = Kepler::thesis();
    let (de, dl) = max_deviations(Rk4::new(), &h, &THESIS_Z0, 0.15, 1000);
    assert!(de > 1e-6 && dl > 1e-6);
    let (de, dl) = max_deviations(Trapezoidal::new(), &h, &THESIS_Z0, 0.15, 1000);
    assert!(de > 1e-6 && dl > 1e-6);
}

/// `n` steps forward with dt, then `n` with -dt: a symmetric method returns to the start up to
/// roundoff (O(1) state, 2n steps of a few eps each, ~1e-13 with margin).
fn round_trip<H: Hamiltonian<Const<4>>, M: OneStepMethod<Const<4>, H>>(
    mut method: M,
    h: &H,
) -> f64 {
    let forward = run(&mut method, h, &THESIS_Z0, 0.0, 0.05, 200, &mut ()).unwrap();
    let back = run(&mut method, h, &forward.z, forward.t, -0.05, 200, &mut ()).unwrap();
    (back.z - THESIS_Z0).amax()
}

#[test]
fn symmetric_methods_are_reversible() {
    let h = Kepler::thesis();
    let errors = [
        ("trapezoidal", round_trip(Trapezoidal::new(), &h)),
        ("midpoint", round_trip(ImplicitMidpoint::new(), &h)),
        (
            "discrete mechanics",
            round_trip(DiscreteMechanics::new(), &h),
        ),
        ("verlet", round_trip(StormerVerlet::new(), &h)),
        ("discrete gradient", round_trip(DiscreteGradient::new(), &h)),
        ("gauss-legendre 2", round_trip(GaussLegendre2::new(), &h)),
    ];
    for (name, e) in errors {
        assert!(e < 1e-12, "{name}: {e:e}");
    }
    // Control: RK4 is not symmetric.
    assert!(round_trip(Rk4::new(), &h) > 1e-9);
}

/// A non-separable H (the q-p block of the Hessian is not zero).
struct Coupled;
impl Hamiltonian<Const<2>> for Coupled {
    fn dim(&self) -> Const<2> {
        Const
    }

    fn value(&self, z: &dth_core::nalgebra::Vector2<f64>) -> f64 {
        0.5 * (z[0] * z[0] + z[1] * z[1]) + 0.1 * z[0] * z[0] * z[1] * z[1]
    }
    fn gradient_into(
        &self,
        z: &dth_core::nalgebra::Vector2<f64>,
        out: &mut dth_core::nalgebra::Vector2<f64>,
    ) {
        *out = dth_core::nalgebra::Vector2::new(
            z[0] + 0.2 * z[0] * z[1] * z[1],
            z[1] + 0.2 * z[0] * z[0] * z[1],
        );
    }
    fn hessian_into(
        &self,
        z: &dth_core::nalgebra::Vector2<f64>,
        out: &mut dth_core::nalgebra::Matrix2<f64>,
    ) {
        *out = {
            let c = 0.4 * z[0] * z[1];
            dth_core::nalgebra::Matrix2::new(1.0 + 0.2 * z[1] * z[1], c, c, 1.0 + 0.2 * z[0] * z[0])
        };
    }
}

#[test]
fn verlet_refuses_a_non_separable_hamiltonian() {
    let z0 = dth_core::nalgebra::Vector2::new(1.0, 0.0);
    let err = run(
        &mut StormerVerlet::new(),
        &Coupled,
        &z0,
        0.0,
        0.1,
        10,
        &mut (),
    )
    .unwrap_err();
    assert!(matches!(
        err.error,
        Error::NotSeparable { method: "verlet" }
    ));
    assert_eq!(err.partial.steps, 0);
    // The implicit methods take it.
    assert!(run(
        &mut ImplicitMidpoint::new(),
        &Coupled,
        &z0,
        0.0,
        0.1,
        10,
        &mut ()
    )
    .is_ok());
}

#[test]
fn newton_failure_names_the_step_and_keeps_the_states() {
    // dt = 2 on the thesis orbit (period 3.75): the trapezoidal Newton cannot converge near
    // perihelion within 3 iterations. The run must stop with a typed error carrying the step
    // index and iterations, keeping the earlier states.
    let h = Kepler::thesis();
    let newton = dth_core::methods::NewtonOptions::default()
        .with_max_iterations(3)
        .unwrap();
    let mut seen = 0;
    let err = run(
        &mut Trapezoidal::with_newton(newton),
        &h,
        &THESIS_Z0,
        0.0,
        0.5,
        100,
        &mut |_: &StepRecord<Const<4>>| seen += 1,
    )
    .unwrap_err();
    eprintln!("{:?} after {} steps", err.error, err.partial.steps);
    match err.error {
        Error::MethodNotConverged {
            method: "trapezoidal",
            step,
            iterations: 3,
            residual,
        } => {
            assert_eq!(step, err.partial.steps + 1);
            assert!(residual > 0.0 && residual.is_finite());
        }
        Error::MethodSingularMatrix { step, .. } => assert_eq!(step, err.partial.steps + 1),
        ref other => panic!("unexpected {other:?}"),
    }
    assert_eq!(seen, err.partial.steps + 1);
}

/// `H = p^2/2 + k q^2/2` that counts its gradient evaluations.
struct CountingOscillator {
    k: f64,
    gradients: std::cell::Cell<usize>,
}

impl Hamiltonian<Const<2>> for CountingOscillator {
    fn dim(&self) -> Const<2> {
        Const
    }
    fn flags(&self) -> Flags {
        Flags::default().with_separable(true)
    }
    fn value(&self, z: &dth_core::nalgebra::Vector2<f64>) -> f64 {
        0.5 * (z[1] * z[1] + self.k * z[0] * z[0])
    }
    fn gradient_into(
        &self,
        z: &dth_core::nalgebra::Vector2<f64>,
        out: &mut dth_core::nalgebra::Vector2<f64>,
    ) {
        self.gradients.set(self.gradients.get() + 1);
        *out = dth_core::nalgebra::Vector2::new(self.k * z[0], z[1]);
    }
    fn hessian_into(
        &self,
        _: &dth_core::nalgebra::Vector2<f64>,
        out: &mut dth_core::nalgebra::Matrix2<f64>,
    ) {
        *out = dth_core::nalgebra::Matrix2::new(self.k, 0.0, 0.0, 1.0);
    }
}

/// One Stormer-Verlet value stepping a Hamiltonian whose parameter changes between steps
/// (a parameter sweep or schedule, each step from where the last ended): each step is the
/// step a fresh integrator takes, not one with the force of the previous parameter (which it
/// reused when the step started from the last step's end); within a run on one `H` the last
/// force is still reused (two gradient evaluations per step).
#[test]
fn verlet_does_not_reuse_the_force_of_another_hamiltonian() {
    let oscillator = |k| CountingOscillator {
        k,
        gradients: std::cell::Cell::new(0),
    };
    let mut verlet = StormerVerlet::new();
    let mut z = dth_core::nalgebra::Vector2::new(1.0, 0.0);
    for k in [1.0, 4.0, 0.25, 9.0] {
        let h = oscillator(k);
        let next = verlet.step(&h, &z, 0.1).expect("step");
        assert_eq!(
            next,
            StormerVerlet::new().step(&h, &z, 0.1).expect("step"),
            "k = {k}"
        );
        z = next;
    }
    // Two runs from where the last ended, with another parameter: the second starts afresh.
    let (a, b) = (oscillator(1.0), oscillator(4.0));
    let end = run(&mut verlet, &a, &z, 0.0, 0.1, 10, &mut ()).expect("run");
    let fresh = run(&mut StormerVerlet::new(), &b, &end.z, 0.0, 0.1, 10, &mut ()).expect("run");
    let b_gradients = b.gradients.get();
    assert_eq!(
        run(&mut verlet, &b, &end.z, 0.0, 0.1, 10, &mut ()),
        Ok(fresh)
    );
    // First-same-as-last within a run: 3 evaluations for the first step, 2 for each other.
    assert_eq!(a.gradients.get(), 3 + 2 * 9);
    assert_eq!(b.gradients.get() - b_gradients, 3 + 2 * 9);
}
