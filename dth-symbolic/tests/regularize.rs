//! Levi-Civita regularization in the engine: `K = |u|^2 (H(q(u), p(u, P)) + p_t)` agrees with
//! the original `H` at the mapped state, its derivatives with finite differences, its Psi is
//! positive for Kepler at every state of negative energy, and the radius cancels symbolically.

use dth_symbolic::regularize::levi_civita;
use dth_symbolic::{compile, ErrorKind, Method, Node, System};
use proptest::prelude::*;

const KEPLER: &str = "(p1^2 + p2^2)/(2*m) - k*(q1^2 + q2^2)^(-1/2)";

/// `(q, p)` of the Levi-Civita map at `(u, P)`.
fn physical(u: [f64; 2], pp: [f64; 2]) -> ([f64; 2], [f64; 2]) {
    let s = u[0] * u[0] + u[1] * u[1];
    let q = [u[0] * u[0] - u[1] * u[1], 2.0 * u[0] * u[1]];
    let p = [
        (u[0] * pp[0] - u[1] * pp[1]) / (2.0 * s),
        (u[1] * pp[0] + u[0] * pp[1]) / (2.0 * s),
    ];
    (q, p)
}

fn eval(system: &System, z: &[f64], params: &[f64]) -> dth_symbolic::Evaluation {
    system.program(Method::All).eval(z, params).unwrap()
}

/// `K` at `(u, t, P, p_t)` and `|u|^2 (H(q, p) + p_t)` from the original text, compared to
/// roundoff of the terms (each a few eps of the largest term of `H` times `|u|^2`).
fn agrees(src: &str, names: &[&str], params: &[f64], u: [f64; 2], pp: [f64; 2], pt: f64) {
    let k = levi_civita(src, names).unwrap();
    let h = compile(src, names).unwrap();
    let (q, p) = physical(u, pp);
    let s = u[0] * u[0] + u[1] * u[1];
    let hv = eval(&h, &[q[0], q[1], p[0], p[1]], params).value;
    let kv = eval(&k, &[u[0], u[1], 0.7, pp[0], pp[1], pt], params).value;
    let want = s * (hv + pt);
    let scale = s * (hv.abs() + pt.abs() + p[0] * p[0] + p[1] * p[1]) + 1.0;
    assert!(
        (kv - want).abs() <= 64.0 * f64::EPSILON * scale,
        "{src}: K = {kv}, |u|^2 (H + p_t) = {want}"
    );
}

proptest! {
    #[test]
    fn k_is_the_substituted_h(
        u1 in -2.0..2.0f64, u2 in -2.0..2.0f64,
        p1 in -3.0..3.0f64, p2 in -3.0..3.0f64,
        pt in -2.0..2.0f64,
    ) {
        prop_assume!(u1 * u1 + u2 * u2 > 1e-3);
        let (u, pp) = ([u1, u2], [p1, p2]);
        agrees(KEPLER, &["m", "k"], &[0.5, 1.0], u, pp, pt);
        // A Stark field, a softened potential, a non-separable term: substituted as they stand.
        agrees("(p1^2 + p2^2)/2 - (q1^2 + q2^2)^(-1/2) + f*q1", &["f"], &[0.3], u, pp, pt);
        agrees("p1^2/2 + p2^2/2 - (q1^2 + q2^2 + e)^(-1/2)", &["e"], &[0.01], u, pp, pt);
        agrees("(p1^2 + p2^2)/2 + q1*p2 - q2*p1 - 1/sqrt(q1^2 + q2^2)", &[], &[], u, pp, pt);
    }

    /// `Psi_K = p_t |P|^2 / (8 m^2) + p_t^2 |u|^2 / m > 0` for `p_t = -E > 0`: at every state,
    /// collisions included (`u = 0`).
    #[test]
    fn kepler_psi_is_positive_at_negative_energy(
        u1 in -2.0..2.0f64, u2 in -2.0..2.0f64,
        p1 in -3.0..3.0f64, p2 in -3.0..3.0f64,
        energy in -3.0..-1e-3f64,
    ) {
        let k = levi_civita(KEPLER, &["m", "k"]).unwrap();
        let m = 0.5;
        let pt = -energy;
        let e = eval(&k, &[u1, u2, 0.0, p1, p2, pt], &[m, 1.0]);
        let want = pt * (p1 * p1 + p2 * p2) / (8.0 * m * m) + pt * pt * (u1 * u1 + u2 * u2) / m;
        prop_assert!(e.psi > 0.0 || want == 0.0);
        prop_assert!((e.psi - want).abs() <= 16.0 * f64::EPSILON * want, "{} vs {want}", e.psi);
    }
}

/// The gradient and Hessian of `K` against central differences of its value (step `h`:
/// truncation `h^2` times third derivatives of order 1, roundoff `eps / h`).
#[test]
fn derivatives_match_finite_differences() {
    let k = levi_civita("(p1^2 + p2^2)/2 - (q1^2 + q2^2)^(-1/2) + f*q1*q2", &["f"]).unwrap();
    let params = [0.3];
    let z = [0.8, -0.45, 1.3, 0.6, -1.1, 0.4];
    let e = eval(&k, &z, &params);
    let value = |z: &[f64]| eval(&k, z, &params).value;
    let gradient = |z: &[f64]| eval(&k, z, &params).gradient;
    let h = 1e-5;
    for i in 0..6 {
        let (mut plus, mut minus) = (z, z);
        plus[i] += h;
        minus[i] -= h;
        let fd = (value(&plus) - value(&minus)) / (2.0 * h);
        assert!(
            (fd - e.gradient[i]).abs() < 1e-8,
            "dK/dz{i}: {fd} vs {}",
            e.gradient[i]
        );
        let (gp, gm) = (gradient(&plus), gradient(&minus));
        for j in 0..6 {
            let fd = (gp[j] - gm[j]) / (2.0 * h);
            let exact = e.hessian[i * 6 + j];
            assert!((fd - exact).abs() < 1e-7, "d2K/dz{i}dz{j}: {fd} vs {exact}");
        }
    }
}

/// No negative power survives in the regularized Kepler problem: `|u|^2` cancelled `r` and
/// the momenta's `1/(2|u|^2)`, so `K` is a polynomial, defined at the collision `u = 0`.
#[test]
fn the_radius_cancels_symbolically() {
    let thesis = levi_civita("p1^2 + p2^2 - (q1^2 + q2^2)^(-1/2)", &[]).unwrap();
    let shown = thesis.expr(thesis.value()).to_string();
    assert_eq!(shown, "-1 + (1/4)*(p1^2 + p2^2) + (q1^2 + q2^2)*p_t");
    let k = levi_civita(KEPLER, &["m", "k"]).unwrap();
    let arena = k.arena();
    let mut stack = vec![k.value()];
    while let Some(id) = stack.pop() {
        if let Node::Pow(b, e) = arena.node(id) {
            let is_parameter = matches!(arena.node(*b), Node::Var(dth_symbolic::Var::Param(_)));
            assert!(!e.is_negative() || is_parameter, "{}", arena.expr(id));
        }
        stack.extend(arena.children(id));
    }
    let at_collision = eval(&k, &[0.0, 0.0, 0.0, 1.0, 2.0, 0.5], &[0.5, 1.0]);
    assert!(at_collision.value.is_finite() && at_collision.psi > 0.0);
    assert!(at_collision.gradient.iter().all(|g| g.is_finite()));
}

#[test]
fn what_does_not_apply_is_an_error() {
    for (src, needle) in [
        (
            "p1^2/2 + p2^2/2 + p3^2/2 - (q1^2 + q2^2 + q3^2)^(-1/2)",
            "planar",
        ),
        ("(p1^2 + p2^2)/2 - (q1^2 + q2^2)^(-1/2)*cos(t)", "uses t"),
    ] {
        let errors = levi_civita(src, &[]).unwrap_err();
        assert!(
            matches!(
                errors.0[0].kind,
                ErrorKind::CannotRegularize {
                    name: "levi-civita",
                    ..
                }
            ),
            "{src}: {errors}"
        );
        assert!(errors.to_string().contains(needle), "{errors}");
    }
    let four = "p1^2 + p2^2 + p3^2 + p4^2 - (q1^2 + q2^2 + q3^2 + q4^2)^(-1/2)";
    let errors = dth_symbolic::regularize::kustaanheimo_stiefel(four, &[]).unwrap_err();
    assert!(
        errors
            .to_string()
            .contains("more than three degrees of freedom"),
        "{errors}"
    );
    // The text's own errors come first, as compile gives them.
    let errors = levi_civita("p1^2 + x", &[]).unwrap_err();
    assert!(
        errors.to_string().contains("unknown variable `x`"),
        "{errors}"
    );
}

/// The exact discrete gradient of the regularized Kepler problem near a collision (`u1`
/// small, crossing toward 0): `gbar . (z1 - z0)` is `K(z1) - K(z0)`, and the defect is
/// `g0 + g1 - 2 gbar`, each to roundoff.
#[test]
fn discrete_gradient_near_a_collision() {
    let k = levi_civita("p1^2 + p2^2 - (q1^2 + q2^2)^(-1/2)", &[]).unwrap();
    let z0 = [
        0.07104879855279093,
        0.0,
        0.7854124768258854,
        -1.9949456816908124,
        0.0,
        1.0,
    ];
    let z1 = [0.021, 0.0, 0.7857, -1.9985, 0.0, 1.0];
    let pair = k
        .program(Method::DiscreteGradient)
        .eval_pair(&z0, &z1, &[])
        .unwrap();
    let defect = k
        .program(Method::DiscreteGradientDefect)
        .eval_pair(&z0, &z1, &[])
        .unwrap();
    let (e0, e1) = (eval(&k, &z0, &[]), eval(&k, &z1, &[]));
    let dot: f64 = (0..6)
        .map(|i| pair.discrete_gradient[i] * (z1[i] - z0[i]))
        .sum();
    // K = |P|^2/4 - 1 + p_t |u|^2 is a sum of squares and a product: its divided
    // differences are the averages (P0 + P1)/4, p_t (u0 + u1), |u|^2's mean (p_t fixed here).
    let want = [
        z1[5] * (z0[0] + z1[0]),
        z1[5] * (z0[1] + z1[1]),
        0.0,
        (z0[3] + z1[3]) / 4.0,
        (z0[4] + z1[4]) / 4.0,
        0.5 * (z0[0] * z0[0] + z0[1] * z0[1] + z1[0] * z1[0] + z1[1] * z1[1]),
    ];
    for (i, want) in want.into_iter().enumerate() {
        let g = pair.discrete_gradient[i];
        let bound = 4.0 * f64::EPSILON * want.abs();
        assert!((g - want).abs() <= bound, "gbar {i}: {g} vs {want}");
        let d = e0.gradient[i] + e1.gradient[i] - 2.0 * g;
        let t = defect.discrete_gradient_defect[i];
        let bound = 8.0 * f64::EPSILON * (e0.gradient[i].abs() + e1.gradient[i].abs());
        assert!((t - d).abs() <= bound, "defect {i}: {t} vs {d}");
    }
    assert!((dot - (e1.value - e0.value)).abs() <= 4.0 * f64::EPSILON);
}
