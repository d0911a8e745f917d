fn main() {
    let _h = dth::hamiltonian!(p01^2 + q1);
}
