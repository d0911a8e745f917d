//! The library behind the `dth` command: thesis reproductions, scenes and benchmarks.
#![warn(missing_docs)]

pub mod workprecision;
