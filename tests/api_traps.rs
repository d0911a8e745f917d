//! The traps a new user fell into (issue 30, "no traps"), one test each: what the API does
//! now where it surprised before.

use dth::nalgebra::DVector;
use dth::runtime::RuntimeHamiltonian;
use dth::Hamiltonian;

/// `RuntimeHamiltonian`'s slice evaluations are named apart (`value_slice`, ...), so with the
/// trait in scope `h.value(&z)` on a `DVector` is the trait's (it was E0308: an inherent
/// `value(&[f64])` shadowed it). `tests/ui/api/runtime-value-on-a-slice.rs` is the old form.
#[test]
fn runtime_trait_methods_are_not_shadowed_by_slice_methods() {
    let h = RuntimeHamiltonian::new("(p1^2 + q1^2)/2 + q1^4", &[]).unwrap();
    let z = DVector::from_column_slice(&[0.5, -1.0]);
    let value: f64 = h.value(&z);
    assert_eq!(value, h.value_slice(z.as_slice()).unwrap());
    assert_eq!(value, 0.625 + 0.0625);
    let gradient: DVector<f64> = h.gradient(&z);
    let mut g = [0.0; 2];
    h.gradient_slice(z.as_slice(), &mut g).unwrap();
    assert_eq!(gradient.as_slice(), &g);
    assert_eq!(g, [0.5 + 4.0 * 0.125, -1.0]);
    let psi: f64 = h.psi(&z);
    assert_eq!(psi, h.psi_slice(z.as_slice()).unwrap());
    let d = h.derivatives(&z);
    let mut buffer = h.derivatives_buffer();
    h.derivatives_slice(z.as_slice(), &mut buffer).unwrap();
    assert_eq!((d.value, d.psi), (buffer.value(), buffer.psi()));
    assert_eq!(d.hessian.as_slice(), buffer.hessian());
    let z1 = DVector::from_column_slice(&[0.25, 1.0]);
    assert_eq!(
        h.energy_difference(&z, &z1),
        h.energy_difference_slice(z.as_slice(), z1.as_slice())
            .unwrap()
    );
}
