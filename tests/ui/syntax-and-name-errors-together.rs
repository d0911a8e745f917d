fn main() {
    let _h = dth::hamiltonian!(x1 + p1^2 q1);
}
