fn main() {
    let _h = dth::hamiltonian!(x1 + p1^2 + y2*foo(q1) + q0);
}
