// Generated: `dth_symbolic::sources::toda_fixed_ends(2)` written out (`tests/structured_newton.rs`
// checks that it is current).
dth::hamiltonian! { #[derive(Clone, Copy, Debug, Default)] pub struct Toda2 = (p1^2 + p2^2)/2 + exp(-q1) + exp(q1 - q2) + exp(q2) }
