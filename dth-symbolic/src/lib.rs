//! The symbolic engine behind `hamiltonian!` (placeholder: filled by the macro issue).
#![warn(missing_docs)]
