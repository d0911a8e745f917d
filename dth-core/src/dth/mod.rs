//! Discrete-Time Hamiltonian dynamics: the stepper, its Newton solvers, trajectories and
//! observers, and the extended phase space for time-dependent Hamiltonians.
//!
//! Entry points: [`integrate`] (one call, returns a [`Trajectory`]) and [`Dth`] (step by step,
//! with an [`Observer`]). Options in [`DthOptions`]; failures are [`crate::Error`] variants, and
//! a failed run keeps what it computed ([`RunError`]).
//!
//! # References
//! Y. Shibberu, *Discrete-Time Hamiltonian Dynamics*, PhD thesis, UT Arlington, 1992
//! (Chapter II, Section 4.1); *A Discrete-Time Formulation of Hamiltonian Dynamics*, 1998
//! (Theorem 1, Corollary 1).

mod extended;
mod newton;
mod observer;
mod options;
mod stepper;
mod trajectory;

pub use extended::{lift, set_momentum_of_time, Extended};
pub use newton::{segment_from_vertex, Segment};
pub use observer::{NoObserver, Observer, StepRecord};
pub use options::{DthOptions, Solver};
pub use stepper::{integrate, Dth, RunError};
pub use trajectory::Trajectory;
