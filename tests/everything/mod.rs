//! One Hamiltonian that uses every function and power form, and so every divided-difference
//! and defect kernel, with parameters: the `hamiltonian!` type and the same text for
//! `dth_symbolic::compile`. Shared by `tests/macro_discrete_gradient.rs` and
//! `tests/macro_defect.rs`, which compare the generated code with the engine's program.

dth::hamiltonian! {
    /// Every function, power form and so every kernel, with parameters.
    pub struct Everything { pub a: f64, pub b: f64 } =
        p1^2/(2*a) + p2^2/2 + sin(q1)*cos(q2) + tan(q1/3) + exp(-q2^2) + ln(1 + q1^2)
        + sqrt(1 + p1^2) + sinh(q1/2) + cosh(q2/2) + tanh(q1*q2) + atan(p2)
        + b*(q1^2 + q2^2)^(-3/2) + (1 + q2^2)^(1/3) + q1^5 - 0.25*q2^(-2) + (1 + p1^2)^(a*q2)
        + pi*q1*p2
}

/// `Everything`'s Hamiltonian as text, parameters `a`, `b`.
pub const EVERYTHING: &str = "p1^2/(2*a) + p2^2/2 + sin(q1)*cos(q2) + tan(q1/3) + exp(-q2^2)
    + ln(1 + q1^2) + sqrt(1 + p1^2) + sinh(q1/2) + cosh(q2/2) + tanh(q1*q2) + atan(p2)
    + b*(q1^2 + q2^2)^(-3/2) + (1 + q2^2)^(1/3) + q1^5 - 0.25*q2^(-2) + (1 + p1^2)^(a*q2)
    + pi*q1*p2";
