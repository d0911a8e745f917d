//! The discrete gradient that `hamiltonian!` generates: Kepler's energy difference at steps of
//! 1e-9 against a double-double reference (and against the plain difference and Gonzalez's
//! default, which lose digits there), `gbar(z, z) = grad H(z)`, the time-dependent extended
//! phase space, and bit-for-bit agreement with the engine's program for every kernel.

use dth::nalgebra::Const;
#[path = "../dth-symbolic/src/double_double.rs"]
#[allow(dead_code)]
mod dd;

use dd::Dd;
use dth::nalgebra::{Matrix4, SVector, Vector4};
use dth::systems::Kepler;
use dth::Hamiltonian;
use dth_symbolic::{compile, Method};

mod everything;
use everything::{Everything, EVERYTHING};

const EPS: f64 = f64::EPSILON;

dth::hamiltonian! {
    /// `H = |p|^2 / (2 m) - k / |q|`.
    #[derive(Clone, Copy, Debug)]
    pub struct KeplerMk { pub m: f64, pub k: f64 } = (p1^2 + p2^2)/(2*m) - k*(q1^2 + q2^2)^(-1/2)
}

dth::hamiltonian! {
    /// A forced oscillator: time-dependent, `z = (q1, t, p1, p_t)`.
    #[derive(Clone, Copy, Debug)]
    pub struct Forced { pub a: f64, pub w: f64 } = p1^2/2 + q1^2/2 - a*q1*cos(w*t)
}

/// The hand-written Kepler with only value, gradient and Hessian: the trait's default
/// (Gonzalez) discrete gradient. (`Kepler` itself overrides it with exact divided differences.)
struct GonzalezKepler(Kepler);

impl Hamiltonian<Const<4>> for GonzalezKepler {
    fn dim(&self) -> Const<4> {
        Const
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

/// Kepler's `H` in double-double.
fn kepler_dd(m: f64, k: f64, z: &Vector4<f64>) -> Dd {
    let x = |i: usize| Dd::from(z[i]);
    let r = (x(0) * x(0) + x(1) * x(1)).sqrt();
    (x(2) * x(2) + x(3) * x(3)) / (Dd::from(2.0) * Dd::from(m)) - Dd::from(k) / r
}

/// Points on and off the thesis orbit (r from 0.3 to 2).
fn points() -> [Vector4<f64>; 4] {
    [
        Vector4::new(0.5, 0.0, 0.0, 1.2),
        Vector4::new(-0.3, 0.4, 0.7, -0.2),
        Vector4::new(1.5, -1.2, -0.1, 0.3),
        Vector4::new(-0.2, -0.25, 2.0, 1.0),
    ]
}

/// Steps of relative size 1e-9, `d_i = 1e-9 (1 + |z_i|) u_i` for directions `u`.
fn steps(z: &Vector4<f64>) -> impl Iterator<Item = Vector4<f64>> + '_ {
    let dirs = [
        Vector4::new(1.0, 0.3, -0.7, 0.2),
        Vector4::new(-0.4, 0.9, 0.1, -1.0),
        Vector4::new(0.2, -0.6, 0.8, 0.5),
        // Along the flow (J grad H): H barely changes, the terms cancel.
        Vector4::new(0.0, 0.0, 0.0, 0.0),
    ];
    dirs.into_iter().map(move |u| {
        let u = if u == Vector4::zeros() {
            let g = Kepler::thesis().gradient(z);
            Vector4::new(g[2], g[3], -g[0], -g[1]).normalize()
        } else {
            u
        };
        z + Vector4::from_fn(|i, _| 1e-9 * (1.0 + z[i].abs()) * u[i])
    })
}

#[test]
fn kepler_energy_difference_at_tiny_steps_matches_double_double() {
    let item = KeplerMk { m: 0.5, k: 1.0 };
    let expr = dth::hamiltonian!(p1 ^ 2 + p2 ^ 2 - (q1 ^ 2 + q2 ^ 2) ^ (-1 / 2));
    let gonzalez = GonzalezKepler(Kepler::thesis());
    let (mut worst, mut worst_plain, mut worst_gonzalez) = (0.0f64, 0.0f64, 0.0f64);
    for z0 in points() {
        for z1 in steps(&z0) {
            let d = z1 - z0;
            let exact = (kepler_dd(0.5, 1.0, &z1) - kepler_dd(0.5, 1.0, &z0)).to_f64();
            // The size of the terms of gbar . d: the error a cancellation-free computation
            // may make is a few eps of it. (Along the flow from the pericenter, grad H . d is
            // 0 and gbar . d = O(|d|^2): the terms are that small too.)
            let terms = item
                .discrete_gradient(&z0, &z1)
                .component_mul(&d)
                .abs()
                .sum();
            for (what, err) in [
                (
                    "item gbar . d",
                    item.discrete_gradient(&z0, &z1).dot(&d) - exact,
                ),
                (
                    "item energy_difference",
                    item.energy_difference(&z0, &z1) - exact,
                ),
                (
                    "expression gbar . d",
                    expr.discrete_gradient(&z0, &z1).dot(&d) - exact,
                ),
                (
                    "expression energy_difference",
                    expr.energy_difference(&z0, &z1) - exact,
                ),
            ] {
                // About ten roundings per term (two square roots, a reciprocal, sums and
                // products) and a four-term dot product: 16 eps of the terms. The reference
                // itself carries a few roundings at 2^-104 of |H| ~ 1: that matters only for
                // the step along the flow from the pericenter, where H(z1) - H(z0) ~ 1e-18.
                let reference_error = 8.0 * 2f64.powi(-104) * (item.value(&z0).abs() + 1.0);
                assert!(
                    err.abs() <= 16.0 * EPS * terms + reference_error,
                    "{what} at {z0} -> {z1}: {:.2} eps of the terms",
                    err.abs() / (EPS * terms)
                );
                if terms > 1e-15 {
                    worst = worst.max(err.abs() / (EPS * terms));
                }
            }
            if terms > 1e-15 {
                let plain = item.value(&z1) - item.value(&z0) - exact;
                worst_plain = worst_plain.max(plain.abs() / (EPS * terms));
                let g = gonzalez.discrete_gradient(&z0, &z1).dot(&d) - exact;
                worst_gonzalez = worst_gonzalez.max(g.abs() / (EPS * terms));
            }
        }
    }
    eprintln!(
        "|d| ~ 1e-9: generated {worst:.2} (steps with terms > 1e-15), plain difference \
         {worst_plain:.3e}, Gonzalez default {worst_gonzalez:.3e} (eps of sum |g_i d_i|)"
    );
    // The plain difference errs by ~ eps |H| ~ eps, 1e9 eps of the terms at this step; even a
    // lucky draw over 15 steps stays above 1e6.
    assert!(worst_plain > 1e6 && worst_gonzalez > 1e6);
}

#[test]
fn discrete_gradient_at_one_point_is_the_gradient() {
    let h = KeplerMk { m: 0.5, k: 1.0 };
    for z in points() {
        let (gbar, g) = (h.discrete_gradient(&z, &z), h.gradient(&z));
        // Both evaluate the chain rule's terms at z, in a different order: a few roundings
        // of the largest term, |p|/m + 1/r^2.
        let scale = z.fixed_rows::<2>(2).norm() / 0.5 + 1.0 / z.fixed_rows::<2>(0).norm_squared();
        assert!(
            (gbar - g).abs().max() <= 8.0 * EPS * scale,
            "{gbar} vs {g} at {z}"
        );
        assert_eq!(h.energy_difference(&z, &z), 0.0);
    }
}

#[test]
fn time_dependent_discrete_gradient_lives_in_the_extended_phase_space() {
    let h = Forced { a: 0.3, w: 1.7 };
    let z0 = Vector4::new(0.4, 2.0, -0.3, 0.1);
    for s in [0.5, 1e-3, 1e-9] {
        let z1 = z0 + Vector4::new(0.7, 1.1, -0.4, 0.9) * s;
        let d = z1 - z0;
        let gbar = h.discrete_gradient(&z0, &z1);
        let terms = gbar.component_mul(&d).abs().sum();
        let delta = h.energy_difference(&z0, &z1);
        assert!((gbar.dot(&d) - delta).abs() <= 8.0 * EPS * terms);
        // At the large step the plain difference (error ~ eps |calH|) is a valid check.
        if s == 0.5 {
            let plain = h.value(&z1) - h.value(&z0);
            assert!((delta - plain).abs() <= 16.0 * EPS * (h.value(&z1).abs() + terms));
        }
        // d calH / d p_t = 1 exactly.
        assert_eq!(gbar[3], 1.0);
    }
    let g = h.gradient(&z0);
    assert!((h.discrete_gradient(&z0, &z0) - g).abs().max() <= 8.0 * EPS * g.abs().max());
}

/// The generated kernels are `Kernel::build`'s formulas written as code (the engine runs the
/// same formulas on `f64`); the generated code performs the engine's program in order: equal bit for bit, at distinct points and at `z0 = z1`
/// (where every kernel takes its limit branch).
#[test]
fn generated_code_performs_the_engine_program_bit_for_bit() {
    let (a, b) = (0.8, 0.3);
    let h = Everything { a, b };
    let program = compile(EVERYTHING, &["a", "b"])
        .unwrap()
        .program(Method::DiscreteGradient);
    let z0 = [0.6, -0.9, 0.4, 1.1];
    for z1 in [
        [0.61, -0.85, 0.38, 1.2],
        [0.6 + 1e-12, -0.9, 0.4, 1.1],
        z0,
        [-0.3, 1.4, 0.9, -0.2],
    ] {
        let e = program.eval_pair(&z0, &z1, &[a, b]).unwrap();
        let (v0, v1) = (SVector::from(z0), SVector::from(z1));
        let g = h.discrete_gradient(&v0, &v1);
        for i in 0..4 {
            assert_eq!(
                g[i].to_bits(),
                e.discrete_gradient[i].to_bits(),
                "gbar {i} at {z1:?}"
            );
        }
        assert_eq!(
            h.energy_difference(&v0, &v1).to_bits(),
            e.energy_difference.to_bits()
        );
    }
}
