// 1000 sites: more than the 512 written out site by site, within what loops. The missing
// boundary `q[N+1]` is the error, not the size.
fn main() {
    let _h = dth::hamiltonian!(sum(i = 1..N, p[i]^2/2 + (q[i+1] - q[i])^2/2) where N = 1000);
}
