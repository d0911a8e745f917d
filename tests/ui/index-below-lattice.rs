fn main() {
    let _h = dth::hamiltonian!(sum(i = 1..N, p[i]^2/2 + (q[i] - q[i-1])^2/2) where N = 4, q[N+1] = 0);
}
