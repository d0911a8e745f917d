fn main() {
    let _h = dth::hamiltonian!(sum(i = 1..4, p[i]^2/2 + (q[i+1] - q[i])^2/2));
}
