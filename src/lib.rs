#![doc = include_str!("../README.md")]
#![warn(missing_docs)]

pub use dth_core::*;
pub use dth_macros::hamiltonian;

/// Paths used by code that `hamiltonian!` emits. Not public API.
#[doc(hidden)]
pub mod __private {
    pub use dth_core;
    pub use nalgebra;
}
