dth::hamiltonian! {
    pub struct Spring { q1: f64, sin: f64, pi: f64 } = p1^2/2 + q1^2/2
}

fn main() {}
