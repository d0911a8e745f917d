fn main() {
    let _h = dth::hamiltonian!(p1^2 + (-8)^(1/3)*q1);
}
