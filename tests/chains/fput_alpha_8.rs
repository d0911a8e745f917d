// Generated: `dth_symbolic::sources::fput_alpha_fixed_ends(8)` written out (`tests/structured_newton.rs`
// checks that it is current).
dth::hamiltonian! { #[derive(Clone, Copy, Debug, Default)] pub struct FputAlpha8 = (p1^2 + p2^2 + p3^2 + p4^2 + p5^2 + p6^2 + p7^2 + p8^2)/2 + q1^2/2 + q1^3/12 + (q2 - q1)^2/2 + (q2 - q1)^3/12 + (q3 - q2)^2/2 + (q3 - q2)^3/12 + (q4 - q3)^2/2 + (q4 - q3)^3/12 + (q5 - q4)^2/2 + (q5 - q4)^3/12 + (q6 - q5)^2/2 + (q6 - q5)^3/12 + (q7 - q6)^2/2 + (q7 - q6)^3/12 + (q8 - q7)^2/2 + (q8 - q7)^3/12 + q8^2/2 - q8^3/12 }
