//! Order of accuracy of every peer, measured by halving the step: on one period of the thesis
//! Kepler orbit against the exact solution (`kepler.rs`), and on the harmonic oscillator
//! against its closed form.

use dth_core::kepler::KeplerOrbit;
use dth_core::methods::{
    run, DiscreteGradient, DiscreteMechanics, GaussLegendre2, ImplicitMidpoint, OneStepMethod, Rk4,
    StormerVerlet, Trapezoidal,
};
use dth_core::nalgebra::Const;
use dth_core::nalgebra::{SVector, Vector2, Vector4};
use dth_core::systems::{HarmonicOscillator, Kepler};
use dth_core::Hamiltonian;

/// Global error at `t_end` of `steps` steps, in the max norm.
fn error<const D: usize, H: Hamiltonian<Const<D>>, M: OneStepMethod<Const<D>, H>>(
    mut method: M,
    h: &H,
    z0: &SVector<f64, D>,
    exact: &SVector<f64, D>,
    t_end: f64,
    steps: usize,
) -> f64 {
    let end = run(
        &mut method,
        h,
        z0,
        0.0,
        t_end / steps as f64,
        steps,
        &mut (),
    )
    .expect("run");
    (end.z - exact).amax()
}

/// Observed orders `log2(e(dt) / e(dt/2))` over three halvings from `steps`.
fn observed_orders<
    const D: usize,
    H: Hamiltonian<Const<D>>,
    M: OneStepMethod<Const<D>, H> + Clone,
>(
    method: M,
    h: &H,
    z0: &SVector<f64, D>,
    exact: &SVector<f64, D>,
    t_end: f64,
    steps: usize,
) -> Vec<f64> {
    let errors: Vec<f64> = (0..4)
        .map(|i| error(method.clone(), h, z0, exact, t_end, steps << i))
        .collect();
    eprintln!(
        "{}: errors {:?}",
        M::NAME,
        errors
            .iter()
            .map(|e| format!("{e:.3e}"))
            .collect::<Vec<_>>()
    );
    errors.windows(2).map(|w| (w[0] / w[1]).log2()).collect()
}

/// The band: the error is `C dt^p (1 + O(dt^s))` with `s = 2` for the symmetric methods (their
/// expansion has only even powers) and `s = 1` for RK4, so the observed order is
/// `p + O(dt^s)`. The step counts below put that correction at a few hundredths (measured:
/// symmetric methods within 0.013 of p, RK4 on Kepler 4.05 -> 4.01, halving per halving as
/// `O(dt)` predicts); `0.1` is that with a margin, and tight enough to tell 2 from 3, 4 from 5.
/// Errors stay >= 4e-9, far above the roundoff accumulated over <= 3200 steps (~1e-13).
const BAND: f64 = 0.1;

fn assert_order(orders: &[f64], p: u32, name: &str) {
    eprintln!("{name}: observed orders {orders:.3?}");
    for &o in orders {
        assert!(
            (o - p as f64).abs() < BAND,
            "{name}: observed {orders:?}, expected {p}"
        );
    }
}

fn kepler_case() -> (Kepler, Vector4<f64>, Vector4<f64>, f64) {
    let h = Kepler::thesis();
    let z0 = Vector4::new(0.5, 0.0, 0.0, 1.2);
    let orbit = KeplerOrbit::new(&h, &z0).unwrap();
    // 1.3 periods: ends away from the symmetric point, so no error component cancels.
    let t_end = 1.3 * orbit.elements().period;
    (h, z0, orbit.state_at(t_end), t_end)
}

fn oscillator_case() -> (HarmonicOscillator, Vector2<f64>, Vector2<f64>, f64) {
    let h = HarmonicOscillator { mass: 2.0, k: 3.0 };
    let z0 = Vector2::new(0.7, -0.4);
    let omega = (h.k / h.mass).sqrt();
    let t_end = 5.3;
    let (s, c) = (omega * t_end).sin_cos();
    let q = z0[0] * c + z0[1] / (h.mass * omega) * s;
    let p = -z0[0] * h.mass * omega * s + z0[1] * c;
    (h, z0, Vector2::new(q, p), t_end)
}

macro_rules! order_tests {
    ($($name:ident: $method:expr, $p:expr, $kepler_steps:expr, $osc_steps:expr;)*) => {$(
        mod $name {
            use super::*;
            #[test]
            fn kepler() {
                let (h, z0, exact, t_end) = kepler_case();
                let orders = observed_orders($method, &h, &z0, &exact, t_end, $kepler_steps);
                assert_order(&orders, $p, concat!(stringify!($name), " on Kepler"));
            }
            #[test]
            fn oscillator() {
                let (h, z0, exact, t_end) = oscillator_case();
                let orders = observed_orders($method, &h, &z0, &exact, t_end, $osc_steps);
                assert_order(&orders, $p, concat!(stringify!($name), " on the oscillator"));
            }
        }
    )*};
}

/// Greenspan's discrete mechanics needs a central force in R^n with r > 0 along the orbit; the
/// 1-D oscillator passes through q = 0, so it is measured on Kepler only.
#[test]
fn discrete_mechanics_on_kepler() {
    let (h, z0, exact, t_end) = kepler_case();
    let orders = observed_orders(DiscreteMechanics::new(), &h, &z0, &exact, t_end, 400);
    assert_order(&orders, 2, "discrete mechanics on Kepler");
}

order_tests! {
    trapezoidal: Trapezoidal::new(), 2, 400, 100;
    midpoint: ImplicitMidpoint::new(), 2, 400, 100;
    verlet: StormerVerlet::new(), 2, 400, 100;
    discrete_gradient: DiscreteGradient::new(), 2, 400, 100;
    rk4: Rk4::new(), 4, 400, 50;
    gauss_legendre2: GaussLegendre2::new(), 4, 100, 25;
}

/// The exact Kepler solution against a tightly converged GL2 run (0.77 period, 2000 and 4000
/// steps): GL2's error must be small *and* shrink by ~2^4 when the step halves, which checks
/// `kepler.rs` independently of its own formulas.
#[test]
fn exact_kepler_agrees_with_converged_gauss_legendre() {
    let h = Kepler::thesis();
    let z0 = Vector4::new(0.5, 0.0, 0.0, 1.2);
    let orbit = KeplerOrbit::new(&h, &z0).unwrap();
    let t_end = 0.77 * orbit.elements().period;
    let exact = orbit.state_at(t_end);
    let e1 = error(GaussLegendre2::new(), &h, &z0, &exact, t_end, 2000);
    let e2 = error(GaussLegendre2::new(), &h, &z0, &exact, t_end, 4000);
    eprintln!("GL2 vs exact Kepler: {e1:.3e}, {e2:.3e}");
    // Measured 5e-11 and 3e-12 (C dt^4, dt = 1.4e-3); 8000 steps already reach the roundoff
    // floor (~1e-13), where the ratio test would be meaningless.
    assert!(e1 < 1e-9, "{e1:e}");
    // Ratio 2^4 = 16 up to O(dt^2): at least 12.
    assert!(e2 < e1 / 12.0, "{e1:e} -> {e2:e}");
}

/// Time-dependent H through the extended phase space (q, t, p, p_t): the fixed-step methods
/// need nothing special and keep their order on the forced oscillator; the `t` coordinate
/// tracks the driver's clock.
mod forced_oscillator {
    use super::*;
    use dth_core::systems::ForcedOscillator;

    const H: ForcedOscillator = ForcedOscillator {
        omega0: 1.3,
        force: 0.4,
        omega: 0.7,
    };

    /// `exact_clock`: the method advances the `t` coordinate by exactly `dt` (every method here
    /// except the Gonzalez discrete gradient, whose correction term is along `z1 - z0`, which
    /// has a `t` component: there `t` differs from the clock by `O(dt^2)`, still second order).
    fn orders<M: OneStepMethod<Const<4>, ForcedOscillator> + Clone>(
        method: M,
        steps: usize,
        exact_clock: bool,
    ) -> Vec<f64> {
        let (q0, p0, t_end) = (0.6, -0.2, 4.1);
        let z0 = H.initial_state(q0, p0, 0.0);
        let (q, p) = H.exact(q0, p0, t_end);
        let errors: Vec<f64> = (0..4)
            .map(|i| {
                let n = steps << i;
                let end = run(
                    &mut method.clone(),
                    &H,
                    &z0,
                    0.0,
                    t_end / n as f64,
                    n,
                    &mut (),
                )
                .expect("run");
                // t is a coordinate: it advances by exactly dt per step up to roundoff.
                let clock = (end.z[1] - end.t).abs();
                let bound = if exact_clock {
                    1e-12
                } else {
                    0.1 / (n * n) as f64
                };
                assert!(clock < bound, "t {} vs {}", end.z[1], end.t);
                (end.z[0] - q).abs().max((end.z[2] - p).abs())
            })
            .collect();
        errors.windows(2).map(|w| (w[0] / w[1]).log2()).collect()
    }

    #[test]
    fn peers_keep_their_order() {
        assert_order(
            &orders(ImplicitMidpoint::new(), 50, true),
            2,
            "midpoint, forced",
        );
        assert_order(
            &orders(Trapezoidal::new(), 50, true),
            2,
            "trapezoidal, forced",
        );
        assert_order(&orders(StormerVerlet::new(), 50, true), 2, "verlet, forced");
        assert_order(
            &orders(DiscreteGradient::new(), 50, false),
            2,
            "discrete gradient, forced",
        );
        assert_order(&orders(Rk4::new(), 50, true), 4, "rk4, forced");
        assert_order(
            &orders(GaussLegendre2::new(), 25, true),
            4,
            "gauss-legendre 2, forced",
        );
    }
}

/// A 10-particle periodic Toda chain (D = 20): the generic methods run at that size and keep
/// the linear invariant (total momentum) to roundoff, GL2 the energy to its O(dt^4) error.
#[test]
fn toda_chain_of_ten() {
    use dth_core::systems::{TodaBoundary, TodaChain};
    let toda = TodaChain::<10>::new(TodaBoundary::Periodic);
    let z0 = SVector::<f64, 20>::from_fn(|i, _| {
        if i < 10 {
            0.1 * i as f64
        } else {
            (i as f64 * 0.7).sin()
        }
    });
    let momentum = |z: &SVector<f64, 20>| z.rows(10, 10).sum();
    let e0 = toda.value(&z0);
    for (name, end) in [
        (
            "verlet",
            run(
                &mut StormerVerlet::new(),
                &toda,
                &z0,
                0.0,
                0.01,
                1000,
                &mut (),
            )
            .unwrap(),
        ),
        (
            "gauss_legendre2",
            run(
                &mut GaussLegendre2::new(),
                &toda,
                &z0,
                0.0,
                0.01,
                1000,
                &mut (),
            )
            .unwrap(),
        ),
    ] {
        // 1000 steps of O(1) momenta summed over 10 particles: ~1e-13 roundoff.
        assert!((momentum(&end.z) - momentum(&z0)).abs() < 1e-12, "{name}");
        assert!((toda.value(&end.z) - e0).abs() < 1e-4 * e0.abs(), "{name}");
    }
}
