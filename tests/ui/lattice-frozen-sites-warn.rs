// A warning of a lattice compiled to loops, made an error here so that trybuild shows it.
#![deny(deprecated)]

fn main() {
    let _h = dth::hamiltonian!(sum(i = 1..4, p[i]^2/2) + sum(i = 1..N, q[i]^2/2) where N = 8);
}
