fn main() {
    let _h = dth::hamiltonian!(p1^2/2 - cos(2*π*q1));
}
