fn main() {
    let _h = dth::hamiltonian!();
}
