// Generated: `dth_symbolic::sources::toda_fixed_ends(4)` written out (`tests/structured_newton.rs`
// checks that it is current).
dth::hamiltonian! { #[derive(Clone, Copy, Debug, Default)] pub struct Toda4 = (p1^2 + p2^2 + p3^2 + p4^2)/2 + exp(-q1) + exp(q1 - q2) + exp(q2 - q3) + exp(q3 - q4) + exp(q4) }
