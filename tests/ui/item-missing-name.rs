dth::hamiltonian! {
    pub struct = p1^2/2 + q1^2/2
}

fn main() {}
