fn main() {
    let _h = dth::hamiltonian!(p1^2 + exp(1000)*q1);
}
