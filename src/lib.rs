#![doc = include_str!("../docs/library.md")]
#![warn(missing_docs)]

pub use dth_core::*;
pub use dth_macros::hamiltonian;

/// Hamiltonians built from text at run time (the `hamiltonian!` grammar, the same engine),
/// their derivatives compiled to machine code by Cranelift when built. [`runtime::Typed`] is
/// one that implements [`Hamiltonian<D>`], so the DTH stepper and every peer integrator run
/// it. (Feature `runtime`, on by default; the crate `dth_runtime`.)
///
/// ```
/// use dth::nalgebra::Vector4;
/// use dth::runtime::{RuntimeHamiltonian, Typed};
/// use dth::{integrate, DthOptions, Hamiltonian};
///
/// // Kepler, read from text with its parameters, as the thesis's orbit.
/// let text = "(p1^2 + p2^2)/(2*m) - k*(q1^2 + q2^2)^(-1/2)";
/// let kepler = Typed::<4>::new(RuntimeHamiltonian::new(text, &[("m", 0.5), ("k", 1.0)])?)?;
/// let zbar0 = Vector4::new(0.5, 0.0, 0.0, 1.2); // H = 1.44 - 2
/// let options = DthOptions::new(0.06277)?.with_lambda0(1.0)?;
/// let run = integrate(kepler.clone(), zbar0, options, 1_000)?;
/// let e0 = kepler.value(&zbar0);
/// // DTH conserves the energy at its midpoints to roundoff (|H| = 0.56: a few eps).
/// assert!(run.midpoints().iter().all(|z| (kepler.value(z) - e0).abs() < 1e-15));
///
/// // The dimension is checked when the view is built: a typed error, not a panic.
/// let h = RuntimeHamiltonian::new(text, &[("m", 0.5), ("k", 1.0)])?;
/// assert!(Typed::<6>::new(h).is_err());
/// # Ok::<(), dth::Error>(())
/// ```
#[cfg(feature = "runtime")]
pub mod runtime {
    pub use dth_runtime::*;
}

/// Paths used by code that `hamiltonian!` emits. Not public API.
#[doc(hidden)]
pub mod __private {
    pub use dth_core;
    pub use dth_symbolic::double_double;
    pub use nalgebra;
}

/// The Rust examples of the README and the guide's pages, compiled and run as doctests so they
/// cannot go stale (the front page above is `docs/library.md`).
#[cfg(doctest)]
mod docs {
    #[doc = include_str!("../README.md")]
    struct Readme;
    #[doc = include_str!("../docs/grammar.md")]
    struct Grammar;
    #[doc = include_str!("../docs/limits.md")]
    struct Limits;
}
