//! Nothing here: the crate exists for `benches/solvers.rs`.
