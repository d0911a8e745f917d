//! Ordinary failures in hard cases: every failure path of the DTH stepper returns its typed
//! error variant, with data, checked before the first step where it can be, and keeps what was
//! computed. (The stepper's own failure tests are in `dth_failures.rs`; these add invalid
//! options and parameters, near collisions, steps far too large, inconsistent discrete
//! gradients, `Psi = 0` starts and the robust mode's own failure.)

use dth_core::dth::{integrate, segment_from_vertex, Dth, DthOptions};
use dth_core::nalgebra::Const;
use dth_core::nalgebra::{Matrix2, Matrix4, Vector2, Vector4};
use dth_core::observer::StepKind;
use dth_core::systems::{Kepler, Pendulum};
use dth_core::Flags;
use dth_core::{Error, Hamiltonian};

mod fixtures;
use fixtures::{Saddle, Walled};

fn thesis_z0() -> Vector4<f64> {
    Vector4::new(0.5, 0.0, 0.0, 1.2)
}

#[test]
fn invalid_options_are_rejected_with_name_and_value() {
    let o = DthOptions::thesis_kepler();
    for bad in [0.0, -0.1, f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
        assert!(matches!(
            o.with_dtau(bad),
            Err(Error::InvalidOption { name: "dtau", .. })
        ));
        assert!(matches!(
            o.with_lambda0(bad),
            Err(Error::InvalidOption {
                name: "lambda0",
                ..
            })
        ));
    }
    let e = o.with_dtau(-2.5).expect_err("negative dtau");
    assert!(matches!(e, Error::InvalidOption { name: "dtau", value, .. } if value == -2.5));
    for bad in [1.0, 0.5, f64::NAN, f64::INFINITY] {
        assert!(matches!(
            o.with_max_lambda_ratio(bad),
            Err(Error::InvalidOption {
                name: "max_lambda_ratio",
                ..
            })
        ));
    }
    assert!(matches!(
        o.with_max_iterations(0),
        Err(Error::InvalidOption {
            name: "max_iterations",
            ..
        })
    ));
    assert!(matches!(
        o.with_residual_tolerance(f64::NAN),
        Err(Error::InvalidOption {
            name: "residual_tolerance",
            ..
        })
    ));
    assert!(matches!(
        o.with_stall_tolerance(0.0),
        Err(Error::InvalidOption {
            name: "stall_tolerance",
            ..
        })
    ));
    let dth = Dth::new(Kepler::thesis(), thesis_z0(), o).expect("start");
    assert!(matches!(
        dth.with_tbar0(f64::NAN),
        Err(Error::InvalidOption { name: "tbar0", .. })
    ));
    assert!(matches!(
        segment_from_vertex(&Kepler::thesis(), &thesis_z0(), -0.56, 0.0, &o),
        Err(Error::InvalidOption {
            name: "lambda_guess",
            ..
        })
    ));
}

#[test]
fn non_finite_initial_state_is_rejected_before_the_first_step_for_every_component() {
    for index in 0..4 {
        for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
            let mut z = thesis_z0();
            z[index] = bad;
            let e = integrate(Kepler::thesis(), z, DthOptions::thesis_kepler(), 10)
                .expect_err("non-finite start");
            assert!(
                matches!(e.error, Error::NonFiniteInitialState { index: i, .. } if i == index),
                "{:?}",
                e.error
            );
            assert!(e.partial.is_empty());
        }
    }
}

#[test]
fn non_finite_parameters_are_rejected_before_the_first_step() {
    // Parameters enter through H: a NaN or infinite parameter (or one that makes H infinite,
    // mass 0) makes H, grad H or Hess H non-finite at zbar_0, caught by the constructor.
    for kepler in [
        Kepler {
            mass: f64::NAN,
            k: 1.0,
        },
        Kepler {
            mass: 0.5,
            k: f64::INFINITY,
        },
        Kepler { mass: 0.0, k: 1.0 },
    ] {
        let r = Dth::new(kepler, thesis_z0(), DthOptions::thesis_kepler());
        assert!(
            matches!(r, Err(Error::NonFinite { step: 0, .. })),
            "{kepler:?}: {r:?}"
        );
    }
}

#[test]
fn near_collision_makes_the_newton_matrix_singular() {
    // An orbit with pericentre r = 0.03 (a third of the thesis's time scale per unit radius:
    // period ~ 0.06) and dtau = 0.02, lambda_0 = 1: Newton's iterates are pulled towards the
    // singularity, where Hess H ~ k / r^3 dominates A = I - (h lambda/2) J Hess H and A is
    // numerically singular (pivot below D eps max|A_ij|). Typed, step 1, zbar_0 kept; with a
    // step 4x smaller on the r = 0.1 orbit the run is fine (control).
    let kepler = Kepler::thesis();
    let start = |r: f64| Vector4::new(r, 0.0, 0.0, 1.2 * (0.5 / r).sqrt());
    let options = DthOptions::new(0.02).expect("valid");
    let e = integrate(kepler, start(0.03), options, 200).expect_err("near collision");
    assert!(
        matches!(e.error, Error::SingularMatrix { step: 1 }),
        "{:?}",
        e.error
    );
    assert_eq!(e.partial.len(), 1);
    let fine = DthOptions::new(0.005).expect("valid");
    assert!(integrate(kepler, start(0.1), fine, 200).is_ok());
}

#[test]
fn a_step_far_too_large_does_not_converge_and_is_not_retried() {
    // The pendulum in libration with dtau lambda_0 = 6 (about a period): Newton stalls with a
    // residual above tolerance at step 3. The step is not retried with a smaller dtau (see
    // Dth::step): the run stops with NewtonDiverged and keeps midpoints 0..2, and the stepper
    // stays at k = 2.
    let options = DthOptions::new(2.0)
        .and_then(|o| o.with_lambda0(3.0))
        .expect("valid");
    let z0 = Vector2::new(0.3, 1.0);
    let e = integrate(Pendulum::normalized(), z0, options, 10).expect_err("too large");
    assert!(
        matches!(e.error, Error::NewtonDiverged { step: 3, iterations, residual }
            if iterations > 1 && residual > 64.0 * f64::EPSILON),
        "{:?}",
        e.error
    );
    assert_eq!(e.partial.len(), 3);
    let mut dth = Dth::new(Pendulum::normalized(), z0, options).expect("start");
    assert!(dth.advance(10).is_err());
    assert_eq!(dth.k(), 2);
}

/// Kepler with a discrete gradient whose `p1` component is off by 0.1%: inconsistent with its
/// value (a uniform scaling would not do: the cancellation-free residual is homogeneous in
/// `gbar`).
struct WrongDiscreteGradient(Kepler);

impl Hamiltonian<Const<4>> for WrongDiscreteGradient {
    fn dim(&self) -> Const<4> {
        Const
    }

    fn flags(&self) -> Flags {
        Flags::default().with_exact_divided_differences(true)
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
    fn discrete_gradient_into(&self, z0: &Vector4<f64>, z1: &Vector4<f64>, out: &mut Vector4<f64>) {
        *out = {
            let mut g = self.0.discrete_gradient(z0, z1);
            g[2] *= 1.001;
            g
        };
    }
    fn discrete_gradient_defect_into(
        &self,
        z0: &Vector4<f64>,
        z1: &Vector4<f64>,
        gbar: &Vector4<f64>,
        out: &mut Vector4<f64>,
    ) {
        *out = self.0.discrete_gradient_defect(z0, z1, gbar);
    }
}

#[test]
fn inconsistent_discrete_gradient_fails_the_energy_check() {
    let e = integrate(
        WrongDiscreteGradient(Kepler::thesis()),
        thesis_z0(),
        DthOptions::thesis_kepler(),
        10,
    )
    .expect_err("inconsistent override");
    assert!(
        matches!(e.error, Error::EnergyCheckFailed { step: 1, deviation, scaled }
            if deviation.abs() > 0.0 && scaled > 64.0 * f64::EPSILON),
        "{:?}",
        e.error
    );
    assert_eq!(e.partial.len(), 1);
}

#[test]
fn start_where_psi_is_exactly_zero_on_the_whole_orbit_is_singular() {
    // zbar_0 = (1, 1) lies on the saddle's stable manifold p = q, where Psi = p^2 - q^2 = 0
    // exactly, and stays there: H(z(lambda)) = 0 for every lambda, so the energy equation does
    // not determine lambda (g_lambda = 0). The Schur complement is exactly zero: a singular
    // Newton matrix, reported at step 1, nothing else computed.
    let mut dth = Dth::new(
        Saddle,
        Vector2::new(1.0, 1.0),
        DthOptions::new(0.06277).expect("valid dtau"),
    )
    .expect("start");
    assert_eq!(dth.record().dth.map(|d| d.psi), Some(0.0));
    let r = dth.step();
    assert!(matches!(r, Err(Error::SingularMatrix { step: 1 })), "{r:?}");
    assert_eq!(dth.k(), 0);
}

/// `H = p^2 / 2 + q^3 / 3`: `Psi = p^2 V'' + V'^2 = 2 q p^2 + q^4`, exactly 0 at `q = 0` and
/// changing sign there.
struct Cubic;

impl Hamiltonian<Const<2>> for Cubic {
    fn dim(&self) -> Const<2> {
        Const
    }

    fn value(&self, z: &Vector2<f64>) -> f64 {
        0.5 * z[1] * z[1] + z[0] * z[0] * z[0] / 3.0
    }
    fn gradient_into(&self, z: &Vector2<f64>, out: &mut Vector2<f64>) {
        *out = Vector2::new(z[0] * z[0], z[1]);
    }
    fn hessian_into(&self, z: &Vector2<f64>, out: &mut Matrix2<f64>) {
        *out = Matrix2::new(2.0 * z[0], 0.0, 0.0, 1.0);
    }
}

#[test]
fn start_where_psi_is_exactly_zero_then_changes_sign() {
    // zbar_0 = (0, 1): Psi = 0 exactly. The law of time gives no verdict there (its constant is
    // 0), so Newton decides from lambda_0; Psi > 0 ahead (q grows), so the first steps succeed
    // and set the law of time. The orbit H = 1/2 turns at q = 1.14 and comes back through
    // q = 0, where Psi changes sign: a breakdown, reported with its data; in robust mode the
    // run goes through with fallback steps (and on to q -> -infinity, where this orbit
    // escapes), energy exact at every point.
    let options = DthOptions::new(0.05).expect("valid");
    let z0 = Vector2::new(0.0, 1.0);
    assert_eq!(Cubic.psi(&z0), 0.0);
    let e = integrate(Cubic, z0, options, 2_000).expect_err("Psi changes sign at q = 0");
    println!(
        "cubic, Psi(zbar_0) = 0: {:?} after {} midpoints",
        e.error,
        e.partial.len()
    );
    assert!(e.partial.len() > 10, "steps away from Psi = 0 succeed");
    assert!(
        matches!(e.error, Error::Breakdown { psi, psi_previous, .. } if psi * psi_previous <= 0.0
            || psi.abs() < psi_previous.abs()),
        "{:?}",
        e.error
    );
    let t = integrate(Cubic, z0, options.with_robust(true), 2_000).expect("robust");
    assert!(t.fallback_steps() > 0 && t.fallback_steps() < t.len());
    for z in t.midpoints() {
        // The check-and-project keeps every point within a few eps of the size of the terms.
        let terms = 0.5 * z[1] * z[1] + (z[0] * z[0] * z[0] / 3.0).abs();
        assert!(
            (Cubic.value(z) - 0.5).abs() <= 8.0 * f64::EPSILON * terms.max(1.0),
            "{z:?}"
        );
    }
    assert_eq!(t.kinds()[0], StepKind::Dth);
}

#[test]
fn robust_mode_stops_with_the_fallback_error_where_the_orbit_cannot_be_followed() {
    // The orbit of amplitude 1.2 runs into q > 1 where H is NaN. The robust mode turns the DTH
    // failure into fallback steps, halves them towards the wall down to 2^-20 of their size,
    // then stops with the fallback's typed error; everything before is kept and marked.
    let options = DthOptions::new(0.1).expect("valid").with_robust(true);
    let e = integrate(Walled, Vector2::new(0.0, 1.2), options, 1_000).expect_err("wall");
    assert!(
        matches!(e.error, Error::MethodNonFinite { method: "discrete_gradient", step, .. } if step == e.partial.len()),
        "{}",
        e.error
    );
    let t = &e.partial;
    assert!(t.fallback_steps() > 0);
    assert!(t
        .midpoints()
        .iter()
        .all(|z| z[0] <= 1.0 && (Walled.value(z) - 0.72).abs() <= 8.0 * f64::EPSILON));
}
