dth::hamiltonian! {
    pub struct Spring { k: f32 } = p1^2/2 + k*q1^2/2
}

fn main() {}
