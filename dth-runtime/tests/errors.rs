//! Bad input to a runtime Hamiltonian is a typed error naming what and where, never a panic:
//! parameters unknown, missing or not finite, slices of the wrong length, non-finite values.

use dth_runtime::{RuntimeError, RuntimeHamiltonian};
use dth_symbolic::ErrorKind;

const SPRING: &str = "p1^2/(2*m) + k*q1^2/2";

#[test]
fn a_parameter_given_but_not_used_is_named() {
    let r = RuntimeHamiltonian::new(SPRING, &[("m", 1.0), ("k", 2.0), ("mm", 3.0)]);
    assert!(
        matches!(&r, Err(RuntimeError::UnknownParameter { name }) if name == "mm"),
        "{r:?}"
    );
}

#[test]
fn a_parameter_used_but_not_given_is_named_at_its_token() {
    let Err(RuntimeError::Expression(errors)) = RuntimeHamiltonian::new(SPRING, &[("m", 1.0)])
    else {
        panic!("expected an expression error");
    };
    assert_eq!(errors.0.len(), 1);
    let e = &errors.0[0];
    assert_eq!(
        e.kind,
        ErrorKind::UnknownVariable {
            name: "k".to_string()
        }
    );
    assert_eq!(&SPRING[e.span.range()], "k");
}

#[test]
fn parameter_values_must_be_finite() {
    let r = RuntimeHamiltonian::new(SPRING, &[("m", f64::NAN), ("k", 2.0)]);
    assert!(
        matches!(&r, Err(RuntimeError::NonFiniteParameter { name, .. }) if name == "m"),
        "{r:?}"
    );
    let mut h = RuntimeHamiltonian::new(SPRING, &[("m", 1.0), ("k", 2.0)]).unwrap();
    let r = h.set_parameter("k", f64::INFINITY);
    assert!(matches!(&r, Err(RuntimeError::NonFiniteParameter { name, .. }) if name == "k"));
    let r = h.set_parameter("c", 1.0);
    assert!(matches!(&r, Err(RuntimeError::UnknownParameter { name }) if name == "c"));
    // A new value is read by the next call, without recompiling.
    h.set_parameter("k", 4.0).unwrap();
    assert_eq!(h.value_slice(&[1.0, 0.0]).unwrap(), 2.0);
    let values: Vec<(&str, f64)> = h.parameters().collect();
    assert_eq!(values, vec![("m", 1.0), ("k", 4.0)]);
}

#[test]
fn slices_of_the_wrong_length_are_refused() {
    let h = RuntimeHamiltonian::new(SPRING, &[("m", 1.0), ("k", 2.0)]).unwrap();
    let r = h.value_slice(&[1.0, 2.0, 3.0]);
    assert!(matches!(
        r,
        Err(RuntimeError::WrongLength {
            what: "z",
            expected: 2,
            found: 3
        })
    ));
    let r = h.hessian_slice(&[1.0, 2.0], &mut [0.0; 3]);
    assert!(matches!(
        r,
        Err(RuntimeError::WrongLength {
            what: "out",
            expected: 4,
            found: 3
        })
    ));
    let r = h.discrete_gradient_slice(&[1.0, 2.0], &[1.0], &mut [0.0; 2]);
    assert!(matches!(
        r,
        Err(RuntimeError::WrongLength { what: "z1", .. })
    ));
    let mut other = RuntimeHamiltonian::new("p1^2 + p2^2 + q1*q2", &[])
        .unwrap()
        .derivatives_buffer();
    let r = h.derivatives_slice(&[1.0, 2.0], &mut other);
    assert!(matches!(
        r,
        Err(RuntimeError::WrongLength { what: "out", .. })
    ));
}

#[test]
fn a_non_finite_value_names_the_method_and_output() {
    let h = RuntimeHamiltonian::new("p1^2/2 + ln(q1)", &[]).unwrap();
    let r = h.value_slice(&[-1.0, 0.0]);
    assert!(
        matches!(r, Err(RuntimeError::NonFinite { what: "value", value, .. }) if value.is_nan()),
        "{r:?}"
    );
    let mut g = [0.0; 2];
    let r = h.gradient_slice(&[0.0, 1.0], &mut g);
    assert!(
        matches!(
            r,
            Err(RuntimeError::NonFinite {
                what: "gradient",
                output: dth_symbolic::Output::Gradient(0),
                ..
            })
        ),
        "{r:?}"
    );
}

/// Through the core trait (`Hamiltonian<Dyn>`, whose methods cannot fail), a point of the
/// wrong length gives NaN outputs, which the steppers' finiteness checks report; never a panic.
#[test]
fn a_point_of_the_wrong_length_through_the_trait_is_nan() {
    use dth_core::nalgebra::{DVector, Dyn};
    use dth_core::{Derivatives, Hamiltonian};
    let h = RuntimeHamiltonian::new(SPRING, &[("m", 1.0), ("k", 2.0)]).unwrap();
    let z = DVector::from_column_slice(&[1.0, 2.0, 3.0]); // D = 2 in the text
    let mut out = Derivatives::zeros(Dyn(2));
    Hamiltonian::derivatives_into(&h, &z, &mut out);
    assert!(out.value.is_nan() && out.psi.is_nan());
    assert!(out
        .gradient
        .iter()
        .chain(out.hessian.iter())
        .all(|x| x.is_nan()));
    let mut g = DVector::zeros(2);
    Hamiltonian::gradient_into(&h, &z, &mut g);
    assert!(g.iter().all(|x| x.is_nan()));
}
