fn main() {
    let _h = dth::hamiltonian!(p1^2 + ln(-1)*q1);
}
