// `RuntimeHamiltonian`'s own evaluations on slices are `value_slice`, `gradient_slice`, ...:
// `value` is the `Hamiltonian` trait's, on nalgebra vectors. (An inherent `value(&[f64])` once
// shadowed it, and `h.value(&dvector)` was the error instead.)
use dth::runtime::RuntimeHamiltonian;
use dth::Hamiltonian;

fn main() -> Result<(), dth::Error> {
    let h = RuntimeHamiltonian::new("(p1^2 + q1^2)/2", &[])?;
    let _ = h.value(&[1.0, 0.0]);
    Ok(())
}
