// The bad expression is the only error: the fallback implements the trait for every D,
// so the call below does not add a second one.
fn needs_kepler<H: dth::Hamiltonian<dth::nalgebra::U4>>(_: H) {}

fn main() {
    needs_kepler(dth::hamiltonian!(p1^2 + p2^2 - (x1^2 + q2^2)^(-1/2)));
}
