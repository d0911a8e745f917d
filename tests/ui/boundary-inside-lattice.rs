fn main() {
    let _h = dth::hamiltonian!(sum(i = 1..N, p[i]^2/2 + (q[i+1] - q[i])^2/2) where N = 4, q[4] = 0, q[5] = 0);
}
