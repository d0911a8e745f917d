//! The macro's generated code performs exactly the engine's straight-line programs, so it
//! agrees with `dth_symbolic::Program::eval` bit for bit (same operations, same order, no
//! fused multiply-add in either), for every function, power form, parameter and the
//! time-dependent extended phase space.

use dth::nalgebra::Const;
use dth::nalgebra::SVector;
use dth::Hamiltonian;
use dth_symbolic::{compile, Method};

dth::hamiltonian! {
    /// Every function and power form of the grammar, with two parameters.
    pub struct Everything { pub a: f64, pub b: f64 } =
        p1^2/(2*a) + p2^2/2 + sin(q1)*cos(q2) + tan(q1/3) + exp(-q2^2) + ln(1 + q1^2)
        + sqrt(1 + p1^2) + sinh(q1/2) + cosh(q2/2) + tanh(q1*q2) + atan(p2)
        + b*(q1^2 + q2^2)^(-3/2) + (1 + q2^2)^(1/3) + q1^5 - 0.25*q2^(-2) + (1 + p1^2)^(a*q2)
        + pi*q1*p2
}

const EVERYTHING: &str =
    "p1^2/(2*a) + p2^2/2 + sin(q1)*cos(q2) + tan(q1/3) + exp(-q2^2) + ln(1 + q1^2)
        + sqrt(1 + p1^2) + sinh(q1/2) + cosh(q2/2) + tanh(q1*q2) + atan(p2)
        + b*(q1^2 + q2^2)^(-3/2) + (1 + q2^2)^(1/3) + q1^5 - 0.25*q2^(-2) + (1 + p1^2)^(a*q2)
        + pi*q1*p2";

fn same<const D: usize>(
    h: &impl Hamiltonian<Const<D>>,
    src: &str,
    params: &[&str],
    values: &[f64],
    z: [f64; D],
) {
    let system = compile(src, params).unwrap();
    assert_eq!(system.dim(), D);
    let zv = SVector::<f64, D>::from(z);
    let e = system.program(Method::All).eval(&z, values).unwrap();
    let d = h.derivatives(&zv);
    assert_eq!(d.value.to_bits(), e.value.to_bits());
    assert_eq!(d.psi.to_bits(), e.psi.to_bits());
    for i in 0..D {
        assert_eq!(
            d.gradient[i].to_bits(),
            e.gradient[i].to_bits(),
            "gradient {i}"
        );
        for j in 0..D {
            assert_eq!(
                d.hessian[(i, j)].to_bits(),
                e.hessian[i * D + j].to_bits(),
                "hessian {i} {j}"
            );
        }
    }
    // The separate methods run their own (smaller) programs.
    let value = system
        .program(Method::Value)
        .eval(&z, values)
        .unwrap()
        .value;
    assert_eq!(h.value(&zv).to_bits(), value.to_bits());
    let psi = system.program(Method::Psi).eval(&z, values).unwrap().psi;
    assert_eq!(h.psi(&zv).to_bits(), psi.to_bits());
    assert_eq!(h.gradient(&zv), d.gradient);
    assert_eq!(h.hessian(&zv), d.hessian);
}

#[test]
fn every_function_and_power_matches_the_engine() {
    let h = Everything { a: 0.7, b: 1.3 };
    for z in [
        [0.4, -0.8, 1.1, 0.3],
        [1.7, 0.6, -0.2, -1.4],
        [-0.3, 2.2, 0.0, 0.9],
    ] {
        same(&h, EVERYTHING, &["a", "b"], &[0.7, 1.3], z);
    }
}

#[test]
fn forced_oscillator_lives_in_the_extended_phase_space() {
    // z = (q1, t, p1, p_t), value = p_t + H.
    let h = dth::hamiltonian!(p1 ^ 2 / 2 + q1 ^ 2 / 2 - 0.3 * q1 * cos(1.2 * t));
    let src = "p1^2/2 + q1^2/2 - 0.3*q1*cos(1.2*t)";
    same(&h, src, &[], &[], [0.5, 2.0, -0.1, 0.25]);
    let z = SVector::<f64, 4>::new(0.5, 2.0, -0.1, 0.25);
    let expected = 0.25 + 0.005 + 0.125 - 0.3 * 0.5 * (2.4f64).cos();
    // Same terms summed in another order: a few ulps of the largest term (0.25).
    assert!((h.value(&z) - expected).abs() <= 4.0 * f64::EPSILON * 0.25);
    // The p_t row: dcalH/dp_t = 1; the t row: dH/dt = 0.36 q1 sin(1.2 t).
    let g = h.gradient(&z);
    assert_eq!(g[3], 1.0);
    assert!((g[1] - 0.36 * 0.5 * (2.4f64).sin()).abs() <= 4.0 * f64::EPSILON * 0.18);
}
