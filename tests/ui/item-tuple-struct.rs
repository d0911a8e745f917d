// The tuple struct is the only error: it is still declared as written, so using it adds none.
dth::hamiltonian! {
    pub struct Spring(f64) = p1^2/2 + q1^2/2
}

// Used from another module, where rustc reports a missing type even after a macro error.
mod energy {
    use dth::Hamiltonian;

    pub fn of(s: &super::Spring) -> f64 {
        s.value(&dth::nalgebra::Vector2::new(1.0, 0.0))
    }
}

fn main() {
    let _ = energy::of(&Spring(2.0));
}
