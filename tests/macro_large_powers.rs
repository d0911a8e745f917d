//! Regression: large integer powers compile quickly and exactly. `q1^1024` made the macro
//! panic (an infinite constant in the defect's binomial series) and `(q1 + p1)^1000000` had
//! not compiled after 300 s (the series has `k/2` terms); both are now built by squaring.
//! The generated code must agree bit for bit with the engine's programs.

use dth::nalgebra::Vector2;
use dth::Hamiltonian;
use dth_symbolic::{compile, Method};

dth::hamiltonian! {
    pub struct Power1024 = p1^2/2 + q1^1024
}

dth::hamiltonian! {
    pub struct SumToTheMillion = (q1 + p1)^1000000
}

#[test]
fn q1_to_the_1024_is_exact() {
    let h = Power1024;
    let z = Vector2::new(1.0, 0.5);
    assert_eq!(h.value(&z), 1.125);
    assert_eq!(h.gradient(&z), Vector2::new(1024.0, 0.5));
    assert_eq!(h.hessian(&z)[(0, 0)], 1024.0 * 1023.0);
    // Powers of two are exact in f64, and so is every step of the squaring.
    let z = Vector2::new(0.5, 0.0);
    assert_eq!(h.value(&z), 0.5f64.powi(1024));
}

/// The generated defect `t(z0, z1)`.
type Defect<'a> = &'a dyn Fn(&Vector2<f64>, &Vector2<f64>) -> Vector2<f64>;

#[test]
fn generated_defects_match_the_engine() {
    let cases: [(&str, Defect); 2] = [
        ("p1^2/2 + q1^1024", &|z0, z1| {
            Power1024.discrete_gradient_defect(z0, z1, &Power1024.discrete_gradient(z0, z1))
        }),
        ("(q1 + p1)^1000000", &|z0, z1| {
            let h = SumToTheMillion;
            h.discrete_gradient_defect(z0, z1, &h.discrete_gradient(z0, z1))
        }),
    ];
    for (src, generated) in cases {
        let program = compile(src, &[])
            .unwrap()
            .program(Method::DiscreteGradientDefect);
        let (z0, z1) = ([0.6, 0.4], [0.6 + 1e-7, 0.4 - 2e-7]);
        let t = program
            .eval_pair(&z0, &z1, &[])
            .unwrap()
            .discrete_gradient_defect;
        let g = generated(&Vector2::from(z0), &Vector2::from(z1));
        for i in 0..2 {
            assert_eq!(g[i].to_bits(), t[i].to_bits(), "{src}: component {i}");
            assert!(t[i].is_finite(), "{src}: {t:?}");
        }
    }
}
