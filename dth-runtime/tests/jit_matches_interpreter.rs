//! Compiled code returns the interpreter's bits: every method of every catalogue system, the
//! engine's Toda sources, and generated expressions, at seeded points, with the second point
//! of the two-point methods far, near and equal (every branch of the divided-difference
//! kernels).
//!
//! The bound is zero ulps, not a tolerance: both perform the same operations in the same
//! order, arithmetic and square roots are correctly rounded in both, Cranelift neither
//! reassociates nor fuses floating-point operations (its float rewrites, constant folding of
//! non-NaN results, `-(-x) = x` and `(-x)(-y) = xy`, are exact), and every other function is
//! a call to the same Rust function. Errors must agree too: a non-finite output is reported
//! by both, on the same output.

mod catalogue;
#[path = "../../dth-symbolic/tests/common/mod.rs"]
mod common;

use catalogue::{Rng, CATALOGUE};
use dth_runtime::{Backend, RuntimeError, RuntimeHamiltonian};
use proptest::prelude::*;

/// Every method at `(z0, z1)`, as bits, or the output an error names.
fn run_all(h: &RuntimeHamiltonian, z0: &[f64], z1: &[f64]) -> Vec<Result<Vec<u64>, String>> {
    let d = h.dimension();
    let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<u64>>();
    let err = |e: RuntimeError| match e {
        RuntimeError::NonFinite { what, output, .. } => format!("{what} {output:?}"),
        other => panic!("unexpected error {other}"),
    };
    let vector = |f: &dyn Fn(&mut [f64]) -> Result<(), RuntimeError>, n: usize| {
        let mut out = vec![0.0; n];
        f(&mut out).map(|()| bits(&out)).map_err(err)
    };
    let mut d_buf = h.derivatives_buffer();
    let derivatives = h.derivatives_slice(z0, &mut d_buf).map_err(err).map(|()| {
        let mut all = vec![d_buf.value(), d_buf.psi()];
        all.extend(d_buf.gradient());
        all.extend(d_buf.hessian());
        bits(&all)
    });
    vec![
        h.value_slice(z0).map(|v| bits(&[v])).map_err(err),
        vector(&|o| h.gradient_slice(z0, o), d),
        vector(&|o| h.hessian_slice(z0, o), d * d),
        h.psi_slice(z0).map(|v| bits(&[v])).map_err(err),
        derivatives,
        vector(&|o| h.discrete_gradient_slice(z0, z1, o), d),
        h.energy_difference_slice(z0, z1)
            .map(|v| bits(&[v]))
            .map_err(err),
        vector(&|o| h.discrete_gradient_defect_slice(z0, z1, o), d),
    ]
}

/// The JIT and the interpreter built from `src`, compared at `points` random points, each
/// with three second points (a step of 0.3, of 1e-7, and none).
fn same_bits(src: &str, params: &[(&str, f64)], rng: &mut Rng, points: usize) {
    let jit = RuntimeHamiltonian::new(src, params).unwrap();
    // Otherwise the comparison below would be the interpreter against itself.
    assert_eq!(
        (jit.backend(), jit.fallback_reason()),
        (Backend::Jit, None),
        "{src}"
    );
    let reference = RuntimeHamiltonian::with_backend(src, params, Backend::Interpreter).unwrap();
    assert_eq!(reference.backend(), Backend::Interpreter);
    let d = jit.dimension();
    for _ in 0..points {
        let z0 = rng.point(d);
        let dir = rng.point(d);
        for step in [0.3, 1e-7, 0.0] {
            let z1: Vec<f64> = z0.iter().zip(&dir).map(|(a, b)| a + step * b).collect();
            assert_eq!(
                run_all(&jit, &z0, &z1),
                run_all(&reference, &z0, &z1),
                "{src} at {z0:?}, {z1:?}"
            );
        }
    }
}

#[test]
fn catalogue_systems() {
    let mut rng = Rng(0x5eed_0001);
    for entry in &CATALOGUE {
        same_bits(entry.src, entry.params, &mut rng, 20);
    }
}

#[test]
fn engine_sources() {
    let mut rng = Rng(0x5eed_0002);
    for n in [1, 2, 5, 12] {
        same_bits(&dth_symbolic::sources::toda_fixed_ends(n), &[], &mut rng, 5);
    }
}

/// Every function, power form and kernel of the grammar in one Hamiltonian, and points where
/// some outputs are not finite (`ln` and `sqrt` of negatives, `1/q1` at 0): both backends
/// must name the same output.
#[test]
fn every_function_and_non_finite_values() {
    let src = "p1^2/(2*a) + p2^2/2 + sin(q1)*cos(q2) + tan(q1/3) + exp(-q2^2) + ln(1 + q1^2)
        + sqrt(1 + p1^2) + sinh(q1/2) + cosh(q2/2) + tanh(q1*q2) + atan(p2)
        + b*(q1^2 + q2^2)^(-3/2) + (1 + q2^2)^(1/3) + q1^5 - 0.25*q2^(-2) + (1 + p1^2)^(a*q2)
        + pi*q1*p2 + q1^(1/3) + ln(q2) + sqrt(q1*p1)";
    let mut rng = Rng(0x5eed_0003);
    same_bits(src, &[("a", 0.7), ("b", 1.3)], &mut rng, 30);
    let jit = RuntimeHamiltonian::new(src, &[("a", 0.7), ("b", 1.3)]).unwrap();
    let err = jit.value_slice(&[0.5, -1.0, 0.5, 0.5]).unwrap_err();
    assert!(
        matches!(err, RuntimeError::NonFinite { what: "value", .. }),
        "{err}"
    );
}

/// A system whose longest program (the defect) is longer than one chunk of compiled code
/// ([`dth_runtime::jit::CHUNK`] operations), so slots cross between the functions it is cut
/// into: 16 particles on a line, every pair bound by a Gaussian, driven in time.
#[test]
fn programs_longer_than_one_chunk() {
    let n = 16;
    let kinetic: Vec<String> = (1..=n).map(|i| format!("p{i}^2")).collect();
    let mut src = format!("({})/2 + q1*cos(t)", kinetic.join(" + "));
    for i in 1..=n {
        for j in i + 1..=n {
            src.push_str(&format!(" + exp(-(q{i} - q{j})^2)"));
        }
    }
    let h = dth_symbolic::compile(&src, &[]).unwrap();
    let longest = h
        .program(dth_symbolic::Method::DiscreteGradientDefect)
        .ops
        .len();
    assert!(longest > dth_runtime::jit::CHUNK, "{longest} operations");
    same_bits(&src, &[], &mut Rng(0x5eed_0004), 1);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// The generators of the engine's own property tests (safe domains, every function and
    /// power form, time dependence, a parameter).
    #[test]
    fn generated_expressions(e in common::expr(), seed in 1u64.., a in 0.5f64..2.0) {
        let src = format!("{} + p1^2/2 + p2^2/2", common::render(&e));
        let params = [("a", a)];
        // The parameter is given only when the expression names it.
        let uses = dth_symbolic::lexer::lex(&src).0.iter().any(|t| &src[t.span.range()] == "a");
        let params: &[(&str, f64)] = if uses { &params } else { &[] };
        prop_assume!(dth_symbolic::compile(&src, &["a"]).is_ok());
        same_bits(&src, params, &mut Rng(seed), 2);
    }
}
