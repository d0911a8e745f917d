fn main() {
    let _h = dth::hamiltonian!(p1^2 + x1);
}
