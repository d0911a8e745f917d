dth::hamiltonian! {
    pub struct Spring<T> { k: T } = p1^2/2 + k*q1^2/2
}

fn main() {}
