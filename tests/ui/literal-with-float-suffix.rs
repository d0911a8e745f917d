fn main() {
    let _h = dth::hamiltonian!(p1^2/2 + 2.0f64*q1^2);
}
