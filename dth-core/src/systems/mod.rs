//! Hand-written reference Hamiltonians with analytic derivatives.
//!
//! They are the baselines the generated code is checked and benchmarked against, and they let
//! `dth-core` be tested without the macro. Every derivative is checked against num-dual
//! (automatic differentiation of an independent restatement of the formula) in the tests
//! below.

mod central_force;
mod double_pendulum;
mod forced_oscillator;
mod henon_heiles;
mod kepler;
mod oscillator;
mod pendulum;
mod toda;

pub use central_force::{guarded_divided_difference, CentralForce, DIVIDED_DIFFERENCE_SWITCH};
pub use double_pendulum::DoublePendulum;
pub use forced_oscillator::ForcedOscillator;
pub use henon_heiles::HenonHeiles;
pub use kepler::Kepler;
pub use oscillator::HarmonicOscillator;
pub use pendulum::Pendulum;
pub use toda::{TodaBoundary, TodaChain};

#[cfg(test)]
mod derivative_tests {
    //! value, gradient and Hessian of every system against num-dual's second-order dual
    //! numbers at several points. Both sides are exact derivatives evaluated in floating
    //! point, so they agree to a few eps relative to the size of the terms: the tolerance is
    //! `64 eps (1 + |entry|)`, loose enough for the cancellation inside `cos(d)` products of
    //! the double pendulum, tight enough to catch any wrong term.

    use super::*;
    use crate::Hamiltonian;
    use nalgebra::{Const, SVector};
    use num_dual::{hessian, Dual2SVec64, DualNum};

    type X<const D: usize> = SVector<Dual2SVec64<D>, D>;

    fn check<const D: usize, H: Hamiltonian<Const<D>>>(
        h: &H,
        f: impl Fn(X<D>) -> Dual2SVec64<D>,
        points: &[SVector<f64, D>],
    ) {
        for z in points {
            let (v, g, m) = hessian(&f, z);
            let close = |a: f64, b: f64| (a - b).abs() <= 64.0 * f64::EPSILON * (1.0 + b.abs());
            assert!(close(h.value(z), v), "value at {z}: {} vs {v}", h.value(z));
            let hg = h.gradient(z);
            let hm = h.hessian(z);
            for i in 0..D {
                assert!(
                    close(hg[i], g[i]),
                    "gradient[{i}] at {z}: {} vs {}",
                    hg[i],
                    g[i]
                );
                for j in 0..D {
                    assert!(
                        close(hm[(i, j)], m[(i, j)]),
                        "hessian[{i},{j}] at {z}: {} vs {}",
                        hm[(i, j)],
                        m[(i, j)]
                    );
                }
            }
        }
    }

    fn points<const D: usize>(seed: u64) -> Vec<SVector<f64, D>> {
        // A small deterministic generator (splitmix64) for points in [-1.5, 1.5]^D.
        let mut s = seed;
        let mut next = move || {
            s = s.wrapping_add(0x9E37_79B9_7F4A_7C15);
            let mut x = s;
            x = (x ^ (x >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            x = (x ^ (x >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            x ^= x >> 31;
            3.0 * (x as f64 / u64::MAX as f64) - 1.5
        };
        (0..8).map(|_| SVector::from_fn(|_, _| next())).collect()
    }

    #[test]
    fn pendulum() {
        let h = Pendulum {
            mass: 1.3,
            length: 0.7,
            gravity: 9.81,
        };
        check(
            &h,
            |z: X<2>| z[1] * z[1] / (2.0 * 1.3 * 0.7 * 0.7) - z[0].cos() * (1.3 * 9.81 * 0.7),
            &points(1),
        );
    }

    #[test]
    fn henon_heiles() {
        check(
            &HenonHeiles,
            |z: X<4>| {
                (z[2] * z[2] + z[3] * z[3]) * 0.5
                    + (z[0] * z[0] + z[1] * z[1]) * 0.5
                    + z[0] * z[0] * z[1]
                    - z[1].powi(3) / 3.0
            },
            &points(2),
        );
    }

    #[test]
    fn double_pendulum() {
        let h = DoublePendulum {
            m1: 1.2,
            m2: 0.8,
            l1: 1.1,
            l2: 0.9,
            g: 9.81,
        };
        let (m1, m2, l1, l2, g) = (1.2, 0.8, 1.1, 0.9, 9.81);
        check(
            &h,
            |z: X<4>| {
                let d = z[0] - z[1];
                let num = z[2] * z[2] * (m2 * l2 * l2) + z[3] * z[3] * ((m1 + m2) * l1 * l1)
                    - z[2] * z[3] * d.cos() * (2.0 * m2 * l1 * l2);
                let den = (d.sin() * d.sin() * m2 + m1) * (2.0 * m2 * l1 * l1 * l2 * l2);
                num / den - z[0].cos() * ((m1 + m2) * g * l1) - z[1].cos() * (m2 * g * l2)
            },
            &points(3),
        );
    }

    #[test]
    fn toda_periodic_and_fixed_ends() {
        let periodic = TodaChain::<3>::new(TodaBoundary::Periodic);
        check(
            &periodic,
            |z: X<6>| {
                (z[3] * z[3] + z[4] * z[4] + z[5] * z[5]) * 0.5
                    + (z[0] - z[1]).exp()
                    + (z[1] - z[2]).exp()
                    + (z[2] - z[0]).exp()
            },
            &points(4),
        );
        let fixed = TodaChain::<3>::new(TodaBoundary::FixedEnds);
        check(
            &fixed,
            |z: X<6>| {
                (z[3] * z[3] + z[4] * z[4] + z[5] * z[5]) * 0.5
                    + (-z[0]).exp()
                    + (z[0] - z[1]).exp()
                    + (z[1] - z[2]).exp()
                    + z[2].exp()
            },
            &points(5),
        );
    }

    #[test]
    fn toda_ten_particles() {
        let toda = TodaChain::<10>::new(TodaBoundary::Periodic);
        check(
            &toda,
            |z: X<20>| {
                let mut v = z[10] * z[10] * 0.5;
                for i in 11..20 {
                    v += z[i] * z[i] * 0.5;
                }
                for i in 0..10 {
                    v += (z[i] - z[(i + 1) % 10]).exp();
                }
                v
            },
            &points(6)[..2],
        );
    }

    #[test]
    fn forced_oscillator() {
        let h = ForcedOscillator {
            omega0: 1.3,
            force: 0.4,
            omega: 0.7,
        };
        check(
            &h,
            |z: X<4>| {
                z[3] + z[2] * z[2] * 0.5 + z[0] * z[0] * (0.5 * 1.3 * 1.3)
                    - z[0] * (z[1] * 0.7).cos() * 0.4
            },
            &points(7),
        );
    }

    #[test]
    fn kepler_and_oscillator() {
        check(
            &Kepler { mass: 0.7, k: 1.3 },
            |z: X<4>| {
                (z[2] * z[2] + z[3] * z[3]) / 1.4 - (z[0] * z[0] + z[1] * z[1]).sqrt().recip() * 1.3
            },
            &points(8),
        );
        check(
            &HarmonicOscillator { mass: 2.0, k: 3.0 },
            |z: X<2>| z[1] * z[1] / 4.0 + z[0] * z[0] * 1.5,
            &points(9),
        );
    }

    #[test]
    fn kepler_is_a_consistent_central_force() {
        // H = |p|^2/(2m) + phi(|q|) with the CentralForce description.
        let h = Kepler { mass: 0.7, k: 1.3 };
        for z in points::<4>(10) {
            let r = z[0].hypot(z[1]);
            let from_description = (z[2] * z[2] + z[3] * z[3]) / (2.0 * h.mass()) + h.phi(r);
            assert!(
                (from_description - h.value(&z)).abs()
                    <= 8.0 * f64::EPSILON * (1.0 + h.value(&z).abs())
            );
            let (_, dphi) = num_dual::first_derivative(|r| -r.recip() * 1.3, r);
            assert!((h.dphi(r) - dphi).abs() <= 8.0 * f64::EPSILON * dphi.abs());
            let dd = h.phi_divided_difference(r, 1.3 * r);
            let plain = (h.phi(1.3 * r) - h.phi(r)) / (0.3 * r);
            assert!((dd - plain).abs() <= 1e3 * f64::EPSILON * dd.abs());
        }
    }

    #[test]
    fn separability_flags_match_the_hessians() {
        // SEPARABLE must mean a zero q-p block of the Hessian, at every point.
        fn agrees<const D: usize, H: Hamiltonian<Const<D>>>(h: &H, seed: u64) -> bool {
            let n = D / 2;
            points::<D>(seed).iter().all(|z| {
                let m = h.hessian(z);
                let zero = (0..n).all(|i| (n..D).all(|j| m[(i, j)] == 0.0));
                zero == h.flags().separable
            })
        }
        assert!(agrees(&HenonHeiles, 11));
        assert!(agrees(&Kepler::thesis(), 12));
        assert!(agrees(&DoublePendulum::unit(), 13));
        assert!(agrees(&Pendulum::normalized(), 14));
        assert!(agrees::<8, _>(
            &TodaChain::<4>::new(TodaBoundary::FixedEnds),
            15
        ));
        let forced = ForcedOscillator {
            omega0: 1.0,
            force: 1.0,
            omega: 2.0,
        };
        assert!(agrees(&forced, 16));
        // Extended phase space: calH = p_t + H, so dcalH/dp_t = 1 everywhere.
        assert!(points::<4>(17).iter().all(|z| forced.gradient(z)[3] == 1.0));
    }
}
