fn main() {
    let _h = dth::hamiltonian!(2 + 3*pi);
}
