fn main() {
    let _h = dth::hamiltonian!(p1^2/2 + cos(q1, q2));
}
