// The bad parameters are the only errors: the struct is still declared with every field name
// (as `f64`) and implements the trait, so constructing and using it adds no error of its own.
use dth::Hamiltonian;

dth::hamiltonian! {
    pub struct Spring { k: f32, q1: f64 } = p1^2/2 + k*q1^2/2
}

fn main() {
    let s = Spring { k: 2.0, q1: 1.0 };
    let _ = s.value(&dth::nalgebra::Vector2::new(1.0, 0.0));
}
