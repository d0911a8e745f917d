dth::hamiltonian! {
    pub struct Chain { k: f64 } = sum(i = 1..k, p[i]^2/2 + q[i]^2/2)
}

fn main() {}
