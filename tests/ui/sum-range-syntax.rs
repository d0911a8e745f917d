fn main() {
    let _h = dth::hamiltonian!(sum(i, p[i]^2/2));
}
