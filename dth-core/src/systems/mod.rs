//! Hand-written reference Hamiltonians with analytic derivatives.
//!
//! They are the baselines the generated code is checked and benchmarked against, and they let
//! `dth-core` be tested without the macro.

mod kepler;
mod oscillator;

pub use kepler::Kepler;
pub use oscillator::HarmonicOscillator;
