dth::hamiltonian! {
    pub struct Spring { k: f64 } p1^2/2 + k*q1^2/2
}

fn main() {}
