fn main() {
    let _h = dth::hamiltonian!(p1^2 + 2f64*q1);
}
