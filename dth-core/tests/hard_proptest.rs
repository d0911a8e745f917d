//! Property tests over random initial conditions and steps: never a panic, never a
//! NaN; either Ok with the invariants (energy at every midpoint or node, lambda > 0, time
//! increasing) or a typed error variant with a valid partial trajectory.

use dth_core::dth::{integrate, DthOptions, Trajectory};
use dth_core::nalgebra::Const;
use dth_core::nalgebra::{SVector, Vector2, Vector4};
use dth_core::systems::{HenonHeiles, Kepler, Pendulum};
use dth_core::{Error, Hamiltonian};
use proptest::prelude::*;

const EPS: f64 = f64::EPSILON;

/// The invariants every stored point keeps, whatever the outcome.
fn check<H: Hamiltonian<Const<D>>, const D: usize>(
    h: &H,
    t: &Trajectory<Const<D>>,
    e0: f64,
) -> Result<(), TestCaseError> {
    for (i, z) in t.midpoints().iter().enumerate() {
        prop_assert!(z.iter().all(|x| x.is_finite()), "NaN at {i}");
        // Roundoff scale of H at a float point: sum |z_i dH/dz_i| (an ulp per component), at
        // least |H0|; the check-and-project (or the plain residual) keeps H within 64 eps of it.
        let scale = z
            .component_mul(&h.gradient(z))
            .abs()
            .sum()
            .max(e0.abs())
            .max(1e-300);
        let de = (h.value(z) - e0).abs() / scale;
        prop_assert!(de <= 64.0 * EPS, "energy at {i}: {de:e}");
    }
    prop_assert!(t.lambdas().iter().all(|l| l.is_finite() && *l > 0.0));
    prop_assert!(t.midpoint_times().windows(2).all(|w| w[1] > w[0]));
    prop_assert!(t.vertices().iter().all(|z| z.iter().all(|x| x.is_finite())));
    Ok(())
}

fn typed(e: &Error) -> bool {
    matches!(
        e,
        Error::NewtonDiverged { .. }
            | Error::SpuriousRoot { .. }
            | Error::SingularMatrix { .. }
            | Error::NonFinite { .. }
            | Error::Breakdown { .. }
            | Error::EnergyCheckFailed { .. }
            | Error::MethodNotConverged { .. }
            | Error::MethodSingularMatrix { .. }
            | Error::MethodNonFinite { .. }
    )
}

fn run_case<H: Hamiltonian<Const<D>> + Copy, const D: usize>(
    h: H,
    z0: SVector<f64, D>,
    dtau: f64,
    lambda0: f64,
    robust: bool,
    steps: usize,
) -> Result<(), TestCaseError> {
    let options = DthOptions::new(dtau)
        .and_then(|o| o.with_lambda0(lambda0))
        .expect("valid by construction")
        .with_robust(robust);
    let e0 = h.value(&z0);
    match integrate(h, z0, options, steps) {
        Ok(t) => {
            prop_assert_eq!(t.len(), steps + 1);
            check(&h, &t, e0)
        }
        Err(e) => {
            // Seen over 3 x 256 cases: Breakdown (most), SingularMatrix, NewtonDiverged,
            // SpuriousRoot; none in robust mode.
            let breakdown = matches!(e.error, Error::Breakdown { .. });
            prop_assert!(!(robust && breakdown), "robust mode stopped at a breakdown");
            prop_assert!(typed(&e.error), "unexpected variant {:?}", e.error);
            prop_assert!(!e.partial.is_empty(), "zbar_0 kept");
            check(&h, &e.partial, e0)
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, ..ProptestConfig::default() })]

    #[test]
    fn kepler_random_orbits_and_steps(
        r in 0.2f64..3.0,
        angle in 0.0f64..std::f64::consts::TAU,
        speed in 0.1f64..2.0,
        direction in 0.0f64..std::f64::consts::TAU,
        log_dtau in -4.0f64..-0.5,
        lambda0 in 0.1f64..10.0,
        robust: bool,
    ) {
        let z0 = Vector4::new(r * angle.cos(), r * angle.sin(), speed * direction.cos(), speed * direction.sin());
        run_case(Kepler::thesis(), z0, 10f64.powf(log_dtau), lambda0, robust, 200)?;
    }

    #[test]
    fn pendulum_random_states_and_steps(
        q in -3.0f64..3.0,
        p in -3.0f64..3.0,
        log_dtau in -3.0f64..0.0,
        lambda0 in 0.1f64..10.0,
        robust: bool,
    ) {
        run_case(Pendulum::normalized(), Vector2::new(q, p), 10f64.powf(log_dtau), lambda0, robust, 200)?;
    }

    #[test]
    fn henon_heiles_random_states_and_steps(
        q1 in -0.5f64..0.5,
        q2 in -0.5f64..0.5,
        p1 in -0.5f64..0.5,
        p2 in -0.5f64..0.5,
        log_dtau in -3.0f64..0.0,
        robust: bool,
    ) {
        run_case(HenonHeiles, Vector4::new(q1, q2, p1, p2), 10f64.powf(log_dtau), 1.0, robust, 200)?;
    }
}
