// The regularizations there are, by name: `polar` is not one.
dth::hamiltonian! {
    #[regularize(polar)]
    struct Kepler = p1^2 + p2^2 - (q1^2 + q2^2)^(-1/2)
}

fn main() {}
