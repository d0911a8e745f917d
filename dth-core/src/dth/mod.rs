//! Discrete-Time Hamiltonian dynamics: the stepper, its Newton solvers, trajectories, and the
//! extended phase space for time-dependent Hamiltonians.
//!
//! Entry points (also at the crate root: `dth::integrate`, `dth::Dth`, `dth::DthOptions`):
//! [`integrate`] (one call, returns a [`Trajectory`]) and [`Dth`] (step by step,
//! with an [`Observer`](crate::observer::Observer), the protocol every integrator reports to). Options in [`DthOptions`]; failures are [`crate::Error`] variants, and
//! a failed run keeps what it computed ([`RunError`]).
//!
//! # Conditioning, breakdown, robust mode
//!
//! - **Energy residual** ([`EnergyResidual`]). For Hamiltonians with exact divided differences
//!   (`Flags::exact_divided_differences`, e.g. [`Kepler`](crate::systems::Kepler)) the
//!   energy equation is solved cancellation-free, so `lambda` is exact to about one `eps` for
//!   any `dtau` (the plain residual's error grows like `eps / dtau^2`), then checked and
//!   projected against `H(zbar_0)` so the energy does not random-walk.
//! - **Breakdown** ([`Error::Breakdown`](crate::Error::Breakdown)). Where
//!   `Psi = (J grad H)^T Hess H (J grad H)` changes sign along the orbit (Cartesian Kepler above
//!   e ~ 0.79, the pendulum in rotation), a step has no positive root. The stepper detects it
//!   from `Psi` at the predicted midpoint and from the law of time before Newton runs (and
//!   diagnoses Newton failures along the orbit), and stops with the step, time, `Psi` and
//!   `lambda`, keeping the trajectory.
//! - **Robust mode** ([`DthOptions::with_robust`], opt-in). The bands where `Psi` changes sign,
//!   and steps whose Newton fails, are carried through with energy-conserving
//!   discrete-gradient steps sized by the state and `dtau` alone, marked
//!   [`StepKind::Fallback`](crate::observer::StepKind::Fallback); DTH runs on both sides of each
//!   sign change, and the run converges at the order of its steps and ends where asked.
//! - **No retry**: a failed DTH step is not retried with a smaller `dtau` (see [`Dth::step`]).
//! - **Order 4, 6, 8** ([`DthOptions::with_order`], [`Composition`]): each step is a symmetric
//!   composition of DTH steps in `tau` (5, 9 or 17 sub-steps, some negative), energy exact at
//!   every midpoint; the vertex invariants hold for order 2 only.
//! - **Cost against size.** Each Newton iteration factors `A = I - (h lambda/2) J Hess H`
//!   and borders it with two solves. For small `D` (and for Hamiltonians that do not declare
//!   their Hessian pattern) that is the dense fixed-size LU, `O(D^3)` (for a separable `H`
//!   the LU of the `D/2 x D/2` Schur complement `I + c^2 H_pp H_qq`, half the operations of
//!   the full factorization, where it is as stable: `dense_newton`); generated types beyond
//!   the crossover (`Flags::structured_newton`: from `D = 8`, `D = 16` if separable, unless more than a quarter
//!   of the Hessian is nonzero) take the banded LU of [`crate::structured`] on the Hessian's
//!   nonzeros, analysed once in [`Dth::new`], and never form a `D x D` matrix: a step of a
//!   chain (FPUT, Toda) costs time linear in the number of particles and a few vectors of
//!   stack (the chain of 512 particles steps on a 2 MB thread). `docs/performance.md`
//!   ("Step cost against size") has the measurements.
//! - **Ending at a time** ([`Dth::step_toward`]): the last step is shortened in `tau` so that
//!   the last midpoint lands on the requested time to roundoff.
//!
//! ```
//! use dth_core::dth::{integrate, DthOptions};
//! use dth_core::observer::StepKind;
//! use dth_core::nalgebra::Vector4;
//! use dth_core::{systems::Kepler, Error, Hamiltonian};
//!
//! // Kepler with e = 0.9: Psi changes sign between pericentre and apocentre.
//! let kepler = Kepler::thesis();
//! let z0 = Vector4::new(0.5, 0.0, 0.0, 1.9f64.sqrt());
//! let options = DthOptions::new(0.0157)?;
//! let stopped = integrate(kepler, z0, options, 1_000).unwrap_err();
//! assert!(matches!(stopped.error, Error::Breakdown { psi, .. } if psi < 0.0));
//! assert_eq!(stopped.partial.len(), 19); // zbar_0 .. zbar_18 kept
//!
//! let t = integrate(kepler, z0, options.with_robust(true), 1_000)?;
//! assert!(t.fallback_steps() > 0);
//! assert_eq!(t.kinds()[0], StepKind::Dth);
//! let e0 = kepler.value(&z0);
//! assert!(t.midpoints().iter().all(|z| (kepler.value(z) - e0).abs() < 1e-14));
//! # Ok::<(), Error>(())
//! ```
//!
//! # References
//! Y. Shibberu, *Discrete-Time Hamiltonian Dynamics*, PhD thesis, UT Arlington, 1992
//! (Chapter II, Section 4.1); *A Discrete-Time Formulation of Hamiltonian Dynamics*, 1998
//! (Theorem 1, Corollary 1).

mod compensated;
mod composition;
mod extended;
mod linear;
mod newton;
mod options;
mod robust;
mod stepper;
mod trajectory;

pub use crate::error::RunError;
pub use composition::Composition;
pub use extended::{lift, set_momentum_of_time, Extended};
pub use newton::{segment_from_vertex, Segment};
pub use options::{DthOptions, EnergyResidual, Solver};
pub use stepper::{integrate, Dth};
pub use trajectory::Trajectory;
