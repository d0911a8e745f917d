// Levi-Civita regularizes the plane: a Hamiltonian of three degrees of freedom is refused,
// underlined whole.
dth::hamiltonian! {
    #[regularize(levi_civita)]
    struct Kepler3 = p1^2 + p2^2 + p3^2 - (q1^2 + q2^2 + q3^2)^(-1/2)
}

fn main() {}
