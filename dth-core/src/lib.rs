//! Discrete-Time Hamiltonian dynamics (Shibberu 1992, 1998): the [`Hamiltonian`] trait, the
//! DTH stepper, the peer integrators it is compared with, and diagnostics.
//!
//! Phase-space convention: `z = (q1..qn, p1..pn)`, `D = 2n`, `J = [[0, I], [-I, 0]]`.
//! A time-dependent Hamiltonian lives in the extended phase space of the paper's Theorem 1,
//! `z = (q1..qn, t, p1..pn, p_t)`, `D = 2n + 2`, with `calH = p_t + H(t, q, p)`.
//!
//! # Layers
//! Each layer imports only from the layers above it:
//! 1. [`error`], [`hamiltonian`] (the traits), [`observer`] (the one per-step protocol every
//!    integrator reports to), [`event`] (conditions a run watches, and the root search that
//!    locates where they turn true), `linalg` (small dense LU), `dense_newton` (the dense Newton
//!    matrix `I - c J Hess H` of small systems: that LU, or for a separable `H` the LU of its
//!    half-size Schur complement), [`structured`] (banded LU and the
//!    sparse Newton matrices of large systems) and `newton` (the one Newton stopping rule and
//!    loop);
//! 2. [`systems`] (concrete Hamiltonians), then [`kepler`] (the exact Kepler solution) and
//!    [`regularize`] (physical states in and out of a regularization);
//! 3. [`methods`] (the peer integrators), then [`dth`] (the DTH stepper, whose robust mode
//!    steps with a peer);
//! 4. [`solve`](mod@solve) (one driver for DTH and every peer, one [`Solution`]), [`diagnostics`]
//!    (invariants and errors of computed trajectories).
#![warn(missing_docs)]

// Test modules shared with the integration tests name this crate `dth_core`.
#[cfg(test)]
extern crate self as dth_core;

mod dense_newton;
pub mod diagnostics;
/// Double-double arithmetic: the symbolic engine's (one source; this crate does not depend
/// on the engine), for the starts of runs solved in double-double.
#[allow(dead_code)]
#[path = "../../dth-symbolic/src/double_double.rs"]
mod double_double;
pub mod dth;
pub mod error;
pub mod event;
pub mod hamiltonian;
pub mod kepler;
pub mod linalg;
pub mod methods;
mod newton;
pub mod observer;
pub mod regularize;
pub mod solve;
pub mod structured;
pub mod systems;

pub use error::{Error, RunError};
// The flat paths of the entry points: `dth::Dth`, not only `dth::dth::Dth`.
pub use dth::{integrate, Dth, DthOptions, Trajectory};
pub use hamiltonian::{
    j_times, j_times_into, psi_from, zeros, zeros_matrix, Alloc, ConstFlags, Derivatives, Flags,
    Hamiltonian,
};
pub use nalgebra;
pub use solve::{solve, Method, Solution};
