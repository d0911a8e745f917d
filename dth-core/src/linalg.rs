//! Small dense LU with partial pivoting on `OMatrix<f64, D, D>` (and the two floating-point
//! kernels the rest shares: `largest`, `two_sum`), generic over `const D` without
//! the `DimMin` bounds nalgebra's `lu()` would push onto every caller. No heap allocation.
//! Shared by the DTH Newton solvers and the implicit peer methods; the fastest path for small
//! `D` (see [`crate::structured`] for large sparse systems). Public for code that integrates
//! alongside the stepper (e.g. variational equations) and must not allocate per step.
//!
//! ```
//! use dth_core::linalg::Lu;
//! use dth_core::nalgebra::{Matrix2, Vector2};
//!
//! let a = Matrix2::new(0.0, 2.0, 1.0, 1.0); // needs a row exchange
//! let lu = Lu::factor(&a).expect("nonsingular");
//! let x = lu.solve(&Vector2::new(4.0, 3.0));
//! assert!((a * x - Vector2::new(4.0, 3.0)).amax() <= 4.0 * f64::EPSILON);
//! ```

use crate::hamiltonian::Alloc;
use nalgebra::{DefaultAllocator, Dim, OMatrix, OVector, U1};

/// `a + b` rounded, and its rounding error: `a + b = sum + error` exactly, for any magnitudes
/// (Knuth's two-sum). The compensated sums of the diagnostics and of a regularized run's state
/// (`dth::compensated`).
#[inline]
pub(crate) fn two_sum(a: f64, b: f64) -> (f64, f64) {
    let sum = a + b;
    let b_virtual = sum - a;
    let error = (a - (sum - b_virtual)) + (b - b_virtual);
    (sum, error)
}

/// `max |x_i|` over `entries`: infinite when one is infinite, NaN when one is NaN (so not
/// finite exactly when an entry is not). The Hessian's size at an evaluation, the sizes the
/// DTH Newton loop measures its iterates, residuals and updates by, and a matrix's size for
/// the LU's singularity test.
///
/// Four running maxima and a NaN flag, with no branch and no early return: a fold through one
/// `f64::max` is a chain of dependent, NaN-aware compares, and on a 6 x 6 Hessian at every
/// Newton iterate that chain was about a sixth of a regularized Kepler run's time.
#[inline]
pub(crate) fn largest(entries: &[f64]) -> f64 {
    fn fold(lane: &mut f64, nan: &mut bool, x: f64) {
        let a = x.abs();
        *nan |= a.is_nan();
        *lane = if a > *lane { a } else { *lane };
    }
    let mut lanes = [0.0f64; 4];
    let mut nan = false;
    let mut chunks = entries.chunks_exact(4);
    for chunk in &mut chunks {
        for (lane, &x) in lanes.iter_mut().zip(chunk) {
            fold(lane, &mut nan, x);
        }
    }
    for (lane, &x) in lanes.iter_mut().zip(chunks.remainder()) {
        fold(lane, &mut nan, x);
    }
    if nan {
        f64::NAN
    } else {
        lanes[0].max(lanes[1]).max(lanes[2].max(lanes[3]))
    }
}

/// Why a factorization failed (dense here, banded in [`crate::structured`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
pub enum Pivot {
    /// A pivot is at or below `m eps` times the size of the entries it was formed from: the
    /// matrix is numerically singular (a solve would carry no correct digits). For the pivoted
    /// LU of an `m x m` matrix `A` (dense or banded) that size is `max|A_ij|`; for a separable
    /// Newton matrix factored through its `m x m` Schur complement `S = I + P Q` it is
    /// `1 + |P|_inf |Q|_inf`, `S`'s pivots being tested, not `A`'s (the two rules differ near
    /// the threshold; see the dense Newton module's docs).
    #[error(
        "the matrix is numerically singular (a pivot at or below m eps times the size of the \
         entries it was formed from)"
    )]
    Singular,
    /// A pivot was NaN or infinite.
    #[error("a pivot is not finite")]
    NonFinite,
}

/// `$self.$kernel::<N>($args)` for the dimension `N = $m` when it is 2-8 (the sizes with
/// constant-size kernels below), `None` otherwise.
macro_rules! at_constant_size {
    ($m:expr, $self:ident . $kernel:ident ( $($arg:expr),* )) => {
        match $m {
            2 => $self.$kernel::<2>($($arg),*),
            3 => $self.$kernel::<3>($($arg),*),
            4 => $self.$kernel::<4>($($arg),*),
            5 => $self.$kernel::<5>($($arg),*),
            6 => $self.$kernel::<6>($($arg),*),
            7 => $self.$kernel::<7>($($arg),*),
            8 => $self.$kernel::<8>($($arg),*),
            _ => None,
        }
    };
}

/// `P A = L U`, stored in place (unit lower `L` below the diagonal, `U` on and above).
#[derive(Clone, Debug)]
pub struct Lu<D: Dim>
where
    DefaultAllocator: Alloc<D>,
{
    lu: OMatrix<f64, D, D>,
    perm: OVector<usize, D>,
    /// `1 / U_ii`: back substitution multiplies by it (a division is several times the
    /// latency of a product, on the dependent chain of a substitution).
    inv: OVector<f64, D>,
}

impl<D: Dim> Lu<D>
where
    DefaultAllocator: Alloc<D>,
{
    /// Factor `a`; `Err(Pivot::Singular)` when a pivot is at or below `D eps max|A_ij|`
    /// (singular as a value, like nalgebra's `lu().solve()`), `Err(Pivot::NonFinite)` when
    /// elimination overflowed.
    pub fn factor(a: &OMatrix<f64, D, D>) -> Result<Self, Pivot> {
        let (d, _) = a.shape_generic();
        let mut lu = Lu {
            lu: a.clone(),
            perm: OVector::from_element_generic(d, U1, 0usize),
            inv: OVector::zeros_generic(d, U1),
        };
        lu.eliminate()?;
        Ok(lu)
    }

    /// An empty factorization of dimension `d` (the zero matrix, not factored): storage for
    /// [`factor_from`](Self::factor_from).
    pub(crate) fn empty(d: D) -> Self {
        Lu {
            lu: OMatrix::zeros_generic(d, d),
            perm: OVector::from_element_generic(d, U1, 0usize),
            inv: OVector::zeros_generic(d, U1),
        }
    }

    /// The dimension.
    fn n(&self) -> usize {
        self.lu.nrows()
    }

    /// Factor the matrix with entries `a(i, j)` in place, reusing this storage (no copy of a
    /// `D x D` matrix in or out); errors as [`factor`](Self::factor), after which the contents
    /// are meaningless until the next successful factorization.
    pub(crate) fn factor_from(&mut self, a: impl Fn(usize, usize) -> f64) -> Result<(), Pivot> {
        let n = self.n();
        for j in 0..n {
            for i in 0..n {
                self.lu[(i, j)] = a(i, j);
            }
        }
        self.eliminate()
    }

    /// Factor the matrix the caller wrote into [`storage_mut`](Self::storage_mut), in place;
    /// errors as [`factor`](Self::factor).
    pub(crate) fn factor_in_place(&mut self) -> Result<(), Pivot> {
        self.eliminate()
    }

    /// Gaussian elimination with partial pivoting of `self.lu` in place.
    fn eliminate(&mut self) -> Result<(), Pivot> {
        let n = self.n();
        let size = largest(self.lu.as_slice());
        if size.is_nan() {
            return Err(Pivot::NonFinite);
        }
        self.eliminate_leading(n, n as f64 * f64::EPSILON * size)
    }

    /// Gaussian elimination with partial pivoting of the leading `m x m` block of `self.lu` in
    /// place, a pivot at or below `tiny` being [`Pivot::Singular`]. Rows are exchanged over the
    /// whole width, so entries right of the block move with their rows (the permutation is
    /// [`row`](Self::row)); rows below the block are not touched.
    #[inline]
    pub(crate) fn eliminate_leading(&mut self, m: usize, tiny: f64) -> Result<(), Pivot> {
        if m == self.n() {
            if let Some(result) = at_constant_size!(m, self.eliminate_small(tiny)) {
                return result;
            }
        }
        self.eliminate_general(m, tiny)
    }

    /// [`eliminate_leading`](Self::eliminate_leading) for any `m` and dimension.
    fn eliminate_general(&mut self, m: usize, tiny: f64) -> Result<(), Pivot> {
        let Lu { lu, perm, inv } = self;
        for (i, p) in perm.iter_mut().enumerate() {
            *p = i;
        }
        // Column-oriented (right-looking, column by column on the column-major storage): the
        // inner loops run over contiguous slices, without per-entry index checks.
        let n = lu.nrows();
        let a = lu.as_mut_slice();
        for k in 0..m {
            let piv = k + choose_pivot(&a[k * n + k..k * n + m], tiny)?;
            if piv != k {
                for j in 0..n {
                    a.swap(j * n + piv, j * n + k);
                }
                perm.swap_rows(piv, k);
            }
            inv[k] = 1.0 / a[k * n + k];
            // Multipliers below the pivot, then each later column minus a multiple of them.
            let (left, right) = a.split_at_mut((k + 1) * n);
            let multipliers = &mut left[k * n + k + 1..k * n + m];
            for l in multipliers.iter_mut() {
                *l *= inv[k];
            }
            for column in right.chunks_exact_mut(n).take(m - k - 1) {
                let ukj = column[k];
                for (x, l) in column[k + 1..m].iter_mut().zip(multipliers.iter()) {
                    *x -= l * ukj;
                }
            }
        }
        Ok(())
    }

    /// [`eliminate_leading`](Self::eliminate_leading) of the whole matrix when its dimension is
    /// the constant `N` (`None` otherwise): see [`eliminate_columns`].
    #[inline(always)]
    fn eliminate_small<const N: usize>(&mut self, tiny: f64) -> Option<Result<(), Pivot>> {
        let Lu { lu, perm, inv } = self;
        let a: &mut [[f64; N]; N] = lu.as_mut_slice().as_chunks_mut::<N>().0.try_into().ok()?;
        let perm: &mut [usize; N] = perm.as_mut_slice().try_into().ok()?;
        let inv: &mut [f64; N] = inv.as_mut_slice().try_into().ok()?;
        Some(eliminate_columns(a, perm, inv, tiny))
    }

    /// The storage, for a caller that lays out a matrix around a leading block it factors with
    /// [`eliminate_leading`](Self::eliminate_leading).
    pub(crate) fn storage_mut(&mut self) -> &mut OMatrix<f64, D, D> {
        &mut self.lu
    }

    /// The storage (factored leading block, and what the caller keeps around it).
    pub(crate) fn storage(&self) -> &OMatrix<f64, D, D> {
        &self.lu
    }

    /// The original row that elimination moved to row `i`.
    pub(crate) fn row(&self, i: usize) -> usize {
        self.perm[i]
    }

    /// Solve `A x = b`.
    pub fn solve(&self, b: &OVector<f64, D>) -> OVector<f64, D> {
        let mut x = b.clone();
        self.solve_into(b, &mut x);
        x
    }

    /// Solve `A x = b` into `x` (no allocation; `x` and `b` distinct).
    pub fn solve_into(&self, b: &OVector<f64, D>, x: &mut OVector<f64, D>) {
        let n = self.n();
        for i in 0..n {
            x[i] = b[self.perm[i]];
        }
        self.substitute(x);
    }

    /// Forward and back substitution of a permuted right-hand side in `x`.
    fn substitute(&self, x: &mut OVector<f64, D>) {
        self.substitute_leading(self.n(), x);
    }

    /// Forward and back substitution with the factored leading `m x m` block of a permuted
    /// right-hand side in `x[..m]` (the rest of `x` is not touched).
    #[inline]
    pub(crate) fn substitute_leading(&self, m: usize, x: &mut OVector<f64, D>) {
        if m == self.n() && at_constant_size!(m, self.substitute_small(x)).is_some() {
            return;
        }
        self.substitute_general(m, x);
    }

    /// [`substitute_leading`](Self::substitute_leading) for any `m` and dimension.
    fn substitute_general(&self, m: usize, x: &mut OVector<f64, D>) {
        // Column-oriented, like the elimination: each solved entry is subtracted from the rest
        // along a contiguous column.
        let n = self.lu.nrows();
        let a = self.lu.as_slice();
        let x = &mut x.as_mut_slice()[..m];
        for j in 0..m {
            let (done, rest) = x.split_at_mut(j + 1);
            let xj = done[j];
            for (xi, l) in rest.iter_mut().zip(&a[j * n + j + 1..j * n + m]) {
                *xi -= l * xj;
            }
        }
        for j in (0..m).rev() {
            let (rest, solved) = x.split_at_mut(j);
            solved[0] *= self.inv[j];
            let xj = solved[0];
            for (xi, u) in rest.iter_mut().zip(&a[j * n..j * n + j]) {
                *xi -= u * xj;
            }
        }
    }

    /// [`substitute_leading`](Self::substitute_leading) of the whole matrix when its dimension
    /// is the constant `N` (`None`, `x` untouched, otherwise): see [`substitute_columns`].
    #[inline(always)]
    fn substitute_small<const N: usize>(&self, x: &mut OVector<f64, D>) -> Option<()> {
        let a: &[[f64; N]; N] = self.lu.as_slice().as_chunks::<N>().0.try_into().ok()?;
        let inv: &[f64; N] = self.inv.as_slice().try_into().ok()?;
        let x: &mut [f64; N] = x.as_mut_slice().try_into().ok()?;
        substitute_columns(a, inv, x)
    }

    /// Solve `A X = B` for the columns of `b` (`b` with `C` columns).
    pub fn solve_matrix<C: Dim>(&self, b: &OMatrix<f64, D, C>) -> OMatrix<f64, D, C>
    where
        DefaultAllocator: nalgebra::allocator::Allocator<D, C>,
    {
        let (d, _) = self.lu.shape_generic();
        let mut x = b.clone();
        let mut column = OVector::zeros_generic(d, U1);
        for c in 0..b.ncols() {
            for (i, y) in column.iter_mut().enumerate() {
                *y = b[(self.perm[i], c)];
            }
            self.substitute(&mut column);
            x.set_column(c, &column);
        }
        x
    }
}

/// Partial pivoting's choice among a column's candidate `entries` (the diagonal entry first):
/// the index of the first of the largest `|x|`; [`Pivot::NonFinite`] when that is not finite,
/// [`Pivot::Singular`] when it is at or below `tiny` (or zero). Shared by the dense
/// eliminations here and the banded one ([`crate::structured`]).
#[inline(always)]
pub(crate) fn choose_pivot(entries: &[f64], tiny: f64) -> Result<usize, Pivot> {
    let mut piv = 0;
    let mut best = entries.first().map_or(f64::NAN, |x| x.abs());
    for (i, x) in entries.iter().enumerate().skip(1) {
        let v = x.abs();
        if v > best {
            best = v;
            piv = i;
        }
    }
    if !best.is_finite() {
        return Err(Pivot::NonFinite);
    }
    if best <= tiny || best == 0.0 {
        return Err(Pivot::Singular);
    }
    Ok(piv)
}

/// `$step(k)?` for each `k` in `0..$n` (`$n <= 8`, the dimensions [`Lu`] dispatches to the
/// kernels below), each `k` a literal: after inlining every loop bound in the step is a
/// constant, and the compiler unrolls the step's loops completely.
macro_rules! for_each_index {
    ($n:expr, $step:expr) => {
        for_each_index!(@ $n, $step, 0 1 2 3 4 5 6 7)
    };
    (@ $n:expr, $step:expr, $($k:literal)*) => {
        $(if $k < $n { $step($k)?; })*
    };
}

/// [`Lu::eliminate_leading`] of an `N x N` matrix stored by columns (`a[j][i]` is row `i`
/// of column `j`), the same operations in the same order (so the same result to the bit),
/// with the dimension a constant and the pivot steps written out (`for_each_index`): the
/// compiler drops the index checks and unrolls every loop. The general loop's slice iterators
/// and loop counters cost about 25 instructions per multiply-add at `N = 6` (the regularized
/// Kepler problem's Newton matrix), a fifth of a DTH step.
#[inline(always)]
fn eliminate_columns<const N: usize>(
    a: &mut [[f64; N]; N],
    perm: &mut [usize; N],
    inv: &mut [f64; N],
    tiny: f64,
) -> Result<(), Pivot> {
    for (i, p) in perm.iter_mut().enumerate() {
        *p = i;
    }
    for_each_index!(N, |k| pivot_step(k, a, perm, inv, tiny));
    Ok(())
}

/// Step `k` of [`eliminate_columns`]: the pivot of column `k`, the multipliers below it, and
/// the later columns updated.
#[inline(always)]
fn pivot_step<const N: usize>(
    k: usize,
    a: &mut [[f64; N]; N],
    perm: &mut [usize; N],
    inv: &mut [f64; N],
    tiny: f64,
) -> Result<(), Pivot> {
    let piv = k + choose_pivot(&a[k][k..], tiny)?;
    if piv != k {
        for column in a.iter_mut() {
            column.swap(piv, k);
        }
        perm.swap(piv, k);
    }
    inv[k] = 1.0 / a[k][k];
    for x in a[k].iter_mut().skip(k + 1) {
        *x *= inv[k];
    }
    let multipliers = a[k];
    for column in a.iter_mut().skip(k + 1) {
        let ukj = column[k];
        for i in k + 1..N {
            column[i] -= multipliers[i] * ukj;
        }
    }
    Ok(())
}

/// [`Lu::substitute_leading`] with the factors of [`eliminate_columns`], the same operations
/// in the same order, written out the same way (`Some` always: the steps cannot fail).
#[inline(always)]
fn substitute_columns<const N: usize>(
    a: &[[f64; N]; N],
    inv: &[f64; N],
    x: &mut [f64; N],
) -> Option<()> {
    for_each_index!(N, |j| forward_step(j, a, x));
    for_each_index!(N, |k| back_step(N - 1 - k, a, inv, x));
    Some(())
}

/// Forward substitution's step `j` (unit lower factor): `x_j` out of the later entries.
#[inline(always)]
fn forward_step<const N: usize>(j: usize, a: &[[f64; N]; N], x: &mut [f64; N]) -> Option<()> {
    let xj = x[j];
    for i in j + 1..N {
        x[i] -= a[j][i] * xj;
    }
    Some(())
}

/// Back substitution's step `j` (upper factor, reciprocal pivots): `x_j` solved, then out of
/// the earlier entries.
#[inline(always)]
fn back_step<const N: usize>(
    j: usize,
    a: &[[f64; N]; N],
    inv: &[f64; N],
    x: &mut [f64; N],
) -> Option<()> {
    x[j] *= inv[j];
    let xj = x[j];
    for i in 0..j {
        x[i] -= a[j][i] * xj;
    }
    Some(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Matrix3, Vector3};

    #[test]
    fn two_sum_is_exact() {
        assert_eq!(two_sum(1.0, 2f64.powi(-60)), (1.0, 2f64.powi(-60)));
        assert_eq!(two_sum(2f64.powi(53), 1.0), (2f64.powi(53), 1.0));
        // 0.1 + 0.2 (as doubles) is 0.30000000000000004 less 2.7755575615628914e-17 exactly.
        assert_eq!(
            two_sum(0.1, 0.2),
            (0.30000000000000004, -2.7755575615628914e-17)
        );
        // Any order of magnitudes.
        assert_eq!(two_sum(2f64.powi(-60), 1.0), (1.0, 2f64.powi(-60)));
    }

    /// The constant-size kernels against the general loop, to the bit, at every size they
    /// serve: random matrices (pivoting on most columns), a singular one and one with a NaN.
    fn kernels_match_the_general_loop<const N: usize>() {
        use nalgebra::{Const, SMatrix, SVector};
        let mut seed = 0x9e37_79b9_7f4a_7c15_u64 ^ N as u64;
        let mut random = move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        };
        for trial in 0..20 {
            let mut a = SMatrix::<f64, N, N>::from_fn(|_, _| random());
            if trial == 1 {
                // Two equal columns: singular (the last pivot is roundoff).
                let c = a.column(0).into_owned();
                a.set_column(N - 1, &c);
            }
            if trial == 2 {
                a[(N / 2, N - 1)] = f64::NAN;
            }
            let b = SVector::<f64, N>::from_fn(|_, _| random());
            let tiny = N as f64 * f64::EPSILON * a.amax();
            let (mut small, mut general) = (Lu::empty(Const::<N>), Lu::empty(Const::<N>));
            small.lu.copy_from(&a);
            general.lu.copy_from(&a);
            let got = small.eliminate_small::<N>(tiny).expect("an N x N matrix");
            let want = general.eliminate_general(N, tiny);
            assert_eq!(got, want, "N = {N}, trial {trial}");
            if want.is_err() {
                continue;
            }
            let same =
                |x: &[f64], y: &[f64]| x.iter().zip(y).all(|(p, q)| p.to_bits() == q.to_bits());
            assert!(same(small.lu.as_slice(), general.lu.as_slice()), "N = {N}");
            assert_eq!(small.perm, general.perm, "N = {N}");
            assert!(
                same(small.inv.as_slice(), general.inv.as_slice()),
                "N = {N}"
            );
            let (mut x, mut y) = (b, b);
            small.substitute_small::<N>(&mut x).expect("an N-vector");
            general.substitute_general(N, &mut y);
            assert!(same(x.as_slice(), y.as_slice()), "N = {N}");
            // And it solves: the residual within the backward error bound of partial pivoting,
            // n^2 eps 2^(n-1) max|A| max|x| (the worst-case growth factor 2^(n-1)).
            let mut solved = b;
            small.solve_into(&b, &mut solved);
            let r = (a * solved - b).amax();
            let growth = 2f64.powi(N as i32 - 1);
            let bound = (N * N) as f64 * f64::EPSILON * growth * a.amax() * solved.amax();
            assert!(r <= bound, "N = {N}: residual {r} > {bound}");
        }
    }

    #[test]
    fn constant_size_kernels_match_the_general_loop() {
        kernels_match_the_general_loop::<2>();
        kernels_match_the_general_loop::<3>();
        kernels_match_the_general_loop::<4>();
        kernels_match_the_general_loop::<5>();
        kernels_match_the_general_loop::<6>();
        kernels_match_the_general_loop::<7>();
        kernels_match_the_general_loop::<8>();
    }

    #[test]
    fn solves_several_right_hand_sides() {
        let a = Matrix3::new(4.0, 1.0, 0.0, 1.0, 3.0, 1.0, 0.0, 1.0, 2.0);
        let x = nalgebra::Matrix3x2::new(1.0, 2.0, -1.0, 0.5, 3.0, -4.0);
        let got = Lu::factor(&a).expect("nonsingular").solve_matrix(&(a * x));
        // Well-conditioned (cond ~ 4): a few eps times |x|.
        assert!((got - x).amax() <= 32.0 * f64::EPSILON * x.amax(), "{got}");
        assert!(Lu::factor(&Matrix3::zeros()).is_err());
    }

    #[test]
    fn solves_a_pivoting_system_and_flags_singular() {
        let a = Matrix3::new(0.0, 2.0, 1.0, 1.0, 1.0, 0.0, 3.0, 0.0, 1.0);
        let x = Vector3::new(1.0, -2.0, 0.5);
        let b = a * x;
        let lu = Lu::factor(&a).expect("nonsingular");
        let err = (lu.solve(&b) - x).amax();
        // Backward-stable LU on a well-conditioned 3x3: error a few eps times |x|.
        assert!(err <= 16.0 * f64::EPSILON * x.amax(), "err {err}");
        let s = Matrix3::new(1.0, 2.0, 3.0, 2.0, 4.0, 6.0, 0.0, 0.0, 1.0);
        assert!(matches!(Lu::factor(&s), Err(Pivot::Singular)));
        let n = Matrix3::new(f64::NAN, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0);
        assert!(matches!(Lu::factor(&n), Err(Pivot::NonFinite)));
    }
}
