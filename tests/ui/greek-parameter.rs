fn main() {
    let _h = dth::hamiltonian!(p1^2/2 + ω^2*q1^2/2);
}
