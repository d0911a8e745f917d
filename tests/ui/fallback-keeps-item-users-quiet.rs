// The bad parameter type is the only error: the struct is still declared (with `k: f64`)
// and implements the trait, so constructing and using it adds no second error.
use dth::Hamiltonian;

dth::hamiltonian! {
    pub struct Spring { k: f32 } = p1^2/2 + k*q1^2/2
}

fn main() {
    let s = Spring { k: 2.0 };
    let _ = s.value(&dth::nalgebra::Vector2::new(1.0, 0.0));
}
