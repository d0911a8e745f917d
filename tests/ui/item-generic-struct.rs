// The generic parameter is the only error: the struct is still declared (without it), so
// using it adds none.
dth::hamiltonian! {
    pub struct Spring<T> { k: T } = p1^2/2 + k*q1^2/2
}

// Used from another module, where rustc reports a missing type even after a macro error.
mod energy {
    use dth::Hamiltonian;

    pub fn of(s: &super::Spring) -> f64 {
        s.value(&dth::nalgebra::Vector2::new(1.0, 0.0))
    }
}

fn main() {
    let _ = energy::of(&Spring { k: 2.0 });
}
