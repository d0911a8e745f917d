fn main() {
    let _h = dth::hamiltonian!(sum(i = 1..N, p[i]^2/2) + sum(i = 0..N, (q[i+1] - q[i])^2/2) where N = 1000000000000, q[0] = q[N+1] = 0);
}
