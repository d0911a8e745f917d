fn main() {
    let _h = dth::hamiltonian!(p1^2 + {q1 - q2}^2 + p2^2);
}
