// A warning, made an error here so that trybuild shows it.
#![deny(deprecated)]

dth::hamiltonian! {
    pub struct Coupled { pub eps: f64 } = p1^2/2 + q1^2/2 + eps*q1*q2
}

fn main() {}
