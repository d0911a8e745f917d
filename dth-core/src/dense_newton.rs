//! The dense Newton matrix `A = I - c J Hess H` of small systems, the one of the DTH solvers
//! (`c = h lambda / 2`) and of the one-stage implicit peers (`c = dt / 2`): storage for the
//! derivatives of `H` at the iterate and a factorization of `A`, with no allocation after
//! [`DenseNewton::new`] (for `Const<N>` and `Dyn` alike).
//!
//! # Two factorizations
//! With `z = (q, p)`, `J = [[0, I], [-I, 0]]` and `m = D/2`, `J Hess = [[H_pq, H_pp],
//! [-H_qq, -H_qp]]`. For a separable `H = T(p) + V(q)` the off-diagonal blocks vanish and,
//! writing `P = c H_pp`, `Q = c H_qq`,
//!
//! ```text
//! A = [[I, -P], [Q, I]] = [[I, -P], [0, I]] [[S, 0], [Q, I]],   S = I + P Q,
//! ```
//!
//! so `A (x, y) = (b1, b2)` is `S x = b1 + P b2`, `y = b2 - Q x`: one `m x m` LU (of the
//! Schur complement of the lower identity block) instead of a `D x D` one, `det A = det S`.
//! Forming `S` takes `2 m^3` operations and its LU `2 m^3 / 3`, half the `D x D` LU's
//! `2 D^3 / 3` (the pivot test's scale is an `O(m^2)` bound, below); a solve takes `3 m^2`
//! multiply-adds against `D^2 = 4 m^2`.
//! This path is taken when [`Flags::separable`](crate::Flags::separable) is set, the
//! off-diagonal blocks of the Hessian are indeed zero (a flag that does not hold costs
//! nothing in correctness) and the bound below holds; otherwise `A` is factored by the
//! partially pivoted LU of [`crate::linalg`].
//!
//! # When block elimination is stable
//! Block elimination does not pivot across the blocks; its backward error is governed by the
//! factors' size (Higham, *Accuracy and Stability of Numerical Algorithms*, 2nd ed., Section
//! 13.2; Demmel, Higham and Schreiber, *Stability of block LU factorization*, 1995): the
//! computed solution solves `(A + dA) x = b` with `|dA| <~ gamma (|A| + |L| |U|)`, `gamma` a
//! small multiple of `m eps`. For the factors above, `|L| |U| = [[|S| + |P| |Q|, |P|], [|Q|,
//! I]]` and `|S| <= I + |P| |Q|`. With `a = |P|_inf`, `b = |Q|_inf` (largest row sums),
//! `|A|_inf = 1 + max(a, b)` and `| |L| |U| |_inf <= 1 + max(a, b) + 2 a b`, so
//!
//! ```text
//! |dA|_inf / |A|_inf <~ gamma (2 + 2 a b / (1 + max(a, b))) <= gamma (2 + 2 min(a, b)).
//! ```
//!
//! Growth, hence lost accuracy against the pivoted LU, needs both blocks large: `S` is then
//! formed from terms of size `a b` that may cancel (a unit test builds such a matrix and
//! measures the loss). The Schur path is taken while
//! `min(a, b) <= `[`SCHUR_BOUND`]` = 1`, where the bound is at most `4 gamma |A|_inf`, the
//! size of the pivoted LU's own (`gamma (|A| + |L| |U|)` with `|L|, |U|` of order `|A|`). The
//! common case passes with a wide margin: `H_pp` is an inverse mass matrix, and `c |H_pp|` is
//! half a time step over a mass, whatever the stiffness of `V` (`b` may be large). On the
//! thesis Kepler orbit (`m = 1/2`, mean `dt` 0.15) and a Henon-Heiles orbit, DTH and the
//! midpoint rule at `dt = 0.15`, every factorization takes the Schur path: `a <= 0.26`,
//! `b <= 1.8`, `min(a, b) <= 0.22` (measured by the unit test's 200-step runs, which also
//! count the factorizations and Newton iterations: the same on both paths).
//!
//! # Singularity
//! The pivots of `S`'s LU are tested against `m eps (1 + a b)`. `1 + a b` bounds the size of
//! the terms `S` was formed from, `max_ij (delta_ij + sum_k |P_ik Q_kj|)`, from above
//! (`sum_k |P_ik| |Q_kj| <= a max_kj |Q_kj| <= a b`) and costs nothing beyond the row sums the
//! bound test already took; `S`'s entries' rounding errors are of that size, so a pivot at or
//! below it carries no correct digit (the bound makes the test more conservative, never
//! less). It is the dense LU's rule (`m eps max|A_ij|` for an `m x m` matrix) applied to `S`
//! with the scale of its formation.
//!
//! It is not the rule the pivoted LU applies to the same `A`: that one tests `A`'s pivots
//! against `D eps max|A_ij| = 2m eps max(1, max|P_ij|, max|Q_ij|)`, and these are other
//! pivots (only their products agree, `det A = det S`) against another scale. Neither rule
//! implies the other: a matrix whose smallest pivot is within a small factor of either
//! threshold may be reported singular on one path and not on the other (each is right that
//! its own solve would carry few or no correct digits). Far from the thresholds they agree, and
//! a unit test puts pivots at half and twice the Schur threshold, at `a b ~ 1` and at
//! `a ~ 1e-3, b ~ 1e6`. Both report [`Pivot::Singular`]; a non-finite Hessian
//! entry takes the pivoted LU, which reports it as before ([`Pivot::NonFinite`] for a NaN; an
//! infinity makes its threshold infinite, [`Pivot::Singular`]).

use crate::hamiltonian::{Alloc, Derivatives};
use crate::linalg::{Lu, Pivot};
use crate::Hamiltonian;
use nalgebra::{DefaultAllocator, Dim, OMatrix, OVector};

/// The largest `min(c |H_pp|_inf, c |H_qq|_inf)` for which a separable Newton matrix is
/// factored through its Schur complement (see the [module docs](self): its backward error
/// stays within twice that of the pivoted LU's bound).
pub(crate) const SCHUR_BOUND: f64 = 1.0;

/// Per-thread counts of [`DenseNewton`]'s factorizations and solves, with the largest block
/// norms of its Schur factorizations: how the tests see which path an integrator's solves
/// take (each test runs on its own thread).
#[cfg(test)]
pub(crate) mod census {
    use std::cell::Cell;

    /// The counts since the last [`take`].
    #[derive(Clone, Copy, Debug, Default, PartialEq)]
    pub(crate) struct Census {
        /// Factorizations through the Schur complement.
        pub(crate) schur: usize,
        /// Factorizations by the pivoted LU.
        pub(crate) lu: usize,
        /// Solves (one per Newton iteration).
        pub(crate) solves: usize,
        /// The largest `a = c |H_pp|_inf` of the Schur factorizations.
        pub(crate) a: f64,
        /// The largest `b = c |H_qq|_inf` of the Schur factorizations.
        pub(crate) b: f64,
        /// The largest `min(a, b)` of the Schur factorizations.
        pub(crate) min_ab: f64,
    }

    thread_local! {
        static CENSUS: Cell<Census> = Cell::new(Census::default());
    }

    /// The counts of this thread since the last call, reset to zero.
    pub(crate) fn take() -> Census {
        CENSUS.with(Cell::take)
    }

    /// Update this thread's counts.
    pub(crate) fn record(f: impl FnOnce(&mut Census)) {
        CENSUS.with(|cell| {
            let mut census = cell.get();
            f(&mut census);
            cell.set(census);
        });
    }
}

/// The derivatives of `H` at the iterate and the factorization of `A = I - c J Hess H`.
///
/// In Schur form the factorization's storage holds `[[LU of S, P], [Q, unused]]` (the rows of
/// `P` exchanged with those of `S`), so that a solve needs nothing else: the DTH solvers solve
/// with a kept factorization after evaluating `H` at a new iterate.
#[derive(Clone, Debug)]
pub(crate) struct DenseNewton<D: Dim>
where
    DefaultAllocator: Alloc<D>,
{
    derivatives: Derivatives<D>,
    /// [`Flags::separable`](crate::Flags::separable) of the Hamiltonian last evaluated.
    separable: bool,
    lu: Lu<D>,
    /// Whether the last factorization is the Schur complement's.
    schur: bool,
}

impl<D: Dim> DenseNewton<D>
where
    DefaultAllocator: Alloc<D>,
{
    /// Zero storage of dimension `d`.
    pub(crate) fn new(d: D) -> Self {
        DenseNewton {
            derivatives: Derivatives::zeros(d),
            separable: false,
            lu: Lu::empty(d),
            schur: false,
        }
    }

    /// Value, gradient, Hessian and `Psi` of `ham` at `z` (the fused evaluation), kept for
    /// [`factor`](Self::factor).
    pub(crate) fn derivatives_at<H: Hamiltonian<D>>(
        &mut self,
        ham: &H,
        z: &OVector<f64, D>,
    ) -> &Derivatives<D> {
        ham.derivatives_into(z, &mut self.derivatives);
        self.separable = ham.flags().separable;
        &self.derivatives
    }

    /// The Hessian of `ham` at `y` only, kept for [`factor`](Self::factor) (the other
    /// derivatives are left as they were).
    pub(crate) fn hessian_at<H: Hamiltonian<D>>(&mut self, ham: &H, y: &OVector<f64, D>) {
        ham.hessian_into(y, &mut self.derivatives.hessian);
        self.separable = ham.flags().separable;
    }

    /// The derivatives last evaluated.
    pub(crate) fn derivatives(&self) -> &Derivatives<D> {
        &self.derivatives
    }

    /// The Hessian last evaluated and the factorization's storage, for a caller done solving
    /// with it that needs a `D x D` factorization of its own (Gauss-Legendre's second one):
    /// [`solve_into`](Self::solve_into) is meaningless until the next
    /// [`factor`](Self::factor).
    pub(crate) fn hessian_and_spare_lu(&mut self) -> (&OMatrix<f64, D, D>, &mut Lu<D>) {
        (&self.derivatives.hessian, &mut self.lu)
    }

    /// Factor `A = I - c J Hess` with the Hessian last evaluated: through the Schur
    /// complement when the [module docs](self)' conditions hold, by the pivoted LU otherwise.
    /// Errors as [`Lu::factor`]; the factorization is meaningless after one.
    pub(crate) fn factor(&mut self, c: f64) -> Result<(), Pivot> {
        let norms = if self.separable {
            self.block_norms(c)
        } else {
            None
        };
        match norms {
            Some((a, b)) if a.min(b) <= SCHUR_BOUND => {
                #[cfg(test)]
                census::record(|n| {
                    n.schur += 1;
                    n.a = n.a.max(a);
                    n.b = n.b.max(b);
                    n.min_ab = n.min_ab.max(a.min(b));
                });
                self.schur = true;
                self.factor_schur(c, a * b)
            }
            _ => {
                #[cfg(test)]
                census::record(|n| n.lu += 1);
                self.schur = false;
                self.factor_lu(c)
            }
        }
    }

    /// Whether the last factorization is through the Schur complement.
    #[cfg(test)]
    pub(crate) fn is_schur(&self) -> bool {
        self.schur
    }

    /// `(a, b) = (c |H_pp|_inf, c |H_qq|_inf)` (largest row sums) when the Hessian is block
    /// diagonal and they are finite; `None` otherwise.
    fn block_norms(&self, c: f64) -> Option<(f64, f64)> {
        let h = &self.derivatives.hessian;
        let m = h.nrows() / 2;
        debug_assert!(h.nrows().is_multiple_of(2), "odd dimension {}", h.nrows());
        let (mut a, mut b) = (0.0f64, 0.0f64);
        for i in 0..m {
            let (mut row_p, mut row_q) = (0.0, 0.0);
            for j in 0..m {
                if h[(i, m + j)] != 0.0 || h[(m + i, j)] != 0.0 {
                    return None;
                }
                row_p += h[(m + i, m + j)].abs();
                row_q += h[(i, j)].abs();
            }
            // `f64::max` drops a NaN: finiteness is tested on its own.
            if !(row_p.is_finite() && row_q.is_finite()) {
                return None;
            }
            a = a.max(row_p);
            b = b.max(row_q);
        }
        let (a, b) = (c.abs() * a, c.abs() * b);
        (a.is_finite() && b.is_finite()).then_some((a, b))
    }

    /// `A = I - c J Hess`, column by column (`J Hess` is `Hess` with its halves exchanged and
    /// one negated), factored by the pivoted LU.
    fn factor_lu(&mut self, c: f64) -> Result<(), Pivot> {
        let hessian = &self.derivatives.hessian;
        let dim = hessian.nrows();
        let n = dim / 2;
        let a = self.lu.storage_mut().as_mut_slice();
        let columns = a
            .chunks_exact_mut(dim)
            .zip(hessian.as_slice().chunks_exact(dim));
        for (j, (column, h)) in columns.enumerate() {
            let (top, bottom) = column.split_at_mut(n);
            for (x, hv) in top.iter_mut().zip(&h[n..]) {
                *x = -(hv * c);
            }
            for (x, hv) in bottom.iter_mut().zip(&h[..n]) {
                *x = hv * c;
            }
            column[j] += 1.0;
        }
        self.lu.factor_in_place()
    }

    /// `S = I + P Q` into the leading block, `P` to its right, `Q` below it, and `S` factored
    /// with the pivot test of the [module docs](self), `ab` being `|P|_inf |Q|_inf` (whatever
    /// the bound: the tests call it beyond).
    fn factor_schur(&mut self, c: f64, ab: f64) -> Result<(), Pivot> {
        let h = &self.derivatives.hessian;
        let m = h.nrows() / 2;
        debug_assert!(h.nrows().is_multiple_of(2), "odd dimension {}", h.nrows());
        let a = self.lu.storage_mut();
        for j in 0..m {
            for i in 0..m {
                a[(i, m + j)] = c * h[(m + i, m + j)];
                a[(m + i, j)] = c * h[(i, j)];
            }
        }
        for j in 0..m {
            for i in 0..m {
                let mut s = if i == j { 1.0 } else { 0.0 };
                for k in 0..m {
                    s += a[(i, m + k)] * a[(m + k, j)];
                }
                a[(i, j)] = s;
            }
        }
        // `1 + a b` bounds the size of the terms `S` is formed from,
        // `max_ij (delta_ij + sum_k |P_ik Q_kj|)`, from above (module docs).
        self.lu
            .eliminate_leading(m, m as f64 * f64::EPSILON * (1.0 + ab))
    }

    /// `x = A^{-1} b` with the last factorization (`x` and `b` distinct).
    pub(crate) fn solve_into(&self, b: &OVector<f64, D>, x: &mut OVector<f64, D>) {
        #[cfg(test)]
        census::record(|n| n.solves += 1);
        if !self.schur {
            self.lu.solve_into(b, x);
            return;
        }
        let a = self.lu.storage();
        let m = b.len() / 2;
        // x = S^{-1} (b1 + P b2), the rows of P already exchanged with those of S.
        for i in 0..m {
            let mut s = b[self.lu.row(i)];
            for j in 0..m {
                s += a[(i, m + j)] * b[m + j];
            }
            x[i] = s;
        }
        self.lu.substitute_leading(m, x);
        // y = b2 - Q x.
        for i in 0..m {
            let mut s = b[m + i];
            for j in 0..m {
                s -= a[(m + i, j)] * x[j];
            }
            x[m + i] = s;
        }
    }

    /// Evaluate the Hessian of `ham` at `y`, factor `A` and solve `A x = b` (`x` and `b`
    /// distinct): one Newton update of a one-stage peer.
    pub(crate) fn solve_at<H: Hamiltonian<D>>(
        &mut self,
        ham: &H,
        y: &OVector<f64, D>,
        c: f64,
        b: &OVector<f64, D>,
        x: &mut OVector<f64, D>,
    ) -> Result<(), Pivot> {
        self.hessian_at(ham, y);
        self.factor(c)?;
        self.solve_into(b, x);
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dth::{Dth, DthOptions};
    use crate::methods::{ImplicitMidpoint, OneStepMethod};
    use crate::systems::{HenonHeiles, Kepler};
    use crate::{Flags, Hamiltonian};
    use nalgebra::{Const, Dyn, OMatrix, Vector4};
    use proptest::prelude::*;

    const EPS: f64 = f64::EPSILON;

    /// Storage whose Hessian is `[[h_qq, 0], [0, h_pp]]` (entries column-major, `m x m`),
    /// flagged separable.
    fn separable<D: Dim>(d: D, h_qq: &[f64], h_pp: &[f64]) -> DenseNewton<D>
    where
        DefaultAllocator: Alloc<D>,
    {
        let mut dense = DenseNewton::new(d);
        let m = d.value() / 2;
        let h = &mut dense.derivatives.hessian;
        for j in 0..m {
            for i in 0..m {
                h[(i, j)] = h_qq[i + m * j];
                h[(m + i, m + j)] = h_pp[i + m * j];
            }
        }
        dense.separable = true;
        dense
    }

    /// `A = I - c J Hess` written out.
    fn newton_matrix<D: Dim>(dense: &DenseNewton<D>, c: f64) -> OMatrix<f64, D, D>
    where
        DefaultAllocator: Alloc<D>,
    {
        let h = &dense.derivatives.hessian;
        let (d, _) = h.shape_generic();
        let n = d.value() / 2;
        OMatrix::from_fn_generic(d, d, |i, j| {
            let jh = if i < n { h[(i + n, j)] } else { -h[(i - n, j)] };
            (if i == j { 1.0 } else { 0.0 }) - c * jh
        })
    }

    /// `|A x - b|_inf / (|A|_inf |x|_inf + |b|_inf)`, in units of `eps`.
    fn relative_residual<D: Dim>(
        a: &OMatrix<f64, D, D>,
        x: &OVector<f64, D>,
        b: &OVector<f64, D>,
    ) -> f64
    where
        DefaultAllocator: Alloc<D>,
    {
        let norm = a
            .row_iter()
            .map(|r| r.iter().map(|x| x.abs()).sum::<f64>())
            .fold(0.0, f64::max);
        (a * x - b).amax() / (norm * x.amax() + b.amax()) / EPS
    }

    /// The tolerance of [`relative_residual`] in `eps` for `m = D/2`: the backward error of
    /// the [module docs](super), `gamma (2 + 2 min(a, b)) <= 4 gamma` with `gamma = (m + 2)
    /// eps` (the inner products forming `S`, its LU and the substitutions), plus the rounding
    /// of `A x - b` itself (`2m eps` relative to `|A| |x| + |b|`). The pivoted LU's is of the
    /// same size.
    fn tolerance(m: usize) -> f64 {
        4.0 * (m as f64 + 2.0) + 2.0 * m as f64
    }

    /// Solves `A x = b` through the path [`DenseNewton::factor`] chooses; the relative
    /// residual in `eps`, and whether that path was the Schur complement.
    fn residual_of_chosen<D: Dim>(
        dense: &mut DenseNewton<D>,
        c: f64,
        b: &OVector<f64, D>,
    ) -> (f64, bool)
    where
        DefaultAllocator: Alloc<D>,
    {
        dense.factor(c).expect("nonsingular");
        let mut x = b.clone();
        dense.solve_into(b, &mut x);
        (
            relative_residual(&newton_matrix(dense, c), &x, b),
            dense.is_schur(),
        )
    }

    /// The same with the pivoted LU, whatever the flags.
    fn residual_of_lu<D: Dim>(dense: &mut DenseNewton<D>, c: f64, b: &OVector<f64, D>) -> f64
    where
        DefaultAllocator: Alloc<D>,
    {
        dense.schur = false;
        dense.factor_lu(c).expect("nonsingular");
        let mut x = b.clone();
        dense.solve_into(b, &mut x);
        relative_residual(&newton_matrix(dense, c), &x, b)
    }

    /// A random symmetric `m x m` matrix from entries in `[-1, 1]`, times `scale`.
    fn symmetric(m: usize, raw: &[f64], scale: f64) -> Vec<f64> {
        let mut s = vec![0.0; m * m];
        for j in 0..m {
            for i in 0..m {
                s[i + m * j] = 0.5 * (raw[i + m * j] + raw[j + m * i]) * scale;
            }
        }
        s
    }

    /// `|S|_inf` (the largest row sum) of the column-major `m x m` matrix `s`.
    fn inf_norm(m: usize, s: &[f64]) -> f64 {
        (0..m)
            .map(|i| (0..m).map(|j| s[i + m * j].abs()).sum::<f64>())
            .fold(0.0, f64::max)
    }

    /// One random separable case at dimension `d`: `H_qq` and `H_pp` symmetric, one of them
    /// scaled by `stiff` (stiff potential, or a light mass), `c` set so that
    /// `min(c |H_pp|, c |H_qq|) = u <= 1`: the Schur path must be taken and its residual be
    /// roundoff, as the LU's. Cases where either factorization reports a singular matrix
    /// (`S` near singular for this draw) are skipped.
    fn agrees_with_the_lu<D: Dim>(
        d: D,
        raw: &[f64],
        stiff: f64,
        stiff_potential: bool,
        u: f64,
    ) -> Result<(), TestCaseError>
    where
        DefaultAllocator: Alloc<D>,
    {
        let m = d.value() / 2;
        let (s_qq, s_pp) = if stiff_potential {
            (stiff, 1.0)
        } else {
            (1.0, stiff)
        };
        let h_qq = symmetric(m, &raw[..m * m], s_qq);
        let h_pp = symmetric(m, &raw[m * m..2 * m * m], s_pp);
        let c = u / inf_norm(m, &h_qq).min(inf_norm(m, &h_pp));
        let b = OVector::from_iterator_generic(d, nalgebra::U1, raw[2 * m * m..].iter().copied());
        let mut dense = separable(d, &h_qq, &h_pp);
        prop_assume!(dense.factor(c).is_ok() && dense.factor_lu(c).is_ok());
        let (schur, taken) = residual_of_chosen(&mut dense, c, &b);
        let lu = residual_of_lu(&mut dense, c, &b);
        prop_assert!(taken, "min(a, b) = {u} <= 1 must take the Schur path");
        let tol = tolerance(m);
        prop_assert!(schur <= tol, "Schur residual {schur} eps > {tol} (LU {lu})");
        prop_assert!(lu <= tol, "LU residual {lu} eps > {tol}");
        Ok(())
    }

    /// The random entries of one case at `D = 2m`: `H_qq`'s and `H_pp`'s `m x m` (before
    /// [`symmetric`]), then the right-hand side's `2m`, all in `[-1, 1)`.
    fn raw(m: usize) -> impl Strategy<Value = Vec<f64>> {
        prop::collection::vec(-1.0..1.0f64, 2 * m * m + 2 * m)
    }

    /// One proptest per dimension: random separable Hessians (`raw(m)`), a stiffness scale and
    /// `c` (see `agrees_with_the_lu`).
    macro_rules! agrees_at {
        ($($name:ident: $dim:expr, $m:expr;)*) => {
            proptest! {
                #![proptest_config(ProptestConfig::with_cases(64))]
                $(
                    #[test]
                    fn $name(
                        r in raw($m), stiff in -3.0..3.0f64, which: bool, u in 1e-3..1.0f64
                    ) {
                        agrees_with_the_lu($dim, &r, 10f64.powf(stiff), which, u)?;
                    }
                )*
            }
        };
    }

    agrees_at! {
        schur_agrees_with_the_lu_at_d_2: Const::<2>, 1;
        schur_agrees_with_the_lu_at_d_4: Const::<4>, 2;
        schur_agrees_with_the_lu_at_d_6: Const::<6>, 3;
        schur_agrees_with_the_lu_at_d_12: Const::<12>, 6;
        schur_agrees_with_the_lu_at_dyn: Dyn(10), 5;
    }

    /// `H_qq = [[0.9, -0.4], [-0.4, 1.1]] s`, `H_pp = [[1, 0.3], [0.3, 0.7]] t` at `c = 1`.
    fn two_blocks(s: f64, t: f64) -> DenseNewton<Const<4>> {
        separable(
            Const::<4>,
            &[0.9, -0.4, -0.4, 1.1],
            &[1.0, 0.3, 0.3, 0.7].map(|x| x * t),
        )
        .scaled_qq(s)
    }

    impl DenseNewton<Const<4>> {
        fn scaled_qq(mut self, s: f64) -> Self {
            for j in 0..2 {
                for i in 0..2 {
                    self.derivatives.hessian[(i, j)] *= s;
                }
            }
            self
        }
    }

    const B: [f64; 4] = [0.3, -1.0, 0.7, 0.2];

    #[test]
    fn the_bound_is_on_the_smaller_block() {
        let b = Vector4::from(B);
        // |H_pp|_inf = 1.3, |H_qq|_inf = 1.5 s = 15: at c = (1 -+ 1e-12) / 1.3, a = 1 -+ 1e-12
        // and b ~ 11.5, so min(a, b) = a, just below and just above the bound.
        for (factor, schur) in [(1.0 - 1e-12, true), (1.0 + 1e-12, false)] {
            let mut dense = two_blocks(10.0, 1.0);
            let (residual, taken) = residual_of_chosen(&mut dense, factor / 1.3, &b);
            assert_eq!(taken, schur, "c |H_pp| = {factor}");
            assert!(residual <= tolerance(2), "{residual} eps");
        }
        // One block huge, the other small (a light mass in a soft potential, or a stiff
        // potential at a small step): min(a, b) = 1.5e-3 and 1.3e-3, the Schur path and
        // roundoff.
        for (s, t) in [(1e-3, 1e6), (1e6, 1e-3)] {
            let mut dense = two_blocks(s, t);
            let (residual, taken) = residual_of_chosen(&mut dense, 1.0, &b);
            assert!(taken && residual <= tolerance(2), "{s} {t}: {residual} eps");
        }
    }

    #[test]
    fn schur_beyond_the_bound_loses_accuracy_and_the_lu_is_taken() {
        // a = 1.3e6, b = 1.5e6: S = I + P Q is formed from terms of size a b ~ 2e12 whose
        // rounding (~ 2e12 eps ~ 4e-4) swamps the identity; the residual of the forced Schur
        // solve is then about eps min(a, b) ~ 1e6 eps relative (module docs), the pivoted LU's
        // stays at roundoff, and factor takes the LU.
        let b = Vector4::from(B);
        let mut dense = two_blocks(1e6, 1e6);
        dense.schur = true;
        let (norm_p, norm_q) = dense.block_norms(1.0).expect("block diagonal");
        dense
            .factor_schur(1.0, norm_p * norm_q)
            .expect("nonsingular");
        let mut x = b;
        dense.solve_into(&b, &mut x);
        let forced = relative_residual(&newton_matrix(&dense, 1.0), &x, &b);
        assert!(
            forced > 1e3 * tolerance(2),
            "forced Schur residual {forced} eps"
        );
        let (chosen, taken) = residual_of_chosen(&mut dense, 1.0, &b);
        assert!(
            !taken && chosen <= tolerance(2),
            "{chosen} eps, Schur {taken}"
        );
    }

    #[test]
    fn singular_schur_complement_is_singular() {
        // c = 1/2, H_pp = I, H_qq = diag(-4, 1): S = I + c^2 H_pp H_qq = diag(0, 5/4) exactly,
        // min(a, b) = 1/2: the Schur path reports it, as the LU does on A itself.
        let mut dense = separable(Const::<4>, &[-4.0, 0.0, 0.0, 1.0], &[1.0, 0.0, 0.0, 1.0]);
        assert_eq!(dense.factor(0.5), Err(Pivot::Singular));
        assert!(dense.is_schur());
        assert_eq!(dense.factor_lu(0.5), Err(Pivot::Singular));
        // D = 2, the saddle at c = 1/2: H = diag(-2, 2), S = 1 - 1 = 0.
        let mut dense = separable(Const::<2>, &[-2.0], &[2.0]);
        assert_eq!(dense.factor(0.5), Err(Pivot::Singular));
    }

    #[test]
    fn pivots_at_half_and_twice_the_threshold() {
        // What a factorization must return for a matrix below (`singular`) or above the
        // threshold.
        let verdict = |singular: bool| {
            if singular {
                Err(Pivot::Singular)
            } else {
                Ok(())
            }
        };
        // D = 2, c = 1, P = 1 - delta, Q = -1: S = delta exactly, a b = 1 - delta, threshold
        // eps (2 - delta) ~ 2 eps. The LU on A = [[1, -P], [-1, 1]] meets the same pivot
        // (delta, exactly) against its own 2 eps max|A_ij| = 2 eps: the rules agree here.
        for (k, singular) in [(0.5, true), (2.0, false)] {
            let delta = k * 2.0 * EPS;
            let mut dense = separable(Const::<2>, &[-1.0], &[1.0 - delta]);
            let want = verdict(singular);
            assert_eq!(dense.factor(1.0), want, "{k} x the threshold");
            assert!(dense.is_schur());
            assert_eq!(dense.factor_lu(1.0), want, "LU, {k} x the threshold");
        }
        // A large scale: P = 2^-10 I, Q = 2^10 [[512, y], [y, 512]] (a = 2^-10 ~ 1e-3,
        // b = 2^10 (512 + y) ~ 1e6, a b = 512 + y), so S = [[513, y], [y, 513]] exactly. With
        // y = 513 - delta its second pivot is delta (1026 - delta) / 513 ~ 2 delta, up to the
        // rounding of the elimination (~ 513 eps ~ 1.1e-13, a quarter of the threshold
        // 2 eps (1 + a b) ~ 4.6e-13).
        for (k, singular) in [(0.5, true), (2.0, false)] {
            let y = 513.0 - k * 1025.0 * EPS;
            let delta = 513.0 - y; // exact (Sterbenz)
            let threshold = 2.0 * EPS * (1.0 + 512.0 + y);
            let ratio = delta * (1026.0 - delta) / 513.0 / threshold;
            assert!(
                (ratio / k - 1.0).abs() < 0.1,
                "pivot {ratio} x the threshold"
            );
            let scale = 1024.0;
            let h_qq = [512.0, y, y, 512.0].map(|x| x * scale);
            let mut dense = separable(Const::<4>, &h_qq, &[1.0 / scale, 0.0, 0.0, 1.0 / scale]);
            let want = verdict(singular);
            assert_eq!(dense.factor(1.0), want, "{k} x the threshold");
            assert!(dense.is_schur());
            // The LU tests A's own pivots against 4 eps max|A_ij| ~ 4 eps 5e5 and reports
            // both singular, twice the Schur threshold included: the rules differ here.
            assert_eq!(dense.factor_lu(1.0), Err(Pivot::Singular), "LU, {k}");
        }
    }

    #[test]
    fn non_finite_hessians_and_wrong_flags_take_the_lu() {
        // A NaN or an infinity in either block: the pivoted LU's typed error, as before
        // (NaN is `NonFinite`; an infinity makes its singularity threshold infinite).
        for (bad, want) in [
            (f64::NAN, Pivot::NonFinite),
            (f64::INFINITY, Pivot::Singular),
        ] {
            for (h_qq, h_pp) in [
                ([1.0, 0.0, 0.0, bad], [1.0; 4]),
                ([1.0; 4], [0.0, 0.0, 0.0, bad]),
            ] {
                let mut dense = separable(Const::<4>, &h_qq, &h_pp);
                assert_eq!(dense.factor(0.1), Err(want), "{bad}");
                assert!(!dense.is_schur());
                assert_eq!(dense.factor_lu(0.1), Err(want), "{bad}");
            }
        }
        // Flagged separable, but H_qp = 0.5: the LU, and the solve is right.
        let mut dense = two_blocks(1.0, 1.0);
        dense.derivatives.hessian[(0, 3)] = 0.5;
        dense.derivatives.hessian[(3, 0)] = 0.5;
        let (residual, taken) = residual_of_chosen(&mut dense, 0.3, &Vector4::from(B));
        assert!(!taken && residual <= tolerance(2), "{residual} eps");
    }

    #[test]
    fn kepler_takes_the_schur_path_at_the_thesis_settings() {
        // The peers' entry point at the midpoint rule's c = dt/2 = 0.075 near the thesis
        // orbit's pericentre (r = 0.5): c |H_pp| = 0.15, the Schur path.
        let mut dense = DenseNewton::new(Const::<4>);
        let (y, mut x) = (Vector4::new(0.5, 0.1, 0.2, 1.2), Vector4::zeros());
        let b = Vector4::from(B);
        dense
            .solve_at(&Kepler::thesis(), &y, 0.075, &b, &mut x)
            .expect("solve");
        assert!(dense.is_schur());
        let residual = relative_residual(&newton_matrix(&dense, 0.075), &x, &b);
        assert!(residual <= tolerance(2), "{residual} eps");
    }

    /// `H` with its `separable` flag cleared: the pivoted LU on the same Hessians.
    struct Unflagged<H>(H);

    impl<H: Hamiltonian<Const<4>>> Hamiltonian<Const<4>> for Unflagged<H> {
        fn dim(&self) -> Const<4> {
            Const
        }
        fn flags(&self) -> Flags {
            self.0.flags().with_separable(false)
        }
        fn value(&self, z: &Vector4<f64>) -> f64 {
            self.0.value(z)
        }
        fn gradient_into(&self, z: &Vector4<f64>, out: &mut Vector4<f64>) {
            self.0.gradient_into(z, out)
        }
        fn hessian_into(&self, z: &Vector4<f64>, out: &mut nalgebra::Matrix4<f64>) {
            self.0.hessian_into(z, out)
        }
        fn psi(&self, z: &Vector4<f64>) -> f64 {
            self.0.psi(z)
        }
        fn derivatives_into(&self, z: &Vector4<f64>, out: &mut Derivatives<Const<4>>) {
            self.0.derivatives_into(z, out)
        }
        fn discrete_gradient_into(
            &self,
            z0: &Vector4<f64>,
            z1: &Vector4<f64>,
            out: &mut Vector4<f64>,
        ) {
            self.0.discrete_gradient_into(z0, z1, out)
        }
        fn discrete_gradient_defect_into(
            &self,
            z0: &Vector4<f64>,
            z1: &Vector4<f64>,
            gbar: &Vector4<f64>,
            out: &mut Vector4<f64>,
        ) {
            self.0.discrete_gradient_defect_into(z0, z1, gbar, out)
        }
        fn energy_difference(&self, z0: &Vector4<f64>, z1: &Vector4<f64>) -> f64 {
            self.0.energy_difference(z0, z1)
        }
    }

    /// Factor `A(H1, c)` with `H1` the Hessian of `h` at `z1`, evaluate `h` at two other
    /// points (the fused evaluation, then the Hessian alone), then solve: the residual
    /// against `A(H1, c)` is roundoff. The DTH simplified Newton relies on this: it solves
    /// with a kept factorization after evaluating `H` at new iterates. Whether the path was
    /// the Schur complement's.
    fn solves_with_the_kept_factorization<H: Hamiltonian<Const<4>>>(h: &H) -> bool {
        let c = 0.075;
        let b = Vector4::from(B);
        let mut dense = DenseNewton::new(Const::<4>);
        dense.derivatives_at(h, &Vector4::new(0.5, 0.1, 0.2, 1.2));
        dense.factor(c).expect("factor");
        let a1 = newton_matrix(&dense, c);
        dense.derivatives_at(h, &Vector4::new(-0.3, 0.8, 1.0, -0.4));
        assert!(
            (newton_matrix(&dense, c) - a1).amax() > 1e-3,
            "the Hessian must change"
        );
        dense.hessian_at(h, &Vector4::new(0.9, -0.6, 0.1, 0.3));
        assert!(
            (newton_matrix(&dense, c) - a1).amax() > 1e-3,
            "the Hessian must change"
        );
        let mut x = Vector4::zeros();
        dense.solve_into(&b, &mut x);
        let residual = relative_residual(&a1, &x, &b);
        assert!(residual <= tolerance(2), "{residual} eps");
        dense.is_schur()
    }

    #[test]
    fn a_kept_factorization_solves_with_the_matrix_it_was_factored_from() {
        assert!(solves_with_the_kept_factorization(&Kepler::thesis()));
        assert!(!solves_with_the_kept_factorization(&Unflagged(
            Kepler::thesis()
        )));
    }

    /// DTH with `steps` steps from `z0`: the final midpoint and lambda.
    fn dth<H: Hamiltonian<Const<4>>>(h: H, z0: Vector4<f64>, steps: usize) -> (Vector4<f64>, f64) {
        let mut dth = Dth::new(h, z0, DthOptions::thesis_kepler()).expect("start");
        dth.advance(steps).expect("steps");
        (*dth.zbar(), dth.lambda())
    }

    fn midpoint<H: Hamiltonian<Const<4>>>(h: &H, z0: Vector4<f64>, steps: usize) -> Vector4<f64> {
        let (mut method, mut z, mut next) = (ImplicitMidpoint::new(), z0, z0);
        for _ in 0..steps {
            method.step_into(h, &z, 0.15, &mut next).expect("step");
            z = next;
        }
        z
    }

    /// The tolerance on states `steps` apart from the same start: each step's Newton solves
    /// converge to the same root up to roundoff (a few eps relative), whatever the linear
    /// solver; Kepler's flow then shears such differences (an energy perturbation `delta`
    /// moves the frequency by about `delta`, the phase after the `N - k` remaining steps by
    /// `(N - k) delta`), and `N` per-step roundoffs of random sign add to about
    /// `sqrt(N) N eps` times the size of the state (or of `lambda`). Measured: 0.05 to 0.2 of
    /// this at `N = 100..800` (DTH and midpoint, Kepler; Henon-Heiles at this regular orbit
    /// agrees to the bit).
    fn shear_tolerance(steps: usize, size: f64) -> f64 {
        EPS * (steps as f64).powf(1.5) * size
    }

    /// The result of `run` and the census of its factorizations and solves.
    fn counted<T>(run: impl FnOnce() -> T) -> (T, census::Census) {
        census::take();
        let out = run();
        (out, census::take())
    }

    /// Every factorization of the flagged run took the Schur path, every one of the
    /// unflagged run the LU, and both took as many factorizations and Newton iterations
    /// (solves).
    fn same_work_on_each_path(what: &str, schur: &census::Census, lu: &census::Census) {
        assert!(schur.schur > 0 && schur.lu == 0, "{what}: {schur:?}");
        assert!(lu.schur == 0, "{what}: {lu:?}");
        assert_eq!(
            (schur.schur, schur.solves),
            (lu.lu, lu.solves),
            "{what}: factorizations and solves, Schur {schur:?}, LU {lu:?}"
        );
    }

    #[test]
    fn dth_and_midpoint_take_the_schur_path_and_reach_the_same_states_as_with_the_lu() {
        const STEPS: usize = 200;
        let kepler = Vector4::new(0.5, 0.0, 0.0, 1.2); // the thesis orbit
        let henon = Vector4::new(0.0, 0.1, 0.39, 0.0); // H = 0.081 < 1/8, regular
        let mut largest = census::Census::default();
        let mut widen = |n: &census::Census| {
            largest.a = largest.a.max(n.a);
            largest.b = largest.b.max(n.b);
            largest.min_ab = largest.min_ab.max(n.min_ab);
        };
        let ((z, lambda), n) = counted(|| dth(Kepler::thesis(), kepler, STEPS));
        let ((z_lu, lambda_lu), n_lu) = counted(|| dth(Unflagged(Kepler::thesis()), kepler, STEPS));
        same_work_on_each_path("DTH Kepler", &n, &n_lu);
        widen(&n);
        let tol = shear_tolerance(STEPS, z.amax());
        assert!((z - z_lu).amax() <= tol, "{:e}", (z - z_lu).amax());
        assert!(
            (lambda - lambda_lu).abs() <= shear_tolerance(STEPS, lambda),
            "{lambda} {lambda_lu}"
        );
        let ((z, lambda), n) = counted(|| dth(HenonHeiles, henon, STEPS));
        let ((z_lu, lambda_lu), n_lu) = counted(|| dth(Unflagged(HenonHeiles), henon, STEPS));
        same_work_on_each_path("DTH Henon-Heiles", &n, &n_lu);
        widen(&n);
        let tol = shear_tolerance(STEPS, z.amax());
        assert!((z - z_lu).amax() <= tol, "{:e}", (z - z_lu).amax());
        assert!(
            (lambda - lambda_lu).abs() <= shear_tolerance(STEPS, lambda),
            "{lambda} {lambda_lu}"
        );
        for (start, (schur, n), (lu, n_lu)) in [
            (
                kepler,
                counted(|| midpoint(&Kepler::thesis(), kepler, STEPS)),
                counted(|| midpoint(&Unflagged(Kepler::thesis()), kepler, STEPS)),
            ),
            (
                henon,
                counted(|| midpoint(&HenonHeiles, henon, STEPS)),
                counted(|| midpoint(&Unflagged(HenonHeiles), henon, STEPS)),
            ),
        ] {
            same_work_on_each_path(&format!("midpoint from {start}"), &n, &n_lu);
            widen(&n);
            let tol = shear_tolerance(STEPS, schur.amax());
            assert!(
                (schur - lu).amax() <= tol,
                "{start}: {:e}",
                (schur - lu).amax()
            );
        }
        // The figures of the module docs (measured: a = 0.256, b = 1.794, min = 0.211).
        assert!(
            largest.a <= 0.26 && largest.b <= 1.8 && largest.min_ab <= 0.22,
            "{largest:?}"
        );
    }
}
