//! Which Newton solver a generated Hamiltonian asks for (`Flags::structured_newton` of
//! `dth_core`): decided here, outside the `emit` feature, so that the macro's types and the
//! run-time Hamiltonians of `dth-runtime` decide alike.

/// The smallest dimension from which generated types take the structured Newton path
/// (`Flags::structured_newton`): below it the dense fixed-size path is faster. Measured side by
/// side (`dth-examples/benches/step_vs_size.rs`, `docs/performance.md`, "Cost against
/// system size"), one implicit-midpoint step, FPUT and Toda chains: a non-separable type's dense path
/// is the `D x D` LU, 1.4-1.6x faster than the structured one at `D = 4`, within 10-15% at
/// `D = 8` (structured ahead), 2.7x slower at `D = 16`; a separable type's dense path factors
/// the `D/2 x D/2` Schur complement (`dth_core`'s dense Newton matrix), 1.6-1.8x faster than
/// the structured one at `D = 8` and within 5% at `D = 16` (structured ahead), 2.5x slower at
/// `D = 32`.
pub const STRUCTURED_MIN_DIM: usize = 8;

/// [`STRUCTURED_MIN_DIM`] for separable types.
pub const STRUCTURED_MIN_DIM_SEPARABLE: usize = 16;

/// Whether a generated type of dimension `d` whose Hessian's upper triangle has `nnz` nonzero
/// entries, `diagonal` of them on the diagonal, takes the structured Newton path: from
/// [`STRUCTURED_MIN_DIM`] on ([`STRUCTURED_MIN_DIM_SEPARABLE`] for a `separable` one), unless
/// more than a quarter of the full Hessian is nonzero (all pairs coupled, as in N-body gravity:
/// after any ordering the band is then nearly the whole matrix, and the banded LU does the
/// dense LU's work with more indexing).
pub fn structured_newton(d: usize, nnz: usize, diagonal: usize, separable: bool) -> bool {
    let min_dim = if separable {
        STRUCTURED_MIN_DIM_SEPARABLE
    } else {
        STRUCTURED_MIN_DIM
    };
    d >= min_dim && 4 * (2 * nnz - diagonal) <= d * d
}
