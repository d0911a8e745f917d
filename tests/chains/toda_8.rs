// Generated: `dth_symbolic::sources::toda_fixed_ends(8)` written out (`tests/structured_newton.rs`
// checks that it is current).
dth::hamiltonian! { #[derive(Clone, Copy, Debug, Default)] pub struct Toda8 = (p1^2 + p2^2 + p3^2 + p4^2 + p5^2 + p6^2 + p7^2 + p8^2)/2 + exp(-q1) + exp(q1 - q2) + exp(q2 - q3) + exp(q3 - q4) + exp(q4 - q5) + exp(q5 - q6) + exp(q6 - q7) + exp(q7 - q8) + exp(q8) }
