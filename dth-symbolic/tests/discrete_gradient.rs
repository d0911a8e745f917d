//! The discrete gradient `gbar(z0, z1)` of `Method::DiscreteGradient` against references:
//! double-double energy differences for algebraic Hamiltonians (where the accuracy contrast with
//! the plain `H(z1) - H(z0)` is measured), and Gauss-Legendre quadrature of the exact gradient
//! along the segment for random expressions (`H(z1) - H(z0) = int_0^1 grad H(z0 + s d) . d ds`).

mod common;

use common::dd::Dd;
use common::*;
use dth_symbolic::{compile, Method, Output, Program};
use proptest::prelude::*;

const EPS: f64 = f64::EPSILON;

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

fn dot_abs(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| (x * y).abs()).sum()
}

fn value_dd(p: &Program, z: &[f64]) -> Dd {
    let v = eval_dd(p, z, &[]).expect("algebraic Hamiltonian");
    let s = p
        .outputs
        .iter()
        .find(|(o, _)| *o == Output::Value)
        .map(|&(_, s)| s)
        .expect("a value");
    v[s as usize]
}

/// A deterministic pseudo-random sequence in [-1, 1) (a 64-bit LCG), for directions.
struct Lcg(u64);

impl Lcg {
    fn next(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (self.0 >> 11) as f64 / (1u64 << 52) as f64 - 1.0
    }
}

/// For steps `|d_i| = scale (1 + |z_i|)` along random directions: the error of `delta` (the
/// divided-difference energy difference) and of the plain `H(z1) - H(z0)` against the
/// double-double difference, relative to the size of the terms `sum |g_i d_i|` (for a generic
/// direction about |H(z1) - H(z0)| itself). The divided difference stays at a few eps at every
/// scale; the plain difference loses digits like eps |H| / |d|.
#[test]
fn tiny_steps_keep_full_relative_accuracy_where_the_plain_difference_does_not() {
    let systems = [
        (
            "kepler",
            "p1^2 + p2^2 - (q1^2 + q2^2)^(-1/2)",
            vec![
                [0.5f64, 0.0, 0.0, 1.2],
                [-0.3, 0.4, 0.7, -0.2],
                [1.5, -1.2, -0.1, 0.3],
            ],
        ),
        (
            "henon-heiles",
            "p1^2/2 + p2^2/2 + q1^2/2 + q2^2/2 + q1^2*q2 - q2^3/3",
            vec![[0.1f64, -0.2, 0.3, 0.35], [0.3, 0.1, -0.2, 0.1]],
        ),
    ];
    let mut rng = Lcg(7);
    eprintln!("system        scale   max err delta  max err plain  (units: eps * sum |g_i d_i|)");
    for (name, src, points) in systems {
        let h = compile(src, &[]).unwrap();
        let (pair, all) = (h.program(Method::DiscreteGradient), h.program(Method::All));
        for scale in [1e-2, 1e-4, 1e-6, 1e-8, 1e-10, 1e-12] {
            let (mut worst_dg, mut worst_plain) = (0.0f64, 0.0f64);
            for z0 in &points {
                for _ in 0..20 {
                    let z1: Vec<f64> = z0
                        .iter()
                        .map(|z| z + scale * (1.0 + z.abs()) * rng.next())
                        .collect();
                    let d: Vec<f64> = z1.iter().zip(z0).map(|(a, b)| a - b).collect();
                    let exact = (value_dd(&all, &z1) - value_dd(&all, z0)).to_f64();
                    let e = pair.eval_pair(z0, &z1, &[]).unwrap();
                    let plain =
                        all.eval(&z1, &[]).unwrap().value - all.eval(z0, &[]).unwrap().value;
                    let terms = dot_abs(&all.eval(z0, &[]).unwrap().gradient, &d);
                    worst_dg = worst_dg.max((e.energy_difference - exact).abs() / (EPS * terms));
                    worst_dg =
                        worst_dg.max((dot(&e.discrete_gradient, &d) - exact).abs() / (EPS * terms));
                    worst_plain = worst_plain.max((plain - exact).abs() / (EPS * terms));
                }
            }
            eprintln!("{name:12} {scale:7.0e} {worst_dg:14.2} {worst_plain:14.3e}");
            // A few roundings of each term: the Kepler divided difference chains about ten
            // operations per term (sums, two square roots, reciprocals, a product).
            assert!(worst_dg <= 16.0, "{name} at scale {scale}: {worst_dg} eps");
            if scale <= 1e-8 {
                // The plain difference has absolute error ~ eps |H| ~ eps, i.e. eps / scale
                // relative to the terms: at least 1e4 eps here, where the divided difference
                // stays below 16 eps.
                assert!(
                    worst_plain >= 1e4,
                    "{name} at scale {scale}: plain {worst_plain} eps"
                );
            }
        }
    }
}

/// `w_k`, `s_k` of the `n`-point Gauss-Legendre rule on [0, 1], by Newton's method on the
/// Legendre polynomial (Golub-Welsch would do too; this is exact to rounding for n <= 16).
fn gauss_legendre(n: usize) -> Vec<(f64, f64)> {
    (0..n)
        .map(|i| {
            let mut x = (std::f64::consts::PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
            let mut dp = 1.0;
            for _ in 0..100 {
                let (mut p0, mut p1) = (1.0, x);
                for k in 2..=n {
                    let k = k as f64;
                    (p0, p1) = (p1, ((2.0 * k - 1.0) * x * p1 - (k - 1.0) * p0) / k);
                }
                dp = n as f64 * (x * p1 - p0) / (x * x - 1.0);
                let dx = p1 / dp;
                x -= dx;
                if dx.abs() < 1e-17 {
                    break;
                }
            }
            let w = 2.0 / ((1.0 - x * x) * dp * dp);
            ((1.0 + x) / 2.0, w / 2.0)
        })
        .collect()
}

/// `int_0^1 grad H(z0 + s d) . d ds` by `rule`, with a first-order bound `m` on its rounding
/// error (|computed - exact| <= eps m): the gradient's running error bound at each node, the
/// rounding of the node itself (|Hess| eps |z| moves the gradient), and the sum.
fn quadrature(all: &Program, z0: &[f64], d: &[f64], a: f64, rule: &[(f64, f64)]) -> (f64, f64) {
    let dim = z0.len();
    let (mut q, mut m) = (0.0, 0.0);
    for &(s, w) in rule {
        let z: Vec<f64> = z0.iter().zip(d).map(|(z, d)| z + s * d).collect();
        let e = all.eval(&z, &[a]).unwrap();
        let bounds = error_bounds(all, &z, a);
        q += w * dot(&e.gradient, d);
        for i in 0..dim {
            let mg = output_bound(all, &bounds, Output::Gradient(i));
            let moved: f64 = (0..dim)
                .map(|j| (e.hessian[i * dim + j] * (z[j].abs() + (s * d[j]).abs())).abs())
                .sum();
            m += w * (mg + moved + dim as f64 * e.gradient[i].abs()) * d[i].abs();
        }
    }
    (q, m)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(1024))]

    /// Random expressions (the generator of `derivatives_match_oracles`), random points and
    /// steps from 1e-12 to 1e-1: `delta` and `gbar . d` equal the quadrature of the exact
    /// gradient, and `gbar(z, z) = grad H(z)`, within running error bounds.
    #[test]
    fn identity_holds_for_random_hamiltonians(
        e in expr().prop_filter("constant-only operation", no_constant_operations),
        x in prop::array::uniform6(-1.5f64..1.5),
        dir in prop::array::uniform6(-1.0f64..1.0),
        log_scale in -12.0f64..-1.0,
        a in 0.5f64..2.0,
    ) {
        let src = format!("{} + p1^2/2 + p2^2/2", render(&e));
        let Ok(h) = compile(&src, &["a"]) else {
            // Only a constant H is rejected here (see derivatives_match_oracles).
            prop_assume!(false);
            unreachable!()
        };
        let coords: Vec<usize> = h.coordinates().iter().map(|&v| oracle_index(v)).collect();
        let z0: Vec<f64> = coords.iter().map(|&k| x[k]).collect();
        let scale = 10f64.powf(log_scale);
        let z1: Vec<f64> = coords.iter().map(|&k| x[k] + scale * dir[k]).collect();
        let d: Vec<f64> = z1.iter().zip(&z0).map(|(a, b)| a - b).collect();
        let (pair, all) = (h.program(Method::DiscreteGradient), h.program(Method::All));
        let ev = pair.eval_pair(&z0, &z1, &[a]).unwrap();
        let g0 = all.eval(&z0, &[a]).unwrap();
        prop_assume!(g0.value.is_finite() && g0.gradient.iter().chain(&g0.hessian).all(|v| v.is_finite()));
        prop_assert!(ev.discrete_gradient.iter().all(|v| v.is_finite()) && ev.energy_difference.is_finite(),
            "non-finite {ev:?} for {src}");

        // Reference: 8- and 16-point Gauss-Legendre. Their difference estimates the
        // truncation error of the 8-point rule (the 16-point one is far smaller); a step that
        // the rules do not resolve (oscillation within the segment) says nothing: skipped.
        let (q8, _) = quadrature(&all, &z0, &d, a, &gauss_legendre(8));
        let (q16, m16) = quadrature(&all, &z0, &d, a, &gauss_legendre(16));
        let terms = dot_abs(&g0.gradient, &d);
        prop_assume!((q8 - q16).abs() <= 1e-6 * terms + f64::MIN_POSITIVE);

        // Tolerance: both first-order running error bounds (the divided-difference program's
        // own, kernels included, and the quadrature's), times 4 as in derivatives_match_oracles,
        // plus the truncation estimate.
        let bounds = error_bounds_pair(&pair, &z0, &z1, a);
        let m_delta = output_bound(&pair, &bounds, Output::EnergyDifference);
        let tol = 4.0 * EPS * (m_delta + m16) + (q8 - q16).abs() + f64::MIN_POSITIVE;
        prop_assert!((ev.energy_difference - q16).abs() <= tol,
            "delta {} vs quadrature {q16}: error {:.3e}, tol {tol:.3e}, terms {terms:.3e} for {src}",
            ev.energy_difference, (ev.energy_difference - q16).abs());
        let m_dot: f64 = (0..d.len())
            .map(|i| (output_bound(&pair, &bounds, Output::DiscreteGradient(i))
                + d.len() as f64 * ev.discrete_gradient[i].abs()) * d[i].abs())
            .sum();
        let dot_tol = 4.0 * EPS * (m_dot + m16) + (q8 - q16).abs() + f64::MIN_POSITIVE;
        let gd = dot(&ev.discrete_gradient, &d);
        prop_assert!((gd - q16).abs() <= dot_tol,
            "gbar . d {gd} vs quadrature {q16}: tol {dot_tol:.3e} for {src}");

        // gbar(z, z) = grad H(z), within both programs' bounds.
        let same = pair.eval_pair(&z0, &z0, &[a]).unwrap();
        let b_same = error_bounds_pair(&pair, &z0, &z0, a);
        let b_all = error_bounds(&all, &z0, a);
        for i in 0..d.len() {
            let tol = 4.0 * EPS * (output_bound(&pair, &b_same, Output::DiscreteGradient(i))
                + output_bound(&all, &b_all, Output::Gradient(i))) + f64::MIN_POSITIVE;
            prop_assert!((same.discrete_gradient[i] - g0.gradient[i]).abs() <= tol,
                "gbar(z, z)_{i} = {} vs grad {} for {src}", same.discrete_gradient[i], g0.gradient[i]);
        }
    }
}
