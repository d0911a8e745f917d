fn main() {
    let _h = dth::hamiltonian!(p1^2 + p3^2 + q1^2 + q3^2);
}
