// `RuntimeHamiltonian`'s dimension as a `usize` is `dimension()`: `dim()` is the `Hamiltonian`
// trait's, `Dyn` of it. (An inherent `dim() -> usize` once shadowed the trait's, so `h.dim()`
// was a `usize` on a `RuntimeHamiltonian` and a `Dyn` on every other `Hamiltonian<Dyn>`.)
use dth::runtime::RuntimeHamiltonian;
use dth::Hamiltonian;

fn main() -> Result<(), dth::Error> {
    let h = RuntimeHamiltonian::new("(p1^2 + q1^2)/2", &[])?;
    let _d: usize = h.dim();
    Ok(())
}
