//! Hand-written reference Hamiltonians with analytic derivatives.
//!
//! They are the baselines the generated code is checked and benchmarked against, and they let
//! `dth-core` be tested without the macro.

mod central_force;
mod kepler;
mod oscillator;

pub use central_force::{guarded_divided_difference, CentralForce, DIVIDED_DIFFERENCE_SWITCH};
pub use kepler::Kepler;
pub use oscillator::HarmonicOscillator;
