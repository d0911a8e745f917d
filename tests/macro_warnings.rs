//! The engine's warnings (a coordinate without its conjugate) are compiler warnings that the
//! user's `#[allow(deprecated)]` silences, in both forms. Warnings are errors in this file, so
//! it does not compile if the allows are not honoured (`tests/ui/*-warns.rs` show the message).
#![deny(deprecated)]

use dth::{nalgebra::Vector4, Hamiltonian};

dth::hamiltonian! {
    /// A position `q2` without its momentum: a constant in disguise.
    #[allow(deprecated)]
    #[derive(Clone, Copy)]
    pub struct Coupled { pub eps: f64 } = p1^2/2 + q1^2/2 + eps*q1*q2
}

#[test]
fn a_cyclic_coordinate_compiles_without_warning() {
    // Kepler in polar coordinates (r, theta): theta = q2 is cyclic, p2 the angular momentum.
    let polar = dth::hamiltonian!(p1 ^ 2 / 2 + p2 ^ 2 / (2 * q1 ^ 2) - 1 / q1);
    let z = Vector4::new(2.0, 0.3, 0.1, 0.5);
    assert_eq!(polar.gradient(&z)[1], 0.0);
    assert!((polar.value(&z) - (0.005 + 0.25 / 8.0 - 0.5)).abs() < 1e-16);
}

#[test]
#[allow(deprecated)]
fn allow_silences_the_warnings_of_the_expression_form() {
    // `q2` without `p2` (frozen) and beside it `p3` without `q3`: two warnings, allowed here.
    let h = dth::hamiltonian!(p1 ^ 2 / 2 + p3 ^ 2 / 2 + q1 ^ 2 + q2 ^ 2);
    assert_eq!(h.gradient(&dth::nalgebra::Vector6::repeat(1.0))[1], 2.0);
}

#[test]
fn an_item_with_allow_compiles_without_warning() {
    let h = Coupled { eps: 0.5 };
    let z = Vector4::new(1.0, 2.0, 3.0, 4.0);
    assert_eq!(h.gradient(&z)[1], 0.5);
    assert_eq!(h.gradient(&z)[3], 0.0);
}
