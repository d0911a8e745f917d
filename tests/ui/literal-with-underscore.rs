fn main() {
    let _h = dth::hamiltonian!(p1^2/2 + 1_000*q1^2);
}
