fn main() {
    let _h = dth::hamiltonian!(sum(i = 5..4, p[i]^2/2) + p1^2);
}
