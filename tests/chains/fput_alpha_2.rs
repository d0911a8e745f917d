// Generated: `dth_symbolic::sources::fput_alpha_fixed_ends(2)` written out (`tests/structured_newton.rs`
// checks that it is current).
dth::hamiltonian! { #[derive(Clone, Copy, Debug, Default)] pub struct FputAlpha2 = (p1^2 + p2^2)/2 + q1^2/2 + q1^3/12 + (q2 - q1)^2/2 + (q2 - q1)^3/12 + q2^2/2 - q2^3/12 }
