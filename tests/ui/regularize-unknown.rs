// The regularizations there are, by name: `ks` is not one yet.
dth::hamiltonian! {
    #[regularize(ks)]
    struct Kepler = p1^2 + p2^2 - (q1^2 + q2^2)^(-1/2)
}

fn main() {}
