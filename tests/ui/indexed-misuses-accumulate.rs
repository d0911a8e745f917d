fn main() {
    let _h = dth::hamiltonian!(sum(i = 1..4, p[i]^2/2 + x[i]^2 + q[i+1]*q[k]) + sum(i = 3..2, p[i]) + p5^2);
}
