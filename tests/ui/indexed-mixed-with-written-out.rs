fn main() {
    let _h = dth::hamiltonian!(sum(i = 1..N, p[i]^2/2 + q[i]^2/2) + q9^4 where N = 8);
}
