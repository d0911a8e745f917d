dth::hamiltonian! {
    pub struct Spring(f64) = p1^2/2 + q1^2/2
}

fn main() {}
