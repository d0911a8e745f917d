//! Bad input to a runtime Hamiltonian is a typed error naming what and where, never a panic:
//! parameters unknown, missing or not finite, slices of the wrong length, non-finite values.
//! The one exception is the `Hamiltonian` trait, whose methods cannot return an error: there a
//! `Dyn` vector of the wrong length panics, with a message naming the method, the length and
//! the dimension (the slice methods are the checked alternative); a non-finite value is
//! returned as it is.

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

/// Through the core trait (`Hamiltonian<Dyn>`, whose methods cannot return an error), a point
/// or an output of the wrong size panics, naming the trait method, the argument, its size, the
/// dimension and the checked slice method (it gave NaN outputs, which a caller of the trait
/// outside the steppers never saw reported); the right sizes evaluate.
#[test]
fn a_wrong_size_through_the_trait_panics_with_what_to_fix() {
    use dth_core::nalgebra::{DMatrix, DVector, Dyn};
    use dth_core::{Derivatives, Hamiltonian};
    use std::panic::{catch_unwind, AssertUnwindSafe};
    let h = RuntimeHamiltonian::new(SPRING, &[("m", 1.0), ("k", 2.0)]).unwrap();
    let (z, short) = (DVector::from_element(2, 0.5), DVector::from_element(3, 0.5));
    let message = |call: &dyn Fn()| -> String {
        let payload = catch_unwind(AssertUnwindSafe(call)).expect_err("no panic");
        payload
            .downcast_ref::<String>()
            .cloned()
            .unwrap_or_default()
    };
    let expected = |method: &str, what: &str, found: &str, checked: &str| {
        format!(
            "RuntimeHamiltonian::{method}: {what} {found}, the Hamiltonian's dimension is 2 \
             (the checked RuntimeHamiltonian::{checked} returns an error instead)"
        )
    };
    let three = "has 3 components";
    let cases: [(&dyn Fn(), String); 12] = [
        (
            &|| {
                let _ = h.value(&short);
            },
            expected("value", "z", three, "value_slice"),
        ),
        (
            &|| {
                let _ = h.psi(&short);
            },
            expected("psi", "z", three, "psi_slice"),
        ),
        (
            &|| {
                let _ = h.gradient(&short);
            },
            expected("gradient_into", "z", three, "gradient_slice"),
        ),
        (
            &|| h.gradient_into(&z, &mut DVector::zeros(3)),
            expected("gradient_into", "out", three, "gradient_slice"),
        ),
        (
            &|| h.hessian_into(&short, &mut DMatrix::zeros(2, 2)),
            expected("hessian_into", "z", three, "hessian_slice"),
        ),
        // Four entries, as a 2 x 2 Hessian, but not its shape.
        (
            &|| h.hessian_into(&z, &mut DMatrix::zeros(1, 4)),
            expected("hessian_into", "out", "is 1 x 4", "hessian_slice"),
        ),
        (
            &|| h.derivatives_into(&short, &mut Derivatives::zeros(Dyn(2))),
            expected("derivatives_into", "z", three, "derivatives_slice"),
        ),
        (
            &|| h.derivatives_into(&z, &mut Derivatives::zeros(Dyn(3))),
            expected(
                "derivatives_into",
                "out.gradient",
                three,
                "derivatives_slice",
            ),
        ),
        (
            &|| {
                let mut out = Derivatives::zeros(Dyn(2));
                out.hessian = DMatrix::zeros(2, 3);
                h.derivatives_into(&z, &mut out);
            },
            expected(
                "derivatives_into",
                "out.hessian",
                "is 2 x 3",
                "derivatives_slice",
            ),
        ),
        (
            &|| {
                let _ = h.energy_difference(&z, &short);
            },
            expected("energy_difference", "z1", three, "energy_difference_slice"),
        ),
        (
            &|| h.discrete_gradient_into(&short, &z, &mut DVector::zeros(2)),
            expected(
                "discrete_gradient_into",
                "z0",
                three,
                "discrete_gradient_slice",
            ),
        ),
        (
            &|| {
                let g = DVector::zeros(2);
                h.discrete_gradient_defect_into(&z, &z, &g, &mut DVector::zeros(1));
            },
            expected(
                "discrete_gradient_defect_into",
                "out",
                "has 1 component",
                "discrete_gradient_defect_slice",
            ),
        ),
    ];
    for (call, expected) in cases {
        assert_eq!(message(call), expected);
    }
    // The right sizes evaluate (the fused buffer was not left borrowed by a panic).
    let d = h.derivatives(&z);
    assert_eq!((d.value, h.value(&z)), (1.0 / 8.0 + 0.25, 1.0 / 8.0 + 0.25));
}

/// Through the trait, a non-finite output is returned as it is (the steppers' checks report
/// it as a typed error): NaN outside the domain of `ln`, not a panic.
#[test]
fn a_non_finite_output_through_the_trait_is_returned() {
    use dth_core::nalgebra::DVector;
    use dth_core::Hamiltonian;
    let h = RuntimeHamiltonian::new("p1^2/2 + ln(q1)", &[]).unwrap();
    let z = DVector::from_column_slice(&[-1.0, 0.0]);
    assert!(h.value(&z).is_nan());
    let d = h.derivatives(&z);
    assert!(d.value.is_nan());
    // The rest is finite there: `d ln(q1)/d q1 = 1/q1`.
    assert_eq!(d.gradient.as_slice(), &[-1.0, 0.0]);
}
