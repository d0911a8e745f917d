fn main() {
    let _h = dth::hamiltonian!(q1^2 + q2^2);
}
